"""Testing tools for blocks: the fuzz campaign of the block contract, for any block.

The promises every block makes (docs/reliability.md): no exception from
process data, a finite output inside its limits, a refused configuration
that changes nothing, the per-call path equal to the two phases, bumpless
transfers, ``restore(snapshot())`` that repeats a step, a finite state and
the block's own oracle.  :mod:`.fuzz` checks them under random and hostile
actions; a block takes part through a :class:`FuzzSpec` -- how to make a
random valid configuration of it and how to feed it one process step --
registered with :func:`register_fuzz`.  Every shipped block has one
(:mod:`.generators`); a block of your own gets one the same way and is then
fuzzed like the shipped ones (a controller through the
:class:`~ctrlblocks.blocks.protocols.Controller` interface, any other block
through its call)::

    from ctrlblocks.testing import FuzzSpec, register_fuzz, run

    register_fuzz(FuzzSpec("MyPI", MyPI, config=lambda r: {"kp": r.uniform(0.1, 10.0)}))
    assert run(["MyPI"], steps=100_000, seed=1) == 0     # 1 and a report on a breach

The long campaign over every registered block, with a progress line every
``--every`` seconds (also when not on a terminal)::

    python -m ctrlblocks.testing --steps 10000000
    python -m ctrlblocks.testing --steps 100000 --block PID --seed 3

The tests run the same actions as a hypothesis state machine (short CI
profile, tests/blocks/test_fuzz_campaign.py).
"""

from .fuzz import (
    BAD_PARAMS,
    BUMP_TOL,
    FUZZ_SPECS,
    HOSTILE,
    HOSTILE_DT,
    LANE_TOL,
    Breach,
    Driver,
    FuzzSpec,
    RandomRun,
    exported_blocks,
    main,
    register_fuzz,
    run,
    traces,
)
from .generators import register_shipped

register_shipped()

__all__ = [
    "BAD_PARAMS",
    "BUMP_TOL",
    "FUZZ_SPECS",
    "HOSTILE",
    "HOSTILE_DT",
    "LANE_TOL",
    "Breach",
    "Driver",
    "FuzzSpec",
    "RandomRun",
    "exported_blocks",
    "main",
    "register_fuzz",
    "run",
    "traces",
]
