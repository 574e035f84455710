"""Moved: sweeps of scenarios are :mod:`ctrlblocks.sim.sweep` (they run the simulator).

``ctrlblocks.fast`` and ``ctrlblocks.sim`` import nothing of each other
(docs/architecture.md); a sweep runs the simulator's scenarios, so it lives
there: ``from ctrlblocks.sim import sweep``.
"""

raise ImportError(
    "ctrlblocks.fast.sweep moved to ctrlblocks.sim.sweep: sweeps run the simulator's "
    "scenarios (from ctrlblocks.sim import sweep, SweepError, dask_executor, write_rows)"
)
