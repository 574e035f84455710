"""ctrlblocks: industrial control function blocks for Python.

PID, ADRC and lead-lag blocks with the small blocks they are built from,
process models, tuning from step-response data and a closed-loop simulator
that reproduces the published experiments.  See README.md for a tour.
"""

from .blocks import *  # noqa: F403  (the public API is the blocks' __all__)
from .blocks import __all__ as _blocks_all

__version__ = "0.1.0"
__all__ = [*_blocks_all, "__version__"]
