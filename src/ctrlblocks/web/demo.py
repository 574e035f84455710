"""A simulated plant for the faceplate: the runtime's in-memory I/O driven by process models.

``ctrlblocks serve`` without a configuration file runs :data:`DEMO_TOML`:
two loops on the runtime's in-memory adapter, each with a process model that
steps once per written MV (:class:`SimulatedIO`), so the runtime's real-time
cycle is the plant's clock and every sample the runtime records is one sample
of the discrete closed loop:

* ``pressure``: ADRC (n = 2, Table 2 of Nowak et al. 2018: b0 = 0.05, omega_o = 1.75,
  omega_c = 0.35, ts = 0.1 s) on the pneumatic three-tank process
  (:class:`~ctrlblocks.plants.ThreeTank`, p3 in bar, supply pressure 0..5 bar,
  1 mbar measurement noise), starting in its steady state at p3 = 1.5 bar;
* ``flow``: PI (kp = 1.0, ti = 1.2 s, ts = 0.05 s) on a fast second-order
  lag (gain 1, time constants 1.0 s and 0.3 s, MV and PV in %, 0.2 % noise),
  starting steady at 40 %.

The same machinery runs the browser tests on their own small configuration.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..plants import PT2, Noise, Plant, ThreeTank, process

__all__ = [
    "DEMO_MVS",
    "DEMO_TOML",
    "SimulatedIO",
    "demo_plants",
    "demo_runtime",
    "simulated_runtime",
]

DEMO_TOML = """
[runtime]
name = "ctrlblocks demo"

[connections.sim]
protocol = "memory"
timeout = 5.0  # in-memory I/O never waits; a busy machine must not look like a fault

[[loops]]
name = "pressure"
ts = 0.1
pv = "sim:pressure.pv"
mv = "sim:pressure.mv"
sp = 1.5
safe_value = 0.0
unit = { pv = "bar", mv = "bar" }  # p3 and the supply pressure
sp_range = [0.0, 3.0]
mv_range = [0.0, 5.0]

[loops.block]  # Nowak et al. 2018, Table 2 (n = 2); u0: steady supply pressure for 1.5 bar
type = "ADRC"
order = 2
b0 = 0.05
omega_o = 1.75
omega_c = 0.35
u0 = 2.19
u_min = 0.0
u_max = 5.0

[[loops]]
name = "flow"
ts = 0.05
pv = "sim:flow.pv"
mv = "sim:flow.mv"
sp = 40.0
safe_value = 0.0
unit = { pv = "%", mv = "%" }
sp_range = [0.0, 100.0]

[loops.block]
type = "PID"
kp = 1.0
ti = 1.2
reset_value = 40.0
u_min = 0.0
u_max = 100.0

[historian]
path = "@HISTORY@"
flush_interval = 0.5

[web]
public_view = true  # the demo: anyone may watch
"""
"""The demo configuration (``@HISTORY@`` is replaced by the historian file)."""


class SimulatedIO:
    """Process models behind a :class:`~ctrlblocks.runtime.MemoryBus`.

    Loop ``NAME`` reads its PV at address ``NAME.pv`` and writes its MV to
    ``NAME.mv``; each accepted MV write steps that loop's plant once (by its
    sample time) and publishes the new PV.

    Parameters
    ----------
    plants : mapping
        Loop name -> plant (a :class:`~ctrlblocks.plants.Plant`, usually
        wrapped by :func:`~ctrlblocks.plants.process`), already at its initial
        state.
    mvs : mapping, optional
        Loop name -> the MV the device holds at the start (what the runtime
        reads back for its bumpless start); without one the MV cannot be read.
    """

    def __init__(self, plants: Mapping[str, Plant], mvs: Mapping[str, float] | None = None) -> None:
        from ..runtime import MemoryAdapter, MemoryBus

        self.plants = dict(plants)
        self.bus = MemoryBus({f"{n}.pv": float(p.y) for n, p in self.plants.items()})
        self.bus.values.update({f"{n}.mv": float(u) for n, u in (mvs or {}).items()})
        self.bus.on_write = self._on_write
        self.adapter = MemoryAdapter(self.bus)
        self.steps = dict.fromkeys(self.plants, 0)

    def _on_write(self, address: str, value: float) -> None:
        name, _, sig = address.rpartition(".")
        plant = self.plants.get(name)
        if sig != "mv" or plant is None:
            return
        self.bus.values[f"{name}.pv"] = float(plant.step(float(value)))
        self.steps[name] += 1


DEMO_MVS = {"pressure": ThreeTank(ts=0.1).u_for_y(1.5), "flow": 40.0}
"""The MVs the demo's devices hold at the start (their steady states)."""


def demo_plants() -> dict[str, Plant]:
    """The demo's process models at their initial steady states (see the module docstring)."""
    tank = ThreeTank(ts=0.1)
    pressure = process(tank, u_min=0.0, u_max=5.0, noise=Noise(0.001, kind="gaussian", seed=1))
    pressure.reset(DEMO_MVS["pressure"])  # steady state p3 = 1.5 bar
    lag = PT2(k=1.0, t1=1.0, t2=0.3, ts=0.05)
    flow = process(lag, u_min=0.0, u_max=100.0, noise=Noise(0.2, kind="gaussian", seed=2))
    flow.reset(DEMO_MVS["flow"])
    return {"pressure": pressure, "flow": flow}


def simulated_runtime(
    toml_text: str,
    plants: Mapping[str, Plant],
    mvs: Mapping[str, float] | None = None,
    **runtime_kw: Any,
) -> tuple[Any, SimulatedIO]:
    """A :class:`~ctrlblocks.runtime.Runtime` for ``toml_text`` whose connection ``sim``
    (protocol ``memory``) is served by ``plants`` (see :class:`SimulatedIO`)."""
    from ..runtime import Runtime, parse_config

    cfg = parse_config(toml_text, file="<faceplate demo>")
    sim = SimulatedIO(plants, mvs)
    rt = Runtime(cfg, adapters={"sim": sim.adapter}, **runtime_kw)
    return rt, sim


def demo_runtime(history: str | Path, **runtime_kw: Any) -> tuple[Any, SimulatedIO]:
    """The runtime of :data:`DEMO_TOML`, recording into the SQLite file ``history``."""
    text = DEMO_TOML.replace('"@HISTORY@"', json.dumps(str(history)))
    return simulated_runtime(text, demo_plants(), DEMO_MVS, **runtime_kw)
