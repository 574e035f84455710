"""Speed: compiled closed loops, banks of many loops, the simulator's compiled lane.

Everything here runs the blocks' own pure functions (one implementation of each law):
numba compiles and inlines them when the ``fast`` extra is installed
(``pip install 'ctrlblocks[fast]'``); without numba the same functions run
interpreted (slower, same results).  See ``docs/performance.md``.

* :func:`closed_loop` -- one PID/ADRC block with a linear plant or the
  three-tank process, compiled (:mod:`.loops`);
* :class:`PIDBank`, :class:`ADRCBank` -- many independent loops, each with its own
  tunings and plant (:mod:`.bank`);
* :mod:`.simlane` -- the simulator's compiled lane: a structure's wiring in a
  closed loop (found by the simulator as an installed lane,
  :mod:`ctrlblocks.loops.lane`; neither package imports the other).

Sweeps of scenarios (many runs on a process pool or a Dask cluster) run the
simulator: :func:`ctrlblocks.sim.sweep` (they were ``ctrlblocks.fast.sweep``).

The compiled parts are imported on first use (PEP 562).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:  # pragma: no cover
    from ._jit import HAVE_NUMBA
    from .bank import ADRCBank, BankResult, PIDBank
    from .kernels import UnsupportedConfig
    from .loops import LoopResult, closed_loop, reference_loop

_WHERE = {
    "._jit": ("HAVE_NUMBA",),
    ".bank": ("ADRCBank", "BankResult", "PIDBank"),
    ".kernels": ("UnsupportedConfig",),
    ".loops": ("LoopResult", "closed_loop", "reference_loop"),
}

__all__ = [
    "HAVE_NUMBA",
    "ADRCBank",
    "BankResult",
    "LoopResult",
    "PIDBank",
    "UnsupportedConfig",
    "closed_loop",
    "reference_loop",
]


_lazy_getattr, __dir__ = lazy_exports(__name__, _WHERE)
_MOVED = ("SweepError", "dask_executor", "sweep", "write_rows")


def __getattr__(name: str) -> object:
    if name in _MOVED:  # a clear message for the names that moved to the simulator
        raise AttributeError(
            f"ctrlblocks.fast.{name} moved to ctrlblocks.sim.{name}: sweeps run the "
            "simulator's scenarios (from ctrlblocks.sim import sweep)"
        )
    return _lazy_getattr(name)
