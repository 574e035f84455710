"""Manual control station: increase/decrease buttons with acceleration, tracking input.

Source
------
Åström 1987 (*Implementation of PID Regulators*), section 4
"Manual Control" and Fig. 4.5 "Manual control module": "It has two inputs, a
tracking input and an input for the manual control commands.  The system has
two parameters, the time constant T_m for the manual control input and the
reset time constant T_r.  In digital implementations it is convenient to add a
feature so that the command signal accelerates as long as one of the
increase-decrease buttons are pushed."  The text also says that "the command
buttons only give the changes in the control variables", so the module holds
an integrator state, and that "the integrator associated with manual control
must be reset to a proper value when the regulator is in automatic mode" by a
tracking feedback like the one of the PID module (Figs. 3.6 and 4.4).

The figure itself is lost in the text extraction.  The equations below are
ctrlblocks' design from that text, built like Åström's PID module with a
tracking input (Appendix A, system ``reg``: ``dI/dt = ... + (v - u)/Tt``).

Equations
---------
State ``v`` (the station's output) [output units, e.g. %]; buttons ``inc``,
``dec``; tracking input ``w`` (the value actually applied to the process)::

    dv/dt = s * a(tau) * span / Tm  +  (w - v) / Tr

* ``s = +1`` while only ``inc`` is held, ``-1`` while only ``dec`` is held,
  ``0`` otherwise (no button, or both: nothing moves).
* ``span / Tm`` is the base rate: held without acceleration, the output
  travels ``span`` in ``Tm`` seconds (``Tm`` is the time constant of the
  integrator ``1/(Tm s)`` on the manual command ``s * span``).
* Acceleration: ``tau`` is the time the button has been held without
  interruption, and ``a(tau) = min(1 + tau / t_accel, accel_max)``: the rate
  grows by one base rate every ``t_accel`` seconds up to ``accel_max`` times
  the base rate.  The travel after holding for ``T`` seconds is therefore
  ``span/Tm * A(T)`` with ``A(T) = T + T^2 / (2 t_accel)`` until the cap is
  reached at ``T_c = t_accel (accel_max - 1)``, and
  ``A(T) = A(T_c) + accel_max (T - T_c)`` after it.  ``accel_max = 1`` turns
  acceleration off.  Releasing the button (or pressing the other one) starts
  ``tau`` again from 0.
* Tracking (``w`` given): ``v`` follows ``w`` with the time constant ``Tr``.
  In automatic mode the caller passes the applied output (the PID output after
  its limits) so that ``v`` is already at that value when the operator
  switches to manual: the switch is bumpless.  In manual mode the caller passes
  ``w = None`` (no tracking), or the value applied after an external
  saturation: then ``v`` cannot wind up beyond what the actuator takes (as
  the tracking of Åström's PID module).  ``Tr = 0`` means ideal tracking:
  ``v = w`` and the buttons have no effect while ``w`` is given.

Discretisation, sample time ``h``: the button increment over the sample is
integrated exactly, ``delta = s * span/Tm * (A(tau + h) - A(tau))``.  Without
tracking ``v[k+1] = v[k] + delta`` (exact).  With tracking the linear equation
is solved exactly for the sample's mean manual rate ``m = delta / h`` and
``w`` held over the sample::

    v[k+1] = w + m Tr + (v[k] - w - m Tr) exp(-h / Tr)

Finally ``v`` is limited to ``[out_min, out_max]`` (the station's own range,
0..100 % by default).

Calling order (Åström 1987, section 6, ComputeOutput / UpdateState): the output of
a sample is the state after that sample's update, so a button acts in the same
call.  For the two-phase form ``compute_output()`` returns the present output
and ``update_state(applied, inc, dec)`` advances with the applied value as the
tracking input.

Errors
------
NaN/inf tracking input: output and state held, ``BAD_INPUT``; recovers with
the next finite value.  A bad per-call ``dt`` holds and sets ``NO_CYCLE``.
"""

from __future__ import annotations

import dataclasses
import math

from .base import (
    MAX_TIME,
    Block,
    BlockConfig,
    ErrorCode,
    ParameterError,
    as_flag,
    as_input,
    is_finite,
    require_finite,
    require_limits,
    require_nonnegative,
    require_positive,
)
from .signals import clamp

__all__ = [
    "ManualStation",
    "ManualStationConfig",
    "manual_increment",
    "manual_station_step",
    "manual_station_update",
    "manual_travel",
]


# ---------------------------------------------------------------------------
# The module's law: pure functions over floats
# ---------------------------------------------------------------------------


def manual_travel(tau: float, t_accel: float, accel_max: float) -> float:
    """``A(tau)``: integral over ``[0, tau]`` of ``min(1 + t/t_accel, accel_max)`` [s].

    The travel after holding a button for ``tau`` seconds is ``span/Tm * A(tau)``.
    """
    t_cap = t_accel * (accel_max - 1.0)
    if tau <= t_cap:
        return tau + tau * tau / (2.0 * t_accel)
    return t_cap + t_cap * t_cap / (2.0 * t_accel) + accel_max * (tau - t_cap)


