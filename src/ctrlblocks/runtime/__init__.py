"""The soft-controller runtime: blocks running cyclically against real process I/O.

* :func:`load_config` reads a loop configuration (TOML) and checks it;
* :class:`Runtime` runs the loops on absolute deadlines with I/O supervision,
  the historian and a graceful stop; its in-process API (``state``,
  ``command``) is what a faceplate uses;
* adapters: :class:`MemoryAdapter` (tests), OPC UA and Modbus TCP
  (:mod:`.opcua`, :mod:`.modbus`; the ``runtime`` extra);
* :class:`PlantServer` serves a simulated plant from a scenario over OPC UA
  and Modbus (``ctrlblocks plant-server``) so the chain runs on loopback.

See ``docs/runtime.md``.  The OPC UA, Modbus and PostgreSQL parts import their
libraries only when used (``pip install 'ctrlblocks[runtime]'``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:  # pragma: no cover
    from .clock import Clock, FakeClock, MonotonicClock
    from .config import (
        Binding,
        ConnectionConfig,
        HistorianConfig,
        LoopConfig,
        RetainConfig,
        RuntimeConfig,
        RuntimeConfigError,
        load_config,
        parse_config,
    )
    from .historian import Historian, PostgresHistorian, SQLiteHistorian, export_history
    from .io import Adapter, Connection, IOFault, MemoryAdapter, MemoryBus, Reading
    from .loop import CommandError, ControlLoop, Sample
    from .plant_server import PairServer, PlantServer
    from .runtime import Runtime

# imported on first use (PEP 562): ``ctrlblocks <command> --help`` imports none of them
_WHERE = {
    ".clock": ("Clock", "FakeClock", "MonotonicClock"),
    ".config": (
        "Binding",
        "ConnectionConfig",
        "HistorianConfig",
        "LoopConfig",
        "RetainConfig",
        "RuntimeConfig",
        "RuntimeConfigError",
        "load_config",
        "parse_config",
    ),
    ".historian": ("Historian", "PostgresHistorian", "SQLiteHistorian", "export_history"),
    ".io": ("Adapter", "Connection", "IOFault", "MemoryAdapter", "MemoryBus", "Reading"),
    ".loop": ("CommandError", "ControlLoop", "Sample"),
    ".plant_server": ("PairServer", "PlantServer"),
    ".runtime": ("Runtime",),
}

__all__ = [
    "Adapter",
    "Binding",
    "Clock",
    "CommandError",
    "Connection",
    "ConnectionConfig",
    "ControlLoop",
    "FakeClock",
    "Historian",
    "HistorianConfig",
    "IOFault",
    "LoopConfig",
    "MemoryAdapter",
    "MemoryBus",
    "MonotonicClock",
    "PairServer",
    "PlantServer",
    "PostgresHistorian",
    "Reading",
    "RetainConfig",
    "Runtime",
    "RuntimeConfig",
    "RuntimeConfigError",
    "SQLiteHistorian",
    "Sample",
    "export_history",
    "load_config",
    "parse_config",
]

__getattr__, __dir__ = lazy_exports(__name__, _WHERE)
