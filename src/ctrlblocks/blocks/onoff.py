"""On/off controllers: two-point with hysteresis, three-point with a neutral zone.

The controllers of a thermostat, a level switch pair or a motorised valve
driven by raise/lower relays, as PLC libraries ship them: Beckhoff's TwinCAT
Controller Toolbox (Beckhoff TF4100, ``FB_CTRL_2POINT`` -- a 2-point element
with a hysteresis range -- and ``FB_CTRL_3POINT``) and the building
automation library's ``FB_BA_SwiHys2P`` (Beckhoff TF8040), whose switching
points are ``SP + Hys/2`` and ``SP - Hys/2`` and whose action is "heating"
(on below the setpoint) or "cooling" (on above it).

Two-point (:class:`TwoPoint`)
-----------------------------
Heating action (``reverse=False``), hysteresis ``H >= 0``::

    on  when  PV <= SP - H/2          off  when  PV >= SP + H/2

and the output keeps its state in between.  Cooling action (``reverse=True``)
mirrors it: on at ``PV >= SP + H/2``, off at ``PV <= SP - H/2``.  On a
first-order process ``K/(T s + 1)`` without dead time the PV then oscillates
between the two switching points (the limit cycle's amplitude is ``H``; a
dead time adds its overshoot on both sides).

Three-point (:class:`ThreePoint`)
---------------------------------
Control error ``e = SP - PV`` (``reverse``: ``PV - SP``), neutral zone
half-width ``D >= 0`` and hysteresis ``H`` (``0 <= H <= 2 D``)::

    +1 (raise)  from  e >= D,   back to 0 when  e < D - H
    -1 (lower)  from  e <= -D,  back to 0 when  e > -D + H

A reversal (+1 to -1 or back) passes through 0: the relays of a motor never
switch over in one sample.

Minimum times (both blocks)
---------------------------
``t_min_on`` and ``t_min_off`` [s]: an output that switched on stays on at
least ``t_min_on``, one that switched off stays off at least ``t_min_off``
(compressors, contactors; Beckhoff's ``FB_BA_SwiHys2P`` has switch-on and
switch-off delays for the same purpose).  Each state change restarts the
time; the first switch after a reset is not delayed.

Bad data
--------
An invalid PV (``pv_ok`` false, NaN, inf, beyond the REAL range) or setpoint
switches the output off at once (the safe state of a heater, a cooler and a
motor: minimum times do not hold a switch-off for safety) and sets
``BAD_MEASUREMENT`` or ``BAD_INPUT``; the controller resumes with the next
valid sample.  ``enable=False`` switches off likewise (no error).

The sample of each block is one pure function (:func:`two_point_cycle`,
:func:`three_point_cycle`) in the subset the PLC translator accepts: the
block, its ``precision="float32"`` lane and the exported ``CB_TWOPOINT`` /
``CB_THREEPOINT`` run it (:mod:`.cycleblock`).
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
    require_nonnegative,
    require_positive,
)
from .cycleblock import TIME_CAP, CycleBlock, require_precision, time_add
from .plc_cycle import is_real

__all__ = [
    "THREE_POINT_RESULTS",
    "TWO_POINT_RESULTS",
    "ThreePoint",
    "ThreePointConfig",
    "TwoPoint",
    "TwoPointConfig",
    "min_time_switch",
    "three_point_cycle",
    "two_point_cycle",
]

NO_ERROR = int(ErrorCode.NO_ERROR)
BAD_INPUT = int(ErrorCode.BAD_INPUT)
BAD_MEASUREMENT = int(ErrorCode.BAD_MEASUREMENT)


# ---------------------------------------------------------------------------
# The cycles (the PLC translator's subset)
# ---------------------------------------------------------------------------


def min_time_switch(
    want: int, state: int, t_in: float, t_min_on: float, t_min_off: float, h: float
) -> tuple[int, float]:
    """The next output state: ``want`` once the present ``state`` has lasted its minimum time.

    ``t_in`` [s] is how long ``state`` has lasted before this sample; the
    minimum is ``t_min_on`` for an on state (non-zero), ``t_min_off`` for 0.
    A small slack makes a minimum of ``k h`` hold exactly ``k`` samples.
    Returns ``(state, t_in)`` after this sample.
    """
    if want != state:
        t_min = t_min_off
        if state != 0:
            t_min = t_min_on
        if t_in >= t_min - 1e-9 * h:
            return want, h
    return state, time_add(t_in, h)


TWO_POINT_RESULTS = ("out", "error_id", "on", "t_in")
"""Names of the values :func:`two_point_cycle` returns: outputs, then the new memory."""


def two_point_cycle(
    sp: float,
    pv: float,
    pv_ok: bool,
    enable: bool,
    hysteresis: float,
    reverse: bool,
    t_min_on: float,
    t_min_off: float,
    ts: float,
    on: bool,
    t_in: float,
) -> tuple[float, int, bool, float]:
    """One sample of :class:`TwoPoint` (module docstring).  Returns :data:`TWO_POINT_RESULTS`."""
    err = NO_ERROR
    if not pv_ok:
        err = BAD_MEASUREMENT
    elif not (is_real(pv) and is_real(sp)):
        err = BAD_INPUT
    state = 0
    if on:
        state = 1
    if err != NO_ERROR or not enable:
        # the safe state at once; the off time starts now
        if on:
            t_in = 0.0
        on = False
        t_in = time_add(t_in, ts)
    else:
        d = pv - sp  # heating: on below SP - H/2, off above SP + H/2
        if reverse:
            d = sp - pv
        want = state
        if d <= -0.5 * hysteresis:
            want = 1
        elif d >= 0.5 * hysteresis:
            want = 0
        state, t_in = min_time_switch(want, state, t_in, t_min_on, t_min_off, ts)
        on = state == 1
    out = 0.0
    if on:
        out = 1.0
    return out, err, on, t_in


THREE_POINT_RESULTS = ("out", "error_id", "raise_out", "lower_out", "state", "t_in")
"""Names of the values :func:`three_point_cycle` returns: outputs, then the new memory."""


def three_point_cycle(
    sp: float,
    pv: float,
    pv_ok: bool,
    enable: bool,
    deadband: float,
    hysteresis: float,
    reverse: bool,
    t_min_on: float,
    t_min_off: float,
    ts: float,
    state: int,
    t_in: float,
) -> tuple[float, int, bool, bool, int, float]:
    """One sample of :class:`ThreePoint` (module docstring).

    Returns :data:`THREE_POINT_RESULTS`.
    """
    err = NO_ERROR
    if not pv_ok:
        err = BAD_MEASUREMENT
    elif not (is_real(pv) and is_real(sp)):
        err = BAD_INPUT
    if err != NO_ERROR or not enable:
        if state != 0:
            t_in = 0.0
        state = 0
        t_in = time_add(t_in, ts)
    else:
        e = sp - pv
        if reverse:
            e = pv - sp
        want = 0
        if e >= deadband:
            want = 1
        elif e <= -deadband:
            want = -1
        if state == 1 and e >= deadband - hysteresis:
            want = 1  # hysteresis: +1 holds down to D - H
        if state == -1 and e <= hysteresis - deadband:
            want = -1
        if want != 0 and state != 0 and want != state:
            want = 0  # a reversal passes through 0
        state, t_in = min_time_switch(want, state, t_in, t_min_on, t_min_off, ts)
    return float(state), err, state == 1, state == -1, state, t_in


# ---------------------------------------------------------------------------
# The blocks
# ---------------------------------------------------------------------------


def _require_times(c: Any) -> None:
    require_nonnegative("t_min_on", c.t_min_on, ErrorCode.BAD_TIME_CONSTANT)
    require_nonnegative("t_min_off", c.t_min_off, ErrorCode.BAD_TIME_CONSTANT)
    for name in ("t_min_on", "t_min_off"):
        if getattr(c, name) > TIME_CAP:
            raise ParameterError(
                ErrorCode.BAD_TIME_CONSTANT,
                name,
                f"must be <= {TIME_CAP:g} s, got {getattr(c, name)!r}",
            )
    require_positive("ts", c.ts, ErrorCode.NO_CYCLE)
    require_bool("reverse", c.reverse)
    require_precision(c)


def _require_band(name: str, value: Any) -> float:
    x = require_nonnegative(name, value, ErrorCode.BAD_LIMITS)
    if x > 1e37:
        raise ParameterError(ErrorCode.BAD_LIMITS, name, f"must be <= 1e37, got {value!r}")
    return x


class _OnOff(CycleBlock):
    """What the two on/off controllers share: the inputs of a sample."""

    _process: ClassVar[dict[str, Any]] = {"sp": 0.0, "pv": 0.0, "pv_ok": True, "enable": True}

    def __call__(
        self, sp: float, pv: float, *, pv_ok: Any = True, enable: Any = True,
        dt: float | None = None,
    ) -> float:  # fmt: skip
        """One sample: setpoint ``sp``, measurement ``pv`` -> the output (module docstring)."""
        h = self._sample_time(dt)
        if h is None:
            return self.out
        res = self._run({"sp": as_input(sp), "pv": as_input(pv), "pv_ok": as_flag(pv_ok, False),
                         "enable": as_flag(enable, False)}, h)  # fmt: skip
        self.out = float(res["out"])
        return self.out


@dataclasses.dataclass(frozen=True)
class TwoPointConfig(BlockConfig):
    """Configuration of :class:`TwoPoint`.

    Attributes
    ----------
    hysteresis : float
        Width H >= 0 of the hysteresis around the setpoint [PV units]: the
        switching points are ``SP - H/2`` and ``SP + H/2``.
    reverse : bool
        False: heating action (on below the setpoint); True: cooling action.
    t_min_on, t_min_off : float
        Minimum on and off times [s] >= 0.
    ts : float
        Sample time [s] > 0.
    precision : str
        ``"float64"`` or ``"float32"`` (the cycle as a PLC's REAL computes it).
    """

    hysteresis: float = 1.0
    reverse: bool = False
    t_min_on: float = 0.0
    t_min_off: float = 0.0
    ts: float = 1.0
    precision: str = "float64"

    def validate(self) -> None:
        _require_band("hysteresis", self.hysteresis)
        _require_times(self)


class TwoPoint(_OnOff):
    """Two-point (on/off) controller with hysteresis and minimum on/off times.

    ``out = tp(sp, pv)`` returns 1.0 (on) or 0.0 (off); :attr:`on` is the same
    as a bool.  See the module docstring for the switching rule.

    Examples
    --------
    A thermostat at 20 °C with 1 K hysteresis: on at 19.5 °C, off at 20.5 °C.

    >>> tp = TwoPoint(hysteresis=1.0, ts=1.0)
    >>> [tp(20.0, pv) for pv in (19.4, 20.0, 20.6, 20.0, 19.5)]
    [1.0, 1.0, 0.0, 0.0, 1.0]
    """

    Config = TwoPointConfig
    config: TwoPointConfig
    _config: TwoPointConfig
    _cycle = staticmethod(two_point_cycle)
    _results = TWO_POINT_RESULTS
    _outputs: ClassVar[dict[str, Any]] = {"out": 0.0, "error_id": 0}

    def _parameters(self) -> dict[str, Any]:
        c = self._config
        return {"hysteresis": float(c.hysteresis), "reverse": bool(c.reverse),
                "t_min_on": float(c.t_min_on), "t_min_off": float(c.t_min_off),
                "ts": float(c.ts)}  # fmt: skip

    def _initial(self) -> dict[str, Any]:
        return {"on": False, "t_in": TIME_CAP}

    def output_limits(self) -> tuple[float, float]:
        """``(0, 1)``: off or on."""
        return 0.0, 1.0

    @property
    def on(self) -> bool:
        """The output of the last sample."""
        return bool(self._mem["on"])



@dataclasses.dataclass(frozen=True)
class ThreePointConfig(BlockConfig):
    """Configuration of :class:`ThreePoint`.

    Attributes
    ----------
    deadband : float
        Half-width D >= 0 of the neutral zone [PV units]: +1 from ``e >= D``,
        -1 from ``e <= -D``.
    hysteresis : float
        Hysteresis H of each switching point [PV units], ``0 <= H <= 2 D``.
    reverse : bool
        False: ``e = SP - PV`` (raise when the PV is low); True: ``e = PV - SP``.
    t_min_on, t_min_off : float
        Minimum times [s] >= 0 of an output on (+1 or -1) and of the output at 0.
    ts : float
        Sample time [s] > 0.
    precision : str
        ``"float64"`` or ``"float32"``.
    """

    deadband: float = 1.0
    hysteresis: float = 0.5
    reverse: bool = False
    t_min_on: float = 0.0
    t_min_off: float = 0.0
    ts: float = 1.0
    precision: str = "float64"

    def validate(self) -> None:
        d = _require_band("deadband", self.deadband)
        if _require_band("hysteresis", self.hysteresis) > 2.0 * d:
            raise ParameterError(
                ErrorCode.BAD_LIMITS,
                "hysteresis",
                f"must be <= 2 deadband = {2.0 * d:.6g} (the release points would cross), "
                f"got {self.hysteresis!r}",
            )
        _require_times(self)


class ThreePoint(_OnOff):
    """Three-point controller: raise (+1), stop (0), lower (-1), with a neutral zone.

    ``out = c(sp, pv)`` returns +1.0, 0.0 or -1.0; :attr:`raise_out` and
    :attr:`lower_out` are the two relays.  See the module docstring.

    Examples
    --------
    >>> c = ThreePoint(deadband=1.0, hysteresis=0.5, ts=1.0)
    >>> [c(10.0, pv) for pv in (8.5, 9.4, 9.6, 11.2, 10.4)]
    [1.0, 1.0, 0.0, -1.0, 0.0]
    """

    Config = ThreePointConfig
    config: ThreePointConfig
    _config: ThreePointConfig
    _cycle = staticmethod(three_point_cycle)
    _results = THREE_POINT_RESULTS
    _outputs: ClassVar[dict[str, Any]] = {
        "out": 0.0,
        "error_id": 0,
        "raise_out": False,
        "lower_out": False,
    }

    def _parameters(self) -> dict[str, Any]:
        c = self._config
        return {"deadband": float(c.deadband), "hysteresis": float(c.hysteresis),
                "reverse": bool(c.reverse), "t_min_on": float(c.t_min_on),
                "t_min_off": float(c.t_min_off), "ts": float(c.ts)}  # fmt: skip

    def _initial(self) -> dict[str, Any]:
        return {"state": 0, "t_in": TIME_CAP}

    def output_limits(self) -> tuple[float, float]:
        """``(-1, 1)``."""
        return -1.0, 1.0

    @property
    def raise_out(self) -> bool:
        """The raise (+1) relay of the last sample."""
        return int(self._mem["state"]) == 1

    @property
    def lower_out(self) -> bool:
        """The lower (-1) relay of the last sample."""
        return int(self._mem["state"]) == -1

