"""The runtime's configuration file (TOML): connections, loops, historian.

A minimal file that runs one PID loop against an OPC UA server::

    [connections.plc]
    protocol = "opcua"
    url = "opc.tcp://127.0.0.1:4840"

    [[loops]]
    name = "level"
    ts = 0.1
    block = { type = "PID", kp = 2.0, ti = 8.0, u_min = 0.0, u_max = 100.0 }
    pv = "plc:ns=2;s=pv"
    mv = "plc:ns=2;s=mv"
    sp = 50.0
    safe_value = 0.0

A binding is either a constant (a number; a mode name for ``mode``) or a
string ``"CONNECTION:ADDRESS"`` (the address as the protocol spells it:
``ns=2;s=pv`` for OPC UA, ``hr:0``/``ir:4`` for Modbus FLOAT32 registers, any
name for the in-memory adapter).  ``docs/runtime.md`` lists every key.

Every error names the file, the key path (``loops[1].block.kp``) and the
problem, as :class:`RuntimeConfigError`; the blocks are built while loading
(with :func:`ctrlblocks.loops.build`, the simulator's factory, so a block
table here is the same as a ``[[controllers]]`` block of a scenario), and a
parameter a block refuses is reported with its key path.

The package, by concept: :mod:`.model` (the checked configuration, plain
dataclasses), :mod:`.protocols` (the registry of I/O protocols: a new one is
one :func:`register_protocol` call), :mod:`.parser` (the document, its
connections and side tables), :mod:`.loops` (a ``[[loops]]`` entry) and
:mod:`.engineering` (ranges, units, ``[web]``).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import Any

from ...loops.toml import located, read_text, read_toml
from .engineering import ENGINEERING_KEYS, UNIT_SIGNALS
from .model import (
    MAX_DT_TS,
    MEASUREMENTS,
    MODES,
    READS,
    STRUCTURES,
    Binding,
    ConnectionConfig,
    HistorianConfig,
    LoopConfig,
    RetainConfig,
    RuntimeConfig,
    RuntimeConfigError,
    WebConfig,
    build_side,
)
from .parser import Parser
from .protocols import PROTOCOLS, SECURITY_MODES, Protocol, parse_modbus_address, register_protocol

__all__ = [
    "ENGINEERING_KEYS",
    "MAX_DT_TS",
    "MEASUREMENTS",
    "MODES",
    "PROTOCOLS",
    "READS",
    "SECURITY_MODES",
    "STRUCTURES",
    "UNIT_SIGNALS",
    "Binding",
    "ConnectionConfig",
    "HistorianConfig",
    "LoopConfig",
    "Protocol",
    "RetainConfig",
    "RuntimeConfig",
    "RuntimeConfigError",
    "WebConfig",
    "build_side",
    "load_config",
    "parse_config",
    "parse_modbus_address",
    "register_protocol",
    "require_packages",
]


def load_config(path: str | Path) -> RuntimeConfig:
    """Read and check the runtime configuration file ``path``."""
    p = Path(path)
    return parse_config(read_text(p, RuntimeConfigError), file=str(p), base=p.parent)


def parse_config(text: str, *, file: str = "<string>", base: Path | None = None) -> RuntimeConfig:
    """Parse runtime configuration TOML ``text``; relative paths are resolved against ``base``.

    An error names the file, the line (where the key path is written in
    ``text``) and the key path.
    """
    doc = read_toml(text, file, RuntimeConfigError)
    with located(text):
        return Parser(file, base or Path.cwd()).config(doc)


def require_packages(config: RuntimeConfig, connections: Any = None) -> None:
    """Refuse a configuration whose protocols' libraries are not installed.

    ``connections`` limits the check to these names (default all).  The
    error names the connection and the install command, so ``serve --check``
    fails and ``serve`` does not start a runtime that would retry for ever.
    """
    for name, c in config.connections.items():
        if connections is not None and name not in connections:
            continue
        pkg = PROTOCOLS[c.protocol].package
        if pkg is not None and importlib.util.find_spec(pkg) is None:
            raise RuntimeConfigError(
                config.file,
                f"connections.{name}.protocol",
                f"{c.protocol} needs the {pkg} package, which is not installed: "
                "pip install 'ctrlblocks[runtime]'",
            )
