"""The adapter factory: the :class:`~ctrlblocks.runtime.io.Adapter` for a connection's protocol.

It lives above :mod:`.io`, :mod:`.opcua` and :mod:`.modbus` (which build on
:mod:`.io`), so none of them imports another in a circle.  The OPC UA and
Modbus adapters import their libraries only when connected.
"""

from __future__ import annotations

from .config import ConnectionConfig
from .io import Adapter, MemoryAdapter
from .modbus import ModbusAdapter
from .opcua import OpcUaAdapter

__all__ = ["make_adapter"]


def make_adapter(config: ConnectionConfig) -> Adapter:
    """The adapter for ``config.protocol`` (``memory``, ``opcua`` or ``modbus``)."""
    if config.protocol == "memory":
        return MemoryAdapter()
    if config.protocol == "opcua":
        return OpcUaAdapter(config)
    if config.protocol == "modbus":
        return ModbusAdapter(config)
    raise ValueError(f"unknown protocol {config.protocol!r}")
