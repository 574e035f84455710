"""Setpoint programmer: ramps and soaks in segments, with guaranteed ramp/soak (holdback).

What a process controller's setpoint programmer does (ABB ControlMaster
CM10/CM30/CM50 user manual IM/CM/S-EN, section 7.6.2 "Guaranteed Ramp /
Soak"; Honeywell UDC2500 product manual, "Setpoint Ramp/Soak"): a profile of
segments, each a *ramp* to a target at a rate followed by a *soak* (a dwell
at the target) for a time.

Segments
--------
``segments = ((target, rate, soak), ...)``, up to :data:`MAX_SEGMENTS`:

* ramp from the present setpoint to ``target`` at ``rate`` [units/s] (either
  direction); ``rate = 0`` steps to the target at once (UDC2500: "Entering 0
  will imply an immediate step change in setpoint to the next soak");
* then soak at ``target`` for ``soak`` [s] (0: none).

The profile starts at ``start`` (or, with ``start_at_pv``, at the PV of the
first sample, so that a hot furnace does not first fall to a cold start value)
and ends at the last target (``done``), or starts again from the first
segment (``repeat``).  Time is carried exactly across segment ends: a sample
that finishes a ramp spends the rest of its time in the soak, and so on.

Guaranteed ramp and soak (holdback)
-----------------------------------
``holdback_ramp`` / ``holdback_soak`` [PV units] (0: off): while ``|PV - SP|``
exceeds the band of the present phase, the program holds (the setpoint stops
moving and the soak time stops counting) until the PV catches up -- the ABB
manual's "High/Low" hysteresis ("HOLD set if PV > [SP + Hysteresis] or PV <
[SP - Hysteresis]"), per ramp and per soak.

Inputs of each sample: ``run`` (FALSE: the program holds where it is),
``reset`` (back to the start: the start value, segment 0), ``pv``.  An
invalid PV (``pv_ok`` false, NaN, inf) holds the program when a holdback band
is on (``BAD_MEASUREMENT`` / ``BAD_INPUT``) and is ignored otherwise.

The sample is one pure function, :func:`setpoint_cycle` (the PLC translator's
subset; the segments are ARRAYs): the block, its ``precision="float32"``
lane and the exported ``CB_SETPOINT`` run it.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

from .base import (
    BlockConfig,
    ErrorCode,
    ParameterError,
    as_flag,
    as_input,
    require_bool,
    require_finite,
    require_nonnegative,
    require_positive,
)
from .cycleblock import CycleBlock, float_rows, require_precision
from .plc_cycle import is_real

__all__ = [
    "MAX_SEGMENTS",
    "SETPOINT_RESULTS",
    "SetpointProgram",
    "SetpointProgramConfig",
    "setpoint_cycle",
]

MAX_SEGMENTS = 32
"""The most segments a program holds."""

NO_ERROR = int(ErrorCode.NO_ERROR)
BAD_INPUT = int(ErrorCode.BAD_INPUT)
BAD_MEASUREMENT = int(ErrorCode.BAD_MEASUREMENT)

RAMP = 0
SOAK = 1

# ---------------------------------------------------------------------------
# The cycle (the PLC translator's subset)
# ---------------------------------------------------------------------------

SETPOINT_RESULTS = (
    "out", "error_id", "held", "seg", "phase", "done", "sp", "t_soak", "started",
)  # fmt: skip
"""Names of the values :func:`setpoint_cycle` returns: outputs, then the new memory."""


def setpoint_cycle(
    pv: float,
    pv_ok: bool,
    run: bool,
    reset: bool,
    target: list[float],
    rate: list[float],
    soak: list[float],
    start: float,
    start_at_pv: bool,
    repeat: bool,
    holdback_ramp: float,
    holdback_soak: float,
    ts: float,
    seg: int,
    phase: int,
    done: bool,
    sp: float,
    t_soak: float,
    started: bool,
) -> tuple[float, int, bool, int, int, bool, float, float, bool]:
    """One sample of :class:`SetpointProgram` (module docstring).

    ``seg``/``phase`` (0 ramp, 1 soak) say where the program is, ``t_soak`` the
    soak time spent, ``sp`` the setpoint.  Returns :data:`SETPOINT_RESULTS`.
    """
    err = NO_ERROR
    good = True
    if not pv_ok:
        good = False
        err = BAD_MEASUREMENT
    elif not is_real(pv):
        good = False
        err = BAD_INPUT
    if reset or not started:
        sp = start
        if start_at_pv and good:
            sp = pv
        seg = 0
        phase = RAMP
        done = False
        t_soak = 0.0
        started = True
    band = holdback_ramp
    if phase == SOAK:
        band = holdback_soak
    held = False
    if band > 0.0:
        held = not good  # an invalid PV holds; a valid one is compared (no NaN compared)
        if good:
            held = abs(pv - sp) > band
    if band <= 0.0 and not good:
        err = NO_ERROR  # the PV is not used
    n = len(target)
    left = ts
    if not run or held or done:
        left = 0.0
    for _k in range(2 * n + 1):
        if left > 0.0:
            tgt = target[seg]
            if phase == RAMP:
                r = rate[seg]
                dist = abs(tgt - sp)
                if r <= 0.0 or dist <= r * left:
                    if r > 0.0:
                        left = left - dist / r
                    sp = tgt
                    phase = SOAK
                    t_soak = 0.0
                elif tgt > sp:
                    sp = sp + r * left
                    left = 0.0
                else:
                    sp = sp - r * left
                    left = 0.0
            else:
                need = soak[seg] - t_soak
                if need <= left:
                    if need > 0.0:
                        left = left - need
                    t_soak = 0.0
                    phase = RAMP
                    seg = seg + 1
                    if seg >= n:
                        if repeat:
                            seg = 0
                        else:
                            seg = n - 1
                            phase = SOAK
                            t_soak = soak[seg]
                            done = True
                            left = 0.0
                else:
                    t_soak = t_soak + left
                    left = 0.0
    return sp, err, held, seg, phase, done, sp, t_soak, started


# ---------------------------------------------------------------------------
# The block
# ---------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class SetpointProgramConfig(BlockConfig):
    """Configuration of :class:`SetpointProgram`.

    Attributes
    ----------
    segments : tuple of (target, rate, soak)
        1 .. :data:`MAX_SEGMENTS` segments: ramp to ``target`` [units] at
        ``rate`` [units/s] >= 0 (0: a step), then soak ``soak`` [s] >= 0.
    start : float
        Setpoint at the start [units].
    start_at_pv : bool
        Start at the PV of the first (or reset) sample instead, when it is valid.
    repeat : bool
        After the last segment start again with the first (from the last target).
    holdback_ramp, holdback_soak : float
        Guaranteed ramp / soak bands [PV units] >= 0; 0: off.
    ts : float
        Sample time [s] > 0.
    precision : str
        ``"float64"`` or ``"float32"``.
    """

    segments: tuple[tuple[float, float, float], ...] = ((0.0, 0.0, 0.0),)
    start: float = 0.0
    start_at_pv: bool = False
    repeat: bool = False
    holdback_ramp: float = 0.0
    holdback_soak: float = 0.0
    ts: float = 1.0
    precision: str = "float64"

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "segments", float_rows(self.segments))

    def validate(self) -> None:
        s = self.segments
        if not isinstance(s, tuple) or not 1 <= len(s) <= MAX_SEGMENTS:
            raise ParameterError(
                ErrorCode.BAD_PARAMETER,
                "segments",
                f"must be 1..{MAX_SEGMENTS} segments (target, rate, soak), got {s!r}",
            )
        for j, row in enumerate(s):
            f = f"segments[{j}]"
            if not isinstance(row, tuple) or len(row) != 3:
                raise ParameterError(
                    ErrorCode.BAD_PARAMETER, f, f"must be (target, rate, soak), got {row!r}"
                )
            _real_range(f"{f}.target", require_finite(f"{f}.target", row[0]))
            _real_range(f"{f}.rate", require_nonnegative(f"{f}.rate", row[1], ErrorCode.BAD_RATE))
            soak = require_nonnegative(f"{f}.soak", row[2], ErrorCode.BAD_TIME_CONSTANT)
            _real_range(f"{f}.soak", soak)
        _real_range("start", require_finite("start", self.start))
        require_bool("start_at_pv", self.start_at_pv)
        require_bool("repeat", self.repeat)
        for name in ("holdback_ramp", "holdback_soak"):
            _real_range(name, require_nonnegative(name, getattr(self, name), ErrorCode.BAD_LIMITS))
        _real_range("ts", require_positive("ts", self.ts, ErrorCode.NO_CYCLE))
        require_precision(self)


def _real_range(field: str, x: float) -> None:
    if abs(x) > 1e30:
        raise ParameterError(ErrorCode.BAD_PARAMETER, field, f"must be within 1e30, got {x!r}")


class SetpointProgram(CycleBlock):
    """Setpoint programmer: ramp/soak segments with guaranteed ramp and soak.

    ``sp = prog(pv, run=True)`` runs one sample and returns the setpoint; see
    the module docstring.  :attr:`segment`, :attr:`phase` (``"ramp"`` or
    ``"soak"``), :attr:`done` and :attr:`held` say where the program is.

    Examples
    --------
    From 20 °C, ramp to 100 °C at 2 °C/s, soak 10 s, step back to 20 °C:

    >>> prog = SetpointProgram(segments=((100.0, 2.0, 10.0), (20.0, 0.0, 0.0)), start=20.0,
    ...                        ts=1.0)
    >>> sps = [prog(0.0) for _ in range(52)]
    >>> sps[0], sps[39], sps[40], sps[49], sps[50], prog.done
    (22.0, 100.0, 100.0, 100.0, 20.0, True)
    """

    Config = SetpointProgramConfig
    config: SetpointProgramConfig
    _config: SetpointProgramConfig
    _cycle = staticmethod(setpoint_cycle)
    _results = SETPOINT_RESULTS
    _process: ClassVar[dict[str, Any]] = {"pv": 0.0, "pv_ok": True, "run": True, "reset": False}
    _outputs: ClassVar[dict[str, Any]] = {"out": 0.0, "error_id": 0, "held": False}
    _state_fields = ("out", "_mem", "_held")

    def _reset_state(self) -> None:
        super()._reset_state()
        self._held = False

    def _parameters(self) -> dict[str, Any]:
        c = self._config
        cols = list(zip(*c.segments, strict=True))
        return {"target": list(cols[0]), "rate": list(cols[1]), "soak": list(cols[2]),
                "start": float(c.start), "start_at_pv": bool(c.start_at_pv),
                "repeat": bool(c.repeat), "holdback_ramp": float(c.holdback_ramp),
                "holdback_soak": float(c.holdback_soak), "ts": float(c.ts)}  # fmt: skip

    def _initial(self) -> dict[str, Any]:
        return {"seg": 0, "phase": RAMP, "done": False, "sp": float(self._config.start),
                "t_soak": 0.0, "started": False}  # fmt: skip

    def _initial_out(self) -> float:
        return float(self._config.start)

    def _reconfigured(self, old: BlockConfig) -> None:
        n = len(self._config.segments)
        if self._mem["seg"] >= n:  # fewer segments: the program is at its end
            self._mem.update(seg=n - 1, phase=SOAK, done=True, t_soak=self._config.segments[-1][2])

    @property
    def segment(self) -> int:
        """The segment the program is in (0-based)."""
        return int(self._mem["seg"])

    @property
    def phase(self) -> str:
        """``"ramp"`` or ``"soak"``."""
        return "soak" if int(self._mem["phase"]) == SOAK else "ramp"

    @property
    def done(self) -> bool:
        """The program has finished its last segment (and does not repeat)."""
        return bool(self._mem["done"])

    @property
    def held(self) -> bool:
        """A holdback band held the program in the last sample."""
        return self._held

    def restart(self) -> None:
        """Start the program again at the next sample (as the ``reset`` input)."""
        self._mem["started"] = False

    def __call__(
        self, pv: float = 0.0, *, pv_ok: Any = True, run: Any = True, reset: Any = False,
        dt: float | None = None,
    ) -> float:  # fmt: skip
        """One sample; return the setpoint."""
        h = self._sample_time(dt)
        if h is None:
            return self.out
        inputs = {"pv": as_input(pv), "pv_ok": as_flag(pv_ok, False), "run": as_flag(run, False),
                  "reset": as_flag(reset, False)}  # fmt: skip
        res = self._run(inputs, h)
        self._held = bool(res["held"])
        self.out = float(res["out"])
        return self.out
