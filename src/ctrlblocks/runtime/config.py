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
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..loops.spec import BlockSpec, ControllerSpec
from ..loops.structures import STRUCTURES as _STRUCTURES
from ..loops.structures import ControllerSide, parse_controller
from ..loops.toml import (
    NAME_RE,
    KeyPathError,
    TableReader,
    located,
    read_text,
    read_toml,
    type_name,
)
from .health import check_health_tables

__all__ = [
    "PROTOCOLS",
    "Binding",
    "ConnectionConfig",
    "HistorianConfig",
    "LoopConfig",
    "RetainConfig",
    "RuntimeConfig",
    "RuntimeConfigError",
    "WebConfig",
    "load_config",
    "parse_config",
    "require_packages",
]

PROTOCOLS = ("opcua", "modbus", "memory")
"""Protocols of ``[connections.NAME]``."""

MODES = ("auto", "manual")
"""Modes a loop can be put in (from a binding or a command)."""

SECURITY_MODES = ("none", "Basic256Sha256_SignAndEncrypt")
"""OPC UA security settings of a connection."""

STRUCTURES: dict[str, tuple[str, ...]] = {
    # a single loop's block is its "block" table; the others' keys are a scenario's
    name: s.runtime_tables()
    for name, s in _STRUCTURES.items()
    if s.runtime
}
"""Loop structures the runtime runs and the loop keys holding their blocks (as in a scenario);
derived from :data:`ctrlblocks.loops.STRUCTURES`."""

MEASUREMENTS = {"pv": "y", "pv2": "y2", "dv": "dv", "wild": "w"}
"""Loop measurement bindings -> the names of :class:`~ctrlblocks.loops.ControllerSide`."""

READS: dict[str, tuple[str, ...]] = {
    name: tuple(sig for sig, m in MEASUREMENTS.items() if m in _STRUCTURES[name].measurements)
    for name in STRUCTURES
}
"""The measurement bindings each structure reads (an override: what its blocks' ``measure`` say)."""


class RuntimeConfigError(KeyPathError):
    """A runtime configuration file is malformed.

    ``file``, ``key`` (key path, e.g. ``loops[0].pv``), ``problem`` and
    ``line`` are attributes; the message reads ``FILE, line N: KEY: PROBLEM``.
    """


@dataclasses.dataclass(frozen=True)
class Binding:
    """Where a loop signal comes from or goes to.

    Either ``connection`` and ``address`` (process I/O) or a constant
    ``value`` (``connection`` is None).
    """

    connection: str | None = None
    address: str = ""
    value: Any = None

    @property
    def is_io(self) -> bool:
        """True when the signal is process I/O (not a constant)."""
        return self.connection is not None

    def __str__(self) -> str:
        return f"{self.connection}:{self.address}" if self.is_io else repr(self.value)


@dataclasses.dataclass(frozen=True)
class ConnectionConfig:
    """One ``[connections.NAME]`` table (see ``docs/runtime.md``)."""

    name: str
    protocol: str
    url: str = ""
    host: str = "127.0.0.1"
    port: int = 502
    unit: int = 1
    word_order: str = "big"
    timeout: float = 0.5
    reconnect_min: float = 0.1
    reconnect_max: float = 5.0
    security: str = "none"
    certificate: str | None = None
    private_key: str | None = None
    server_certificate: str | None = None
    user: str | None = None
    password: str | None = dataclasses.field(default=None, repr=False)  # a secret: never shown
    application_uri: str = "urn:ctrlblocks:runtime"
    stale_after: float = 0.0
    # -- plant-scale settings (see _Parser.connection_scale) --
    connect_timeout: float = 10.0
    stop_timeout: float = 2.0
    heartbeat: str | None = None
    heartbeat_max: int = 65535


