"""Every identifier of every export is an IEC 61131-3 identifier that every target takes.

The standard (6.1.2): a letter or underscore, then letters, digits and single
underscores, no trailing underscore, case-insensitive, not a keyword; the
compilers refuse the standard names too (MATIEC: ``EXP``, ``PID``, ``RAMP``,
``REAL_TO_DINT`` as a variable), CODESYS/TwinCAT and SCL add keywords.  The
escaping (:func:`ctrlblocks.plc.names.iec_name`) is checked property-based
over hostile names, the translator over functions written with hostile
names, and the text of every export token by token (a token with ``__`` or a
trailing ``_`` anywhere fails, whatever produced it).
"""

from __future__ import annotations

import importlib.util
import keyword
import re
import sys

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ctrlblocks import ADRC, PID, LeadLag, Regulator, plc
from ctrlblocks.plc.names import RESERVED, iec_name, is_iec_identifier, is_reserved
from ctrlblocks.plc.translate import Program

from .traces import ADRC_OPTIONS, DB_OPTIONS, PID_OPTIONS

# what a hostile Python name is made of: reserved words in any case, underscores, digits, unicode
_PIECES = st.one_of(
    st.sampled_from(sorted(RESERVED)).map(lambda w: w.lower()),
    st.sampled_from(sorted(RESERVED)),
    st.sampled_from(["_", "__", "___", "x", "r", "q", "ref", "step", "v", "v_2", "1", "9", "ω",
                     "é"]),
    st.text(alphabet="abcXYZ_019", min_size=1, max_size=4),
)
HOSTILE_NAMES = st.lists(_PIECES, min_size=1, max_size=4).map("".join)


@settings(max_examples=400, deadline=None)
@given(names=st.lists(HOSTILE_NAMES, min_size=1, max_size=12))
def test_escaping_always_gives_distinct_iec_identifiers(names):
    taken: list[str] = []
    for n in names:
        out = iec_name(n, taken)
        assert is_iec_identifier(out), (n, out)
        assert "__" not in out and not out.endswith("_") and not out.startswith("_")
        assert out.upper() not in {t.upper() for t in taken}, (n, out, taken)
        taken.append(out)


def test_escaping_keeps_plain_names_and_marks_reserved_ones():
    assert iec_name("kp") == "kp" and iec_name("e_prev") == "e_prev"
    assert iec_name("step") == "step_v" and iec_name("ref") == "ref_v" and iec_name("r") == "r"
    assert iec_name("x_") == "x" and iec_name("a__b") == "a_b" and iec_name("_1") == "v1"
    assert iec_name("real_to_dint") == "real_to_dint_v" and iec_name("PID") == "PID_v"
    assert iec_name("x", ["X"]) == "x_2" and iec_name("x", ["X", "x_2"]) == "x_3"
    assert is_reserved("Exp") and is_reserved("dint_to_real") and not is_reserved("kp")


