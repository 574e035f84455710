"""A thermal process with two actuators: a cooler and a heater on one heat capacity.

The model of a split-range heat/cool loop (a jacketed vessel, an extruder
zone, a climate chamber): one lumped heat capacity loses heat to its
surroundings at ``t_amb`` through a thermal resistance, gains the heater's
power and loses the cooler's.  With the temperature ``T`` [°C], the cooling
power ``c`` and the heating power ``h`` (both in % of their actuator's full
power) the energy balance is ::

    t dT/dt = (t_amb - T) + k_heat h(t - dead_time) - k_cool c(t - dead_time)       (HC)

where ``t`` [s] is the time constant (heat capacity times thermal
resistance) and ``k_heat``, ``k_cool`` [K/%] the steady-state temperature
rise (drop) per % of heater (cooler) power.  Both powers enter the same
heat balance, so the model is a first-order lag (:class:`~.linear.PT1`,
exact ZOH and exact dead time) of the net power ``q = k_heat h - k_cool c``
around ``t_amb``; in steady state ``T = t_amb + k_heat h - k_cool c``.

The two inputs: ``u`` (the first actuator, stepped with :meth:`HeatCool.step`)
is the cooler ``c``; ``u2`` (the second actuator) is the heater ``h``.  A
split-range controller drives the cooler from the low half of its output and
the heater from the high half (:mod:`ctrlblocks.loops.split`).  A plant
wrapper drives ``u`` like any plant's input; :class:`SecondInput` makes
``u2`` a plant input of its own, so an :class:`~.wrappers.Actuator` (range,
rate, load) can shape it as well::

    proc = HeatCool(k_heat=0.6, k_cool=0.4, t=60.0, ts=1.0)
    heater = Actuator(SecondInput(proc), u_min=0.0, u_max=100.0)
    cooler = Actuator(proc, u_min=0.0, u_max=100.0)
    heater.step(h)        # holds u2 = h for the next sample
    cooler.step(c)        # the process advances by ts with (c, h)

A plant never raises on process data: a non-finite input holds the previous one.
"""

from __future__ import annotations

import math
from typing import Any

from ..blocks.base import require_finite, require_nonnegative
from .base import Plant
from .linear import PT1

__all__ = ["HeatCool", "SecondInput"]


class HeatCool(Plant):
    """Heat/cool thermal process (HC) of the module docstring.

    Parameters
    ----------
    k_heat : float
        Temperature rise per % heater power in steady state [K/%], >= 0.
    k_cool : float
        Temperature drop per % cooler power in steady state [K/%], >= 0.
    t : float
        Time constant [s], > 0.
    ts : float
        Sample time [s].
    t_amb : float
        Ambient temperature [°C] (the temperature with both actuators off).
    dead_time : float
        Transport delay of both powers [s], >= 0.

    Attributes
    ----------
    u : float
        The cooler power of the last sample [%] (the first input).
    u2 : float
        The heater power held for the next sample [%] (the second input).
    """

    def __init__(
        self,
        k_heat: float,
        k_cool: float,
        t: float,
        ts: float,
        t_amb: float = 20.0,
        dead_time: float = 0.0,
    ) -> None:
        self.k_heat = require_nonnegative("k_heat", k_heat)
        self.k_cool = require_nonnegative("k_cool", k_cool)
        self.t_amb = require_finite("t_amb", t_amb)
        self._lag = PT1(1.0, t, ts, dead_time=dead_time)
        self.ts = self._lag.ts
        self.t = self._lag.t
        self.dead_time = float(dead_time)
        self.u = 0.0
        self.u2 = 0.0
        self.reset(0.0)

    def _q(self, c: float) -> float:
        """The net power ``k_heat h - k_cool c`` [K] with the held heater power."""
        return self.k_heat * self.u2 - self.k_cool * c

    @property
    def y(self) -> float:
        """Temperature [°C]."""
        return self.t_amb + self._lag.y

    def steady_y(self, c: float, h: float) -> float:
        """The steady-state temperature of cooler ``c`` and heater ``h`` [°C]."""
        return self.t_amb + self.k_heat * h - self.k_cool * c

    def step(self, u: float) -> float:
        """Hold the cooler power ``u`` (and the heater power :attr:`u2`) for one sample."""
        if not math.isfinite(u):
            u = self.u
        self.u = float(u)
        self._lag.step(self._q(self.u))
        return self.y

    def set_second(self, u2: float) -> None:
        """Hold the heater power ``u2`` for the next samples (a non-finite value is ignored)."""
        if math.isfinite(u2):
            self.u2 = float(u2)

    def reset(self, u0: float = 0.0) -> None:
        """The steady state of the cooler power ``u0`` and the heater power :attr:`u2`."""
        self.u = float(u0) if math.isfinite(u0) else 0.0
        self._lag.reset(self._q(self.u))

    def snapshot(self) -> dict[str, Any]:
        return {"lag": self._lag.snapshot(), "u": self.u, "u2": self.u2}

    def restore(self, snap: dict[str, Any]) -> None:
        self._lag.restore(snap["lag"])
        self.u, self.u2 = snap["u"], snap["u2"]

    def __repr__(self) -> str:
        return (
            f"HeatCool(k_heat={self.k_heat!r}, k_cool={self.k_cool!r}, t={self.t!r}, "
            f"ts={self.ts!r}, t_amb={self.t_amb!r}, dead_time={self.dead_time!r})"
        )


class SecondInput(Plant):
    """The second input of a two-input plant (``set_second``) as a plant input of its own.

    ``step(u)`` holds ``u`` as the plant's second input and returns the
    plant's output; the plant itself advances when its first input is
    stepped.  Wrapped in an :class:`~.wrappers.Actuator`, the second
    actuator gets its range, rate and load like the first.
    """

    def __init__(self, plant: Any) -> None:
        self.plant = plant
        self.ts = plant.ts
        self.u = float(getattr(plant, "u2", 0.0))

    @property
    def y(self) -> float:
        return float(self.plant.y)

    def step(self, u: float) -> float:
        if math.isfinite(u):
            self.u = float(u)
        self.plant.set_second(self.u)
        return self.y

    def reset(self, u0: float = 0.0) -> None:
        """Hold ``u0`` as the second input (the plant's state is the first input's reset)."""
        self.u = float(u0) if math.isfinite(u0) else 0.0
        self.plant.set_second(self.u)

    def snapshot(self) -> dict[str, Any]:
        return {"u": self.u}

    def restore(self, snap: dict[str, Any]) -> None:
        self.u = snap["u"]