@dataclasses.dataclass(frozen=True)
class LoopConfig:
    """One ``[[loops]]`` entry: a block, its sample time, bindings and fault settings."""

    name: str
    ts: float
    block_type: str
    block_params: Mapping[str, Any]
    pv: Binding
    mv: Binding
    sp: Binding
    mode: Binding
    manual_value: Binding | None
    u_min: Binding | None
    u_max: Binding | None
    safe_value: float
    stop_value: float | None
    on_bad_pv: str
    warn_limit: float | None
    alarm_limit: float | None
    write_retries: int
    key: str
    structure: str = "single"
    controller: ControllerSpec | None = None
    pv2: Binding | None = None
    dv: Binding | None = None
    u0: float = 0.0
    # -- the split range's second MV and the ratio's wild flow (see _Parser.loop) --
    mv2: Binding | None = None
    wild: Binding | None = None
    # -- a structure's optional output tags written with the MV (three_step: open, close) --
    outputs: Mapping[str, Binding] = dataclasses.field(default_factory=dict)
    # -- fault action (see _Parser.fault_action) --
    on_fault: str = "safe_value"
    hold_time: float = 0.0
    # engineering bounds and units (the faceplate's keys, see the section at the end)
    sp_range: tuple[float, float] | None = None
    mv_range: tuple[float, float] | None = None
    tuning_ranges: Mapping[str, tuple[float, float]] = dataclasses.field(default_factory=dict)
    units: Mapping[str, str] = dataclasses.field(default_factory=dict)
    # -- loop health (runtime.health): the checked ``alarms`` and ``assess`` tables --
    health: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    def bindings(self) -> dict[str, Binding]:
        """The signal bindings by name (only those that are set)."""
        names = (
            "pv", "pv2", "dv", "wild", "mv", "mv2", "sp", "mode", "manual_value", "u_min", "u_max"
        )  # fmt: skip
        out = {n: b for n in names if (b := getattr(self, n)) is not None}
        return {**out, **self.outputs}

    def spec(self) -> ControllerSpec:
        """The loop's controller entry (a single loop: its ``block`` as role ``main``)."""
        if self.controller is not None:
            return self.controller
        main = BlockSpec(self.block_type, dict(self.block_params), f"{self.key}.block")
        return ControllerSpec(self.name, {"main": main}, {})


@dataclasses.dataclass(frozen=True)
class HistorianConfig:
    """The ``[historian]`` table."""

    backend: str = "sqlite"
    path: str = "ctrlblocks-history.sqlite"
    dsn: str = dataclasses.field(default="", repr=False)  # may hold a password
    flush_interval: float = 1.0
    batch: int = 10_000
    retention_days: float = 0.0


@dataclasses.dataclass(frozen=True)
class WebConfig:
    """The ``[web]`` table: what the faceplate shows to whom (see the section at the end)."""

    public_view: bool = False
    confirm_step: float = 0.1


@dataclasses.dataclass(frozen=True)
class RetainConfig:
    """The ``[retain]`` table: the retentive state file (a PLC's RETAIN memory)."""

    enabled: bool = True
    path: str = "ctrlblocks-retain.sqlite"
    interval: float = 5.0


@dataclasses.dataclass(frozen=True)
class RuntimeConfig:
    """A parsed, checked runtime configuration."""

    name: str
    connections: Mapping[str, ConnectionConfig]
    loops: tuple[LoopConfig, ...]
    historian: HistorianConfig
    file: str
    web: WebConfig = WebConfig()
    retain: RetainConfig = RetainConfig()

    def build_blocks(self) -> dict[str, Any]:
        """A fresh block for every loop (name -> the block that writes its MV)."""
        return {lc.name: build_side(lc, self.file).main for lc in self.loops}

    def build_sides(self) -> dict[str, ControllerSide]:
        """A fresh controller side (the structure's blocks) for every loop (name -> side)."""
        return {lc.name: build_side(lc, self.file) for lc in self.loops}


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
        return _Parser(file, base or Path.cwd()).config(doc)


PROTOCOL_PACKAGES = {"opcua": "asyncua", "modbus": "pymodbus"}
"""The library each protocol needs (the ``runtime`` extra)."""


def require_packages(config: RuntimeConfig, connections: Any = None) -> None:
    """Refuse a configuration whose protocols' libraries are not installed.

    ``connections`` limits the check to these names (default all).  The
    error names the connection and the install command, so ``serve --check``
    fails and ``serve`` does not start a runtime that would retry for ever.
    """
    import importlib.util

    for name, c in config.connections.items():
        if connections is not None and name not in connections:
            continue
        pkg = PROTOCOL_PACKAGES.get(c.protocol)
        if pkg is not None and importlib.util.find_spec(pkg) is None:
            raise RuntimeConfigError(
                config.file,
                f"connections.{name}.protocol",
                f"{c.protocol} needs the {pkg} package, which is not installed: "
                "pip install 'ctrlblocks[runtime]'",
            )