def _hostile_module(tmp_path, names: list[str]):
    """A module with a function whose parameters, locals and called helper use ``names``."""
    params = ", ".join(f"{n}: float" for n in names[:3])
    lines = ["def helper_(x: float, y_: float) -> tuple[float, float]:",
             "    return x + y_, x - y_", "", "",
             f"def f__({params}) -> float:",
             *(f"    {n} = {names[0]} + {j}.5" for j, n in enumerate(names[3:], start=1)),
             f"    a_, b__ = helper_({names[0]}, {names[-1]})",
             f"    return {' + '.join(names)} + a_ + b__", ""]  # fmt: skip
    src = "\n".join(lines)
    path = tmp_path / f"ctrlblocks_hostile_{abs(hash(tuple(names)))}.py"
    path.write_text(src)
    spec = importlib.util.spec_from_file_location(f"ctrlblocks.{path.stem}", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


_PY_NAME = HOSTILE_NAMES.map(lambda n: re.sub(r"\W", "", n)).filter(
    lambda n: n.isidentifier() and not keyword.iskeyword(n) and not n[0].isdigit()
    and n not in ("float", "helper_", "f__", "a_", "b__", "abs", "min", "max", "len", "int"))


@settings(max_examples=40, deadline=None)
@given(names=st.lists(_PY_NAME, min_size=4, max_size=7, unique=True))
def test_translated_hostile_functions_have_only_iec_identifiers(tmp_path_factory, names):
    mod = _hostile_module(tmp_path_factory.mktemp("hostile"), names)
    prog = Program()
    prog.function(mod.f__)
    for p in prog.pous.values():
        assert is_iec_identifier(p.name), p.name
        for n in [*(n for n, _ in p.inputs), *(n for n, _ in p.outputs), *p.locals]:
            assert is_iec_identifier(n), (p.name, n)
        declared = [n.upper() for n in [*(n for n, _ in p.inputs), *(n for n, _ in p.outputs),
                                        *p.locals, p.name]]  # fmt: skip
        assert len(declared) == len(set(declared)), declared
        _tokens_are_identifiers("\n".join(p.body).replace("\x01", "").replace("\x02", "")
                                .replace("\x03", "").replace("\x04", ""))  # fmt: skip


_ST_WORDS = {"IF", "THEN", "ELSIF", "ELSE", "END_IF", "AND", "OR", "XOR", "NOT", "MOD", "TRUE",
             "FALSE", "RETURN", "FOR", "TO", "DO", "END_FOR", "FUNCTION", "END_FUNCTION",
             "FUNCTION_BLOCK", "END_FUNCTION_BLOCK", "PROGRAM", "END_PROGRAM", "VAR",
             "VAR_INPUT", "VAR_OUTPUT", "VAR_TEMP", "END_VAR", "REAL", "DINT", "BOOL", "ARRAY",
             "OF", "ABS", "EXP", "SEL", "MIN", "MAX", "TRUNC", "DINT_TO_REAL", "EXPT", "LN",
             "SQRT", "BEGIN", "REGION", "END_REGION", "VERSION", "EXTENDS", "TEST",
             "TEST_FINISHED", "ASSERTEQUALS_REAL", "ASSERTEQUALS_DINT", "ASSERTEQUALS_BOOL",
             "EXPECTED", "ACTUAL", "DELTA", "MESSAGE", "RUN", "S7_OPTIMIZED_ACCESS", "VOID",
             "INT"}  # fmt: skip


def _tokens_are_identifiers(text: str) -> set[str]:
    """Every word of ST ``text`` outside comments, strings and numbers: standard words of the
    emitted ST, or IEC identifiers.  Returns the identifiers."""
    code = re.sub(r"\(\*.*?\*\)|//[^\n]*|'[^']*'", " ", text, flags=re.S)
    code = re.sub(r"\{[^}]*\}", " ", code)  # TIA attributes
    code = re.sub(r"^\s*REGION [^\n]*", " ", code, flags=re.M)  # a REGION's title is free text
    code = re.sub(r"\b16#[0-9A-F]+\b|\b\d[\d.]*(E-?\d+)?\b", " ", code)
    words = set(re.findall(r"[A-Za-z_][A-Za-z0-9_]*", code))
    idents = {w for w in words if w.upper() not in _ST_WORDS and w not in ("Real", "Bool",
                                                                         "DInt", "Array", "of")}
    bad = sorted(w for w in idents if not is_iec_identifier(w) and w not in ("TcUnit", "CfUnit",
                                                                              "FB_TestSuite"))
    assert not bad, f"not IEC identifiers: {bad}"
    return idents


CONFIGS = [
    PID(kp=1.2, ti=5.9, td=0.9, ts=0.1),
    *(PID(**{"kp": 1.5, "ti": 4.0, "td": 0.5, **c}) for c in PID_OPTIONS + DB_OPTIONS),
    ADRC(order=2, b0=0.05, t_ref=1.0),
    *(ADRC(**{"order": 2, "b0": 0.05, **c}) for c in ADRC_OPTIONS),
    ADRC(order=1, b0=0.5), ADRC(order=3, b0=0.01, discretisation="exact"),
    LeadLag(k=2.0, t_lead=1.0, t_lag=3.0), LeadLag(method="euler"),
    Regulator(kp=2.0, ti=10.0, tr=0.5),
]  # fmt: skip


@pytest.mark.parametrize(("target", "test"), [("codesys", "plain"), ("codesys", "tcunit"),
                                              ("tia", "plain")])  # fmt: skip
def test_every_identifier_of_every_export_is_an_iec_identifier(target, test):
    """All configurations the tests use in one project, with their test benches."""
    _tokens_are_identifiers(plc.export(CONFIGS, target, test=test))


def test_function_and_fb_names_and_all_declared_names_are_iec_identifiers():
    proj = plc.export_files(CONFIGS, "twincat", test="plain")
    for name, text in proj.items():
        assert is_iec_identifier(name.removesuffix(".TcPOU")), name
        decl = text.split("<Declaration><![CDATA[")[1].split("]]>")[0]
        for m in re.finditer(r"^\s+(\w+) : ", decl, re.M):
            assert is_iec_identifier(m.group(1)), (name, m.group(1))


def test_the_c_macros_an_export_meets_are_reserved_by_the_preprocessors_own_word():
    """MATIEC writes identifiers into C in upper case: a name spelled like a macro of the
    headers it compiles with (``X_OK``) does not compile.  The machine's preprocessor is the
    oracle: every upper-case macro it defines for those headers (and MATIEC's library, when
    built) is reserved, so no export can spell one (``python tests/plc/c_macros_oracle.py
    [MATIEC/lib/C]`` prints the set for ``ctrlblocks/plc/c_macros.py``)."""
    from . import matiec
    from .c_macros_oracle import live_macros

    m = matiec.matiec_dir()
    live = live_macros(m / "lib" / "C" if m is not None else None)
    if live is None:
        pytest.skip("no gcc: the preprocessor is the oracle")
    assert len(live) > 500  # the headers were read
    missing = sorted(live - RESERVED)
    assert not missing, f"C macros an export could spell: {missing[:20]}"
    assert iec_name("x_ok") == "x_ok_v" and is_reserved("eof") and is_reserved("Nan")


@pytest.mark.parametrize("block", [LeadLag(k=2.0, t_lead=1.0, t_lag=3.0), PID(kp=1.0, ti=5.0),
                                   ADRC(order=2, b0=0.05), Regulator(tr=0.5)],
                         ids=["leadlag", "pid", "adrc", "regulator"])  # fmt: skip
def test_no_export_spells_a_c_macro(block):
    from ctrlblocks.plc.c_macros import C_MACROS

    for target in ("codesys", "twincat", "tia"):  # the ST text (the XML targets carry the same)
        words = {w.upper() for w in _tokens_are_identifiers(plc.export(block, target))}
        assert not words & C_MACROS, (target, sorted(words & C_MACROS))
