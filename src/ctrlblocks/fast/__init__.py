"""Speed: compiled closed loops, banks of many loops and parallel sweeps.

Everything here runs the blocks' own pure functions (one implementation of each law):
numba compiles and inlines them when the ``fast`` extra is installed
(``pip install 'ctrlblocks[fast]'``); without numba the same functions run
interpreted (slower, same results).  See ``docs/performance.md``.

* :func:`closed_loop` -- one PID/ADRC block with a linear plant or the
  three-tank process, compiled (:mod:`.loops`);
* :class:`PIDBank`, :class:`ADRCBank` -- many independent loops, each with its own
  tunings and plant (:mod:`.bank`);
* :func:`sweep` -- many scenario runs on a ``concurrent.futures`` executor
  (process pool by default) or a Dask cluster (:mod:`.sweep`).
"""

from ._jit import HAVE_NUMBA
from .bank import ADRCBank, BankResult, PIDBank
from .kernels import UnsupportedConfig
from .loops import LoopResult, closed_loop, reference_loop
from .sweep import SweepError, dask_executor, sweep, write_rows

__all__ = [
    "HAVE_NUMBA",
    "ADRCBank",
    "BankResult",
    "LoopResult",
    "PIDBank",
    "SweepError",
    "UnsupportedConfig",
    "closed_loop",
    "dask_executor",
    "reference_loop",
    "sweep",
    "write_rows",
]