def build_side(lc: LoopConfig, file: str = "<config>") -> ControllerSide:
    """Make the controller side of loop ``lc``: its structure's blocks, wired (errors: key path)."""
    return ControllerSide(
        lc.structure, lc.spec(), lc.ts, u0=lc.u0, file=file, error=RuntimeConfigError
    )


# ---------------------------------------------------------------------------


class _Parser(TableReader):
    error = RuntimeConfigError

    def __init__(self, file: str, base: Path) -> None:
        super().__init__(file)
        self.base = base

    def number(
        self, d: Mapping[str, Any], name: str, key: str, default: Any = ..., *, positive=False
    ) -> Any:
        """A number that is never NaN; ``positive``: finite and > 0."""
        x = super().number(d, name, key, default=default, allow_nan=False)
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

    # -- sections -------------------------------------------------------------

    def config(self, doc: dict[str, Any]) -> RuntimeConfig:
        self.check_keys(
            doc, {"runtime", "connections", "loops", "historian", "web", *_SCALE_TABLES}, ""
        )
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
            for sig, b in (("mv", lc.mv), ("mv2", lc.mv2), *lc.outputs.items()):
                if b is not None and b.is_io:
                    k = str(b)
                    if k in seen:
                        raise self.fail(
                            f"{lc.key}.{sig}", f"{k} is already written by loop {seen[k]!r}"
                        )
                    seen[k] = lc.name
        hist = self.historian(self.table(doc, "historian", "historian", required=False))
        web = _web(self, self.table(doc, "web", "web", required=False))
        retain = self.retain(self.table(doc, "retain", "retain", required=False), hist)
        cfg = RuntimeConfig(name, conns, tuple(loops), hist, self.file, web, retain)
        for lc in loops:  # build once: a refused parameter is reported here
            _check_tuning_ranges(self, lc, build_side(lc, self.file))
        return cfg

    def connection(self, name: str, c: Any) -> ConnectionConfig:
        key = f"connections.{name}"
        if not NAME_RE.match(name):
            raise self.fail(key, "connection names are letters, digits, _ . - only")
        c = self.as_table(c, key)
        protocol = self.choice(c, "protocol", f"{key}.protocol", PROTOCOLS)
        common = {"protocol", "timeout", "reconnect_min", "reconnect_max", *_SCALE_CONNECTION_KEYS}
        per = {
            "opcua": {
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
            },
            "modbus": {"host", "port", "unit", "word_order"},
            "memory": set(),
        }[protocol]
        self.check_keys(c, common | per, key)
        kw: dict[str, Any] = {"name": name, "protocol": protocol}
        kw["timeout"] = self.number(c, "timeout", f"{key}.timeout", 0.5, positive=True)
        kw["reconnect_min"] = self.number(
            c, "reconnect_min", f"{key}.reconnect_min", 0.1, positive=True
        )
        kw["reconnect_max"] = self.number(
            c, "reconnect_max", f"{key}.reconnect_max", 5.0, positive=True
        )
        if kw["reconnect_max"] < kw["reconnect_min"]:
            raise self.fail(f"{key}.reconnect_max", "must be >= reconnect_min")
        if protocol == "opcua":
            url = self.string(c, "url", f"{key}.url")
            if not url.startswith("opc.tcp://"):
                raise self.fail(f"{key}.url", f"must start with opc.tcp://, got {url!r}")
            kw["url"] = url
            kw["security"] = self.choice(c, "security", f"{key}.security", SECURITY_MODES, "none")
            for f in ("certificate", "private_key", "server_certificate"):
                kw[f] = self.path(c, f, f"{key}.{f}")
            if kw["security"] != "none":
                for f in ("certificate", "private_key", "server_certificate"):
                    if kw[f] is None:
                        raise self.fail(
                            f"{key}.{f}",
                            f"missing: security {kw['security']!r} needs the client certificate, "
                            "its private key and the trusted server certificate",
                        )
            kw["user"] = self.string(c, "user", f"{key}.user", default=None)
            pw = self.secret(c, "password", f"{key}.password")
            env = self.string(c, "password_env", f"{key}.password_env", default=None)
            if pw is not None and env is not None:
                raise self.fail(f"{key}.password_env", "give password or password_env, not both")
            if env is not None:
                pw = os.environ.get(env)
                if pw is None:
                    raise self.fail(f"{key}.password_env", f"environment variable {env} is not set")
            if pw is not None and kw["user"] is None:
                raise self.fail(f"{key}.user", "missing: a password needs a user")
            kw["password"] = pw
            kw["application_uri"] = self.string(
                c, "application_uri", f"{key}.application_uri", default="urn:ctrlblocks:runtime"
            )
            kw["stale_after"] = self.number(c, "stale_after", f"{key}.stale_after", 0.0)
            if kw["stale_after"] < 0:
                raise self.fail(f"{key}.stale_after", "must be >= 0 (0 = off)")
        elif protocol == "modbus":
            kw["host"] = self.string(c, "host", f"{key}.host", default="127.0.0.1")
            kw["port"] = self.integer(c, "port", f"{key}.port", 502, 1)
            if kw["port"] > 65535:
                raise self.fail(f"{key}.port", "must be <= 65535")
            kw["unit"] = self.integer(c, "unit", f"{key}.unit", 1, 0)
            kw["word_order"] = self.choice(
                c, "word_order", f"{key}.word_order", ("big", "little"), "big"
            )
        kw.update(self.connection_scale(c, key, protocol))
        return ConnectionConfig(**kw)

    def binding(
        self, raw: Any, key: str, conns: Mapping[str, ConnectionConfig], *, mode=False
    ) -> Binding:
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
            if conns[conn].protocol == "modbus":
                _check_modbus_address(address, key, self)
            return Binding(conn, address)
        if not mode and not isinstance(raw, bool) and isinstance(raw, (int, float)):
            if math.isnan(float(raw)):
                raise self.fail(key, "must not be NaN")
            return Binding(value=float(raw))
        what = "a mode name or an I/O address" if mode else 'a number or "CONNECTION:ADDRESS"'
        raise self.fail(key, f"must be {what}, got {type_name(raw)} {raw!r}")

    def loop(self, raw: Any, key: str, conns: Mapping[str, ConnectionConfig]) -> LoopConfig:
        raw = self.as_table(raw, key)
        structure = self.choice(raw, "structure", f"{key}.structure", tuple(STRUCTURES), "single")
        allowed = {
            "name",
            "ts",
            "structure",
            "pv",
            "pv2",
            "dv",
            "wild",
            "mv",
            "mv2",
            "sp",
            "mode",
            "manual_value",
            "u_min",
            "u_max",
            "safe_value",
            "stop_value",
            "on_bad_pv",
            "warn_limit",
            "alarm_limit",
            "write_retries",
            "u0",
            "alarms",
            "assess",
            *_FAULT_LOOP_KEYS,
            *ENGINEERING_KEYS,
            *STRUCTURES[structure],
            *_STRUCTURES[structure].output_tags,
        }
        self.check_keys(raw, allowed, key)
        name = self.string(raw, "name", f"{key}.name")
        if not NAME_RE.match(name):
            raise self.fail(f"{key}.name", "loop names are letters, digits, _ . - only")
        ts = self.number(raw, "ts", f"{key}.ts", positive=True)
        st = _STRUCTURES[structure]
        used = st.measurements_in(raw)
        needs = tuple(sig for sig, m in MEASUREMENTS.items() if m in used)
        for sig in ("pv", "pv2", "dv", "wild"):
            if sig in raw and sig not in needs:
                raise self.fail(
                    f"{key}.{sig}",
                    f"the {structure} structure does not read {sig} (reads: {', '.join(needs)})",
                )
        optional = {s for s, m in MEASUREMENTS.items() if m in st.optional_measurements}
        needs = tuple(s for s in needs if s not in optional or s in raw)
        for sig in (*needs, "mv"):
            if sig not in raw:
                raise self.fail(f"{key}.{sig}", 'missing (an I/O address "CONNECTION:ADDRESS")')
        meas = {sig: self.binding(raw[sig], f"{key}.{sig}", conns) for sig in needs}
        mv = self.binding(raw["mv"], f"{key}.mv", conns)
        mv2 = self.second_mv(raw, key, structure, conns, mv)
        outputs = self.output_tags(raw, key, st.output_tags, conns, mv)
        for sig, b in (*meas.items(), ("mv", mv)):
            if not b.is_io:
                raise self.fail(f"{key}.{sig}", 'must be an I/O address "CONNECTION:ADDRESS"')
        if "sp" not in raw:
            raise self.fail(f"{key}.sp", 'missing (a number or "CONNECTION:ADDRESS")')
        sp = self.binding(raw["sp"], f"{key}.sp", conns)
        mode = self.binding(raw.get("mode", "auto"), f"{key}.mode", conns, mode=True)
        opt = {}
        for sig in ("manual_value", "u_min", "u_max"):
            opt[sig] = self.binding(raw[sig], f"{key}.{sig}", conns) if sig in raw else None
        if (opt["u_min"] is None) != (opt["u_max"] is None):
            raise self.fail(f"{key}.u_min", "bind u_min and u_max together (or neither)")
        for sig in ("u_min", "u_max"):
            if opt[sig] is not None and not opt[sig].is_io:
                raise self.fail(
                    f"{key}.{sig}", "constant limits belong in the block table (block.u_min ...)"
                )
        if "safe_value" not in raw:
            raise self.fail(
                f"{key}.safe_value",
                "missing: the MV on a measurement fault and on stop (a number) is required",
            )
        safe = self.number(raw, "safe_value", f"{key}.safe_value")
        if not math.isfinite(safe):
            raise self.fail(f"{key}.safe_value", "must be finite")
        stop = self.number(raw, "stop_value", f"{key}.stop_value", None)
        if stop is not None and not math.isfinite(stop):
            raise self.fail(f"{key}.stop_value", "must be finite")
        u0 = self.number(raw, "u0", f"{key}.u0", 0.0)
        if not math.isfinite(u0):
            raise self.fail(f"{key}.u0", "must be finite")
        # the blocks that write the MV get the loop's safe value
        mv_tables = self.mv_tables(raw, key, structure)
        types = {self.string(t, "type", f"{k}.type") for k, t in mv_tables}
        on_bad = self.choice(
            raw,
            "on_bad_pv",
            f"{key}.on_bad_pv",
            ("safe",) if "ADRC" in types else ("safe", "hold"),
            "safe",
        )
        patched: dict[str, dict[str, Any]] = {}
        for k, table in mv_tables:
            btype = self.string(table, "type", f"{k}.type")
            if btype not in ("PID", "ADRC"):
                raise self.fail(f"{k}.type", f"the runtime runs PID or ADRC, got {btype!r}")
            if "ts" in table:
                raise self.fail(f"{k}.ts", "set the sample time once, as the loop's ts")
            params = {n: v for n, v in table.items()}
            if btype == "ADRC":
                if "u_sf" in params:
                    raise self.fail(f"{k}.u_sf", "set the loop's safe_value instead")
                params["u_sf"] = safe
            else:
                if "safe_value" in params:
                    raise self.fail(
                        f"{k}.safe_value", "set the loop's safe_value and on_bad_pv instead"
                    )
                params["safe_value"] = safe if on_bad == "safe" else None
            patched[k] = params
        controller: ControllerSpec | None = None
        if _STRUCTURES[structure].lone_block:
            params = dict(patched[f"{key}.block"])
            btype = params.pop("type")
        else:
            controller = self.structure_entry(raw, key, structure, ts, name, patched)
            if stop is not None and st.off_mv(controller) is not None:
                raise self.fail(
                    f"{key}.stop_value",
                    f"a {structure} loop stops its output stage at its off state "
                    f"(MV {st.off_mv(controller)!r}); there is no stop value to give",
                )
            main_key = mv_tables[0][0]
            btype = patched[main_key]["type"]
            params = {n: v for n, v in patched[main_key].items() if n != "type"}
        warn = self.number(raw, "warn_limit", f"{key}.warn_limit", None)
        alarm = self.number(raw, "alarm_limit", f"{key}.alarm_limit", None)
        for n, v in (("warn_limit", warn), ("alarm_limit", alarm)):
            if v is not None and not (math.isfinite(v) and v > 0):
                raise self.fail(f"{key}.{n}", f"must be a finite number > 0, got {v!r}")
        w, a = (warn if warn is not None else 1.5 * ts), (alarm if alarm is not None else 2 * ts)
        if alarm is None and a < w:
            alarm = a = w  # the default alarm limit (2 ts) never undercuts the warning limit
        if a < w:
            raise self.fail(f"{key}.alarm_limit", f"must be >= warn_limit ({w!r})")
        retries = self.integer(raw, "write_retries", f"{key}.write_retries", 1, 0)
        return LoopConfig(
            name=name,
            ts=ts,
            block_type=btype,
            block_params=params,
            pv=meas.get("pv"),  # type: ignore[arg-type]
            mv=mv,
            sp=sp,
            mode=mode,
            manual_value=opt["manual_value"],
            u_min=opt["u_min"],
            u_max=opt["u_max"],
            safe_value=safe,
            stop_value=stop,
            on_bad_pv=on_bad,
            warn_limit=warn,
            alarm_limit=alarm,
            write_retries=retries,
            key=key,
            structure=structure,
            controller=controller,
            pv2=meas.get("pv2"),
            dv=meas.get("dv"),
            u0=u0,
            mv2=mv2,
            wild=meas.get("wild"),
            outputs=outputs,
            health=check_health_tables(raw, key, ts, self.fail),
            **self.fault_action(raw, key),
            **_engineering(self, raw, key, sp, opt["manual_value"]),
        )

    def second_mv(
        self,
        raw: Mapping[str, Any],
        key: str,
        structure: str,
        conns: Mapping[str, ConnectionConfig],
        mv: Binding,
    ) -> Binding | None:
        """``mv2``: actuator B of a split range, on the MV's connection (one batched write)."""
        if _STRUCTURES[structure].actuators < 2:
            if "mv2" in raw:
                raise self.fail(
                    f"{key}.mv2", f"the {structure} structure writes one MV (mv2: split_range)"
                )
            return None
        if "mv2" not in raw:
            raise self.fail(
                f"{key}.mv2",
                'missing: the split range\'s second actuator (an I/O address "CONNECTION:ADDRESS")',
            )
        mv2 = self.written_with_mv(
            raw["mv2"], f"{key}.mv2", conns, mv, "both actuators are written in one batched request"
        )
        if mv2.address == mv.address:
            raise self.fail(f"{key}.mv2", f"is the address of mv ({mv}); give actuator B's own")
        return mv2

    def written_with_mv(
        self, raw: Any, key: str, conns: Mapping[str, ConnectionConfig], mv: Binding, why: str
    ) -> Binding:
        """An output address written with the MV: I/O, on the MV's connection (``why``)."""
        b = self.binding(raw, key, conns)
        if not b.is_io:
            raise self.fail(key, 'must be an I/O address "CONNECTION:ADDRESS"')
        if b.connection != mv.connection:
            raise self.fail(key, f"must be on the connection of mv ({mv.connection!r}): {why}")
        return b

    def output_tags(
        self,
        raw: Mapping[str, Any],
        key: str,
        tags: tuple[str, ...],
        conns: Mapping[str, ConnectionConfig],
        mv: Binding,
    ) -> dict[str, Binding]:
        """The structure's optional output tags (``open``, ``close``), on the MV's connection."""
        out: dict[str, Binding] = {}
        for tag in tags:
            if tag not in raw:
                continue
            why = "the outputs are written with the MV in one batched request"
            b = self.written_with_mv(raw[tag], f"{key}.{tag}", conns, mv, why)
            taken = [n for n, o in (("mv", mv), *out.items()) if o.address == b.address]
            if taken:
                raise self.fail(f"{key}.{tag}", f"is the address of {taken[0]} ({b})")
            out[tag] = b
        return out

    def mv_tables(
        self, raw: Mapping[str, Any], key: str, structure: str
    ) -> list[tuple[str, dict[str, Any]]]:
        """``(key path, table)`` of the blocks whose output is (or is selected as) the MV."""
        st = _STRUCTURES[structure]
        example = '{ type = "PID", kp = 1.0 }'
        role = "block" if st.lone_block else st.mv_roles[0]
        if role in st.array_roles:
            lst = raw.get(role)
            if not isinstance(lst, list) or len(lst) < 2:
                raise self.fail(
                    f"{key}.{role}", "must be an array of at least two controller tables"
                )
            roles = [(f"{role}[{j}]", b) for j, b in enumerate(lst)]
            example = '{ type = "PID", kp = 1.0, measure = "y" }'
        else:
            roles = [(role, raw.get(role))]
        out = []
        for role, t in roles:
            if not isinstance(t, dict):
                raise self.fail(f"{key}.{role}", f"missing: a table such as {example}")
            out.append((f"{key}.{role}", t))
        return out

    def structure_entry(
        self,
        raw: Mapping[str, Any],
        key: str,
        structure: str,
        ts: float,
        name: str,
        patched: Mapping[str, dict[str, Any]],
    ) -> ControllerSpec:
        """The structure's blocks, checked by the simulator's parser (one controller entry)."""
        entry: dict[str, Any] = {"name": name}
        for k in STRUCTURES[structure]:
            if k in raw:
                entry[k] = raw[k]
        role = _STRUCTURES[structure].mv_roles[0]  # the MV's blocks, as patched
        if role in _STRUCTURES[structure].array_roles:
            entry[role] = [patched[f"{key}.{role}[{j}]"] for j in range(len(raw[role]))]
        else:
            entry[role] = patched[f"{key}.{role}"]
        for k, v in entry.items():
            if isinstance(v, dict) and "ts" in v:
                raise self.fail(f"{key}.{k}.ts", "set the sample time once, as the loop's ts")
        return parse_controller(
            entry, structure, ts, key=key, file=self.file, error=RuntimeConfigError
        )

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

    # -- plant-scale settings: connect/stop timeouts, heartbeat, fault action, retain -----

    def connection_scale(self, c: Mapping[str, Any], key: str, protocol: str) -> dict[str, Any]:
        """Connection keys: ``connect_timeout``, ``stop_timeout``, ``heartbeat(_max)``."""
        kw: dict[str, Any] = {
            "connect_timeout": self.number(
                c, "connect_timeout", f"{key}.connect_timeout", 10.0, positive=True
            ),
            "stop_timeout": self.number(
                c, "stop_timeout", f"{key}.stop_timeout", 2.0, positive=True
            ),
            "heartbeat_max": self.integer(c, "heartbeat_max", f"{key}.heartbeat_max", 65535, 1),
        }
        hb = self.string(c, "heartbeat", f"{key}.heartbeat", default=None)
        if hb is not None:
            if protocol == "modbus":
                _check_modbus_address(hb, f"{key}.heartbeat", self)
                if parse_modbus_address(hb)[0] != "hr":
                    raise self.fail(f"{key}.heartbeat", "must be a holding register (hr:N)")
            elif not hb:
                raise self.fail(f"{key}.heartbeat", "must be an address")
        kw["heartbeat"] = hb
        return kw

    def fault_action(self, raw: Mapping[str, Any], key: str) -> dict[str, Any]:
        """``on_fault`` (``"safe_value"`` or ``"hold"``) and ``hold_time`` [s] of a loop."""
        on_fault = self.choice(
            raw, "on_fault", f"{key}.on_fault", ("safe_value", "hold"), "safe_value"
        )
        hold = self.number(raw, "hold_time", f"{key}.hold_time", 0.0)
        if not (math.isfinite(hold) and hold >= 0):
            raise self.fail(f"{key}.hold_time", f"must be a finite number >= 0, got {hold!r}")
        if "hold_time" in raw and on_fault != "hold":
            raise self.fail(f"{key}.hold_time", 'only with on_fault = "hold"')
        if on_fault == "hold" and "hold_time" not in raw:
            raise self.fail(
                f"{key}.hold_time", 'missing: on_fault = "hold" needs how long to hold [s]'
            )
        return {"on_fault": on_fault, "hold_time": hold}

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


