"""Override (selector) control: a min or max selector picks the MV of two or more controllers.

The structure ``override`` (Åström 1987, Figs. 3.8/3.9): every block
computes on ``y`` or ``y2`` (its ``measure``) with the setpoint input or a
setpoint of its own (its ``sp``); the selector (``min`` or ``max``, the
first of equal values) picks the MV, and every block commits with the
selected value, so the ones not selected track it (no windup).  Every block
runs on the quality of both measurements.  Signals ``v1``, ``v2``, ...: the
blocks' outputs.
"""

from __future__ import annotations

from .spec import BlockSpec
from .structure import ENTRY_KEYS, Structure
from .wiring import SELECTORS, Loop, Wiring

__all__ = ["Override"]


class Override(Structure):
    """A min (or max) selector picks the MV of two or more controllers; all track it."""

    name = "override"
    roles = ("blocks",)
    options = ("selector",)
    measurements = ("y", "y2")
    mv_roles = ("blocks",)
    array_roles = ("blocks",)
    event_target = "blocks[0]"
    series_plant = True
    tuned_roles = ()

    def measurements_in(self, entry):
        blocks = entry.get("blocks") if isinstance(entry, dict) else None
        used = set()
        if isinstance(blocks, list):
            used = {b.get("measure", "y") for b in blocks if isinstance(b, dict)}
        return tuple(m for m in ("y", "y2") if m in used) or ("y",)

    def parse(self, r, e, key, ts, tune):
        r.check_keys(e, {*ENTRY_KEYS, "selector", "blocks"}, key)
        sel = r.string(e, "selector", f"{key}.selector", default="min")
        if sel not in SELECTORS:
            raise r.fail(f"{key}.selector", f"must be 'min' or 'max', got {sel!r}")
        lst = e.get("blocks")
        if not isinstance(lst, list) or len(lst) < 2:
            raise r.fail(f"{key}.blocks", "must be an array of at least two controller tables")
        specs = []
        for j, b in enumerate(lst):
            bkey = f"{key}.blocks[{j}]"
            spec = r.block_spec(b, bkey, ts, kind="block", extra_keys=("measure", "sp"))
            meas = spec.extra.get("measure", "y")
            if meas not in ("y", "y2"):
                raise r.fail(f"{bkey}.measure", f"must be 'y' or 'y2', got {meas!r}")
            sp = spec.extra.get("sp", "sp")
            if sp != "sp" and (isinstance(sp, bool) or not isinstance(sp, (int, float))):
                raise r.fail(f"{bkey}.sp", f"must be 'sp' or a number, got {sp!r}")
            specs.append(spec)
        return {"blocks": specs}, {"selector": sel}

    def wiring_of(self, side):
        loops = tuple(
            Loop(
                f"blocks[{i}]",
                sp=_sp(s),
                pv=s.extra.get("measure", "y"),
                ok=("y", "y2"),
                signal=f"v{i + 1}",
            )
            for i, s in enumerate(side.spec.blocks["blocks"])
        )
        return Wiring(loops, mv=side.spec.options.get("selector", "min"))

    def setup(self, side):
        for i, s in enumerate(side.spec.blocks["blocks"]):
            side.blocks[f"blocks[{i}]"] = side.make(s, "block")


def _sp(spec: BlockSpec) -> str | float:
    """An override block's setpoint: ``"sp"`` (the input), or its own number."""
    sp = spec.extra.get("sp", "sp")
    return "sp" if sp == "sp" else float(sp)
