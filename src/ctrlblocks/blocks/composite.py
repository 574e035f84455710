"""Blocks assembled from other blocks: their states travel in the assembled block's snapshot."""

from __future__ import annotations

from typing import Any

from .base import Block

__all__ = ["CompositeBlock"]


class CompositeBlock(Block):
    """A block built from sub-blocks (:meth:`parts`), each keeping its own contract.

    :meth:`snapshot` holds the snapshots of the parts under ``"parts"``;
    :meth:`restore` puts them back (a part the snapshot lacks, after a
    reconfiguration added it, keeps its state).
    """

    def parts(self) -> dict[str, Block]:
        """The sub-blocks by name (override)."""
        return {}

    def _reconfigure_parts(self) -> None:
        """Configure the parts for the block's restored state, before their states come back.

        (Override where the block configures its parts at run time: the HeatCoolPID's
        parameter set follows its ``cooling`` state.)
        """

    def snapshot(self, *, copy: bool = True) -> dict[str, Any]:
        snap = super().snapshot(copy=copy)
        snap["parts"] = {name: b.snapshot(copy=copy) for name, b in self.parts().items()}
        return snap

    def restore(self, snapshot: dict[str, Any]) -> None:
        super().restore(snapshot)
        self._reconfigure_parts()
        saved = snapshot.get("parts") or {}
        for name, b in self.parts().items():
            if name in saved:
                b.restore(saved[name])
