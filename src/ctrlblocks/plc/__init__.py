"""Export of the tuned blocks as IEC 61131-3 code (ST, SCL, PLCopen XML).

``ctrlblocks.plc.export(block, target="codesys")`` returns the PLC source of a
configured :class:`~ctrlblocks.PID`, :class:`~ctrlblocks.ADRC` or
:class:`~ctrlblocks.LeadLag`.  The statements are translated (:mod:`.translate`)
from the very Python the block runs at ``precision="float32"``
(:mod:`ctrlblocks.blocks.plc_cycle` and the blocks' pure per-cycle functions),
so the PLC computes what the block computes in REAL arithmetic; the tests
execute the emitted code and compare.  See ``docs/plc.md``.
"""

from .export import TARGETS, export, export_files
from .specs import UnsupportedBlock
from .translate import TranslationError

__all__ = ["TARGETS", "TranslationError", "UnsupportedBlock", "export", "export_files"]
