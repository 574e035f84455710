"""The single loop (one controller, one plant) and the open-loop structure (no plant).

``single``: the controller table is the entry itself; a whole sample is the
block's one call (its fast lane, :attr:`~.wiring.Wiring.one_call`), the two
phases where the simulator wires the actuator's measured output to it.
``open_loop``: a block driven by the setpoint profile (Åström 1987, Fig.
5.2: jump and rate), no controller, no plant.
"""

from __future__ import annotations

from .structure import ENTRY_KEYS, Structure
from .wiring import Loop, Wiring

__all__ = ["OpenLoop", "Single"]


class Single(Structure):
    """One controller, one plant; the entry is the block table itself."""

    name = "single"
    roles = ("main",)
    wiring = Wiring((Loop("main"),), measured_mv=True)
    margins_on_plant = True
    lone_block = True

    def parse(self, r, e, key, ts, tune):
        table = {k: v for k, v in e.items() if k not in ENTRY_KEYS}
        spec = r.block_spec(table, key, ts, kind="block", tune=tune, table_keys=ENTRY_KEYS)
        return {"main": spec}, {}


class OpenLoop(Single):
    """A block driven by the setpoint profile (Åström 1987, Fig. 5.2: jump and rate)."""

    name = "open_loop"
    lone_block = False
    wiring = None
    measurements = ()
    runtime = False
    tuned_roles = ()
    closed_loop = False
    margins_on_plant = False

    def parse(self, r, e, key, ts, tune):
        return super().parse(r, e, key, ts, None)

    def compute(self, side, sp, m):
        return float(side.blocks["main"](sp)), {}

    def update(self, side, u, measured):
        pass
