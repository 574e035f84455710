"""The I/O protocols a connection can speak: an open registry, one entry per protocol.

A protocol is one :class:`Protocol` object: its own keys of
``[connections.NAME]`` and how to read them, how its addresses are checked,
the library it needs and where its :class:`~ctrlblocks.runtime.io.Adapter`
lives.  The configuration parser, ``serve --check`` and the runtime ask the
registry; nothing else names a protocol.  Adding one is one call::

    from ctrlblocks.runtime.config import Protocol, register_protocol

    register_protocol(Protocol(
        "s7",
        keys=("host", "rack", "slot"),
        read=read_s7_keys,                 # (reader, table, key) -> dict of settings
        check_address=s7_address_problem,  # address -> why it is refused, or None
        adapter="mypackage.s7:S7Adapter",  # made as S7Adapter(connection_config)
        package="snap7",
    ))

Settings that are not fields of :class:`~.model.ConnectionConfig` go to its
``options``.  The built-in protocols are ``opcua``, ``modbus`` and ``memory``.
"""

from __future__ import annotations

import dataclasses
import importlib
import os
import re
from collections.abc import Callable, Mapping
from typing import Any

__all__ = [
    "PROTOCOLS",
    "SECURITY_MODES",
    "Protocol",
    "parse_modbus_address",
    "register_protocol",
]

SECURITY_MODES = ("none", "Basic256Sha256_SignAndEncrypt")
"""OPC UA security settings of a connection."""


def _no_problem(address: str) -> str | None:
    return None


@dataclasses.dataclass(frozen=True)
class Protocol:
    """One protocol of the registry (module docstring).

    Attributes
    ----------
    name : str
        The ``protocol = "..."`` of a connection.
    keys : tuple of str
        Its own keys of ``[connections.NAME]`` (the common ones, ``timeout``,
        ``heartbeat``, ..., are every protocol's).
    read : callable
        ``read(reader, table, key)`` -> the settings of those keys (a dict);
        ``reader`` has the typed getters of
        :class:`~ctrlblocks.loops.toml.TableReader` and ``fail(key, problem)``.
    check_address : callable
        ``check_address(address)`` -> why the address is refused (None: fine).
    check_writable : callable
        The same for an address the runtime writes (the heartbeat).
    adapter : str
        ``"module:Class"`` (or ``"module:Class.factory"``): the adapter, made as
        ``Class(connection_config)``.
    package : str or None
        The library the adapter needs (``serve --check`` refuses the file
        without it).
    """

    name: str
    keys: tuple[str, ...] = ()
    read: Callable[[Any, Mapping[str, Any], str], dict[str, Any]] | None = None
    check_address: Callable[[str], str | None] = _no_problem
    check_writable: Callable[[str], str | None] | None = None
    adapter: str = ""
    package: str | None = None

    def make_adapter(self, config: Any) -> Any:
        """The adapter for ``config`` (its module imported now)."""
        module, _, path = self.adapter.partition(":")
        make: Any = importlib.import_module(module)
        for name in path.split("."):
            make = getattr(make, name)
        return make(config)

    def writable_problem(self, address: str) -> str | None:
        """Why ``address`` cannot be written (None: it can)."""
        check = self.check_writable or self.check_address
        return check(address)


PROTOCOLS: dict[str, Protocol] = {}
"""The registered protocols by name."""


def register_protocol(protocol: Protocol) -> Protocol:
    """Add ``protocol`` to the registry (replacing one of the same name); returns it."""
    if not protocol.adapter or ":" not in protocol.adapter:
        raise ValueError(f"protocol {protocol.name!r}: adapter must be 'module:Class'")
    PROTOCOLS[protocol.name] = protocol
    return protocol


# ---------------------------------------------------------------------------
# OPC UA
# ---------------------------------------------------------------------------


