"""Feed-forward: the measured disturbance through a lead-lag into the controller's ``ff``.

The structure ``feedforward`` (Bonde et al. 2021, Fig. 10): the block
``feedforward`` (a :class:`~ctrlblocks.LeadLag`, or any block called as
``block(dv)``) filters the measured disturbance ``dv``; its output is added
to the controller output before the limits (the ``ff`` input of the PID and the ADRC).  A bad
``dv`` (flagged or not finite) freezes the lead-lag (not called): ``ff``
keeps its last value.
"""

from __future__ import annotations

import math

from .controller import takes_ff
from .structure import Structure
from .wiring import Loop, Stage, Wiring

__all__ = ["FeedForward", "FeedForwardStage"]


class FeedForwardStage(Stage):
    """The lead-lag on ``dv`` before the controller; its output is the signal ``ff``."""

    name = "feedforward"
    signals = ("ff",)
    measurements = ("dv",)
    block_role = "feedforward"

    def block(self, side):
        """The feed-forward block of ``side``."""
        return side.blocks[self.block_role]

    def setup(self, side):
        side.parts[self.name] = 0.0  # ff: the lead-lag's last output

    def compute(self, side, sp, m, signals):
        if m.dv_ok and math.isfinite(m.dv):
            side.parts[self.name] = float(self.block(side)(m.dv))
        signals["ff"] = side.parts[self.name]


class FeedForward(Structure):
    """The measured disturbance through a lead-lag into the controller's ``ff`` (before limits)."""

    name = "feedforward"
    roles = ("main", "feedforward")
    measurements = ("y", "dv")
    wiring = Wiring((Loop("main", ff="ff"),), stages=(FeedForwardStage(),), measured_mv=True)

    def parse(self, r, e, key, ts, tune):
        blocks, opts = super().parse(r, e, key, ts, tune)
        main_block = r.build(blocks["main"], ts, kind="block")
        if not takes_ff(main_block):
            raise r.fail(
                f"{key}.main.type",
                f"{blocks['main'].type} has no feed-forward input 'ff'; "
                "the feedforward structure needs one (PID, ADRC)",
            )
        return blocks, opts
