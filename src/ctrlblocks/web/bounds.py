"""The engineering bounds of a loop (moved to :mod:`ctrlblocks.runtime.bounds`).

The runtime checks them on every command; this module keeps the old import
path working.
"""

from ..runtime.bounds import TUNING_MAGNITUDE, LoopBounds, Range, derived_tuning_range

__all__ = ["TUNING_MAGNITUDE", "LoopBounds", "Range", "derived_tuning_range"]
