"""The process side of a scenario: the plant in its wrappers and the time line.

:class:`ProcessSide` is everything of a scenario that is not a controller:
the plant (and the inner plant of a cascade or override) built with
:func:`~ctrlblocks.loops.build` inside the plants' ``Actuator`` and
``Sensor`` wrappers (``[actuator]``, ``[sensor]``), its initial steady state
(``[initial]``), the setpoint profile and the process events (setpoint steps
and ramps, loads, plant parameters, sensor faults of ``y`` and of ``y2``).  Two
callers share it:

* :func:`ctrlblocks.sim.simulate` steps it in the closed loop with the
  scenario's controllers;
* :class:`ctrlblocks.sim.PlantProcess` steps it for the runtime's plant
  server, which serves it over OPC UA and Modbus, so a runtime controlling it
  sees exactly the simulator's samples.

The controller-side events (``mode``, ``manual_value``, ``limits``, ``set``)
are left to the caller: :meth:`ProcessSide.apply` returns False for them.

Two more inputs of some structures:

* a **second actuator** (``split_range``, two MVs): the plant has a second
  input (:class:`~ctrlblocks.plants.HeatCool`'s heater); it is shaped by an
  :class:`~ctrlblocks.plants.Actuator` of its own with the same ``[actuator]``
  range and rate (the input load acts on the first actuator only), and
  :meth:`ProcessSide.step` takes both MVs;
* a **wild flow** (``ratio``): a measured signal the loop does not
  manipulate, with its own profile (``initial.wild``, ``do = "wild"``
  events: steps and ramps like the setpoint's, ``ok = false`` or
  ``nan = true`` for a bad measurement), :attr:`ProcessSide.wild`.

The inner measurement ``y2`` of a series process (cascade, override,
three-step) is the inner plant's output; ``sensor`` events with
``target = "y2"`` flag it bad (:attr:`ProcessSide.sensor2_ok`) or replace it
by NaN (:attr:`ProcessSide.y2_measured`), as the others do for ``y``.  The
plants are not affected: the outer plant still receives the true ``y2``.

Sample ``k`` (time ``t_k = k ts``) of a caller::

    if k > 0:
        proc.setpoint.advance(ts)
        proc.wild.advance(ts)
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

from ..loops.spec import ControllerSpec, build
from ..loops.structures import STRUCTURES
from ..plants import Actuator, Noise, Sensor, steady_input
from ..plants.heatcool import SecondInput
from .scenario import INITIAL_Y_PROBLEM, Event, Scenario, ScenarioError

__all__ = [
    "PROCESS_EVENTS",
    "ProcessSide",
    "SetpointProfile",
    "set_plant_parameter",
    "steady_input",
]

log = logging.getLogger(__name__)

PROCESS_EVENTS = ("setpoint", "load", "plant", "sensor", "wild")
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
    controller : ControllerSpec, optional
        The controller entry whose MVs start the plant (a split range maps
        ``initial.u``, the controller output, to its two actuators; default
        the scenario's first entry).

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
    actuator2 : Actuator or None
        The second actuator of a two-MV structure (``split_range``).
    model, inner_model : object or None
        The bare process models (targets of parameter switches).
    setpoint : SetpointProfile
        The setpoint of the current sample (``setpoint.value``).
    inner_load : float
        Load between the inner and the outer plant.
    sensor_ok : bool
        False while a ``sensor`` event flags the measurement invalid.
    sensor2_ok : bool
        False while a ``sensor`` event with ``target = "y2"`` flags the inner
        measurement invalid.
    u0 : float
        The initial MV (``initial.u``, or the MV whose steady state gives
        ``initial.y``); a split range's controller output.
    u0s : tuple of float
        The initial values of the actuators (``(u0,)``; a split range's two).
    wild : SetpointProfile
        The wild flow profile (``initial.wild``, ``wild`` events).
    wild_ok : bool
        False while a ``wild`` event flags the wild-flow measurement invalid.
    """

    def __init__(
        self,
        scenario: Scenario,
        events: Iterable[Event] = (),
        controller: ControllerSpec | None = None,
    ) -> None:
        self.scenario = scenario
        self.ts = scenario.ts
        self.plant: Any = None
        self.inner: Any = None
        self.actuator: Any = None
        self.actuator2: Any = None
        self.model: Any = None
        self.inner_model: Any = None
        if scenario.plant is not None:
            self._make_process()
        ini = scenario.initial
        self.inner_load = 0.0
        self.sensor_ok = True
        self.sensor2_ok = True
        self._y2_nan = False
        self.u0 = ini["u"]
        if self.plant is not None:
            self.actuator.load = ini["load"]
            if not math.isnan(ini["y"]):
                self.u0 = self._u_for_y(ini["y"])
        structure = STRUCTURES[scenario.structure]
        if controller is None and scenario.controllers:
            controller = scenario.controllers[0]
        self.u0s: tuple[float, ...] = (self.u0,)
        if structure.actuators > 1 and controller is not None:
            self.u0s = tuple(structure.actuator_values(controller, self.u0))
        self.reset()
        sp0 = ini["sp"]
        if math.isnan(sp0):
            sp0 = self.plant.y_true if self.plant is not None else 0.0
        self.setpoint = SetpointProfile(sp0)
        self.wild = SetpointProfile(ini.get("wild", 0.0))
        self.wild_ok = True
        self._wild_nan = False
        self.pending: list[Event] = list(events)

    @property
    def wild_value(self) -> float:
        """The wild flow measured in the current sample (NaN during a ``nan`` event)."""
        return math.nan if self._wild_nan else self.wild.value

    @property
    def y2_measured(self) -> float:
        """The inner measurement ``y2``: the inner plant's output, NaN during a ``nan`` event
        (NaN without an inner plant).  Its quality flag is :attr:`sensor2_ok`."""
        if self.inner is None or self._y2_nan:
            return math.nan
        return self.inner.y

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
        if STRUCTURES[sc.structure].actuators > 1:
            if not hasattr(self.model, "set_second"):
                raise ScenarioError(
                    sc.file,
                    "plant.type",
                    f"the {sc.structure} structure writes two MVs; {sc.plant.type} has one "
                    "input (use a two-input plant such as HeatCool)",
                )
            self.actuator2 = Actuator(SecondInput(self.model), **act)

    def _u_for_y(self, y0: float) -> float:
        """The MV whose steady state gives the output ``y0`` (``initial.y``)."""
        chain = [self.model] if self.inner is None else [self.inner_model, self.model]
        u = steady_input(chain, y0)
        if u is None:
            raise ScenarioError(self.scenario.file, "initial.y", INITIAL_Y_PROBLEM)
        return u - self.actuator.load

    def reset(self, u: float | None = None, u2: float | None = None) -> None:
        """Put the plant(s) in the steady state of the MV ``u`` (default :attr:`u0`).

        A two-MV structure's plant: the MVs ``u`` and ``u2`` of its two
        actuators (default :attr:`u0s`).
        """
        if self.actuator2 is not None:
            self.actuator2.reset(self.u0s[1] if u2 is None else u2)  # first: the held input
            u = self.u0s[0] if u is None else u
        u = self.u0 if u is None else u
        if self.inner is not None:
            self.inner.reset(u)
            self.plant.reset(self.inner.y + self.inner_load)
        elif self.plant is not None:
            self.plant.reset(u)

    def step(self, u: float, u2: float | None = None) -> None:
        """Apply the MV ``u`` for one sample: the plant(s) advance by ``ts``.

        ``u2`` is the second actuator's MV of a two-MV structure (held from
        the sample before when None).

        Series plants (cascade, override) are coupled with a zero-order hold:
        the outer plant receives the inner plant's output ``y2`` (plus
        :attr:`inner_load`) of the start of the sample.
        """
        if self.actuator2 is not None and u2 is not None:
            self.actuator2.step(u2)
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
        elif k == "wild":
            if "value" in f:
                self.wild.step_to(f["value"], f.get("ramp"))
            if "ok" in f:
                self.wild_ok = f["ok"]
            if "nan" in f:
                self._wild_nan = f["nan"]
        elif f.get("target", "y") == "y2":  # a sensor event on the inner measurement
            if "ok" in f:
                self.sensor2_ok = f["ok"]
            if "nan" in f:
                self._y2_nan = f["nan"]
        else:  # a sensor event on y
            if "ok" in f:
                self.sensor_ok = f["ok"]
            if "nan" in f:
                self.plant.fault = math.nan if f["nan"] else None
        return True
