"""The block contract: configuration, state, status and error codes.

Every function block of ctrlblocks has the same shape, so that a PLC
programmer, a test and a faceplate can treat them alike:

* a **configuration**: a frozen dataclass, validated when the block is made
  and on every :meth:`Block.configure`; a refused change raises
  :class:`ParameterError` and leaves the old, valid configuration in force;
* a small, explicit **state**: plain Python floats held as attributes, named
  in ``_state_fields``; :meth:`Block.snapshot` copies them and
  :meth:`Block.restore` puts them back;
* a one-call **step**: ``y = block(u)``, called once per sample.  Time is an
  input: the configured sample time ``ts`` or a ``dt`` passed to the call.
  No block reads a clock;
* a **status**: ``error`` (bool) and ``error_id`` (int, one of
  :class:`ErrorCode`).  Process data never raises in a step: a NaN/inf input,
  an invalid-measurement flag or a bad ``dt`` gives a documented fallback
  (normally: hold the last output) and an error code, and the block recovers
  by itself when the input recovers.  Errors from process data are *live*: they
  describe the last cycle and clear when the cause goes away;
* :meth:`Block.reset` returns the block to its initial state;
* a readable ``repr``.

Error codes reuse those of the CODESYS ``PID_Controller`` of controltheplant 2024
(section 2.2, "Status & Error codes") where the meaning is the same, and add
ctrlblocks' own codes in the same 16#8xxx style: 16#80xx cycle time,
16#81xx process data, 16#82xx configuration, 16#83xx warnings (the block keeps
running normally; only a status flag is set).  ``docs/error-codes.md`` lists
them all; a test keeps that table and :class:`ErrorCode` identical.

Blocks whose state a surrounding structure must shape (saturation, selectors,
cascades) also offer the two-phase form of Åström (1987, section 6,
Listing 6.3): ``compute_output(...)`` returns the output without touching the
state; the structure shapes it; ``update_state(applied)`` then updates the
state with the value actually applied, so anti-windup tracking uses
simultaneous values.  Every two-phase block (PID, ADRC) keeps this contract
the same way:

* ``compute_output`` computes the cycle from the *committed* state and keeps
  the result as ONE pending value (``self._pending``, an immutable tuple of
  what the second phase needs; None when no cycle is pending).  It writes the
  readable outputs (``out``, the terms, ``error_id``) but no state: called
  again in the same cycle it starts from the committed state again and
  replaces the pending value, so it gives the same result for the same
  inputs.  Sub-blocks that commit when called (the PID's filters and ramps)
  are run from their committed state and their new state travels in the
  pending value too;
* ``update_state(applied)`` commits the pending value with ``applied`` and
  clears it; without a pending value it does nothing;
* ``reset``, ``restore`` and ``load_kernel_state`` drop a pending value; the
  output guard's ``_resume`` (after ``BAD_RESULT``) rewrites it, so that the
  commit re-initialises the block bumplessly.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import functools
import math
import numbers
import sys
from collections.abc import Callable
from enum import IntEnum
from typing import Any, ClassVar

import numpy as np


class ErrorCode(IntEnum):
    """Status and error codes of every block (``block.error_id``).

    Codes marked *controltheplant 2024* keep the number and meaning of the CODESYS
    ``PID_Controller`` (controltheplant 2024, section 2.2).
    """

    NO_ERROR = 0x0000
    """No error (controltheplant 2024, ``STATUS_NO_ERRORS``)."""

    # --- 16#80xx: cycle time -------------------------------------------------
    NO_CYCLE = 0x8001
    """Cycle time ``ts`` or per-call ``dt`` is zero, negative or not finite
    (controltheplant 2024, ``ERR_NO_CYCLE``).  At run time: the block holds its last output."""

    # --- 16#81xx: process data (set by the step, never raised) ---------------
    BAD_INPUT = 0x8101
    """A process input (setpoint, measurement, feed-forward, ...) is NaN or inf.
    The block holds its last output (or its safe value) and recovers when the
    input is finite again."""
    BAD_MEASUREMENT = 0x8102
    """The measurement was declared invalid by its quality flag (``y_ok`` /
    ``pv_ok`` false).  Fallback as for ``BAD_INPUT``."""
    BAD_RESULT = 0x8103
    """The law computed a value that is not finite (an overflow from extreme
    but finite data, a huge ``dt`` or an unstable discretisation).  The
    output guard of :class:`Block` holds the last valid output (or the safe
    value), limited to the limits in force, re-initialises the block's memory
    so that it continues without a bump, and the code clears by itself when
    the cause goes."""

    # --- 16#82xx: configuration (raised as ParameterError) -------------------
    BAD_LIMITS = 0x8201
    """Bad low and/or high limits, e.g. low > high (controltheplant 2024, ``ERR_BAD_LIMITS``).
    Raised for a configuration; for limits written at run time (``set_limits``)
    it is a status: the last valid limits stay in force until a valid pair is
    written."""
    CANT_TRACK_SETP = 0x8202
    """Bumpless method TRACK_SETPOINT selected but the setpoint ramp is zero
    (controltheplant 2024, ``ERR_CANT_TRACK_SETP``)."""
    BAD_RATE = 0x8203
    """A rate of change is negative or not finite (controltheplant 2024, ``ERR_BAD_RATE``)."""
    BACK_CALC_T = 0x8205
    """Bad back-calculation (tracking) time constant (controltheplant 2024, ``ERR_BACK_CALC_T``)."""
    BAD_ANTIWINDUP = 0x8207
    """Error in the anti-windup settings (controltheplant 2024, ``ERR_BAD_ANTIWINDUP``)."""
    BAD_STAB_TIME = 0x8209
    """Stabilisation time must be positive (controltheplant 2024, ``ERR_BAD_STAB_TIME``)."""
    BAD_DEV_TOL = 0x820A
    """Deviation tolerance must lie in 0..50 % (controltheplant 2024, ``ERR_BAD_DEV_TOL``)."""
    BAD_PID_COEFFS = 0x820B
    """Wrong PID parameters (controltheplant 2024, ``ERR_BAD_PID_COEFFS``)."""
    BAD_PARAMETER = 0x8210
    """Any other invalid parameter: not a finite number, an unknown option
    name, a wrong type."""
    BAD_TIME_CONSTANT = 0x8211
    """A filter or lag time constant is negative or not finite."""
    BAD_WINDOW = 0x8212
    """A window length (moving average, dead-time buffer) is not a positive integer."""
    BAD_ORDER = 0x8213
    """ADRC order is not 1, 2 or 3."""
    BAD_B0 = 0x8214
    """ADRC scaling parameter b0 is not positive and finite."""
    BAD_BANDWIDTH = 0x8215
    """ADRC bandwidth omega_c or omega_o is not positive and finite."""
    BAD_FORM = 0x8216
    """A PID cannot be converted to the requested form (series form needs
    Ti >= 4 Td, Åström 1987, (2.6))."""

    # --- 16#83xx: warnings (status only, the block runs normally) ------------
    WARN_DISCRETISATION = 0x8301
    """The discretisation is outside the range where it is trustworthy
    (e.g. ADRC omega_o * ts too large for the Euler observer)."""


class Mode(IntEnum):
    """Operating mode of a controller block (controltheplant 2024, section 2.3.5).

    Priority when several requests are active (controltheplant 2024): RESET > TRACK >
    HOLD > MANUAL > AUTO.
    """

    AUTO = 0
    MANUAL = 1
    TRACK = 2
    HOLD = 3
    RESET = 4


class ParameterError(ValueError):
    """An invalid configuration value, refused where it was made.

    Carries the numeric ``code`` (an :class:`ErrorCode`) and the ``field``
    that was refused.  Raised by constructors and by ``configure``; the block
    keeps its previous configuration.
    """

    def __init__(self, code: ErrorCode, field: str, message: str) -> None:
        self.code = ErrorCode(code)
        self.field = field
        self.message = message
        super().__init__(f"{field}: {message} (error 16#{self.code:04X} {self.code.name})")


# ---------------------------------------------------------------------------
# Validation helpers for configuration dataclasses
# ---------------------------------------------------------------------------


def _is_number(value: Any) -> bool:
    """True for a real number a configuration may hold: int, float, numpy numbers, Fraction.

    Not for a bool (``True`` is no gain), a numpy ``bool_``, a string (``"0.5"`` is
    refused, never stored or converted: a configuration holds numbers only), an
    array or anything else.
    """
    t = type(value)
    if t is float or t is int:
        return True
    return t is not bool and isinstance(value, numbers.Real) and not isinstance(value, np.bool_)


def require_finite(name: str, value: Any, code: ErrorCode = ErrorCode.BAD_PARAMETER) -> float:
    """Return ``value`` as a float, or raise ParameterError if it is not a finite number.

    Accepted: :func:`_is_number` values (``int``, ``float``, numpy numbers); an int too
    large for a float (``10**400``) is refused like an infinite value.  Refused with
    ``code``: strings (also numeric ones), bools, ``None``, arrays, NaN and +-inf.
    """
    if not _is_number(value):
        raise ParameterError(code, name, f"must be a number, got {value!r}")
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ParameterError(code, name, f"must be a finite number, got {value!r}") from None
    if not math.isfinite(x):
        raise ParameterError(code, name, f"must be finite, got {value!r}")
    return x


def require_range(name: str, value: Any) -> tuple[float, float] | None:
    """A PV range ``(lo, hi)`` scaled to 0..100 % (controltheplant 2024 ``rangeLo/rangeHi``).

    None (no scaling) passes; else a pair of finite numbers with ``lo < hi`` whose
    span ``hi - lo`` is finite too (a span that overflows would scale every PV to 0),
    or ParameterError ``BAD_LIMITS``.
    """
    if value is None:
        return None
    try:
        lo, hi = value
    except (TypeError, ValueError):
        raise ParameterError(
            ErrorCode.BAD_LIMITS, name, "must be None or a pair (lo, hi)"
        ) from None
    lo = require_finite(name, lo, ErrorCode.BAD_LIMITS)
    hi = require_finite(name, hi, ErrorCode.BAD_LIMITS)
    if not lo < hi:
        raise ParameterError(ErrorCode.BAD_LIMITS, name, f"needs lo < hi, got {value!r}")
    if not math.isfinite(hi - lo):
        raise ParameterError(ErrorCode.BAD_LIMITS, name, f"its span hi - lo overflows: {value!r}")
    return lo, hi


def require_positive(name: str, value: Any, code: ErrorCode = ErrorCode.BAD_PARAMETER) -> float:
    """Return ``value`` as a float > 0, or raise ParameterError with ``code``."""
    x = require_finite(name, value, code)
    if x <= 0.0:
        raise ParameterError(code, name, f"must be > 0, got {value!r}")
    return x


def require_nonnegative(name: str, value: Any, code: ErrorCode = ErrorCode.BAD_PARAMETER) -> float:
    """Return ``value`` as a float >= 0, or raise ParameterError with ``code``."""
    x = require_finite(name, value, code)
    if x < 0.0:
        raise ParameterError(code, name, f"must be >= 0, got {value!r}")
    return x


def require_choice(
    name: str, value: Any, choices: tuple[str, ...], code: ErrorCode = ErrorCode.BAD_PARAMETER
) -> str:
    """Return ``value`` if it is one of ``choices``, else raise ParameterError with ``code``."""
    if not isinstance(value, str) or value not in choices:
        raise ParameterError(code, name, f"must be one of {', '.join(choices)}; got {value!r}")
    return value


def require_bool(name: str, value: Any) -> bool:
    """Return ``value`` if it is a bool (``True``/``False``), else raise BAD_PARAMETER."""
    if not isinstance(value, bool):
        raise ParameterError(ErrorCode.BAD_PARAMETER, name, f"must be True or False, got {value!r}")
    return value


def require_limits(
    lo_name: str,
    lo: Any,
    hi_name: str,
    hi: Any,
    *,
    allow_infinite: bool = True,
    code: ErrorCode = ErrorCode.BAD_LIMITS,
) -> tuple[float, float]:
    """Return the limit pair as floats, or raise ParameterError (``code``, default
    BAD_LIMITS) if either is not a number (a bool is not) or NaN, or if reversed.

    Infinite limits (``-inf``/``inf``: no limit) are accepted unless
    ``allow_infinite`` is false.
    """
    field = f"{lo_name}/{hi_name}"
    try:
        if not (_is_number(lo) and _is_number(hi)):
            raise TypeError
        lo_f, hi_f = float(lo), float(hi)
    except (TypeError, ValueError, OverflowError):
        raise ParameterError(code, field, f"must be numbers, got {lo!r}, {hi!r}") from None
    if math.isnan(lo_f) or math.isnan(hi_f):
        raise ParameterError(code, field, "must not be NaN")
    if not allow_infinite and not (math.isfinite(lo_f) and math.isfinite(hi_f)):
        raise ParameterError(code, field, "must be finite")
    if lo_f > hi_f:
        raise ParameterError(code, field, f"low limit {lo_f!r} is above high limit {hi_f!r}")
    if lo_f == math.inf or hi_f == -math.inf:
        raise ParameterError(code, field, f"leave no finite value between {lo_f!r} and {hi_f!r}")
    return lo_f, hi_f


def require_coefficients(field: str, code: ErrorCode, *values: float) -> None:
    """Refuse a configuration whose derived coefficients are not finite.

    Called by a block's ``_apply_config`` on the gains, poles and matrices it
    derives: a finite but extreme parameter (``n = 5e-324``, ``kp = 1e308`` with
    ``ti = 1e-300``) whose coefficients overflow is refused with ``code`` on
    ``field`` (and :meth:`Block.configure` keeps the old configuration).  An
    overflow that only extreme *data* causes is caught by the output guard
    instead (``BAD_RESULT``).
    """
    for v in values:
        if not math.isfinite(v):
            raise ParameterError(
                code, field, f"gives a coefficient that is not finite ({v!r}); too extreme"
            )


def as_input(x: Any) -> float:
    """The one conversion of a process input at a block's edge: a float, NaN when unusable.

    ``float`` passes as is; ``int`` (also a ``bool``: ``True`` is 1.0, as a PLC's
    BOOL_TO_REAL), numpy scalars (``float16``, ``float32``, ``int64``,
    ``bool_``, ...) and any other real number become the nearest float.  An int
    beyond the float range (``10**400``), a string, ``None``, an array or any
    other object becomes NaN, so the block treats it as a bad input
    (``BAD_INPUT``); this function never raises.
    """
    if type(x) is float:
        return x
    if isinstance(x, (str, bytes, np.ndarray)):
        return math.nan
    try:
        return float(x)
    except (TypeError, ValueError, OverflowError):
        return math.nan


def as_flag(x: Any, default: bool) -> bool:
    """A boolean process input (``enable``, ``pv_ok``, a button): never raises.

    ``bool``, numpy ``bool_`` and numbers are read as truth values (a NaN number is
    ``default``); anything else (``None``, a string, an array) is ``default``:
    the caller passes the safe reading (``pv_ok`` unusable reads as False).
    """
    if type(x) is bool:
        return x
    if isinstance(x, (numbers.Number, np.bool_, np.number)):
        try:
            return default if x != x else bool(x)
        except (TypeError, ValueError):
            return default
    return default


MAX_TIME = sys.float_info.max
"""The largest time an accumulating block keeps [s] (:func:`add_time`)."""


def add_time(t: float, h: float) -> float:
    """``t + h`` for a time accumulated over samples, saturating at :data:`MAX_TIME`.

    A clock a block keeps (time held, run time, time steady) grows by the
    sample time each cycle; an absurd but finite ``dt`` (1e308) must not make
    it +inf, which then turns into NaN in the first difference or product.
    """
    s = t + h
    return s if s <= MAX_TIME else MAX_TIME


def is_finite(x: Any) -> bool:
    """True if ``x`` is a finite real number (after :func:`as_input`); never raises.

    False for NaN, inf, None, strings, arrays and ints beyond the float range.
    Used on process data in the step, where a bad value must never raise.
    """
    return math.isfinite(as_input(x))


# ---------------------------------------------------------------------------
# The block base class
# ---------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class BlockConfig:
    """Base of every block configuration: a frozen, validated dataclass.

    Subclasses add their fields and override :meth:`validate`, which must
    raise :class:`ParameterError` for any invalid value.

    Numbers are converted once, when the configuration is made: a field
    annotated ``float`` (or ``float | None``, or a tuple of floats) that holds an
    ``int`` or a numpy number holds the equal ``float`` afterwards, and an
    ``int`` field that holds a numpy integer holds a Python ``int``.  Anything
    else (a string such as ``"0.5"``, a bool, an int beyond the float range) is
    left as given for :meth:`validate` to refuse: a configuration never holds a
    string where a number belongs.
    """

    def __post_init__(self) -> None:
        cls: type = type(self)
        for name, kind in _numeric_fields(cls):
            v = getattr(self, name)
            if kind == "tuple" and isinstance(v, (tuple, list)):
                if all(_is_number(x) for x in v):
                    with contextlib.suppress(OverflowError):  # validate refuses 10**400
                        object.__setattr__(self, name, tuple(float(x) for x in v))
                continue
            if type(v) is (float if kind == "float" else int) or not _is_number(v):
                continue
            if kind == "int":
                if isinstance(v, numbers.Integral):
                    object.__setattr__(self, name, int(v))
                continue
            with contextlib.suppress(OverflowError):  # 10**400: validate refuses it
                object.__setattr__(self, name, float(v))

    def validate(self) -> None:
        """Raise ParameterError if the configuration is invalid."""


@functools.cache
def _numeric_fields(cls: type) -> tuple[tuple[str, str], ...]:
    """``(name, kind)`` of the fields of a config class that hold numbers (see BlockConfig)."""
    kinds = {"float": "float", "float | None": "float", "int": "int"}
    out = []
    for f in dataclasses.fields(cls):
        t = f.type if isinstance(f.type, str) else getattr(f.type, "__name__", "")
        if t in kinds:
            out.append((f.name, kinds[t]))
        elif t.startswith("tuple[float"):
            out.append((f.name, "tuple"))
    return tuple(out)


_NINF, _INF = -math.inf, math.inf
_deepcopy = copy.deepcopy


def _itself(x: Any) -> Any:
    return x


def _guard(step: Callable[..., Any]) -> Callable[..., Any]:
    """Wrap a block's step so that no non-finite or out-of-limit ``out`` leaves it.

    The one output rule of every block (see :meth:`Block._contain`): after the
    step, ``out`` must be finite and inside :meth:`Block.output_limits`.
    """

    @functools.wraps(step)
    def guarded(self: Block, *args: Any, **kwargs: Any) -> Any:
        prev = self.out
        return self._checked(prev, step(self, *args, **kwargs))

    guarded._output_guard = True  # type: ignore[attr-defined]
    return guarded


def _guard_steps(cls: type[Block], **kwargs: Any) -> None:
    """Put the output guard (:func:`_guard`) around the step methods a subclass defines.

    ``_guarded_steps`` counts for the class that sets it: PID and ADRC set it
    empty because their steps call the guard themselves (``Block._checked``,
    as their compiled build must); a subclass of theirs has its own overrides
    wrapped again.
    """
    super(Block, cls).__init_subclass__(**kwargs)
    for name in vars(cls).get("_guarded_steps", Block._guarded_steps):
        fn = vars(cls).get(name)
        if fn is not None and not getattr(fn, "_output_guard", False):
            setattr(cls, name, _guard(fn))


class Block:
    """Base class of every function block (see the module docstring).

    Subclasses set ``Config`` (a :class:`BlockConfig` subclass) and
    ``_state_fields`` (names of the state attributes), and implement
    ``_apply_config(old)`` (derive cached coefficients; ``old`` is the previous
    configuration or None) and ``_reset_state()``.
    """

    Config: ClassVar[type[BlockConfig]] = BlockConfig
    _state_fields: ClassVar[tuple[str, ...]] = ()
    _guarded_steps: ClassVar[tuple[str, ...]] = ("__call__", "compute_output")
    # the attributes a compiled build keeps outside __dict__, space-separated (pid.pxd ...)
    _declared: ClassVar[str] = ""

    error_id: int

    __init_subclass__ = classmethod(_guard_steps)

    def __init__(self, config: BlockConfig | None = None, /, **params: Any) -> None:
        if config is None:
            config = self._make_config(params)
        elif params:
            config = self._replace_config(config, params)
        if not isinstance(config, self.Config):
            raise TypeError(f"{type(self).__name__} needs a {self.Config.__name__}")
        config.validate()
        self._config = config
        self._apply_config(None)
        self.reset()

    # -- configuration -----------------------------------------------------

    @property
    def config(self) -> BlockConfig:
        """The configuration in force (immutable; change it with :meth:`configure`)."""
        return self._config

    def configure(self, **changes: Any) -> None:
        """Change configuration fields, validated as a whole.

        On any error a :class:`ParameterError` (or ``TypeError`` for an unknown
        name) is raised and the old configuration stays in force.  Blocks with
        memory apply the change bumplessly where their docstring says so.
        """
        new = self._replace_config(self._config, changes)
        new.validate()
        old = self._config
        # _apply_config refuses (require_coefficients, ...) before it changes any state,
        # so the attribute bindings of before the call restore everything
        saved = dict(vars(self))
        # and those of a compiled build's C struct (_declared), which are not in __dict__
        kept = {
            name: getattr(self, name)
            for name in self._declared.split()
            if name not in saved and hasattr(self, name)
        }
        self._config = new
        try:
            self._apply_config(old)
        except Exception:
            vars(self).clear()
            vars(self).update(saved)
            for name, value in kept.items():
                setattr(self, name, value)
            raise
        self._relimit()

    def _relimit(self) -> None:
        """Limit ``out`` to the limits now in force (after a change of the limits)."""
        lo, hi = self.output_limits()
        y = self.out
        if not lo <= y <= hi:
            self._contain(y, y, lo, hi)

    def _make_config(self, params: dict[str, Any]) -> BlockConfig:
        try:
            return self.Config(**params)
        except TypeError as exc:
            raise TypeError(f"{type(self).__name__}: {exc}") from None

    def _replace_config(self, config: BlockConfig, changes: dict[str, Any]) -> BlockConfig:
        names = {f.name for f in dataclasses.fields(config)}
        unknown = sorted(set(changes) - names)
        if unknown:
            raise TypeError(
                f"{type(self).__name__} has no parameter {', '.join(unknown)}; "
                f"known: {', '.join(sorted(names))}"
            )
        return dataclasses.replace(config, **changes)

    def _apply_config(self, old: BlockConfig | None) -> None:
        """Derive cached coefficients from ``self._config`` (override)."""

    # -- state -------------------------------------------------------------

    def reset(self) -> None:
        """Return to the initial state: initial output, empty memories, no error."""
        self.error_id = ErrorCode.NO_ERROR
        self._reset_state()

    def _reset_state(self) -> None:
        """Set every state attribute to its initial value (override)."""

    def start_at(self, out: float) -> None:
        """Start again at rest from the output ``out``: :meth:`reset`, then the next
        valid cycle continues from ``out`` without a bump.

        For a runtime that finds its device's MV after a restart or an outage,
        when the block's own state is too old to continue from: the block
        starts as if ``out`` had been applied for ever -- an ADRC's observer at
        rest on the next measurement with ``x4 = -b0 out`` (then its handover
        gives ``out``), a PID's integrator at ``out`` -- the restart a failed
        cycle makes from its held output (:meth:`_resume`), limited to
        :meth:`output_limits`.  A non-finite ``out`` is a plain :meth:`reset`.
        """
        self.reset()
        if _NINF < out < _INF:
            lo, hi = self.output_limits()
            self.out = held = lo if out < lo else hi if out > hi else float(out)
            self._resume(held)

    def snapshot(self, *, copy: bool = True) -> dict[str, Any]:
        """A copy of the block's state; :meth:`restore` puts it back.

        ``copy=False`` gives the block's own state objects (a moving average's
        buffer, ...), to compare two blocks' states at once, cheaply (the fuzz
        campaign of ``ctrlblocks.testing`` does after every action): neither
        keep nor restore it.
        """
        cp = _deepcopy if copy else _itself
        snap = {name: cp(getattr(self, name)) for name in self._state_fields}
        snap["error_id"] = self.error_id
        return snap

    def restore(self, snapshot: dict[str, Any]) -> None:
        """Restore a state taken by :meth:`snapshot` (configuration is unchanged)."""
        missing = [n for n in self._state_fields if n not in snapshot]
        if missing:
            raise ValueError(f"snapshot lacks state fields: {', '.join(missing)}")
        for name in self._state_fields:
            setattr(self, name, copy.deepcopy(snapshot[name]))
        self.error_id = snapshot.get("error_id", ErrorCode.NO_ERROR)

    # -- the output guard ------------------------------------------------------

    def _checked(self, prev: float, result: Any) -> Any:
        """The output rule after a step that started from ``out == prev`` (:func:`_guard`)."""
        y = self.out
        lo, hi = self.output_limits()
        if lo <= y <= hi and _NINF < y < _INF:
            return result
        held = self._contain(prev, y, lo, hi)
        return held if isinstance(result, float) else result

    def output_limits(self) -> tuple[float, float]:
        """The limits ``out`` must lie in, as in force now (override; default: none)."""
        return _NINF, _INF

    def _fallback(self, prev: float) -> float:
        """The value to output when the law fails: the last valid output (override)."""
        return prev

    def _contain(self, prev: float, y: float, lo: float, hi: float) -> float:
        """Replace an output that is not finite or outside ``[lo, hi]``; return the new one.

        A finite value outside the limits (a held output after the limits were
        narrowed) is limited; the status is left as the step set it.  A value
        that is not finite takes the fallback (:meth:`_fallback`: the last valid
        output ``prev`` or the safe value), limited to ``[lo, hi]`` (0 limited,
        if that is not finite either), sets ``BAD_RESULT`` and calls
        :meth:`_resume` so that the memory is finite again and the next good
        cycle continues from the held output without a bump.
        """
        if _NINF < y < _INF:
            self.out = lo if y < lo else hi
            return self.out
        held = self._fallback(prev)
        held = lo if held < lo else hi if held > hi else held
        if not _NINF < held < _INF:
            held = lo if lo > 0.0 else hi if hi < 0.0 else 0.0
        self.out = held
        self.error_id = ErrorCode.BAD_RESULT
        self._resume(held)
        return held

    def _resume(self, held: float) -> None:
        """Make the state finite after a failed step, continuing from ``held`` (override).

        Default: every float state attribute that is not finite becomes
        ``held`` (``out``) or 0.0.  Blocks with memory override it to
        re-initialise bumplessly.
        """
        for name in self._state_fields:
            v = getattr(self, name)
            if isinstance(v, float) and not _NINF < v < _INF:
                setattr(self, name, 0.0)
        if "_plc_state" in self._state_fields:
            self._plc_state = None  # the precision="float32" cycle restarts
        self.out = held

    # -- status ------------------------------------------------------------

    @property
    def error(self) -> bool:
        """True when the last cycle or call reported an error (``error_id != 0``).

        Warnings (16#83xx) do not set ``error``.
        """
        return self.error_id != 0 and not (0x8300 <= self.error_id < 0x8400)

    @property
    def error_name(self) -> str:
        """Symbolic name of ``error_id`` (``"NO_ERROR"`` when all is well)."""
        try:
            return ErrorCode(self.error_id).name
        except ValueError:
            return f"16#{self.error_id:04X}"

    # -- time ----------------------------------------------------------------

    def _cycle_time(self, dt: float | None, ts: float) -> float | None:
        """The sample time of this call: ``ts`` when ``dt`` is None, else ``dt``.

        Returns None (and sets ``NO_CYCLE``) when ``dt`` is zero, negative or
        not finite; the caller then holds its last output.
        """
        if dt is None:
            return ts
        h = as_input(dt)
        if _NINF < h < _INF and h > 0.0:
            return h
        self.error_id = ErrorCode.NO_CYCLE
        return None

    # -- presentation --------------------------------------------------------

    def __repr__(self) -> str:
        fields = ", ".join(
            f"{f.name}={getattr(self._config, f.name)!r}" for f in dataclasses.fields(self._config)
        )
        status = f"out={getattr(self, 'out', None)!r}"
        if self.error_id:
            status += f", error_id=16#{self.error_id:04X} {self.error_name}"
        return f"{type(self).__name__}({fields}) <{status}>"