_SCALE_TABLES = ("retain",)
_SCALE_CONNECTION_KEYS = ("connect_timeout", "stop_timeout", "heartbeat", "heartbeat_max")
_FAULT_LOOP_KEYS = ("on_fault", "hold_time")

_MODBUS_RE = re.compile(r"^(?:(hr|ir):)?(\d+)$")


def parse_modbus_address(address: str) -> tuple[str, int]:
    """``"hr:10"`` -> ``("hr", 10)``; a bare number is a holding register."""
    m = _MODBUS_RE.match(address.strip())
    if m is None:
        raise ValueError(address)
    return (m.group(1) or "hr"), int(m.group(2))


def _check_modbus_address(address: str, key: str, parser: _Parser) -> None:
    try:
        _, reg = parse_modbus_address(address)
    except ValueError:
        raise parser.fail(
            key, f"Modbus address must be hr:N or ir:N (FLOAT32 at register N), got {address!r}"
        ) from None
    if reg > 65534:
        raise parser.fail(key, "Modbus register must be <= 65534 (a FLOAT32 takes two)")


# ---------------------------------------------------------------------------
# Engineering bounds, units and [web]: the keys the faceplate reads
#
#     [[loops]]
#     unit = { pv = "bar", mv = "bar" }          # sp: the PV's unit unless given; or unit = "bar"
#     sp_range = [0.0, 5.0]                      # setpoints an operator may give
#     mv_range = [0.0, 5.0]                      # output limits and manual value stay inside
#     tuning_ranges = { b0 = [0.01, 1.0] }       # per tuning; others: derived from the block
#
#     [web]
#     public_view = false                        # true: live state without a login
#     confirm_step = 0.1                         # the page asks before a bigger step [range]
# ---------------------------------------------------------------------------

