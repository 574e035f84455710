"""The fuzz campaign of the block contract, for any block with a :class:`FuzzSpec`.

One implementation of the actions and the checks (:class:`Driver`), used by two
drivers:

* the hypothesis state machine of ``tests/blocks/test_fuzz_campaign.py`` (short
  CI profile, shrinking), which picks every action and value itself;
* the plain seeded random driver of this module, for the long campaign::

      python -m ctrlblocks.testing --steps 10000000          # per block
      python -m ctrlblocks.testing --steps 100000 --block PID --seed 3

  It prints a progress line every ``--every`` seconds (also when stdout is not
  a terminal): steps, steps/s and the count per block, and exits with status
  1 on the first breach, printing the block, the seed, the step and the last
  actions as Python code (replay: the same command with ``--block``,
  ``--seed`` and ``--steps`` up to that step).

A block takes part through its :class:`FuzzSpec` (:func:`register_fuzz`):
a random valid configuration, how one process step feeds it (default: a
:class:`~ctrlblocks.blocks.protocols.Controller` through its interface, with
a first-order plant in the loop; any other block called with one value),
and what else applies to it (its modes, its limits, its own oracle).

The checks after every action (:class:`Breach` names the broken promise):

1. no exception from process data (inputs, flags, ``dt``, modes, limits);
2. ``out`` finite and inside :meth:`~ctrlblocks.Block.output_limits`;
3. a refused ``configure`` raises :class:`~ctrlblocks.ParameterError` with an
   error code and leaves configuration and state (``snapshot()``) unchanged;
4. the per-call path (``block(...)``, fast lane where it applies) equals the
   two-phase path (``compute_output`` then ``update_state``) of a twin block
   driven with the same actions: same ``out`` (:data:`LANE_TOL`) and ``error_id``,
   and the same state (``snapshot()``, floats to :data:`LANE_TOL`), for every
   block with both paths (PID, ADRC, GainSchedule);
5. a controller's first AUTO cycle after MANUAL/TRACK/HOLD/RESET, and the
   first good cycle after a bad input (``BAD_INPUT``, ``BAD_MEASUREMENT``,
   ``BAD_RESULT``), continue from the last output within :data:`BUMP_TOL`;
6. ``restore(snapshot())`` then the same step gives the same output and status;
7. the state stays finite: every float of ``snapshot()`` (and of the
   statistics a block reports, such as ``CycleMonitor.jitter_std``) is finite
   after every action -- a state that overflowed behind a finite output (an
   accumulator of an absurd ``dt``, an observer in MAN) is a breach even when
   the output is held;
8. a block's own oracle where it has one (:attr:`FuzzSpec.oracle`: the moving
   average is the mean of the window it holds; the cycle monitor's flags
   follow the live condition unless latched, and ``acknowledge()`` sets them
   back to it).
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
import inspect
import math
import random
import sys
import time
import traceback
from collections.abc import Callable
from typing import Any

import numpy as np

from ..blocks.base import Block, ErrorCode, Mode, ParameterError

__all__ = [
    "BAD_PARAMS",
    "BUMP_TOL",
    "FUZZ_SPECS",
    "HOSTILE",
    "HOSTILE_DT",
    "LANE_TOL",
    "Breach",
    "Driver",
    "FuzzSpec",
    "RandomRun",
    "exported_blocks",
    "main",
    "register_fuzz",
    "run",
    "traces",
]

LANE_TOL = 1e-9
"""Per-call and two-phase outputs agree to ``LANE_TOL * max(1, |out|)`` (they run the
same operations, so in practice they are equal)."""

BUMP_TOL = 1e-9
"""A bumpless transfer moves the output by at most ``BUMP_TOL * scale``, ``scale`` =
``max(1, |u|, |P| + |I| + |D| + |FF|)`` (PID) or ``max(1, |u|, |u_raw|)`` (ADRC): the
rounding of re-solving the integrator (PID) or x4 (ADRC, Nowak et al. 2018, (11))."""

_MAX = sys.float_info.max
HOSTILE: tuple[Any, ...] = (
    math.nan, math.inf, -math.inf, -0.0, 5e-324, -5e-324, 1e-310, 1e300, -1e300, _MAX, -_MAX,
    10**400, -(10**400), np.float16(513), np.float16(-0.0), np.float16(65504), np.float32(3.3),
    np.float32(1e38), np.int64(7), np.int64(-(2**62)), np.bool_(True), True, False, 3, -2,
    None, "1", 1 + 1j,
)  # fmt: skip
"""Hostile process values: NaN, +-inf, -0.0, denormals, huge, max float, 10**400, numpy
scalars, ints, bools, and non-numbers."""

HOSTILE_DT: tuple[Any, ...] = (
    0.0, -0.1, math.nan, math.inf, -math.inf, 5e-324, 1e-300, 1e300, _MAX, 10**400,
    np.float32(0.05), np.float16(0.1), 1e-9, 3600.0, 2, True, "0.1",
)  # fmt: skip
"""Hostile per-call sample times: 0, negative, NaN, inf, tiny, huge and odd types."""

BAD_PARAMS: tuple[Any, ...] = (
    math.nan, math.inf, -math.inf, -1.0, 0.0, "1", None, True, 10**400, 5e-324, 1e308,
    -1e308, [1, 2], 7, np.float32(2.0), np.int64(3),
)  # fmt: skip
"""Values for random reconfigurations (most are refused, some accepted)."""

_FLAG_VALUES: tuple[Any, ...] = (True, False, np.bool_(True), np.bool_(False), 1, 0, None)


class Breach(AssertionError):
    """A broken promise of the block contract (the message names it)."""


# ---------------------------------------------------------------------------
# How the campaign makes and drives one block type
# ---------------------------------------------------------------------------

Step = Callable[[Any, bool, list[Any], Any, list[Any], float], Any]
"""``step(block, two_phase, vals, dt, flags, y)``: one process step of ``block``.

