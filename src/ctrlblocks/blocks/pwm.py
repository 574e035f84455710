"""Pulse-width output: an on/off actuator (heater, solenoid) driven by a controller output.

A controller output ``v`` in ``[in_lo, in_hi]`` (0..100 % by default) becomes
a duty cycle ``d = (v - in_lo) / (in_hi - in_lo)``: in every PWM period ``P``
the output is on for ``d P`` and off for the rest.  For a process much slower
than the period the on/off actuator then acts as a continuous one of mean
value ``d`` -- the averaged loop equals the continuous loop -- with a ripple
that shrinks with ``P``.  The rules below are ctrlblocks' design; the ripple
formula is derived here and checked by a test.

Equations
---------
Sample time ``h``; at the start of each period the block latches the duty and
sets the on time of the period::

    t_on = d P + c                 (c: carry from the periods before)

then applies the minimum times: ``t_on < t_min_on`` gives no pulse
(``t_on = 0``), ``P - t_on < t_min_off`` gives a full period on
(``t_on = P``).  A sample is on while ``t + h/2 <= t_on`` (``t``: time since
the period started), so pulses are whole samples.  What the period delivered
less what it was asked for, ``c = d P + c_prev - (on time applied)``, is
carried to the next period (error diffusion, limited to ``|c| <= P``): the
minimum times and the rounding to samples never bias the mean, which stays
``d`` over any number of periods up to one period's rounding.

Ripple (a hand-evaluated formula, tested): a first-order process
``K / (T s + 1)`` driven by a PWM with duty ``d`` and period ``P`` settles to a
periodic response whose peak-to-peak ripple is::

    R = K (1 - a^d) (1 - a^(1-d)) / (1 - a),      a = exp(-P / T)

-- from the exact solution of ``T y' + y = K`` (on) and ``T y' + y = 0``
(off) over one period.  For ``P << T`` this is ``R ~= K d (1 - d) P / T``,
largest at ``d = 0.5``: ``K P / (4 T)``.  The advice that follows, as for the
choice of the sampling period of a digital controller (Åström 1987,
section 2): choose ``P`` small against the dominant time constant -- ``P <=
T / 25`` keeps the ripple below 1 % of the gain ``K`` at any duty.

Errors
------
A NaN/inf controller output keeps the period's latched on time (the pulse in
progress completes) and sets ``BAD_INPUT``; the next period with no valid
input is off (the safe state of a heater).  A bad per-call ``dt`` switches the
output off for that call and sets ``NO_CYCLE``.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from .base import (
    Block,
    BlockConfig,
    ErrorCode,
    ParameterError,
    as_input,
    require_limits,
    require_nonnegative,
    require_positive,
)
from .cycleblock import time_add
from .plc_cycle import REAL_MAX, is_real
from .signals import clamp

__all__ = ["PWM_RESULTS", "PulseWidth", "PulseWidthConfig", "pwm_cycle", "pwm_ripple"]

_EPS = 1e-9  # seconds: time comparisons within a period
NO_ERROR = int(ErrorCode.NO_ERROR)
BAD_INPUT = int(ErrorCode.BAD_INPUT)


def pwm_ripple(k: float, t: float, period: float, duty: float) -> float:
    """Peak-to-peak ripple of ``K/(T s + 1)`` driven by a PWM (see the module docstring)."""
    a = math.exp(-period / t)
    return k * (1.0 - a**duty) * (1.0 - a ** (1.0 - duty)) / (1.0 - a)


@dataclasses.dataclass(frozen=True)
class PulseWidthConfig(BlockConfig):
    """Configuration of :class:`PulseWidth`.

    Attributes
    ----------
    period : float
        PWM period P [s], at least one sample.
    t_min_on, t_min_off : float
        Shortest on pulse and shortest off gap [s].
    in_lo, in_hi : float
        Controller output range that maps to duty 0..1 (default 0..100 %).
    ts : float
        Sample time [s].
    """

    period: float = 10.0
    t_min_on: float = 0.0
    t_min_off: float = 0.0
    in_lo: float = 0.0
    in_hi: float = 100.0
    ts: float = 0.1

    def validate(self) -> None:
        require_positive("ts", self.ts, ErrorCode.NO_CYCLE)
        p = require_positive("period", self.period, ErrorCode.BAD_TIME_CONSTANT)
        if p < float(self.ts) - _EPS:
            raise ParameterError(
                ErrorCode.BAD_TIME_CONSTANT, "period", f"must be >= ts, got {self.period!r}"
            )
        for name in ("t_min_on", "t_min_off"):
            value = getattr(self, name)
            if require_nonnegative(name, value, ErrorCode.BAD_TIME_CONSTANT) > p:
                raise ParameterError(
                    ErrorCode.BAD_TIME_CONSTANT, name, f"must be <= period, got {value!r}"
                )
        lo, hi = require_limits("in_lo", self.in_lo, "in_hi", self.in_hi, allow_infinite=False)
        if lo == hi:
            raise ParameterError(ErrorCode.BAD_LIMITS, "in_lo/in_hi", "must differ")


PWM_RESULTS = (
    "out", "error_id", "t_in", "t_on", "applied", "asked", "carry", "duty", "started",
)  # fmt: skip
"""Names of the values :func:`pwm_cycle` returns: outputs, then the new memory."""


def pwm_cycle(
    v: float,
    period: float,
    t_min_on: float,
    t_min_off: float,
    in_lo: float,
    in_hi: float,
    ts: float,
    t_in: float,
    t_on: float,
    applied: float,
    asked: float,
    carry: float,
    duty: float,
    started: bool,
) -> tuple[float, int, float, float, float, float, float, float, bool]:
    """One sample of :class:`PulseWidth` (module docstring): controller output ``v`` -> on/off.

    The memory: ``t_in`` time since the period started, ``t_on`` the period's on
    time, ``applied`` the on time applied in it, ``asked`` the on time asked for
    (``d P + carry``), ``carry``, the latched ``duty`` and ``started`` (False: a
    period starts now).  A ``v`` that is no finite REAL is a bad input.  Written
    in the subset the PLC translator accepts.  Returns :data:`PWM_RESULTS`.
    """
    err = NO_ERROR
    good = is_real(v)
    if not good:
        err = BAD_INPUT
    if not started or t_in >= period - 0.5 * ts - _EPS:
        # close the period that ends (carry its error) and latch the next on time
        if started:
            carry = clamp(asked - applied, -period, period)
        started = True
        t_in = 0.0
        applied = 0.0
        if not good:  # no valid output at the period start: off (a heater's safe state)
            duty = 0.0
            asked = 0.0
            t_on = 0.0
            carry = 0.0
        else:
            duty = clamp((v - in_lo) / (in_hi - in_lo), 0.0, 1.0)
            asked = duty * period + carry
            t_on = clamp(asked, 0.0, period)
            if t_on < t_min_on - _EPS:
                t_on = 0.0
            elif period - t_on < t_min_off - _EPS:
                t_on = period
    on = t_in + 0.5 * ts <= t_on + _EPS
    if on:
        applied = time_add(applied, ts)
    t_in = time_add(t_in, ts)
    out = 0.0
    if on:
        out = 1.0
    return out, err, t_in, t_on, applied, asked, carry, duty, started


class PulseWidth(Block):
    """Pulse-width modulated on/off output from a controller output.

    ``out = pwm(v)`` returns ``1.0`` (on) or ``0.0`` (off) for one sample;
    :attr:`on` is the same as a bool and :attr:`duty` the latched duty cycle.

    >>> pwm = PulseWidth(period=1.0, ts=0.1)
    >>> [pwm(30.0) for _ in range(10)]
    [1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    """

    Config = PulseWidthConfig
    _state_fields = ("out", "t_in", "t_on", "applied", "asked", "carry", "duty", "started")

    config: PulseWidthConfig
    _config: PulseWidthConfig

    def __init__(self, config: PulseWidthConfig | None = None, /, **params: Any) -> None:
        super().__init__(config, **params)

    def _reset_state(self) -> None:
        self.out = 0.0
        self.t_in = 0.0  # time since the period started [s]
        self.t_on = 0.0  # on time of this period [s]
        self.applied = 0.0  # on time applied in this period [s]
        self.asked = 0.0  # on time asked for in this period (d P + carry) [s]
        self.carry = 0.0
        self.duty = 0.0
        self.started = False  # False: a period starts with the next sample

    @property
    def on(self) -> bool:
        """The digital output of this sample."""
        return self.out > 0.5

    def __call__(self, v: float, dt: float | None = None) -> float:
        """One sample: controller output ``v`` -> on (1.0) or off (0.0)."""
        c: PulseWidthConfig = self._config
        h = self._cycle_time(dt, c.ts)
        if h is None:
            self.out = 0.0
            return 0.0
        x = as_input(v)
        if math.isfinite(x):  # finite beyond REAL: the same duty (clamped to 0..1)
            x = clamp(x, -REAL_MAX, REAL_MAX)
        (self.out, err, self.t_in, self.t_on, self.applied, self.asked, self.carry, self.duty,
         self.started) = pwm_cycle(x, c.period, c.t_min_on, c.t_min_off, c.in_lo, c.in_hi, h,
                                   self.t_in, self.t_on, self.applied, self.asked, self.carry,
                                   self.duty, self.started)  # fmt: skip
        self.error_id = ErrorCode(err)
        return self.out