def manual_increment(tau: float, h: float, t_accel: float, accel_max: float) -> float:
    """``A(tau + h) - A(tau)``: the travel of one sample [s at the base rate], without cancellation.

    The integral over ``[tau, tau + h]`` of ``min(1 + t/t_accel, accel_max)``,
    split at ``t_cap = t_accel (accel_max - 1)``: the ramp part in closed form,
    ``accel_max`` times the rest.  Computed so (and not as the difference of
    two travels) it stays exact however long the button has been held: a
    difference of two travels of 1e300 s loses the sample entirely, and of
    ``inf`` is NaN (a button held through one absurd ``dt``).
    """
    t_cap = t_accel * (accel_max - 1.0)
    if tau >= t_cap:
        return accel_max * h
    end = tau + h
    b = end if end < t_cap else t_cap
    ramp = (b - tau) * (1.0 + (b + tau) / (2.0 * t_accel))
    if end <= t_cap:
        return ramp
    return ramp + accel_max * (end - t_cap)


def manual_station_update(
    v: float,
    delta: float,
    w: float,
    tracking: bool,
    h: float,
    tr: float,
    lo: float,
    hi: float,
    big: float,
) -> float:
    """Advance the station state by one sample (see the module docstring).

    Parameters
    ----------
    v : float
        State (output) at the start of the sample.
    delta : float
        Exact button increment over the sample [output units].
    w : float
        Tracking input (used when ``tracking`` is true).
    tracking : bool
        Whether the tracking input is connected this sample.
    h : float
        Sample time [s].
    tr : float
        Tracking time constant Tr [s]; 0: ideal tracking.
    lo, hi : float
        Output limits.
    big : float
        The largest magnitude the executor holds (the block: the largest float; the
        PLC cycle: the end of the REAL range).
    """
    if not (delta >= -big and delta <= big):
        # a travel beyond any range in one sample (a button held through an absurd dt):
        # the output goes to the limit it travels to (and holds where there is none)
        bound = lo
        if delta > 0.0:
            bound = hi
        if bound >= -big and bound <= big:
            return bound
        return v
    if not tracking:
        v = v + delta
    elif tr <= 0.0:
        v = w
    else:
        target = w + delta / h * tr
        v = target + (v - target) * math.exp(-h / tr)
    return clamp(v, lo, hi)


def manual_station_step(
    inc: bool,
    dec: bool,
    w: float,
    tracking: bool,
    h: float,
    rate: float,
    tr: float,
    t_accel: float,
    accel_max: float,
    lo: float,
    hi: float,
    big: float,
    v: float,
    held: float,
    direction: int,
) -> tuple[float, float, int]:
    """One sample of the station (module docstring): the block's and the PLC cycle's.

    ``inc``, ``dec``: the buttons; ``w``, ``tracking``: the tracking input;
    ``rate = span/Tm`` the base rate; ``big`` as in :func:`manual_station_update`
    (the time held saturates there too).  The memory: ``v`` the output, ``held``
    the time the present button has been held [s], ``direction`` +1, -1 or 0 (the
    button of the last sample).  Returns the new ``(v, held, direction)``.
    """
    s = 0
    if inc:
        s = 1
    if dec:
        s = s - 1
    tau = 0.0
    if s != 0 and s == direction:
        tau = held
    delta = 0.0
    held = 0.0
    if s != 0:
        delta = rate * manual_increment(tau, h, t_accel, accel_max)
        if s < 0:
            delta = -delta
        # the time held saturates: a button held through an absurd dt keeps the station
        # running at its top rate, never inf
        held = tau + h
        if held > big:
            held = big
    v = manual_station_update(v, delta, w, tracking, h, tr, lo, hi, big)
    return v, held, s


