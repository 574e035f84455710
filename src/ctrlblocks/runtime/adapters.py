"""The adapter factory: the :class:`~ctrlblocks.runtime.io.Adapter` for a connection's protocol.

The protocol registry (:mod:`ctrlblocks.runtime.config.protocols`) says where
each protocol's adapter lives; its module is imported here, when a runtime
makes its connections (the OPC UA and Modbus adapters import their libraries
only when they connect).
"""

from __future__ import annotations

from .config import PROTOCOLS, ConnectionConfig
from .io import Adapter

__all__ = ["make_adapter"]


def make_adapter(config: ConnectionConfig) -> Adapter:
    """The adapter for ``config.protocol`` (any registered protocol)."""
    try:
        protocol = PROTOCOLS[config.protocol]
    except KeyError:
        raise ValueError(f"unknown protocol {config.protocol!r}") from None
    adapter: Adapter = protocol.make_adapter(config)
    return adapter