ENGINEERING_KEYS = ("unit", "sp_range", "mv_range", "tuning_ranges")
"""Loop keys of the engineering bounds and units (``docs/faceplate.md``)."""

UNIT_SIGNALS = ("pv", "sp", "mv")
"""Signals that carry a ``unit``."""


def _range(p: _Parser, raw: Any, key: str) -> tuple[float, float]:
    """``[lo, hi]``: two finite numbers, lo < hi."""
    ok = isinstance(raw, list) and len(raw) == 2
    ok = ok and all(not isinstance(v, bool) and isinstance(v, (int, float)) for v in raw)
    if not ok or not all(math.isfinite(float(v)) for v in raw):
        raise p.fail(key, f"must be [low, high], two finite numbers, got {raw!r}")
    lo, hi = float(raw[0]), float(raw[1])
    if not lo < hi:
        raise p.fail(key, f"low {lo!r} must be below high {hi!r}")
    return lo, hi


def _engineering(
    p: _Parser, raw: Mapping[str, Any], key: str, sp: Binding, manual: Binding | None
) -> dict[str, Any]:
    """The loop's ``unit``, ``sp_range``, ``mv_range`` and ``tuning_ranges`` (LoopConfig fields)."""
    out: dict[str, Any] = {}
    for name in ("sp_range", "mv_range"):
        out[name] = _range(p, raw[name], f"{key}.{name}") if name in raw else None
    for name, b, r in (("sp", sp, out["sp_range"]), ("manual_value", manual, out["mv_range"])):
        if b is not None and not b.is_io and r is not None and not r[0] <= b.value <= r[1]:
            raise p.fail(f"{key}.{name}", f"{b.value!r} is outside [{r[0]!r}, {r[1]!r}]")
    t = p.table(raw, "tuning_ranges", f"{key}.tuning_ranges", required=False)
    out["tuning_ranges"] = {n: _range(p, v, f"{key}.tuning_ranges.{n}") for n, v in t.items()}
    u = raw.get("unit", {})
    if isinstance(u, str):
        u = {"pv": u}
    u = p.as_table(u, f"{key}.unit")
    p.check_keys(u, set(UNIT_SIGNALS), f"{key}.unit")
    units = {s: p.string(u, s, f"{key}.unit.{s}", default="") for s in UNIT_SIGNALS}
    for s, text in units.items():
        if len(text) > 16 or any(c in text for c in '<>&"\n'):
            raise p.fail(f"{key}.unit.{s}", f"a unit of at most 16 plain characters, got {text!r}")
    units["sp"] = units["sp"] or units["pv"]
    out["units"] = units
    return out