# ---------------------------------------------------------------------------
# The block
# ---------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class ManualStationConfig(BlockConfig):
    """Configuration of :class:`ManualStation`.

    Attributes
    ----------
    tm : float
        Manual time constant Tm [s] > 0 (Åström 1987, Fig. 4.5): time to travel
        ``span`` at the base rate.
    tr : float
        Tracking (reset) time constant Tr [s] >= 0 (Åström 1987, Fig. 4.5); 0 is
        ideal tracking.
    span : float
        Travel in ``tm`` seconds at the base rate [output units] > 0.
    t_accel : float
        Acceleration time [s] > 0: the rate grows by one base rate every
        ``t_accel`` seconds of holding.
    accel_max : float
        Largest rate as a multiple of the base rate, >= 1 (1: no acceleration).
    out_min, out_max : float
        Output range [output units] (default 0..100 %).
    ts : float
        Sample time [s] > 0.
    y0 : float
        Output after ``reset()`` (limited to the output range).
    """

    tm: float = 20.0
    tr: float = 1.0
    span: float = 100.0
    t_accel: float = 2.0
    accel_max: float = 5.0
    out_min: float = 0.0
    out_max: float = 100.0
    ts: float = 0.1
    y0: float = 0.0

    def validate(self) -> None:
        require_positive("tm", self.tm, ErrorCode.BAD_TIME_CONSTANT)
        require_nonnegative("tr", self.tr, ErrorCode.BACK_CALC_T)
        require_positive("span", self.span)
        require_positive("t_accel", self.t_accel, ErrorCode.BAD_TIME_CONSTANT)
        if require_finite("accel_max", self.accel_max) < 1.0:
            raise ParameterError(
                ErrorCode.BAD_PARAMETER, "accel_max", f"must be >= 1, got {self.accel_max!r}"
            )
        require_limits("out_min", self.out_min, "out_max", self.out_max)
        require_positive("ts", self.ts, ErrorCode.NO_CYCLE)
        require_finite("y0", self.y0)


class ManualStation(Block):
    """Manual control module of Åström 1987, Fig. 4.5 (see the module docstring for the equations).

    Attributes
    ----------
    out : float
        Station output ``v`` [output units].
    held : float
        Time the present button has been held [s] (``tau``).
    direction : int
        +1 increase, -1 decrease, 0 no button in the last sample.
    tracking : bool
        A tracking input was given in the last sample.

    Examples
    --------
    Base rate 100 % in 20 s; hold "increase" for 1 s at ts = 0.1 s with
    acceleration time 2 s: ``A(1) = 1 + 1/4``, travel ``5 * 1.25 = 6.25 %``.

    >>> ms = ManualStation(tm=20.0, t_accel=2.0, ts=0.1)
    >>> for _ in range(10):
    ...     y = ms(inc=True)
    >>> round(y, 12)
    6.25

    In automatic mode pass the applied output as ``track``; switching to
    manual is then bumpless:

    >>> ms = ManualStation(tr=0.0)
    >>> ms(track=37.5)
    37.5
    >>> ms()  # manual, no button: stays where automatic left it
    37.5
    """

    Config = ManualStationConfig
    _state_fields = ("out", "held", "direction", "tracking")
    config: ManualStationConfig
    _config: ManualStationConfig

    def _apply_config(self, old: BlockConfig | None) -> None:
        c = self._config
        self._rate = float(c.span) / float(c.tm)
        self._tr = float(c.tr)
        self._t_accel, self._accel_max = float(c.t_accel), float(c.accel_max)
        self._lo, self._hi = float(c.out_min), float(c.out_max)
        self._ts = float(c.ts)
        if old is not None:  # a narrower range takes effect at once
            self.out = clamp(self.out, self._lo, self._hi)

    def _reset_state(self) -> None:
        c = self._config
        self.out = clamp(float(c.y0), self._lo, self._hi)
        self.held = 0.0
        self.direction = 0
        self.tracking = False

    def output_limits(self) -> tuple[float, float]:
        """``(out_min, out_max)`` in force."""
        return self._lo, self._hi

    def preset(self, value: float) -> None:
        """Set the output to ``value`` (limited to the range); a non-finite value is ignored."""
        if is_finite(value):
            self.out = clamp(float(value), self._lo, self._hi)

    def compute_output(self) -> float:
        """Two-phase form (Åström 1987, section 6): the present output, state untouched."""
        return self.out

    def update_state(
        self, applied: float, inc: bool = False, dec: bool = False, dt: float | None = None
    ) -> float:
        """Two-phase form: advance with the value actually applied as the tracking input."""
        return self(inc, dec, track=applied, dt=dt)

    def __call__(
        self,
        inc: bool = False,
        dec: bool = False,
        track: float | None = None,
        dt: float | None = None,
    ) -> float:
        """Run one sample and return the output.

        Parameters
        ----------
        inc, dec : bool
            The increase and decrease buttons (held = True).
        track : float, optional
            Tracking input: the applied output in automatic mode (or after an
            external saturation); None for no tracking.
        dt : float, optional
            Sample time of this call [s]; default the configured ``ts``.
        """
        h = self._cycle_time(dt, self._ts)
        if h is None:
            return self.out
        tracking = track is not None
        w = as_input(track) if tracking else 0.0
        if not math.isfinite(w):
            self.error_id = ErrorCode.BAD_INPUT
            return self.out
        self.error_id = ErrorCode.NO_ERROR
        self.tracking = tracking
        self.out, self.held, self.direction = manual_station_step(
            as_flag(inc, False), as_flag(dec, False), w, tracking, h, self._rate, self._tr,
            self._t_accel, self._accel_max, self._lo, self._hi, MAX_TIME, self.out, self.held,
            self.direction,
        )  # fmt: skip
        return self.out
