"""What a runtime configuration holds, once read and checked: plain frozen dataclasses.

:class:`RuntimeConfig` has the connections (:class:`ConnectionConfig`), the
loops (:class:`LoopConfig`, each with its :class:`Binding` s) and the
historian, retain and web tables.  The parser that makes them from a TOML
file is :mod:`.parser`; ``docs/runtime.md`` lists every key.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

from ...loops.spec import BlockSpec, ControllerSpec
from ...loops.structures import STRUCTURES as _STRUCTURES
from ...loops.structures import ControllerSide
from ...loops.toml import KeyPathError

__all__ = [
    "MAX_DT_TS",
    "MEASUREMENTS",
    "MODES",
    "READS",
    "STRUCTURES",
    "Binding",
    "ConnectionConfig",
    "HistorianConfig",
    "LoopConfig",
    "RetainConfig",
    "RuntimeConfig",
    "RuntimeConfigError",
    "WebConfig",
    "build_side",
]

MODES = ("auto", "manual")
"""Modes a loop can be put in (from a binding or a command)."""

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

MAX_DT_TS = 20.0
"""The longest ``max_dt`` a loop may configure, in sample times: every block is stable for a
``dt`` from ``ts/10`` to ``20 ts`` (docs/runtime.md, "What the blocks get as dt")."""


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
    """One ``[connections.NAME]`` table (see ``docs/runtime.md``).

    The fields after ``protocol`` up to ``stale_after`` are the built-in
    protocols' own keys (:mod:`.protocols`); a protocol registered later keeps
    its keys in ``options``.
    """

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
    # -- plant-scale settings (see .parser) --
    connect_timeout: float = 10.0
    stop_timeout: float = 2.0
    heartbeat: str | None = None
    heartbeat_max: int = 65535
    # how long a cycle waits for this connection's inputs [s]; None: half the cycle
    deadline: float | None = None
    # the keys of a protocol registered with ctrlblocks.runtime.config.register_protocol
    options: Mapping[str, Any] = dataclasses.field(default_factory=dict)


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
    # -- the split range's second MV and the ratio's wild flow --
    mv2: Binding | None = None
    wild: Binding | None = None
    # -- a structure's optional output tags written with the MV (three_step: open, close) --
    outputs: Mapping[str, Binding] = dataclasses.field(default_factory=dict)
    # -- fault action --
    on_fault: str = "safe_value"
    hold_time: float = 0.0
    # -- time: late inputs, the longest dt, the MV of a cold start without a read-back --
    on_late: str = "hold"
    max_dt: float | None = None  # None: 10 ts (LoopConfig.dt_bound)
    initial_mv: float | None = None
    # a cold start: "read_back" (bumpless from the device's MV) or "block" (the blocks' own
    # initial state, as a simulation without a warm-up)
    start: str = "read_back"
    # engineering bounds and units (the faceplate's keys, .engineering)
    sp_range: tuple[float, float] | None = None
    mv_range: tuple[float, float] | None = None
    tuning_ranges: Mapping[str, tuple[float, float]] = dataclasses.field(default_factory=dict)
    units: Mapping[str, str] = dataclasses.field(default_factory=dict)
    # -- loop health (runtime.health): the checked ``alarms`` and ``assess`` tables --
    health: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    # -- the alarms' states written with the MV (``alarm_outputs``: key -> binding) --
    alarm_outputs: Mapping[str, Binding] = dataclasses.field(default_factory=dict)

    def bindings(self) -> dict[str, Binding]:
        """The signal bindings by name (only those that are set)."""
        names = (
            "pv", "pv2", "dv", "wild", "mv", "mv2", "sp", "mode", "manual_value", "u_min", "u_max"
        )  # fmt: skip
        out = {n: b for n in names if (b := getattr(self, n)) is not None}
        alarms = {f"alarm_outputs.{k}": b for k, b in self.alarm_outputs.items()}
        return {**out, **self.outputs, **alarms}

    def written(self) -> dict[str, Binding]:
        """The bindings the loop writes (MV, a second MV, output tags, alarm outputs)."""
        names = ("mv", "mv2", *self.outputs, *(f"alarm_outputs.{k}" for k in self.alarm_outputs))
        b = self.bindings()
        return {n: b[n] for n in names if n in b}

    def connections(self) -> set[str]:
        """The connections this loop reads or writes."""
        return {b.connection for b in self.bindings().values() if b.connection is not None}

    @property
    def dt_bound(self) -> float:
        """The longest period [s] the blocks integrate over in one step (``max_dt``, 10 ts)."""
        return self.max_dt if self.max_dt is not None else 10.0 * self.ts

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
    """The ``[web]`` table: what the faceplate shows to whom (:mod:`.engineering`)."""

    public_view: bool = False
    confirm_step: float = 0.1
    # reverse proxies whose X-Forwarded-For is believed (addresses or networks)
    trusted_proxies: tuple[str, ...] = ()


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


def build_side(lc: LoopConfig, file: str = "<config>") -> ControllerSide:
    """Make the controller side of loop ``lc``: its structure's blocks, wired (errors: key path)."""
    return ControllerSide(
        lc.structure, lc.spec(), lc.ts, u0=lc.u0, file=file, error=RuntimeConfigError
    )
