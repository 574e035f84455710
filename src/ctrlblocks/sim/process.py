"""The process side of a scenario: the plant in its wrappers and the time line.

:class:`ProcessSide` is everything of a scenario that is not a controller:
the plant (and the inner plant of a cascade or override) built with
:func:`~ctrlblocks.loops.build` inside the plants' ``Actuator`` and
``Sensor`` wrappers (``[actuator]``, ``[sensor]``), its initial steady state
(``[initial]``), the setpoint profile and the process events (setpoint steps
and ramps, loads, plant parameters, sensor faults).  Two callers share it:

* :func:`ctrlblocks.sim.simulate` steps it in the closed loop with the
  scenario's controllers;
* :class:`ctrlblocks.sim.PlantProcess` steps it for the runtime's plant
  server, which serves it over OPC UA and Modbus, so a runtime controlling it
  sees exactly the simulator's samples.

The controller-side events (``mode``, ``manual_value``, ``limits``, ``set``)
are left to the caller: :meth:`ProcessSide.apply` returns False for them.

Sample ``k`` (time ``t_k = k ts``) of a caller::

    if k > 0:
        proc.setpoint.advance(ts)
    for ev in proc.due(t_k):
        if not proc.apply(ev):
            ...  # a controller-side event
    y = proc.plant.y                  # AD
    ...
    proc.step(u)                      # DA, and the plant(s) advance by ts
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable
from typing import Any

from ..loops.spec import build
from ..plants import Actuator, Noise, Sensor, steady_input
from .scenario import INITIAL_Y_PROBLEM, Event, Scenario, ScenarioError

__all__ = [
    "PROCESS_EVENTS",
    "ProcessSide",
    "SetpointProfile",
    "set_plant_parameter",
    "steady_input",
]

log = logging.getLogger(__name__)

PROCESS_EVENTS = ("setpoint", "load", "plant", "sensor")
"""Event kinds that act on the process side (the others act on a controller)."""


class SetpointProfile:
    """Setpoint profile: steps, and ramps at a given rate towards a target.

    Parameters
    ----------
    value : float
        The initial setpoint [PV units].
    """

    def __init__(self, value: float) -> None:
        self.value = self.target = value
        self.rate = math.inf

    def step_to(self, value: float, ramp: float | None) -> None:
        """Step to ``value``, or ramp towards it at ``ramp`` [units/s] when given."""
        self.target = value
        if ramp is None:
            self.value, self.rate = value, math.inf
        else:
            self.rate = ramp

    def advance(self, h: float) -> float:
        """Move towards the target by at most ``rate * h`` (``h`` in s); return the value."""
        d = self.target - self.value
        if d != 0.0:
            lim = self.rate * h
            self.value = self.target if abs(d) <= lim else self.value + math.copysign(lim, d)
        return self.value


def set_plant_parameter(plant: Any, name: str, value: Any) -> None:
    """Switch a plant parameter at run time (``do = "plant"`` events).

    Uses the plant's ``set_parameter`` when it has one, else ``configure``,
    else sets the attribute.
    """
    if hasattr(plant, "set_parameter"):
        plant.set_parameter(name, value)
    elif hasattr(plant, "configure"):
        plant.configure(**{name: value})
    else:
        setattr(plant, name, value)


class ProcessSide:
    """The plant(s), the setpoint profile and the process events of a scenario.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario.  Without a plant (``open_loop``) only the setpoint
        profile and the time line are kept.
    events : iterable of Event
        The time line to play (sorted by time), usually a case's events.

    Attributes
    ----------
    plant : object or None
        The measured chain: ``Sensor(Actuator(model))``, or ``Sensor(model)``
        behind an inner plant; step it with the MV (single loop) or with the
        inner plant's output (series plants).
    inner : Actuator or None
        ``Actuator(inner model)`` of a cascade or override.
    actuator : Actuator or None
        The actuator wrapper (the input load and the applied MV ``u``).
    model, inner_model : object or None
        The bare process models (targets of parameter switches).
    setpoint : SetpointProfile
        The setpoint of the current sample (``setpoint.value``).
    inner_load : float
        Load between the inner and the outer plant.
    sensor_ok : bool
        False while a ``sensor`` event flags the measurement invalid.
    u0 : float
        The initial MV (``initial.u``, or the MV whose steady state gives
        ``initial.y``).
    """

    def __init__(self, scenario: Scenario, events: Iterable[Event] = ()) -> None:
        self.scenario = scenario
        self.ts = scenario.ts
        self.plant: Any = None
        self.inner: Any = None
        self.actuator: Any = None
        self.model: Any = None
        self.inner_model: Any = None
        if scenario.plant is not None:
            self._make_process()
        ini = scenario.initial
        self.inner_load = 0.0
        self.sensor_ok = True
        self.u0 = ini["u"]
        if self.plant is not None:
            self.actuator.load = ini["load"]
            if not math.isnan(ini["y"]):
                self.u0 = self._u_for_y(ini["y"])
        self.reset()
        sp0 = ini["sp"]
        if math.isnan(sp0):
            sp0 = self.plant.y_true if self.plant is not None else 0.0
        self.setpoint = SetpointProfile(sp0)
        self.pending: list[Event] = list(events)

    def _make(self, spec: Any) -> Any:
        return build(spec, self.ts, kind="plant", file=self.scenario.file, error=ScenarioError)

    def _make_process(self) -> None:
        """Wrap the models in the plants' Actuator and Sensor (``[actuator]``, ``[sensor]``)."""
        sc = self.scenario
        act, sen = dict(sc.actuator), dict(sc.sensor)
        noise = None
        if sen.get("noise", 0.0) > 0.0:
            noise = Noise(
                sen["noise"],
                kind=sen.get("noise_kind", "uniform"),
                t_corr=sen.get("noise_t_corr", 0.0),
                ts=self.ts,
                seed=sc.seed,
            )
        self.model = self._make(sc.plant)
        sensor_args = {"noise": noise, "y_min": sen["y_min"], "y_max": sen["y_max"]}
        if sc.inner_plant is not None:
            self.inner_model = self._make(sc.inner_plant)
            self.inner = Actuator(self.inner_model, **act)
            self.actuator = self.inner
            self.plant = Sensor(self.model, **sensor_args)
        else:
            self.plant = Sensor(Actuator(self.model, **act), **sensor_args)
            self.actuator = self.plant.find(Actuator)

    def _u_for_y(self, y0: float) -> float:
        """The MV whose steady state gives the output ``y0`` (``initial.y``)."""
        chain = [self.model] if self.inner is None else [self.inner_model, self.model]
        u = steady_input(chain, y0)
        if u is None:
            raise ScenarioError(self.scenario.file, "initial.y", INITIAL_Y_PROBLEM)
        return u - self.actuator.load

    def reset(self, u: float | None = None) -> None:
        """Put the plant(s) in the steady state of the MV ``u`` (default :attr:`u0`)."""
        u = self.u0 if u is None else u
        if self.inner is not None:
            self.inner.reset(u)
            self.plant.reset(self.inner.y + self.inner_load)
        elif self.plant is not None:
            self.plant.reset(u)

    def step(self, u: float) -> None:
        """Apply the MV ``u`` for one sample: the plant(s) advance by ``ts``.

        Series plants (cascade, override) are coupled with a zero-order hold:
        the outer plant receives the inner plant's output ``y2`` (plus
        :attr:`inner_load`) of the start of the sample.
        """
        if self.inner is not None:
            y2 = self.inner.y
            self.inner.step(u)
            self.plant.step(y2 + self.inner_load)
        else:
            self.plant.step(u)

    # -- the time line ------------------------------------------------------------

    def due(self, t: float) -> list[Event]:
        """Remove and return the pending events due at the sample time ``t`` [s].

        An event is due when its time is at most half a sample after ``t``.
        """
        out = []
        limit = t + 0.5 * self.ts
        while self.pending and self.pending[0].t <= limit:
            out.append(self.pending.pop(0))
        return out

    def apply(self, ev: Event) -> bool:
        """Apply a process event; return False (and do nothing) for a controller-side one."""
        f, k = ev.fields, ev.kind
        if k not in PROCESS_EVENTS:
            return False
        if k == "setpoint":
            self.setpoint.step_to(f["value"], f.get("ramp"))
        elif k == "load":
            at = f.get("at", "input")
            if at == "input":
                self.actuator.load = f["value"]
            elif at == "output":
                self.plant.load = f["value"]
            elif self.inner is not None:
                self.inner_load = f["value"]
            else:
                log.warning("load at %r needs an inner plant (single loop); ignored", at)
        elif k == "plant":
            plant = self.inner_model if f.get("target", "plant") == "inner_plant" else self.model
            set_plant_parameter(plant, f["param"], f["value"])
        else:  # sensor
            if "ok" in f:
                self.sensor_ok = f["ok"]
            if "nan" in f:
                self.plant.fault = math.nan if f["nan"] else None
        return True
