"""Every loop structure by name, and reading a controller entry of one.

:data:`STRUCTURES` holds one :class:`~.structure.Structure` object per
structure; the simulator's and the runtime's tables are derived from it, so a
structure of your own is one subclass and one :func:`register_structure`.
"""

from __future__ import annotations

from typing import Any

from .cascade import Cascade
from .feedforward import FeedForward
from .heatcool import HeatCoolStructure
from .output import PulseWidthStructure, ThreeStepStructure
from .override import Override
from .ratio import RatioStructure
from .schedule import ScheduledStructure
from .single import OpenLoop, Single
from .smith import Smith
from .spec import ControllerSpec, SpecReader, TuneHook
from .split import SplitRangeStructure
from .structure import Structure
from .toml import KeyPathError

__all__ = ["STRUCTURES", "parse_controller", "read_controller", "register_structure"]

STRUCTURES: dict[str, Structure] = {
    s.name: s
    for s in (
        Single(),
        Cascade(),
        Override(),
        FeedForward(),
        Smith(),
        SplitRangeStructure(),
        RatioStructure(),
        PulseWidthStructure(),
        ThreeStepStructure(),
        ScheduledStructure(),
        HeatCoolStructure(),
        OpenLoop(),
    )
}
"""Every loop structure, by name (one object each)."""


def register_structure(structure: Structure) -> None:
    """Make ``structure`` usable as ``structure = "<its name>"`` (scenarios, runtime loops)."""
    STRUCTURES[structure.name] = structure


def parse_controller(
    entry: dict[str, Any],
    structure: str,
    ts: float,
    *,
    key: str,
    file: str = "<string>",
    error: type[KeyPathError] = KeyPathError,
    tune: TuneHook | None = None,
) -> ControllerSpec:
    """Check one controller entry of ``structure`` (its block tables and options).

    ``key`` is its key path in ``file``; a problem raises ``error`` with
    ``key.role.param``.  The simulator reads a scenario's ``[[controllers]]``
    entries with it and the runtime its loops' structures, so both accept the
    same tables.  ``tune`` reads a ``tune`` table of a role that allows one
    (:attr:`Structure.tuned_roles`; None: refused).
    """
    reader = SpecReader(file)
    reader.error = error
    s = STRUCTURES.get(structure)
    if s is None or not s.runtime:
        raise reader.fail(f"{key}.structure", f"no controller entry for {structure!r}")
    return read_controller(reader, entry, key, structure, ts, tune)


def read_controller(
    reader: SpecReader,
    entry: dict[str, Any],
    key: str,
    structure: str,
    ts: float,
    tune: TuneHook | None = None,
) -> ControllerSpec:
    """One controller entry of ``structure`` read with ``reader`` (errors name ``key``)."""
    name = reader.string(entry, "name", f"{key}.name")
    blocks, options = STRUCTURES[structure].parse(reader, entry, key, ts, tune)
    return ControllerSpec(
        name, blocks, {"color": entry.get("color"), "style": entry.get("style"), **options}
    )