``vals`` are five process values (``vals[1]`` None: the plant's output ``y``),
``dt`` the sample time argument (None: the block's own), ``flags`` three
quality or switch flags; ``two_phase``: ``compute_output`` then
``update_state`` instead of the one call."""


def controller_step(b: Any, two_phase: bool, vals: list[Any], dt: Any, flags: list[Any],
                    y: float) -> Any:  # fmt: skip
    """The step of a :class:`~ctrlblocks.blocks.protocols.Controller`: ``(sp, pv)`` with
    ``pv_ok`` and ``dt``, in one call or in two phases."""
    sp, pv = vals[0], (vals[1] if vals[1] is not None else y)
    if two_phase:
        v = b.compute_output(sp, pv, pv_ok=flags[0], dt=dt)
        b.update_state(v)
        return v
    return b(sp, pv, pv_ok=flags[0], dt=dt)


def _plain_step(takes_dt: bool) -> Step:
    def step(b: Any, two_phase: bool, vals: list[Any], dt: Any, flags: list[Any], y: float) -> Any:
        return b(vals[0], dt=dt) if takes_dt else b(vals[0])

    return step


def _takes_dt(cls: type) -> bool:
    try:
        return "dt" in inspect.signature(cls.__call__).parameters
    except (TypeError, ValueError):
        return False


def _default_twin(ctl: Any) -> bool:
    return getattr(ctl.config, "precision", "float64") == "float64"


@dataclasses.dataclass(frozen=True)
class FuzzSpec:
    """How the campaign makes and drives one block type (module docstring).

    Parameters
    ----------
    name : str
        The block's name in the campaign (``--block NAME``).
    cls : type
        Its class.
    config : callable
        ``config(random.Random) -> dict``: the keyword arguments of a random
        configuration (valid or not: a refused one is drawn again).
    step : callable, optional
        One process step (:data:`Step`); default: :func:`controller_step` for
        a controller, else ``block(value)`` (``block(value, dt=dt)`` when its
        call takes ``dt``).
    make : callable, optional
        ``make(config) -> block`` (default ``cls(**config)``).
    controller : bool, optional
        A setpoint/measurement block with modes and limits, run with a plant
        in the loop (default: ``cls`` has the Controller interface's methods).
    two_phase : bool, optional
        Promise 4 applies: a twin runs the two phases (default: ``controller``).
    bumpless : bool, optional
        Promise 5 applies (default: ``controller``).
    modes : tuple of str
        The mode inputs the campaign switches (``manual``, ``track``, ...).
    mode_values : dict
        Mode -> the input of its value (``manual`` -> ``manual_value``).
    limit_fields : tuple of str
        The configuration's output limit fields, for a block without
        ``set_limits`` (``("lo", "hi")``); empty: none.
    inner : callable, optional
        The controller a wrapper block drives (``GainSchedule.controller``):
        modes, limits and the checks act on it.
    twin_ok : callable, optional
        ``twin_ok(controller) -> bool``: whether this configuration has a
        two-phase path equal to the one call (default: float64 precision).
    configurable : bool
        The campaign reconfigures it (``configure``).
    acknowledge : callable, optional
        It has ``acknowledge()`` (the cycle monitor), an action of the campaign;
        ``acknowledge(block) -> str | None`` says what is wrong after it.
    oracle : callable, optional
        ``oracle(block) -> str | None``: what is wrong by the block's own
        measure after an action (promise 8).
    nonfinite_state : tuple of str
        State that is not finite by design (promise 7 skips it).
    records_inputs : bool
        Its state records the process values as they came, NaN included
        (the alarm blocks): promise 7 does not apply.
    float32 : bool
        :func:`traces` also draws seeds that start in ``precision="float32"``.
    """

    name: str
    cls: type
    config: Callable[[random.Random], dict[str, Any]]
    step: Step | None = None
    make: Callable[[dict[str, Any]], Any] | None = None
    controller: bool | None = None
    two_phase: bool | None = None
    bumpless: bool | None = None
    modes: tuple[str, ...] = ("manual", "awin")
    mode_values: dict[str, str] = dataclasses.field(
        default_factory=lambda: {"manual": "manual_value"}
    )
    limit_fields: tuple[str, ...] = ()
    inner: Callable[[Any], Any] | None = None
    twin_ok: Callable[[Any], bool] = _default_twin
    configurable: bool = True
    acknowledge: Callable[[Any], str | None] | None = None
    oracle: Callable[[Any], str | None] | None = None
    nonfinite_state: tuple[str, ...] = ()
    records_inputs: bool = False
    float32: bool = False

    def __post_init__(self) -> None:
        if self.controller is None:
            methods = ("compute_output", "update_state", "set_limits")
            is_ctl = all(callable(getattr(self.cls, m, None)) for m in methods)
            object.__setattr__(self, "controller", is_ctl)
        for name in ("two_phase", "bumpless"):
            if getattr(self, name) is None:
                object.__setattr__(self, name, self.controller)
        if self.step is None:
            step = controller_step if self.controller else _plain_step(_takes_dt(self.cls))
            object.__setattr__(self, "step", step)

    def new(self, cfg: dict[str, Any]) -> Any:
        """A block of this configuration."""
        return self.cls(**cfg) if self.make is None else self.make(cfg)


FUZZ_SPECS: dict[str, FuzzSpec] = {}
"""Every block the campaign knows, by name (:func:`register_fuzz`; the shipped ones:
:mod:`.generators`)."""


def register_fuzz(spec: FuzzSpec) -> None:
    """Make ``spec``'s block part of the campaign (``run([spec.name], ...)``, ``--block``)."""
    FUZZ_SPECS[spec.name] = spec


def exported_blocks() -> dict[str, type[Block]]:
    """Every :class:`~ctrlblocks.Block` subclass exported by ``ctrlblocks.blocks``.

    (``ctrlblocks`` exports the same blocks; the test of the campaign checks
    that each has a :class:`FuzzSpec`.)
    """
    import ctrlblocks.blocks as package

    out = {}
    for name in package.__all__:
        obj = getattr(package, name)
        if inspect.isclass(obj) and issubclass(obj, Block) and obj is not Block:
            out[name] = obj
    return out


# ---------------------------------------------------------------------------
# The driver: actions and checks (one implementation for both drivers)
# ---------------------------------------------------------------------------


_USER_INPUTS = {"u_man", "manual_value", "track_value"}
"""Inputs a user writes that the snapshot keeps (the manual and track values): a NaN
there is a bad input the block reports and holds against, not a state it computed."""


def _non_finite(x: Any, path: str = "") -> str | None:
    """The path of the first non-finite float in a snapshot (dicts, sequences, arrays), or None.

    The float32 cycle's state (``_plc_state``) holds infinite limits as +-REAL_MAX,
    so it is finite too; ``None`` (no state yet) is fine.
    """
    if isinstance(x, float | np.floating):
        return None if -math.inf < x < math.inf else path or "value"
    if isinstance(x, dict):
        for k, v in x.items():
            if k in _USER_INPUTS:
                continue
            bad = _non_finite(v, f"{path}.{k}" if path else str(k))
            if bad:
                return bad
    elif isinstance(x, list | tuple):
        for i, v in enumerate(x):
            bad = _non_finite(v, f"{path}[{i}]")
            if bad:
                return bad
    elif isinstance(x, np.ndarray) and x.dtype.kind == "f" and not np.isfinite(x).all():
        return path
    return None


def _same(a: float, b: float, tol: float) -> bool:
    if a == b:
        return True
    return abs(a - b) <= tol * max(1.0, abs(a), abs(b))


def _snap_equal(a: Any, b: Any, tol: float = 0.0) -> bool:
    """Equality of snapshots that treats NaN as equal to NaN; floats to ``tol`` (relative)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_snap_equal(a[k], b[k], tol) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        if type(a) is list and type(b) is list and _plain_equal(a, b):
            return True  # a moving average's buffer: compared at C speed
        return len(a) == len(b) and all(_snap_equal(x, y, tol) for x, y in zip(a, b, strict=True))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return _arrays_equal(np.asarray(a), np.asarray(b), tol)
    if a != a and b != b:  # NaN, also a numpy NaN (the float32 cycle's state)
        return True
    if tol and type(a) is float and type(b) is float:
        return _same(a, b, tol)
    return bool(a == b)


def _arrays_equal(a: np.ndarray, b: np.ndarray, tol: float) -> bool:
    """:func:`_snap_equal` for arrays (the float32 PLC cycle's dead-band window):
    same shape, NaN equal to NaN, floats to ``tol`` (relative)."""
    if a.shape != b.shape:
        return False
    if a.dtype.kind not in "fc" or b.dtype.kind not in "fc":
        return bool(np.array_equal(a, b))
    x, y = a.astype(np.float64), b.astype(np.float64)
    both_nan = np.isnan(x) & np.isnan(y)
    with np.errstate(invalid="ignore", over="ignore"):
        close = (x == y) | (np.abs(x - y) <= tol * np.maximum(1.0, np.maximum(abs(x), abs(y))))
    return bool(np.all(close | both_nan))


def _plain_equal(a: Any, b: Any) -> bool:
    """``a == b`` at C speed, for containers of plain numbers (False where that cannot
    decide: NaN, tolerance and numpy arrays are :func:`_snap_equal`'s)."""
    try:
        return bool(a == b)
    except (TypeError, ValueError):  # numpy arrays inside
        return False


def _snap_diff(a: dict[str, Any], b: dict[str, Any], tol: float) -> str:
    """The first state variables in which two snapshots differ (for the breach report)."""
    keys = [k for k in a if k not in b or not _snap_equal(a[k], b[k], tol)]
    return ", ".join(f"{k}: {a.get(k)!r} vs {b.get(k)!r}" for k in keys[:4])


_BAD_DATA = (ErrorCode.BAD_INPUT, ErrorCode.BAD_MEASUREMENT, ErrorCode.BAD_RESULT)
_GOOD = (ErrorCode.NO_ERROR, ErrorCode.WARN_DISCRETISATION)


class Driver:
    """One block (and, for two-phase blocks, its twin) under the campaign's actions.

    Each ``act_*`` method performs one action with explicit values and then runs
    the checks; it raises :class:`Breach` when a promise is broken.  ``log``
    keeps the last actions as Python code for the reproducer.
    """

    def __init__(self, spec: FuzzSpec, cfg: dict[str, Any], log_len: int = 40) -> None:
        self.spec = spec
        # the last actions, formatted only for a report (formatting costs more than a step)
        self.log: collections.deque[tuple[Any, ...]] = collections.deque(maxlen=log_len)
        self.log.append(("new", cfg))
        try:
            self.block = spec.new(cfg)
            self.twin = spec.new(cfg) if self._twin_ok() else None
        except ParameterError:
            raise
        except Exception as exc:  # a valid-looking configuration must not crash the constructor
            raise Breach(f"{spec.name}({cfg!r}) raised {exc!r}") from exc
        self.y = 0.0  # plant output for controllers
        self.steps = 0
        self._check_out(self.block, "construction")

    # -- helpers ---------------------------------------------------------------

    def _ctl(self, b: Any) -> Any:
        return b if self.spec.inner is None else self.spec.inner(b)

    def _twin_ok(self) -> bool:
        return bool(self.spec.two_phase) and self.spec.twin_ok(self._ctl(self.block))

    def _check_out(self, b: Block, what: str) -> None:
        y = b.out
        lo, hi = self._ctl(b).output_limits()
        if not (isinstance(y, float) and -math.inf < y < math.inf):
            raise Breach(f"{self.spec.name}: out = {y!r} is not a finite float after {what}")
        if not lo <= y <= hi:
            raise Breach(f"{self.spec.name}: out = {y!r} outside [{lo!r}, {hi!r}] after {what}")
        if not isinstance(b.error_id, int):
            raise Breach(f"{self.spec.name}: error_id {b.error_id!r} is not an int")

    def _check_state(self, b: Block, what: str) -> None:
        """Promises 7 and 8: a finite state, and the block's own oracle."""
        snap = {} if self.spec.records_inputs else b.snapshot(copy=False)
        sentinels = self.spec.nonfinite_state
        bad = _non_finite({k: v for k, v in snap.items() if k not in sentinels})
        if bad:
            raise Breach(f"{self.spec.name}: state {bad} is not finite after {what}")
        oracle = self.spec.oracle
        why = oracle(b) if oracle is not None else None
        if why:
            raise Breach(f"{self.spec.name}: {why} after {what}")

    def act_acknowledge(self) -> None:
        """``acknowledge()`` of a block with alarm flags, then its :attr:`FuzzSpec.acknowledge`."""
        self.log.append(("acknowledge",))
        self._both("acknowledge", lambda b: b.acknowledge())
        self._check_state(self.block, "acknowledge")
        check = self.spec.acknowledge
        why = check(self.block) if check is not None else None
        if why:
            raise Breach(f"{self.spec.name}: acknowledge() left {why}")

    def _guarded(self, what: str, fn: Callable[[], Any]) -> Any:
        try:
            return fn()
        except Breach:
            raise
        except Exception as exc:
            raise Breach(f"{self.spec.name}: {what} raised {exc!r}") from exc

    def _both(self, what: str, fn: Callable[[Any], Any]) -> None:
        self._guarded(what, lambda: fn(self.block))
        if self.twin is not None:
            self._guarded(what + " (twin)", lambda: fn(self.twin))

    def _compare_twin(self, what: str) -> None:
        t = self.twin
        if t is None:
            return
        a, b = self.block, t
        if not _same(a.out, b.out, LANE_TOL) or a.error_id != b.error_id:
            raise Breach(
                f"{self.spec.name}: per-call and two-phase paths differ after {what}: "
                f"out {a.out!r} vs {b.out!r}, error_id {a.error_id!r} vs {b.error_id!r}"
            )
        # the states too, after every action: a divergence behind an output held at a
        # limit shows in the output only later or never (docs/reliability.md); read in
        # place, not copied (snapshot(copy=False): a copy per action made the campaign
        # 1.5x slower)
        sa, sb = a.snapshot(copy=False), b.snapshot(copy=False)
        if not (_plain_equal(sa, sb) or _snap_equal(sa, sb, LANE_TOL)):
            raise Breach(
                f"{self.spec.name}: per-call and two-phase states differ after {what}: "
                + _snap_diff(sa, sb, LANE_TOL)
            )

    # -- one process step ------------------------------------------------------

    def _call(self, b: Any, two_phase: bool, vals: list[Any], dt: Any, flags: list[Any]) -> Any:
        return self.spec.step(b, two_phase, vals, dt, flags, self.y)  # type: ignore[misc]

    def act_step(self, vals: list[Any], dt: Any, flags: list[Any]) -> None:
        """One process step with these values (``vals[1] = None``: the plant's output)."""
        self.log.append(("step", vals, dt, flags, self.y))
        a = self.block
        ctl = self._ctl(a)
        prev_out, prev_err = a.out, a.error_id
        bump = bool(self.spec.bumpless)
        prev_mode = ctl.mode if bump else None
        scale = self._scale(ctl) if bump else 1.0
        self._guarded("step", lambda: self._call(a, False, vals, dt, flags))
        self._check_out(a, "step")
        self._check_state(a, "step")
        if self.twin is not None:
            self._guarded("two-phase step", lambda: self._call(self.twin, True, vals, dt, flags))
            self._check_out(self.twin, "two-phase step")
            self._compare_twin("step")
        if bump:
            self._check_bumpless(ctl, prev_out, prev_err, prev_mode, scale, dt)
        if self.spec.controller:
            self._plant(a.out)
        self.steps += 1

    def _plant(self, u: float) -> None:
        # a first-order process in the loop, so that controllers meet limits and windup
        self.y = 0.95 * self.y + 0.05 * max(-1e6, min(1e6, u))

    def _scale(self, ctl: Block) -> float:
        terms = [getattr(ctl, n, 0.0) for n in ("out", "p", "i", "d", "ff", "u_raw")]
        return max([1.0] + [abs(t) for t in terms if isinstance(t, float) and math.isfinite(t)])

    def _check_bumpless(
        self, ctl: Block, prev_out: float, prev_err: int, prev_mode: Any, scale: float, dt: Any
    ) -> None:
        """Promise 5 (PID and ADRC only)."""
        mode = getattr(ctl, "mode", None)
        if mode != Mode.AUTO or ctl.error_id not in (*_GOOD, ErrorCode.BAD_LIMITS):
            return
        if dt is not None or getattr(ctl, "awin", False):
            return
        if getattr(ctl.config, "precision", "float64") != "float64":
            return  # float32: bumpless to single-precision rounding only (docs/reliability.md)
        was_manual = prev_mode is not None and prev_mode != Mode.AUTO
        # (ADRC with u_real_on: a missing u_real is BAD_INPUT while the law runs on its own u)
        was_bad = prev_err in _BAD_DATA and not getattr(ctl.config, "u_real_on", False)
        if not (was_manual or was_bad) or not self._clean:
            return
        if abs(ctl.out - prev_out) > BUMP_TOL * max(scale, self._scale(ctl)):
            why = "MAN->AUTO" if was_manual else f"recovery from {ErrorCode(prev_err).name}"
            raise Breach(
                f"{self.spec.name}: {why} is not bumpless: {prev_out!r} -> {ctl.out!r} "
                f"(tolerance {BUMP_TOL} x {scale:.3g})"
            )

    @property
    def _clean(self) -> bool:
        """No configuration or limit change since the last step (bumpless applies)."""
        return not self._dirty

    _dirty = False

    def step_done(self) -> None:
        self._dirty = False

    # -- other actions -----------------------------------------------------------

    def act_mode(self, name: str, value: Any) -> None:
        """Set a mode input of a controller (``manual``, ``track``, ``hold``, ...)."""
        self.log.append(("set", name, value))
        self._both(f"mode {name}", lambda b: setattr(self._ctl(b), name, value))

    def act_limits(self, lo: Any, hi: Any) -> None:
        """Write output limits at run time (``set_limits``) or by configure."""
        self.log.append(("limits", lo, hi))
        self._dirty = True
        if callable(getattr(self._ctl(self.block), "set_limits", None)):
            self._both("set_limits", lambda b: self._ctl(b).set_limits(lo, hi))
            self._check_out(self.block, "set_limits")
        elif self.spec.limit_fields:
            self.act_configure(dict(zip(self.spec.limit_fields, (lo, hi), strict=True)))

    def act_configure(self, changes: dict[str, Any]) -> None:
        """Reconfigure: accepted (then the outputs are checked) or refused (promise 3)."""
        if not changes:
            return
        self.log.append(("configure", changes))
        self._dirty = True
        blocks = [self.block] + ([self.twin] if self.twin is not None else [])
        outcomes: list[ErrorCode | str | None] = []
        for b in blocks:
            cfg = b.config
            snap = self._guarded("snapshot", b.snapshot)
            try:
                b.configure(**changes)
                outcomes.append(None)
            except ParameterError as err:
                if not isinstance(err.code, ErrorCode) or err.code == ErrorCode.NO_ERROR:
                    raise Breach(
                        f"{self.spec.name}: refused configure without a code: {err}"
                    ) from err
                if b.config != cfg:
                    raise Breach(
                        f"{self.spec.name}: refused {changes!r} changed the config"
                    ) from err
                if not _snap_equal(b.snapshot(), snap):
                    raise Breach(
                        f"{self.spec.name}: refused {changes!r} changed the state"
                    ) from err
                outcomes.append(err.code)
            except TypeError as err:
                if "has no parameter" not in str(err):
                    raise Breach(
                        f"{self.spec.name}: configure({changes!r}) raised {err!r}"
                    ) from err
                outcomes.append("unknown")
            except Exception as exc:
                raise Breach(f"{self.spec.name}: configure({changes!r}) raised {exc!r}") from exc
            self._check_out(b, f"configure({changes!r})")
        if len(set(map(str, outcomes))) > 1:
            raise Breach(f"{self.spec.name}: block and twin disagree on configure {changes!r}")
        if self.twin is not None and not self._twin_ok():
            self.twin = None

    def act_snapshot_restore(self, vals: list[Any], dt: Any, flags: list[Any]) -> None:
        """``restore(snapshot())`` then the same step twice gives the same result (promise 6)."""
        self.log.append(("snapshot/step/restore/step", vals, dt, flags, self.y))
        a = self.block
        snap = self._guarded("snapshot", a.snapshot)
        y_saved = self.y
        self._guarded("step", lambda: self._call(a, False, vals, dt, flags))
        out1, err1 = a.out, a.error_id
        self._guarded("restore", lambda: a.restore(snap))
        self._check_out(a, "restore")
        self._guarded("step", lambda: self._call(a, False, vals, dt, flags))
        if not (_snap_equal(out1, a.out) and err1 == a.error_id):
            raise Breach(
                f"{self.spec.name}: the same step after restore() differs: "
                f"{out1!r}/{err1!r} vs {a.out!r}/{a.error_id!r}"
            )
        self.y = y_saved
        if self.twin is not None:
            self._guarded("two-phase step", lambda: self._call(self.twin, True, vals, dt, flags))
            self._compare_twin("snapshot/restore")
        self._dirty = True

    def act_reset(self) -> None:
        """``reset()``: back to the initial state; outputs checked."""
        self.log.append(("reset",))
        self._dirty = True
        self._both("reset", lambda b: b.reset())
        self._check_out(self.block, "reset")
        self._compare_twin("reset")

    def reproducer(self) -> str:
        """The last actions, one a line (for the breach report)."""
        lines = []
        for kind, *args in self.log:
            if kind == "new":
                lines.append(f"b = {self.spec.name}(**{args[0]!r})")
            elif kind in ("step", "snapshot/step/restore/step"):
                vals, dt, flags, y = args
                lines.append(f"{kind}: vals={vals!r} dt={dt!r} flags={flags!r} plant y={y!r}")
            elif kind == "set":
                lines.append(f"b.{args[0]} = {args[1]!r}")
            elif kind == "limits":
                lines.append(f"limits {args[0]!r}, {args[1]!r}")
            elif kind == "configure":
                lines.append(f"b.configure(**{args[0]!r})")
            elif kind == "acknowledge":
                lines.append("b.acknowledge()")
            else:
                lines.append(f"b.{kind}()")
        return "\n".join(line if len(line) < 400 else line[:400] + " ..." for line in lines)


# ---------------------------------------------------------------------------
# The plain random driver (long campaign)
# ---------------------------------------------------------------------------


class RandomRun:
    """Draws the actions of :class:`Driver` from a seeded ``random.Random``."""

    def __init__(self, spec: FuzzSpec, seed: int) -> None:
        self.spec = spec
        self.r = random.Random(seed)
        self.driver = self._new_driver()

    def _new_driver(self) -> Driver:
        for _ in range(200):
            cfg = self.spec.config(self.r)
            try:
                return Driver(self.spec, cfg)
            except ParameterError:
                continue
        raise RuntimeError(f"no valid random configuration for {self.spec.name}")

    def _value(self, center: float, spread: float) -> Any:
        r = self.r
        x = r.random()
        if x < 0.04:
            return r.choice(HOSTILE)
        return center + spread * (r.random() - 0.5) * 2.0

    def _inputs(self) -> tuple[list[Any], Any, list[Any]]:
        r = self.r
        if self.spec.controller:
            sp = self._value(r.choice((0.0, 20.0, 50.0)), 60.0) if r.random() < 0.2 else 30.0
            pv = None if r.random() < 0.9 else self._value(30.0, 60.0)
            ff = 0.0 if r.random() < 0.8 else self._value(0.0, 5.0)
            dv = 0.0 if r.random() < 0.8 else self._value(0.0, 5.0)
            w = self._value(50.0, 60.0)
            vals = [sp, pv, ff, dv, w]
        else:
            vals = [self._value(0.0, 120.0) for _ in range(3)]
        dt = None if r.random() < 0.9 else r.choice(HOSTILE_DT)
        flags = [
            r.random() < 0.97 if r.random() < 0.97 else r.choice(_FLAG_VALUES),
            r.random() < 0.5,
            r.random() < 0.5,
        ]
        return vals, dt, flags

    def step(self) -> None:
        r, d = self.r, self.driver
        x = r.random()
        if x < 0.93:
            vals, dt, flags = self._inputs()
            d.act_step(vals, dt, flags)
            d.step_done()
        elif x < 0.95 and self.spec.controller:
            name = r.choice(self.spec.modes)
            value = r.random() < 0.5 if r.random() < 0.95 else r.choice(_FLAG_VALUES)
            d.act_mode(name, value)
            if name in self.spec.mode_values and r.random() < 0.5:
                d.act_mode(self.spec.mode_values[name], self._value(30.0, 100.0))
        elif x < 0.96:
            lo = r.uniform(-100.0, 100.0)
            hi = lo + r.uniform(0.0, 100.0) if r.random() < 0.8 else r.uniform(-100.0, 100.0)
            if r.random() < 0.1:
                lo, hi = (r.choice(HOSTILE), hi) if r.random() < 0.5 else (lo, r.choice(HOSTILE))
            d.act_limits(lo, hi)
        elif x < 0.975:
            fields = [f.name for f in dataclasses.fields(d.block.config)]
            if not self.spec.configurable:
                fields = []
            changes = {}
            if fields and r.random() < 0.5:  # a valid random value for one or more fields
                new = self.spec.config(r)
                for name in r.sample(fields, min(len(fields), r.randint(1, 3))):
                    if name in new:
                        changes[name] = new[name]
            elif fields:
                changes[r.choice(fields)] = r.choice(BAD_PARAMS)
            d.act_configure(changes)
        elif x < 0.985:
            vals, dt, flags = self._inputs()
            d.act_snapshot_restore(vals, dt, flags)
        elif x < 0.99:
            if self.spec.acknowledge is not None and r.random() < 0.5:
                d.act_acknowledge()
            else:
                d.act_reset()
        elif x < 0.9905:
            self.driver = self._new_driver()  # a fresh random configuration
        else:
            vals, dt, flags = self._inputs()
            d.act_step(vals, dt, flags)
            d.step_done()


def run(
    names: list[str],
    steps: int,
    seed: int,
    every: float = 30.0,
    out: Any = None,
    minutes: float | None = None,
) -> int:
    """Run up to ``steps`` actions per block; return 0, or 1 on a breach.

    The blocks take turns in slices of equal CPU time (about 0.1 s), so a cheap
    block is not held back by an expensive one; ``minutes`` stops the campaign
    after that wall time with the counts reached (still 0 on no breach).
    """
    out = out or sys.stdout
    runs: dict[str, RandomRun] = {}
    done = dict.fromkeys(names, 0)
    t0 = last = time.monotonic()
    deadline = math.inf if minutes is None else t0 + 60.0 * minutes
    pending = list(names)
    stopped = False
    while pending and not stopped:
        for n in list(pending):
            t_slice = time.monotonic() + 0.1
            try:
                rr = runs.get(n) or runs.setdefault(
                    n, RandomRun(FUZZ_SPECS[n], seed + names.index(n))
                )
                while done[n] < steps:
                    for _ in range(min(50, steps - done[n])):
                        rr.step()
                        done[n] += 1
                    if time.monotonic() >= t_slice:
                        break
            except Breach as exc:
                s = seed + names.index(n)
                print(f"BREACH in {n} (seed {s}, step {done[n]}): {exc}", file=out)
                print(
                    f"reproduce: python -m ctrlblocks.testing --block {n} --seed {s} "
                    f"--steps {done[n] + 1}",
                    file=out,
                )
                if exc.__cause__ is not None:  # where the block raised, for the fix
                    tb = traceback.format_exception(exc.__cause__)
                    print("".join(tb[-6:]).rstrip(), file=out)
                if n in runs:
                    print("last actions:\n" + runs[n].driver.reproducer(), file=out, flush=True)
                return 1
            if done[n] >= steps:
                pending.remove(n)
        now = time.monotonic()
        stopped = now >= deadline
        if now - last >= every or not pending or stopped:
            last = now
            total = sum(done.values())
            rate = total / max(now - t0, 1e-9)
            counts = " ".join(f"{n}={done[n]}" for n in names)
            print(
                f"[{now - t0:8.0f} s] steps {total} ({rate:,.0f} steps/s) {counts}",
                file=out,
                flush=True,
            )
    total = sum(done.values())
    how = "stopped at the time budget" if stopped and pending else "done"
    print(
        f"{how}: {total} steps, {min(done.values())} to {max(done.values())} per block, 0 breaches",
        file=out,
        flush=True,
    )
    return 0


def traces(steps: int, seeds: int, float32_seeds: int = 0) -> dict[str, Any]:
    """What every block outputs along the campaign's seeded actions, for comparing builds.

    For each exported block and seed ``0 .. seeds-1`` (and, for PID and ADRC,
    the first ``float32_seeds`` seeds from 1000 on whose block starts in
    ``precision="float32"``): after each of ``steps`` actions of
    :class:`RandomRun`, ``repr(out)`` (bit for bit) and the error code.
    Returns ``{"traces": {"NAME/seed": [...]}, "float32": actions in float32}``.
    Used to hold the compiled build to the interpreted blocks
    (``ctrlblocks.compiled``).
    """

    def f32_seeds(spec: FuzzSpec) -> list[int]:
        found: list[int] = []
        seed = 1000
        while len(found) < float32_seeds:
            if getattr(RandomRun(spec, seed).driver.block.config, "precision", "") == "float32":
                found.append(seed)
            seed += 1
        return found

    out: dict[str, Any] = {"traces": {}, "float32": 0}
    for name, spec in sorted(FUZZ_SPECS.items()):
        extra = f32_seeds(spec) if spec.float32 else []
        for seed in [*range(seeds), *extra]:
            run = RandomRun(spec, seed)
            trace = []
            for _ in range(steps):
                run.step()
                b = run.driver.block
                trace.append((repr(b.out), int(b.error_id)))
                out["float32"] += getattr(b.config, "precision", "") == "float32"
            out["traces"][f"{name}/{seed}"] = trace
    return out


def main(argv: list[str] | None = None) -> int:
    """Command line of the long campaign (see the module docstring)."""
    ap = argparse.ArgumentParser(prog="python -m ctrlblocks.testing", description=__doc__
                                 .split("\n")[0])  # fmt: skip
    ap.add_argument("--steps", type=int, default=100_000, help="actions per block")
    ap.add_argument("--seed", type=int, default=0, help="seed of the first block's run")
    ap.add_argument("--block", action="append", choices=sorted(FUZZ_SPECS),
                    help="only this block")  # fmt: skip
    ap.add_argument("--every", type=float, default=30.0, help="seconds between progress lines")
    ap.add_argument("--minutes", type=float, default=None, help="stop after this wall time")
    a = ap.parse_args(argv)
    names = a.block or sorted(FUZZ_SPECS)
    return run(names, a.steps, a.seed, a.every, minutes=a.minutes)