def _read_opcua(p: Any, c: Mapping[str, Any], key: str) -> dict[str, Any]:
    kw: dict[str, Any] = {}
    url = p.string(c, "url", f"{key}.url")
    if not url.startswith("opc.tcp://"):
        raise p.fail(f"{key}.url", f"must start with opc.tcp://, got {url!r}")
    kw["url"] = url
    kw["security"] = p.choice(c, "security", f"{key}.security", SECURITY_MODES, "none")
    for f in ("certificate", "private_key", "server_certificate"):
        kw[f] = p.path(c, f, f"{key}.{f}")
    if kw["security"] != "none":
        for f in ("certificate", "private_key", "server_certificate"):
            if kw[f] is None:
                raise p.fail(
                    f"{key}.{f}",
                    f"missing: security {kw['security']!r} needs the client certificate, "
                    "its private key and the trusted server certificate",
                )
    kw["user"] = p.string(c, "user", f"{key}.user", default=None)
    pw = p.secret(c, "password", f"{key}.password")
    env = p.string(c, "password_env", f"{key}.password_env", default=None)
    if pw is not None and env is not None:
        raise p.fail(f"{key}.password_env", "give password or password_env, not both")
    if env is not None:
        pw = os.environ.get(env)
        if pw is None:
            raise p.fail(f"{key}.password_env", f"environment variable {env} is not set")
    if pw is not None and kw["user"] is None:
        raise p.fail(f"{key}.user", "missing: a password needs a user")
    kw["password"] = pw
    kw["application_uri"] = p.string(
        c, "application_uri", f"{key}.application_uri", default="urn:ctrlblocks:runtime"
    )
    kw["stale_after"] = p.number(c, "stale_after", f"{key}.stale_after", 0.0)
    if kw["stale_after"] < 0:
        raise p.fail(f"{key}.stale_after", "must be >= 0 (0 = off)")
    return kw


def _opcua_address(address: str) -> str | None:
    return None if address else "must be an address"


register_protocol(
    Protocol(
        "opcua",
        keys=(
            "url",
            "security",
            "certificate",
            "private_key",
            "server_certificate",
            "user",
            "password",
            "password_env",
            "application_uri",
            "stale_after",
        ),
        read=_read_opcua,
        check_address=_opcua_address,
        adapter="ctrlblocks.runtime.opcua:OpcUaAdapter",
        package="asyncua",
    )
)

# ---------------------------------------------------------------------------
# Modbus TCP
# ---------------------------------------------------------------------------

_MODBUS_RE = re.compile(r"^(?:(hr|ir):)?(\d+)$")


def parse_modbus_address(address: str) -> tuple[str, int]:
    """``"hr:10"`` -> ``("hr", 10)``; a bare number is a holding register."""
    m = _MODBUS_RE.match(address.strip())
    if m is None:
        raise ValueError(address)
    return (m.group(1) or "hr"), int(m.group(2))


def _modbus_address(address: str) -> str | None:
    try:
        _, reg = parse_modbus_address(address)
    except ValueError:
        return f"Modbus address must be hr:N or ir:N (FLOAT32 at register N), got {address!r}"
    if reg > 65534:
        return "Modbus register must be <= 65534 (a FLOAT32 takes two)"
    return None


def _modbus_writable(address: str) -> str | None:
    why = _modbus_address(address)
    if why is None and parse_modbus_address(address)[0] != "hr":
        return "must be a holding register (hr:N)"
    return why


def _read_modbus(p: Any, c: Mapping[str, Any], key: str) -> dict[str, Any]:
    kw: dict[str, Any] = {"host": p.string(c, "host", f"{key}.host", default="127.0.0.1")}
    kw["port"] = p.integer(c, "port", f"{key}.port", 502, 1)
    if kw["port"] > 65535:
        raise p.fail(f"{key}.port", "must be <= 65535")
    kw["unit"] = p.integer(c, "unit", f"{key}.unit", 1, 0)
    kw["word_order"] = p.choice(c, "word_order", f"{key}.word_order", ("big", "little"), "big")
    return kw


register_protocol(
    Protocol(
        "modbus",
        keys=("host", "port", "unit", "word_order"),
        read=_read_modbus,
        check_address=_modbus_address,
        check_writable=_modbus_writable,
        adapter="ctrlblocks.runtime.modbus:ModbusAdapter",
        package="pymodbus",
    )
)

# ---------------------------------------------------------------------------
# In memory (tests and demos)
# ---------------------------------------------------------------------------

register_protocol(
    Protocol(
        "memory",
        check_address=_opcua_address,
        adapter="ctrlblocks.runtime.io:MemoryAdapter.from_config",
    )
)
