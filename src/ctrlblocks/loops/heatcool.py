"""Heating and cooling: a :class:`~ctrlblocks.HeatCoolPID` on two actuators (``heat_cool``).

The block runs its whole sample in one call -- its PID, the choice of the
heating or cooling parameter set, the neutral zone and the PWM of both
outputs -- and tracks its own demand (its PID's anti-windup acts at the
demand's limits), so the wiring is one loop and an output stage that reads
the block's outputs as signals.  The MV is ``heat - cool`` [%] (one of them
is zero); :meth:`HeatCoolStructure.actuator_values` writes it as two MVs.
"""

from __future__ import annotations

from ..blocks.heatcool import HeatCoolPID
from .controller import set_manual
from .structure import ENTRY_KEYS, Structure
from .wiring import Loop, OutputStage, Wiring

__all__ = ["HeatCoolOutput", "HeatCoolStructure"]


class HeatCoolOutput(OutputStage):
    """The block's heat and cool outputs, its demand and parameter set as signals."""

    def shape(self, side, v, m):
        b: HeatCoolPID = side.blocks["main"]
        return v, {"heat": b.heat, "cool": b.cool, "v_ctrl": b.demand,
                   "cooling": float(b.cooling)}  # fmt: skip


class HeatCoolStructure(Structure):
    """A heating/cooling controller (:class:`~ctrlblocks.HeatCoolPID`) on two actuators.

    The entry's ``main`` table is the HeatCoolPID; its output is ``heat -
    cool`` [%] (one of them is zero), which the structure writes as two MVs:
    actuator A the cooler (``max(0, -u)``), actuator B the heater
    (``max(0, u)``) -- the inputs ``u`` and ``u2`` of the shipped two-input
    plant :class:`~ctrlblocks.plants.HeatCool`.  With PWM outputs the MVs are
    0 or 100 %.  Signals: ``heat``, ``cool``, ``v_ctrl`` (the demand ``v``)
    and ``cooling`` (1 while the cooling parameter set is in force).
    """

    name = "heat_cool"
    roles = ("main",)
    actuators = 2
    tuned_roles = ()
    runtime = False  # the runtime's loops run PID or ADRC blocks (runtime/config.py)
    wiring = Wiring((Loop("main"),), output=HeatCoolOutput())

    def parse(self, r, e, key, ts, tune):
        r.check_keys(e, {*ENTRY_KEYS, "main"}, key)
        main = r.role(e, "main", key, ts)
        if not isinstance(r.build(main, ts, kind="block"), HeatCoolPID):
            raise r.fail(
                f"{key}.main.type",
                f"the heat_cool structure needs a HeatCoolPID, got {main.type}",
            )
        return {"main": main}, {}

    def hold_for_warmup(self, side, u0, y2):
        block: HeatCoolPID = side.blocks["main"]
        set_manual(block, True, block.demand_for(u0))  # the manual value is a demand

    def actuator_values(self, spec, u):
        return (max(0.0, -u), max(0.0, u))

    def off_mv(self, spec):
        return 0.0  # both outputs off
