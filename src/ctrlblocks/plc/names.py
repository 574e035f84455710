"""IEC 61131-3 identifiers for the names of the blocks' Python.

IEC 61131-3 (3rd ed., 6.1.2) defines an identifier as a letter or an
underscore followed by letters, digits and *single* underscores, not ending
in an underscore; it is case-insensitive and must not be a keyword.  The
compilers also refuse the names of the standard data types, functions and
function blocks as variable names (MATIEC refuses ``EXP``, ``PID``,
``RAMP``, ``REAL_TO_DINT`` ...), CODESYS and TwinCAT add their own
keywords (``METHOD``, ``THIS``, ``REF``, ``__NEW`` ...) and Siemens SCL its
own (``REGION``, ``BEGIN``, ``VERSION`` ...).  MATIEC writes the names into
C in upper case, where the macros of the C headers it compiles with
(:data:`~ctrlblocks.plc.c_macros.C_MACROS`: ``X_OK``, ``EOF``, ``NAN`` ...)
would replace them.

:func:`iec_name` maps any Python identifier to a name that is valid in every
target: ASCII letters, digits and single underscores, no leading digit, no
leading or trailing underscore, not in :data:`RESERVED`, and different
(case-insensitively) from the names already taken in the same scope.  A
reserved word gets the suffix ``_v`` (``step`` -> ``step_v``), a clash a
number (``x_2``); :func:`is_iec_identifier` is the check the tests apply to
every identifier of every export.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from .c_macros import C_MACROS

__all__ = ["RESERVED", "iec_name", "is_iec_identifier", "is_reserved"]

_TYPES_TEXT = (
    "BOOL SINT INT DINT LINT USINT UINT UDINT ULINT REAL LREAL TIME LTIME DATE LDATE "
    "TIME_OF_DAY TOD LTOD DATE_AND_TIME DT LDT STRING WSTRING CHAR WCHAR BYTE WORD DWORD LWORD "
    "ANY ANY_DERIVED ANY_ELEMENTARY ANY_MAGNITUDE ANY_NUM ANY_REAL ANY_INT ANY_SIGNED "
    "ANY_UNSIGNED ANY_BIT ANY_STRING ANY_DATE ANY_DURATION ANY_CHAR ANY_CHARS"
)
_ELEMENTARY = _TYPES_TEXT.split()

RESERVED = frozenset(
    w.upper()
    for w in (
        # IEC 61131-3 keywords (3rd edition, Annex C), including IL operators and SFC
        """
        ACTION END_ACTION ARRAY OF AT CASE ELSE END_CASE CONFIGURATION END_CONFIGURATION
        CONSTANT EN ENO EXIT FALSE TRUE F_EDGE R_EDGE FOR TO BY DO END_FOR FUNCTION
        END_FUNCTION FUNCTION_BLOCK END_FUNCTION_BLOCK IF THEN ELSIF END_IF INITIAL_STEP
        INTERVAL NIL NON_RETAIN NOT ON OR XOR AND MOD PRIORITY PROGRAM END_PROGRAM
        READ_ONLY READ_WRITE REPEAT UNTIL END_REPEAT RESOURCE END_RESOURCE RETAIN RETURN
        SINGLE STEP END_STEP STRUCT END_STRUCT TASK TRANSITION FROM END_TRANSITION TYPE
        END_TYPE VAR END_VAR VAR_ACCESS VAR_CONFIG VAR_EXTERNAL VAR_GLOBAL VAR_INPUT
        VAR_IN_OUT VAR_OUTPUT VAR_TEMP VAR_STAT WHILE END_WHILE WITH CONTINUE
        CLASS END_CLASS EXTENDS IMPLEMENTS INTERFACE END_INTERFACE METHOD END_METHOD
        NAMESPACE END_NAMESPACE USING OVERRIDE ABSTRACT FINAL PUBLIC PRIVATE PROTECTED
        INTERNAL REF REF_TO NULL THIS SUPER
        ANDN ORN XORN LD LDN ST STN CAL CALC CALCN JMP JMPC JMPCN RET RETC RETCN ADD SUB
        MUL DIV GT GE EQ NE LE LT
        """,
        # standard functions (Tables 22-36) and function blocks (Tables 43-46)
        """
        ABS SQRT LN LOG EXP SIN COS TAN ASIN ACOS ATAN ATAN2 EXPT MOVE TRUNC ROUND SHL SHR
        ROL ROR SEL MAX MIN LIMIT MUX LEN LEFT RIGHT MID CONCAT INSERT DELETE REPLACE FIND
        ADD_TIME SUB_TIME MUL_TIME DIV_TIME CONCAT_DATE_TOD SPLIT_DATE
        SR RS SEMA R_TRIG F_TRIG CTU CTD CTUD TP TON TOF RTC
        """,
        # MATIEC's library function blocks (lib/*.txt)
        "PID RAMP INTEGRAL DERIVATIVE HYSTERESIS",
        # CODESYS V3 / TwinCAT 3 keywords and operators
        """
        POINTER REFERENCE UNION PROPERTY END_PROPERTY AND_THEN OR_ELSE JMP ADR ADRINST
        BITADR SIZEOF INDEXOF INI NEW DELETE VAR_INST END_STRUCT SUPER __NEW __DELETE
        __QUERYINTERFACE __QUERYPOINTER __ISVALIDREF __TRY __CATCH __FINALLY __ENDTRY
        ISVALIDREF TRUNC_INT
        """,
        # Siemens SCL (TIA Portal) keywords
        """
        BEGIN REGION END_REGION VERSION TITLE AUTHOR FAMILY NAME KNOW_HOW_PROTECT VOID
        DATA_BLOCK END_DATA_BLOCK ORGANIZATION_BLOCK END_ORGANIZATION_BLOCK GOTO LABEL
        END_LABEL DB_ANY VARIANT RUNTIME CONST
        """,
    )
    for w in w.split()
) | frozenset(_ELEMENTARY) | C_MACROS
"""Upper-case words no exported identifier may be (the union over the targets, and
the C macros MATIEC's output would meet)."""

_TYPE_NAMES = "|".join(sorted(_ELEMENTARY, key=len, reverse=True))
_CONVERSION = re.compile(rf"(?:{_TYPE_NAMES}|BCD|TRUNC)_TO_(?:{_TYPE_NAMES}|BCD)", re.I)
_IDENT = re.compile(r"[A-Za-z](?:_?[A-Za-z0-9])*")


def is_reserved(name: str) -> bool:
    """True for a keyword, a standard name or a type conversion (``REAL_TO_DINT``) of a target."""
    return name.upper() in RESERVED or _CONVERSION.fullmatch(name) is not None


def is_iec_identifier(name: str) -> bool:
    """True for an identifier every target takes: ``[A-Za-z](_?[A-Za-z0-9])*``, not reserved."""
    return _IDENT.fullmatch(name) is not None and not is_reserved(name)


def _plain(name: str) -> str:
    """ASCII letters, digits and single inner underscores; a leading digit gets ``v``."""
    text = "".join(c if (c.isascii() and c.isalnum()) or c == "_" else f"_U{ord(c):04X}_"
                   for c in name)  # fmt: skip
    text = re.sub("_+", "_", text).strip("_")
    if not text:
        return "v"
    return "v" + text if text[0].isdigit() else text


def iec_name(name: str, taken: Iterable[str] = ()) -> str:
    """An IEC 61131-3 identifier for ``name``, not (case-insensitively) among ``taken``.

    ``step`` -> ``step_v`` (a keyword), ``x_`` -> ``x``, ``a__b`` -> ``a_b``,
    ``_1`` -> ``v1``, ``ω`` -> ``U03C9``; the result is ``is_iec_identifier``.
    """
    used = {t.upper() for t in taken}
    base = _plain(name)
    if is_reserved(base):
        base += "_v"
    out, n = base, 1
    while out.upper() in used or is_reserved(out):
        n += 1
        out = f"{base}_{n}"
    return out