def _check_tuning_ranges(p: _Parser, lc: LoopConfig, side: ControllerSide) -> None:
    """Refuse a ``tuning_ranges`` entry that is not a numeric tuning or excludes the value."""
    cfg = side.main.config
    for n, (lo, hi) in lc.tuning_ranges.items():
        k = f"{lc.key}.tuning_ranges.{n}"
        if not hasattr(cfg, n) or n in ("ts", "u_min", "u_max"):
            raise p.fail(k, f"{n!r} is not a tuning of the {lc.block_type} block")
        v = getattr(cfg, n)
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise p.fail(k, f"{n!r} is not a number (got {v!r}): it has no range")
        if not lo <= v <= hi:
            raise p.fail(k, f"the configured {n} = {v!r} is outside [{lo!r}, {hi!r}]")


def _web(p: _Parser, w: dict[str, Any]) -> WebConfig:
    p.check_keys(w, {"public_view", "confirm_step"}, "web")
    public = w.get("public_view", False)
    if not isinstance(public, bool):
        raise p.fail("web.public_view", f"must be true or false, got {public!r}")
    step = p.number(w, "confirm_step", "web.confirm_step", 0.1, positive=True)
    if step > 1.0:
        raise p.fail("web.confirm_step", f"a fraction of the range in (0, 1], got {step!r}")
    return WebConfig(public, step)
