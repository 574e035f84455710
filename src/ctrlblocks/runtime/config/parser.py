"""Reading a runtime configuration file: the document, its connections and its side tables.

:class:`Parser` reads a parsed TOML document into a
:class:`~.model.RuntimeConfig`: ``[runtime]``, ``[connections.NAME]`` (the
common keys here, each protocol's own through the registry,
:mod:`.protocols`), ``[[loops]]`` (:class:`~.loops.LoopTables`),
``[historian]``, ``[retain]`` and ``[web]`` (:mod:`.engineering`).  Every
error is a :class:`~.model.RuntimeConfigError` naming the key path.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ...loops.toml import NAME_RE, TableReader, type_name
from .engineering import check_tuning_ranges, web
from .loops import LoopTables
from .model import (
    MODES,
    Binding,
    ConnectionConfig,
    HistorianConfig,
    LoopConfig,
    RetainConfig,
    RuntimeConfig,
    RuntimeConfigError,
    build_side,
)
from .protocols import PROTOCOLS

__all__ = ["COMMON_CONNECTION_KEYS", "Parser"]

COMMON_CONNECTION_KEYS = (
    "protocol", "timeout", "reconnect_min", "reconnect_max", "connect_timeout", "stop_timeout",
    "heartbeat", "heartbeat_max", "deadline",
)  # fmt: skip
"""Keys of every ``[connections.NAME]`` table, whatever its protocol."""

_CONFIG_FIELDS = {f.name for f in dataclasses.fields(ConnectionConfig)}


class Parser(TableReader, LoopTables):
    """The configuration parser (module docstring); ``base`` resolves relative paths."""

    error = RuntimeConfigError

    def __init__(self, file: str, base: Path) -> None:
        super().__init__(file)
        self.base = base

    # -- typed getters -------------------------------------------------------

    def number(
        self, d: Mapping[str, Any], name: str, key: str, default: Any = ..., *, positive=False,
        limit=False,
    ) -> Any:
        """A number that is never NaN, finite unless a ``limit``; ``positive``: finite and > 0."""
        x = super().number(d, name, key, default=default, allow_nan=False, limit=limit)
        if positive and name in d and not (math.isfinite(x) and x > 0):
            raise self.fail(key, f"must be a finite number > 0, got {d[name]!r}")
        return x

    def integer(self, d: Mapping[str, Any], name: str, key: str, default: int, lo: int = 0) -> int:
        v = d.get(name, default)
        if isinstance(v, bool) or not isinstance(v, int) or v < lo:
            raise self.fail(key, f"must be an integer >= {lo}, got {v!r}")
        return v

    def choice(self, d: Mapping[str, Any], name: str, key: str, choices, default: Any = ...) -> str:
        v = self.string(d, name, key, default=default)
        if v not in choices:
            raise self.fail(key, f"must be one of {', '.join(choices)}; got {v!r}")
        return v

    def secret(self, d: Mapping[str, Any], name: str, key: str) -> str | None:
        """An optional string whose value never appears in an error message (a password)."""
        v = d.get(name)
        if v is not None and not isinstance(v, str):
            raise self.fail(key, f"must be a string, got {type_name(v)} (value not shown)")
        return v

    def path(self, d: Mapping[str, Any], name: str, key: str) -> str | None:
        v = self.string(d, name, key, default=None)
        if v is None:
            return None
        p = Path(v)
        return str(p if p.is_absolute() else self.base / p)

    # -- the document ---------------------------------------------------------

    def config(self, doc: dict[str, Any]) -> RuntimeConfig:
        self.check_keys(doc, {"runtime", "connections", "loops", "historian", "web", "retain"}, "")
        head = self.table(doc, "runtime", "runtime", required=False)
        self.check_keys(head, {"name"}, "runtime")
        name = self.string(head, "name", "runtime.name", default="ctrlblocks")
        conns_raw = doc.get("connections", {})
        if not isinstance(conns_raw, dict):
            raise self.fail("connections", "must be a table of [connections.NAME] tables")
        conns = {n: self.connection(n, c) for n, c in conns_raw.items()}
        loops_raw = doc.get("loops")
        if not isinstance(loops_raw, list) or not loops_raw:
            raise self.fail("loops", "missing: give at least one [[loops]] entry")
        loops: list[LoopConfig] = []
        for i, raw in enumerate(loops_raw):
            lc = self.loop(raw, f"loops[{i}]", conns)
            if any(other.name == lc.name for other in loops):
                raise self.fail(f"loops[{i}].name", f"duplicate loop name {lc.name!r}")
            loops.append(lc)
        # an MV is written by one loop only
        seen: dict[str, str] = {}
        for lc in loops:
            for sig, b in lc.written().items():
                if b.is_io:
                    k = str(b)
                    if k in seen:
                        raise self.fail(
                            f"{lc.key}.{sig}", f"{k} is already written by loop {seen[k]!r}"
                        )
                    seen[k] = lc.name
        hist = self.historian(self.table(doc, "historian", "historian", required=False))
        web_cfg = web(self, self.table(doc, "web", "web", required=False))
        retain = self.retain(self.table(doc, "retain", "retain", required=False), hist)
        cfg = RuntimeConfig(name, conns, tuple(loops), hist, self.file, web_cfg, retain)
        for lc in loops:  # build once: a refused parameter is reported here
            check_tuning_ranges(self, lc, build_side(lc, self.file))
        return cfg

    # -- connections ----------------------------------------------------------

    def connection(self, name: str, c: Any) -> ConnectionConfig:
        """One ``[connections.NAME]`` table: the common keys, then the protocol's own."""
        key = f"connections.{name}"
        if not NAME_RE.match(name):
            raise self.fail(key, "connection names are letters, digits, _ . - only")
        c = self.as_table(c, key)
        protocol = PROTOCOLS[self.choice(c, "protocol", f"{key}.protocol", tuple(PROTOCOLS))]
        self.check_keys(c, {*COMMON_CONNECTION_KEYS, *protocol.keys}, key)
        kw: dict[str, Any] = {"name": name, "protocol": protocol.name}
        kw["timeout"] = self.number(c, "timeout", f"{key}.timeout", 0.5, positive=True)
        kw["reconnect_min"] = self.number(
            c, "reconnect_min", f"{key}.reconnect_min", 0.1, positive=True
        )
        kw["reconnect_max"] = self.number(
            c, "reconnect_max", f"{key}.reconnect_max", 5.0, positive=True
        )
        if kw["reconnect_max"] < kw["reconnect_min"]:
            raise self.fail(f"{key}.reconnect_max", "must be >= reconnect_min")
        kw["connect_timeout"] = self.number(
            c, "connect_timeout", f"{key}.connect_timeout", 10.0, positive=True
        )
        kw["stop_timeout"] = self.number(c, "stop_timeout", f"{key}.stop_timeout", 2.0,
                                         positive=True)  # fmt: skip
        kw["heartbeat_max"] = self.integer(c, "heartbeat_max", f"{key}.heartbeat_max", 65535, 1)
        kw["deadline"] = self.number(c, "deadline", f"{key}.deadline", None, positive=True)
        hb = self.string(c, "heartbeat", f"{key}.heartbeat", default=None)
        if hb is not None and (why := protocol.writable_problem(hb)):
            raise self.fail(f"{key}.heartbeat", why)
        kw["heartbeat"] = hb
        own = protocol.read(self, c, key) if protocol.read is not None else {}
        kw["options"] = {k: v for k, v in own.items() if k not in _CONFIG_FIELDS}
        kw.update({k: v for k, v in own.items() if k in _CONFIG_FIELDS})
        return ConnectionConfig(**kw)

    def binding(
        self, raw: Any, key: str, conns: Mapping[str, ConnectionConfig], *, mode=False
    ) -> Binding:
        """A constant or ``"CONNECTION:ADDRESS"`` (the address checked by its protocol)."""
        if isinstance(raw, str):
            if mode and raw in MODES:
                return Binding(value=raw)
            conn, sep, address = raw.partition(":")
            if not sep or not address:
                expected = "a mode name (auto, manual) or " if mode else ""
                raise self.fail(key, f'must be {expected}"CONNECTION:ADDRESS", got {raw!r}')
            if conn not in conns:
                known = ", ".join(conns) or "none defined"
                raise self.fail(key, f"unknown connection {conn!r} (connections: {known})")
            why = PROTOCOLS[conns[conn].protocol].check_address(address)
            if why:
                raise self.fail(key, why)
            return Binding(conn, address)
        if not mode and not isinstance(raw, bool) and isinstance(raw, (int, float)):
            if math.isnan(float(raw)):
                raise self.fail(key, "must not be NaN")
            return Binding(value=float(raw))
        what = "a mode name or an I/O address" if mode else 'a number or "CONNECTION:ADDRESS"'
        raise self.fail(key, f"must be {what}, got {type_name(raw)} {raw!r}")

    # -- the side tables ------------------------------------------------------------

    def historian(self, h: dict[str, Any]) -> HistorianConfig:
        self.check_keys(
            h,
            {"backend", "path", "dsn", "dsn_env", "flush_interval", "batch", "retention_days"},
            "historian",
        )
        backend = self.choice(
            h, "backend", "historian.backend", ("sqlite", "postgresql", "none"), "sqlite"
        )
        # the default file is where the user runs ``serve`` (the README's ``history`` then
        # finds it); a path given in the file is relative to the file
        path = self.path(h, "path", "historian.path") or str(
            Path.cwd().resolve() / "ctrlblocks-history.sqlite"
        )
        dsn = self.secret(h, "dsn", "historian.dsn") or ""
        env = self.string(h, "dsn_env", "historian.dsn_env", default=None)
        if env is not None:
            dsn = os.environ.get(env, "")
            if not dsn:
                raise self.fail("historian.dsn_env", f"environment variable {env} is not set")
        if backend == "postgresql" and not dsn:
            raise self.fail("historian.dsn", "missing: the postgresql backend needs a dsn")
        flush = self.number(h, "flush_interval", "historian.flush_interval", 1.0, positive=True)
        batch = self.integer(h, "batch", "historian.batch", 10_000, 1)
        keep = self.number(h, "retention_days", "historian.retention_days", 0.0)
        if keep < 0 or not math.isfinite(keep):
            raise self.fail("historian.retention_days", "must be >= 0 (0 = keep everything)")
        return HistorianConfig(backend, path, dsn, flush, batch, keep)

    def retain(self, r: dict[str, Any], hist: HistorianConfig) -> RetainConfig:
        """The ``[retain]`` table; the default file sits beside the SQLite historian."""
        self.check_keys(r, {"enabled", "path", "interval"}, "retain")
        # default: on beside a historian; without one, on only where a path is given
        enabled = r.get("enabled", hist.backend != "none" or "path" in r)
        if not isinstance(enabled, bool):
            raise self.fail("retain.enabled", f"must be true or false, got {enabled!r}")
        default_dir = Path(hist.path).parent if hist.backend == "sqlite" else self.base
        path = self.path(r, "path", "retain.path") or str(default_dir / "ctrlblocks-retain.sqlite")
        interval = self.number(r, "interval", "retain.interval", 5.0, positive=True)
        return RetainConfig(enabled, path, interval)
