"""Three-point step controller for motorised valves: OPEN / CLOSE pulses from a position demand.

Source
------
Åström 1987, section 2, "Incremental Form" and Fig. 2.2: the incremental
algorithm "is particularly useful when the actuator is a stepping motor
because the motor can then be used as the summing device".  A motorised
valve without position feedback is such a summing device: while its motor
runs, the valve travels at a constant speed, ``span / travel_time``; when it
stops, the valve stays where it is.  The controller therefore sends only the
*changes* of its output, as OPEN and CLOSE pulses, and the motor integrates
them.  The minimum pulse, the minimum pause, the dead band and the end
switches are what a PLC step controller adds to make that safe for the
motor (the inputs of Siemens' PID_3Step and of the TwinCAT controller
toolbox's stepping-motor block); their rules here are ctrlblocks' design,
stated below and tested.

Equations
---------
Input ``u`` [%] is the position the controller demands (e.g. the output of a
:class:`~ctrlblocks.PID` in 0..100 %); ``s = h span / travel_time`` is the
travel of one sample with the motor running.  The block keeps an estimate
``x`` of the valve position -- the sum of its own pulses, Åström's summing
device modelled inside the block -- and the *pending travel* ``p`` [%], the
travel still owed to the valve::

    p[k] = u[k] - x[k]        (x: the estimate, or the position feedback f)

Between two samples the demand changes by its increment ``u[k] - u[k-1]``,
the estimate by the travel of the pulses, so ``p`` is the sum of the
demand's increments not yet sent -- the incremental algorithm with the
motor as the integrator.  The estimate starts at mid-travel; set it with
:meth:`StepController.preset_position` when the position is known, and the
end switches correct it whenever the valve reaches a stop.

Each sample with the motor running in direction ``d`` (+1 OPEN, -1 CLOSE)
moves the estimated position ``x`` by ``d s`` (limited to ``0..span``) and
``p`` by ``-d s``.  The pulse rules, per sample:

* a pulse **starts** when the motor is idle, the pause is over and
  ``|p| > max(deadband, s_min / 2, s / 2)`` with ``s_min = min_pulse span /
  travel_time`` the travel of a minimum pulse; its direction is ``sign(p)``;
* a running pulse **continues** while it is shorter than ``min_pulse`` or
  while ``d p >= s / 2`` (at least half a sample of travel is still owed);
* after a pulse the motor rests for at least ``min_pause`` (and at least one
  sample) before the next pulse in either direction.

Because a pulse starts only when more than half a minimum pulse is owed and
then travels at most ``max(s_min, |p| + s/2)``, it leaves at most
``max(s_min, s) / 2`` owed in the other direction: below the start threshold,
so the block never hunts between OPEN and CLOSE.  The number of pulses in a
time ``T`` is at most ``T / (max(min_pulse, h) + max(min_pause, h))``.

End switches: ``open_limit`` true means the valve is fully open -- OPEN pulses
stop at once, positive pending travel is dropped (nothing winds up against
the stop) and the estimate is set to ``span``; ``close_limit`` likewise at 0.
A demand at the end of the range (``u >= span`` or ``u <= 0``) drives the
motor on towards that stop until its switch reports it, even where the
estimate already says the valve is there: an estimate that drifted cannot
leave the valve short of fully open or fully closed.

Manual mode: ``manual = True`` drives the motor from ``manual_command``
(+1 OPEN, -1 CLOSE, 0 stop) with the end switches still obeyed, and the
estimate follows the pulses.  The demand is a position, so the return to
automatic is bumpless when the controller's output equals the valve position
at that moment: wire :attr:`position` to the PID's tracking input (or set its
manual value to it) while in manual.

Errors
------
A NaN/inf demand (or feedback) stops the motor (the safe action for a valve
without feedback: it stays where it is), sets ``BAD_INPUT``
(``BAD_MEASUREMENT`` for the feedback) and keeps the pending travel; the
block recovers by itself.  A bad per-call ``dt`` stops the motor and sets
``NO_CYCLE``.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from .base import (
    MAX_TIME,
    Block,
    BlockConfig,
    ErrorCode,
    Mode,
    add_time,
    is_finite,
    require_nonnegative,
    require_positive,
)
from .signals import clamp

__all__ = ["StepController", "StepControllerConfig"]

_EPS = 1e-9  # seconds: pause and pulse times are compared with this slack


@dataclasses.dataclass(frozen=True)
class StepControllerConfig(BlockConfig):
    """Configuration of :class:`StepController`.

    Attributes
    ----------
    travel_time : float
        Motor travel time from fully closed to fully open [s].
    min_pulse : float
        Shortest pulse the motor is given [s] (rounded up to whole samples).
    min_pause : float
        Shortest rest between two pulses [s] (at least one sample).
    deadband : float
        Pending travel that starts no pulse [% of span].
    span : float
        Position range of the valve [%], 100 by default.
    ts : float
        Sample time [s].
    """

    travel_time: float = 60.0
    min_pulse: float = 0.2
    min_pause: float = 0.2
    deadband: float = 0.5
    span: float = 100.0
    ts: float = 0.1

    def validate(self) -> None:
        require_positive("travel_time", self.travel_time, ErrorCode.BAD_TIME_CONSTANT)
        require_nonnegative("min_pulse", self.min_pulse, ErrorCode.BAD_TIME_CONSTANT)
        require_nonnegative("min_pause", self.min_pause, ErrorCode.BAD_TIME_CONSTANT)
        require_nonnegative("deadband", self.deadband)
        require_positive("span", self.span)
        require_positive("ts", self.ts, ErrorCode.NO_CYCLE)


class StepController(Block):
    """Three-point step controller: OPEN/CLOSE pulses for a motorised valve.

    ``out = step(u)`` returns ``+1.0`` (OPEN), ``-1.0`` (CLOSE) or ``0.0``
    (motor off) for one sample; :attr:`open_cmd` and :attr:`close_cmd` give
    the two digital outputs.  See the module docstring for the equations.

    >>> sc = StepController(travel_time=10.0, min_pulse=0.2, min_pause=0.2,
    ...                     deadband=1.0, ts=0.1)
    >>> sc.preset_position(40.0)        # the valve is known to be at 40 %
    >>> sc(40.0)
    0.0
    >>> [sc(45.0) for _ in range(6)]    # 5 % owed, 1 % per sample
    [1.0, 1.0, 1.0, 1.0, 1.0, 0.0]
    >>> sc.position, sc.pulses
    (45.0, 1)
    """

    Config = StepControllerConfig
    _state_fields = (
        "out",
        "pending",
        "position",
        "run_time",
        "pause_left",
        "pulses",
        "manual",
        "manual_command",
    )

    config: StepControllerConfig
    _config: StepControllerConfig

    def __init__(self, config: StepControllerConfig | None = None, /, **params: Any) -> None:
        super().__init__(config, **params)

    def _reset_state(self) -> None:
        c: StepControllerConfig = self._config
        self.out = 0.0
        self.pending = 0.0
        self.position = 0.5 * c.span  # unknown without feedback: mid-travel
        self.run_time = 0.0
        self.pause_left = 0.0
        self.pulses = 0
        self.manual = False
        self.manual_command = 0

    # -- outputs -----------------------------------------------------------

    @property
    def open_cmd(self) -> bool:
        """The OPEN output (motor runs towards open this sample)."""
        return self.out > 0.0

    @property
    def close_cmd(self) -> bool:
        """The CLOSE output (motor runs towards closed this sample)."""
        return self.out < 0.0

    @property
    def mode(self) -> Mode:
        """``Mode.MANUAL`` while :attr:`manual` is set, else ``Mode.AUTO``."""
        return Mode.MANUAL if self.manual else Mode.AUTO

    def preset_position(self, position: float) -> None:
        """Set the position estimate [%] (e.g. after a reference run to an end switch)."""
        c: StepControllerConfig = self._config
        if is_finite(position):
            self.position = clamp(float(position), 0.0, c.span)

    # -- the step ------------------------------------------------------------

    def __call__(
        self,
        u: float,
        dt: float | None = None,
        *,
        open_limit: bool = False,
        close_limit: bool = False,
        feedback: float | None = None,
    ) -> float:
        """One sample: demanded position ``u`` [%] -> motor command (+1, -1 or 0)."""
        c: StepControllerConfig = self._config
        h = self._cycle_time(dt, c.ts)
        if h is None:
            return self._stop()
        if not is_finite(u):
            self.error_id = ErrorCode.BAD_INPUT
            return self._stop()
        u = float(u)
        if feedback is not None and not is_finite(feedback):
            self.error_id = ErrorCode.BAD_MEASUREMENT
            return self._stop()
        self.error_id = ErrorCode.NO_ERROR
        # travel of one running sample [%]; a sample longer than the travel time moves
        # the whole span at most (and an absurd dt gives no inf in the pending travel)
        s = min(h * c.span / c.travel_time, c.span)

        if feedback is not None:
            self.position = clamp(float(feedback), 0.0, c.span)
        if open_limit:
            self.position = c.span
        if close_limit:
            self.position = 0.0
        if self.manual:
            self.pending = 0.0
            direction = int(self.manual_command > 0) - int(self.manual_command < 0)
        else:
            # a demand near the float range apart from the position: saturated, not inf
            self.pending = clamp(u - self.position, -MAX_TIME, MAX_TIME)
            run_on = 0  # a demand at a range end drives on to that stop
            if feedback is None:
                run_on = int(u >= c.span and not open_limit) - int(u <= 0.0 and not close_limit)
            direction = self._pulse_direction(c, h, s, run_on, open_limit, close_limit)
        return self._run(c, h, s, direction, open_limit, close_limit)

    def _pulse_direction(
        self,
        c: StepControllerConfig,
        h: float,
        s: float,
        run_on: int,
        open_limit: bool,
        close_limit: bool,
    ) -> int:
        """Direction of this sample by the pulse rules (see the module docstring)."""
        if open_limit and self.pending > 0.0:
            self.pending = 0.0  # nothing winds up against the open stop
        if close_limit and self.pending < 0.0:
            self.pending = 0.0
        d = int(self.out > 0.0) - int(self.out < 0.0)
        if d != 0:
            if run_on == d or self.run_time < c.min_pulse - _EPS or d * self.pending >= 0.5 * s:
                return d
            self.pause_left = c.min_pause - h  # this sample is the first of the pause
            return 0
        if self.pause_left > _EPS:
            self.pause_left -= h
            return 0
        s_min = c.min_pulse * c.span / c.travel_time
        if run_on == 0 and abs(self.pending) <= max(c.deadband, 0.5 * s_min, 0.5 * s):
            return 0
        self.run_time = 0.0
        self.pulses += 1
        return run_on or (1 if self.pending > 0.0 else -1)

    def _run(
        self,
        c: StepControllerConfig,
        h: float,
        s: float,
        direction: int,
        open_limit: bool,
        close_limit: bool,
    ) -> float:
        """Apply ``direction`` for one sample, obeying the end switches."""
        if (direction > 0 and open_limit) or (direction < 0 and close_limit):
            direction = 0
        if direction != 0:
            self.position = clamp(self.position + direction * s, 0.0, c.span)
            if not self.manual:
                self.pending = clamp(self.pending - direction * s, -MAX_TIME, MAX_TIME)
            self.run_time = add_time(self.run_time, h)
        self.out = float(direction)
        return self.out

    def _stop(self) -> float:
        """Motor off for this sample (bad data or a bad cycle time)."""
        self.out = 0.0
        return 0.0

    def _apply_config(self, old: BlockConfig | None) -> None:
        if old is not None:  # a smaller span keeps the estimate inside the travel
            self.position = clamp(self.position, 0.0, self._config.span)
