"""A scenario's process side stepped sample by sample, for the plant server.

:class:`PlantProcess` is the process side of a scenario (any structure
with a plant: single, cascade, override, feedforward, smith): the
simulator's own :class:`~ctrlblocks.sim.ProcessSide` (the plant inside the
plants' ``Actuator`` and ``Sensor`` wrappers, exactly as
:func:`ctrlblocks.sim.simulate` wires it, the inner plant of a cascade or
override in series with a zero-order hold, and the scenario's time line).
At sample ``k`` (time ``k ts``) it applies the events due (setpoint steps
and ramps, loads, plant parameters, sensor faults, and the controller-side
events mode / manual value / limits, which it *publishes* for the runtime to
read), publishes the measurement, and steps the plant by ``ts`` with the MV
it receives.  :class:`ctrlblocks.runtime.PlantServer` serves it over OPC UA
and Modbus TCP (``ctrlblocks plant-server``).

A split range's second actuator is :attr:`PlantProcess.mv2` (held until the
next :meth:`PlantProcess.step` that gives one) and a ratio loop's wild flow
is ``values()["wild"]`` (NaN while a ``wild`` event flags it bad).
"""

from __future__ import annotations

import logging
import math

from .process import ProcessSide
from .scenario import Event, Scenario

__all__ = ["PlantProcess"]

log = logging.getLogger(__name__)


class PlantProcess:
    """The process side of a scenario, stepped sample by sample.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario with a plant (any structure but ``open_loop``).
    case : str, optional
        The case whose events to play (default the first).
    """

    def __init__(self, scenario: Scenario, case: str | None = None) -> None:
        if scenario.plant is None:
            raise ValueError(
                f"{scenario.file}: the plant server needs a plant; "
                f"structure {scenario.structure!r} has none"
            )
        self.scenario = scenario
        self.case = scenario.cases[0] if case is None else scenario.case(case)
        for ev in self.case.events:
            if ev.kind == "set":
                raise ValueError(
                    f"{scenario.file}: event at t={ev.t:g} of kind 'set' acts inside the "
                    "controller; the plant server cannot serve it"
                )
        if scenario.initial["warmup"] > 0:
            log.warning(
                "%s: initial.warmup (%g s) initialises the simulator's controllers; the plant "
                "server starts the plant in its steady state and cannot serve it",
                scenario.file,
                scenario.initial["warmup"],
            )
        self.ts = scenario.ts
        self.side = ProcessSide(scenario, self.case.events)
        self.plant = self.side.plant
        self.u0 = self.side.u0
        ini = scenario.initial
        self.mode = 1.0 if ini["mode"] == "manual" else 0.0
        self.manual_value = math.nan
        self.u_min = math.nan
        self.u_max = math.nan
        self.mv = self.u0
        self.mv2 = self.side.u0s[1] if len(self.side.u0s) > 1 else math.nan
        if len(self.side.u0s) > 1:
            self.mv = self.side.u0s[0]
        self.k = 0
        self._apply_due()

    # -- the time line ----------------------------------------------------------

    @property
    def t(self) -> float:
        """Time of the current sample [s]."""
        return self.k * self.ts

    @property
    def duration(self) -> float:
        """Duration of the case [s]."""
        return self.case.duration

    @property
    def second_actuator(self) -> bool:
        """True when the process has a split range's second actuator (:attr:`mv2`)."""
        return self.side.actuator2 is not None

    @property
    def sensor_ok(self) -> bool:
        """False while a sensor event flags the measurement invalid."""
        return self.side.sensor_ok

    @property
    def sensor2_ok(self) -> bool:
        """False while a sensor event on ``y2`` flags the inner measurement invalid (a NaN
        event makes :attr:`pv2` NaN with this flag True, as for ``y``)."""
        return bool(self.side.sensor2_ok)

    def _apply_due(self) -> None:
        for ev in self.side.due(self.t):
            if not self.side.apply(ev):
                self._publish(ev)

    def _publish(self, ev: Event) -> None:
        """A controller-side event: published for the runtime to read."""
        f, k = ev.fields, ev.kind
        if k == "mode":
            self.mode = 1.0 if f["mode"] == "manual" else 0.0
            if "manual_value" in f:
                self.manual_value = f["manual_value"]
        elif k == "manual_value":
            self.manual_value = f["value"]
        elif k == "limits":
            self.u_min, self.u_max = f["u_min"], f["u_max"]

    # -- signals and the step ---------------------------------------------------------

    @property
    def pv(self) -> float:
        """The measurement of the current sample."""
        return float(self.plant.y)

    @property
    def sp(self) -> float:
        """The setpoint of the current sample."""
        return float(self.side.setpoint.value)

    def values(self) -> dict[str, float]:
        """Every served variable of the current sample."""
        return {
            "pv": self.pv,
            "mv": float(self.mv),
            "sp": self.sp,
            "mode": self.mode,
            "manual_value": self.manual_value,
            "u_min": self.u_min,
            "u_max": self.u_max,
            "k": float(self.k),
            "pv2": self.pv2,
            "dv": self.dv,
            "mv2": float(self.mv2),
            "wild": self.wild,
        }

    @property
    def wild(self) -> float:
        """The wild flow of the current sample (NaN while flagged bad or NaN)."""
        side = self.side
        return float(side.wild_value) if side.wild_ok else math.nan

    @property
    def pv2(self) -> float:
        """The inner measurement ``y2`` of the current sample (NaN without an inner plant,
        and while a ``sensor`` event on ``y2`` flags it bad or NaN)."""
        side = self.side
        return float(side.y2_measured) if side.sensor2_ok else math.nan

    @property
    def dv(self) -> float:
        """The input load of the current sample (the measured disturbance)."""
        return float(self.side.actuator.load)

    def step(self, u: float, u2: float | None = None) -> None:
        """Apply ``u`` (and a split range's ``u2``) for one sample; then go to the next sample."""
        self.mv = u
        if u2 is not None:
            self.mv2 = u2
        second = None if self.side.actuator2 is None else self.mv2
        self.side.step(u, second)  # series plants coupled exactly as in the simulator
        self.k += 1
        self.side.setpoint.advance(self.ts)
        self.side.wild.advance(self.ts)
        self._apply_due()
