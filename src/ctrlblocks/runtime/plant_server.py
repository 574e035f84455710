"""A simulated plant served over OPC UA and Modbus TCP (``ctrlblocks plant-server``).

:class:`PlantServer` serves one process over OPC UA and/or Modbus TCP: an
object with ``ts``, ``mv``, ``values()`` (the variables below), ``step(u)`` and
``sensor_ok``, usually a scenario's :class:`ctrlblocks.sim.PlantProcess`
(the simulator's process side with its time line).  The runtime does not
import the simulator: the command ``ctrlblocks plant-server`` builds the
process and hands it over.
Variables (OPC UA ``ns=2;s=NAME``; Modbus holding registers, FLOAT32, two
registers each):

========  ========  ==============================================  =========
name      register  meaning                                         access
========  ========  ==============================================  =========
pv        0         measured process value (NaN after a sensor       read
                    NaN event; bad status while the sensor is
                    faulty, NaN on Modbus)
mv        2         manipulated variable (the runtime writes it)     read/write
sp        4         setpoint of the scenario's time line             read
mode      6         0 = auto, 1 = manual (mode events)               read
manual    8         manual value (NaN until a mode/manual event)     read
u_min     10        MV limits (NaN until a limits event)             read
u_max     12                                                         read
k         14        sample counter                                   read
pv2       16        the inner plant's output ``y2`` (cascade,        read
                    override; NaN without an inner plant; as pv
                    during a sensor event on y2)
dv        18        the input load, the measured disturbance of a    read
                    feed-forward structure
mv2       20        a split range's second actuator (actuator B;     read/write
                    writable only when the process has one, NaN
                    otherwise)
wild      22        a ratio loop's wild flow (NaN while a ``wild``   read
                    event flags it bad or NaN)
hb        24        the runtime's heartbeat counter (the watchdog)   read/write
tripped   26        1 while the watchdog holds the safe MV, else 0   read
========  ========  ==============================================  =========

``mv`` (and ``mv2``) read back the MV the process applies: the last one
written, or the watchdog's safe MV while it is tripped.

**Device outputs** (``outputs``): further writable variables, as a PLC holds
them for what the runtime writes besides the MV -- a loop's output tags and
its alarm outputs (``alarm_outputs``: the alarms' ISA-18.2 states, active and
unacknowledged flags).  OPC UA ``ns=2;s=NAME`` of the given data type
(``Double``, ``Float``, ``UInt16`` or ``Boolean``); Modbus FLOAT32 holding
registers after the table's, two each in the given order
(:meth:`PlantServer.output_register`).  :attr:`PlantServer.outputs` holds the
values written to each, in order.  They do not act on the process.

**Device watchdog** (``watchdog`` seconds, the pattern of a real PLC): the
runtime writes a counter to ``hb`` every cycle (``heartbeat = "...:hb"`` on
the connection); when ``hb`` has not changed for ``watchdog`` seconds -- the
runtime died, hangs, or lost the connection -- the server applies its own
safe MV (``watchdog_mv``; a split range's actuators both) and ignores MV
writes until the counter moves again, then the runtime's writes apply again
(the runtime starts from the MV it reads back: bumpless).  The watchdog is
armed from the start: without heartbeats the plant runs on its safe MV after
``watchdog`` seconds.  ``tripped`` and :attr:`PlantServer.trips` tell.

``sync = "write"`` (lock-step, for tests and hardware-in-the-loop checks):
each write of ``mv`` steps the plant once, so a runtime that reads PV,
computes and writes MV once per cycle sees exactly the sample sequence of
:func:`ctrlblocks.sim.simulate`.  A process with a second actuator (a split
range) steps once *both* ``mv`` and ``mv2`` have been written since the last
step, in either order (the runtime writes them in one batch per cycle, but
Modbus sends them as two requests in register order, OPC UA as one request).
``sync = "clock"``: the plant steps every ``ts`` of wall-clock time with the
last MVs written.

Not served: the simulator's ``initial.warmup`` (the plant starts in its steady
state; the runtime's blocks start from their own initial state) and events of
kind ``set`` (they act inside a controller).

Fault injection for tests (attributes of :class:`PlantServer`): ``delay``
(Modbus requests answered ``delay`` seconds late; a delay beyond the
client's timeout makes pymodbus's server answer out of step -- a request
sent after a timed-out one can get the earlier request's response, which
the runtime's adapter refuses and resets the connection for, as it would
for a real device doing so), ``force_nan`` (PV reads
NaN), ``reject_mv`` (Modbus MV writes refused; on OPC UA use
:meth:`PlantServer.set_mv_writable`), ``stale`` (OPC UA PV with a source
timestamp an hour old).
"""

from __future__ import annotations

import asyncio
import contextlib
import datetime as _dt
import logging
import math
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ..sim.plant_process import PlantProcess

__all__ = ["MODBUS_REGISTERS", "OUTPUT_TYPES", "SIGNALS", "PairServer", "PlantServer"]

log = logging.getLogger(__name__)

SIGNALS = (
    "pv", "mv", "sp", "mode", "manual_value", "u_min", "u_max", "k", "pv2", "dv", "mv2", "wild",
    "hb", "tripped",
)  # fmt: skip
"""Variables of the plant server, in register order."""

MODBUS_REGISTERS = {name: 2 * i for i, name in enumerate(SIGNALS)}
"""Holding register of each variable (FLOAT32 in two registers)."""

OUTPUT_TYPES = ("Double", "Float", "UInt16", "Boolean")
"""OPC UA data types of the device outputs (``PlantServer(outputs=...)``)."""

NAMESPACE = "urn:ctrlblocks:plant"


# ---------------------------------------------------------------------------
# The servers
# ---------------------------------------------------------------------------


class _PasswordUsers:
    """asyncua user manager: user/password, on an encrypted channel with a trusted certificate.

    asyncua (2.1) lets a client that skips the endpoint check activate a
    session over an unencrypted channel even when the server offers only
    SignAndEncrypt endpoints.  This manager therefore refuses every session
    whose secure channel carries no client certificate (no encryption) or an
    untrusted one, before it looks at the password.
    """

    def __init__(self, users: dict[str, str], trusted: set[str]) -> None:
        self.users = dict(users)
        self.trusted = trusted

    def get_user(self, iserver: Any, username=None, password=None, certificate=None):
        from asyncua.crypto.permission_rules import User, UserRole

        from .opcua import fingerprint

        if not certificate or fingerprint(bytes(certificate)) not in self.trusted:
            log.warning("refused a session without an encrypted, trusted channel")
            return None
        if username is not None and self.users.get(username) == password:
            return User(role=UserRole.User, name=username)
        return None


class PlantServer:
    """Serves a :class:`PlantProcess` over OPC UA and/or Modbus TCP (see the module docstring).

    Parameters
    ----------
    process : PlantProcess
        The simulated process.
    host : str
        Address to bind (default ``127.0.0.1``: loopback only).
    opcua_port, modbus_port : int or None
        Ports to serve on (None: that protocol is off; 0: any free port, see
        :attr:`opcua_url` / :attr:`modbus_port` after :meth:`start`).
    sync : str
        ``"write"`` (step on each MV write) or ``"clock"`` (step every ``ts``).
    float_signals : iterable of str
        OPC UA variables served as ``Float`` (FLOAT32) instead of ``Double``.
    word_order : str
        Modbus FLOAT32 word order, ``"big"`` or ``"little"``.
    certificate, private_key : path, optional
        OPC UA server certificate (DER) and key (PEM): with them the server
        offers only Basic256Sha256 SignAndEncrypt.
    trusted : iterable of paths
        Client certificates (files or directories) the server accepts;
        empty = none (never any certificate by default).
    users : dict, optional
        ``{user: password}``; required with security (no anonymous login).
    watchdog : float, optional
        Seconds without a new heartbeat value after which the server applies
        ``watchdog_mv`` (module docstring); None: no watchdog.
    watchdog_mv : float
        The plant's own safe MV while the watchdog is tripped.
    outputs : mapping or iterable of str
        Device outputs (module docstring): ``{name: OPC UA data type}`` (one
        of :data:`OUTPUT_TYPES`), or names (``Double``).  :attr:`outputs`
        maps each name to the list of the values written to it.
    """

    def __init__(
        self,
        process: PlantProcess,  # or any object with its ts, mv, values(), step(u), sensor_ok
        *,
        host: str = "127.0.0.1",
        opcua_port: int | None = 4840,
        modbus_port: int | None = 5020,
        sync: str = "write",
        float_signals: Iterable[str] = (),
        word_order: str = "big",
        certificate: str | Path | None = None,
        private_key: str | Path | None = None,
        trusted: Iterable[str | Path] = (),
        users: dict[str, str] | None = None,
        watchdog: float | None = None,
        watchdog_mv: float = 0.0,
        outputs: Mapping[str, str] | Iterable[str] = (),
    ) -> None:
        if sync not in ("write", "clock"):
            raise ValueError(f"sync must be 'write' or 'clock', got {sync!r}")
        if (certificate is None) != (private_key is None):
            raise ValueError("give both the server certificate and its private key")
        if certificate is not None and not users:
            raise ValueError("a secured server needs users (no anonymous login)")
        if watchdog is not None and not (math.isfinite(watchdog) and watchdog > 0):
            raise ValueError(f"the watchdog timeout must be seconds > 0, got {watchdog!r}")
        if not math.isfinite(watchdog_mv):
            raise ValueError(f"the watchdog's safe MV must be finite, got {watchdog_mv!r}")
        self.process = process
        self.host = host
        self.opcua_port = opcua_port
        self.modbus_port = modbus_port
        self.sync = sync
        self.float_signals = set(float_signals)
        unknown = self.float_signals - set(SIGNALS)
        if unknown:
            raise ValueError(f"unknown signals {sorted(unknown)}; signals: {SIGNALS}")
        self.word_order = word_order
        types = dict(outputs) if isinstance(outputs, Mapping) else dict.fromkeys(outputs, "Double")
        for name, vt in types.items():
            if name in SIGNALS or not name.isidentifier():
                raise ValueError(f"output {name!r}: a name of its own (not one of {SIGNALS})")
            if vt not in OUTPUT_TYPES:
                raise ValueError(f"output {name!r}: data type {vt!r} is not one of {OUTPUT_TYPES}")
        self.output_types = types
        self.outputs: dict[str, list[float]] = {name: [] for name in types}
        self.certificate, self.private_key = certificate, private_key
        self.trusted = list(trusted)
        self.users = dict(users or {})
        # fault injection
        self.delay = 0.0
        self.force_nan = False
        self.reject_mv = False
        self.stale = False
        self.mv_writes = 0
        # the MVs a lock-step sample waits for (a split range's process has two)
        two = bool(getattr(process, "second_actuator", False))
        self._mvs = frozenset(("mv", "mv2") if two else ("mv",))
        self._written: dict[str, float] = {}
        self._opcua: Any = None
        self._killed_opcua: Any = None
        self._modbus: Any = None
        self._clock_task: asyncio.Task[None] | None = None
        self.opcua_url = ""
        # the device watchdog (module docstring)
        self.watchdog, self.watchdog_mv = watchdog, float(watchdog_mv)
        self.hb = math.nan  # the last heartbeat value received
        self.tripped = False
        self.trips = 0  # times the watchdog tripped
        self.tripped_at: float | None = None  # loop time of the last trip
        self._hb_at = 0.0  # loop time of the last change of the heartbeat
        self._wd_task: asyncio.Task[None] | None = None

    # -- life cycle -------------------------------------------------------------------

    async def start(self) -> None:
        """Start the configured servers (and the plant clock with ``sync="clock"``).

        A port that is taken raises OSError naming it, before any server starts.
        """
        for port in (self.opcua_port, self.modbus_port):
            if port:
                _check_port(self.host, port)
        if self.opcua_port is not None:
            await self._start_opcua()
        if self.modbus_port is not None:
            await self._start_modbus()
        if self.sync == "clock":
            self._clock_task = asyncio.create_task(self._run_clock())
        if self.watchdog is not None:
            self._hb_at = asyncio.get_running_loop().time()
            self._wd_task = asyncio.create_task(self._run_watchdog())

    async def stop(self) -> None:
        """Stop every server (clients see the connection drop)."""
        for name in ("_clock_task", "_wd_task"):
            task = getattr(self, name)
            if task is not None:
                task.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await task
                setattr(self, name, None)
        await self.kill()
        self._killed_opcua = None

    async def kill(self) -> None:
        """Drop every client and stop serving, keeping the servers' objects (fault tests)."""
        if self._modbus is not None:
            await self._modbus.shutdown()
            self._modbus = None
        if self._opcua is not None:
            await self._opcua.stop()
            self._killed_opcua = self._opcua
            self._opcua = None

    async def revive(self) -> None:
        """Serve again on the same ports after :meth:`kill`."""
        if self._killed_opcua is not None:
            await self._killed_opcua.start()
            self._opcua, self._killed_opcua = self._killed_opcua, None
        if self.modbus_port is not None and self._modbus is None:
            await self._start_modbus()

    async def __aenter__(self) -> PlantServer:
        await self.start()
        return self

    async def __aexit__(self, *exc: Any) -> None:
        await self.stop()

    async def _run_clock(self) -> None:
        loop = asyncio.get_running_loop()
        t0 = loop.time()
        k = 0
        while True:
            k += 1
            await asyncio.sleep(max(0.0, t0 + k * self.process.ts - loop.time()))
            self.process.step(self.process.mv)

    # -- the device watchdog (module docstring) ------------------------------------------

    @property
    def heartbeat_at(self) -> float:
        """The event loop's time [s] of the last change of the heartbeat (the watchdog's start)."""
        return self._hb_at

    def _heartbeat(self, value: float) -> None:
        """A write of ``hb``: a new value feeds the watchdog (and releases a trip)."""
        if value == self.hb:
            return
        self.hb = value
        self._hb_at = asyncio.get_running_loop().time()
        if self.tripped:
            self.tripped = False
            log.warning("watchdog: the heartbeat is back; the runtime's MV writes apply again")

    async def _run_watchdog(self) -> None:
        assert self.watchdog is not None
        loop = asyncio.get_running_loop()
        poll = min(0.05, self.watchdog / 4.0)
        while True:
            await asyncio.sleep(poll)
            if not self.tripped and loop.time() - self._hb_at > self.watchdog:
                self.tripped, self.trips, self.tripped_at = True, self.trips + 1, loop.time()
                self._apply_safe_mv()
                log.warning(
                    "watchdog: no new heartbeat for %g s: the plant's safe MV %g applies",
                    self.watchdog, self.watchdog_mv,
                )  # fmt: skip

    def _apply_safe_mv(self) -> None:
        self.process.mv = self.watchdog_mv
        if "mv2" in self._mvs:
            self.process.mv2 = self.watchdog_mv
        self._written.clear()

    def _mv_written(self, u: float, name: str = "mv") -> None:
        """A write of ``mv`` (or ``mv2``): the lock-step sample steps once all MVs are in."""
        self.mv_writes += 1
        if self.tripped:  # the watchdog holds the safe MV; a lock-step sample goes on with it
            u = self.watchdog_mv
        if name == "mv2":
            self.process.mv2 = u  # held: PlantProcess.step applies the last one written
        if self.sync != "write":
            if name == "mv":
                self.process.mv = u
            return
        self._written[name] = u
        if self._mvs.issubset(self._written):
            self.process.step(self._written["mv"])
            self._written.clear()

    def _values(self) -> dict[str, float]:
        """The served values of the current sample (with the ``force_nan`` fault)."""
        v = self.process.values()
        for name in ("mv2", "wild", "pv2", "dv"):  # a process without them serves NaN
            v.setdefault(name, math.nan)
        v["hb"] = 0.0 if math.isnan(self.hb) else self.hb
        v["tripped"] = 1.0 if self.tripped else 0.0
        if self.force_nan:
            v["pv"] = math.nan
        return v

    def output_register(self, name: str) -> int:
        """The Modbus holding register of device output ``name`` (FLOAT32, two registers)."""
        return 2 * len(SIGNALS) + 2 * list(self.output_types).index(name)

    def _output_written(self, name: str, value: Any) -> None:
        try:
            self.outputs[name].append(float(value))
        except (TypeError, ValueError):
            return

    # -- OPC UA ----------------------------------------------------------------------------

    async def _start_opcua(self) -> None:
        try:
            from asyncua import Server, ua
        except ImportError as exc:  # pragma: no cover - depends on the install
            raise ImportError(
                "the OPC UA server needs asyncua: pip install 'ctrlblocks[runtime]'"
            ) from exc
        from .opcua import trust_list_validator

        secured = self.certificate is not None
        validator = trust_list_validator(self.trusted)
        users = _PasswordUsers(self.users, validator.fingerprints) if secured else None
        server = Server(user_manager=users)
        await server.init()
        port = self.opcua_port or _free_port(self.host)
        self.opcua_port = port
        self.opcua_url = f"opc.tcp://{self.host}:{port}/ctrlblocks/plant"
        server.set_endpoint(self.opcua_url)
        server.set_server_name("ctrlblocks plant server")
        if secured:
            for what, path, load in (
                ("certificate", self.certificate, server.load_certificate),
                ("private key", self.private_key, server.load_private_key),
            ):
                try:
                    await load(str(path))
                except (ValueError, TypeError) as exc:  # not DER/PEM, or the wrong kind
                    raise ValueError(
                        f"{path}: not an OPC UA server {what} (DER or PEM): {exc}".split(". ")[0]
                    ) from None
            server.set_security_policy([ua.SecurityPolicyType.Basic256Sha256_SignAndEncrypt])
            server.set_identity_tokens([ua.UserNameIdentityToken])
            server.set_certificate_validator(validator)
        else:
            server.set_security_policy([ua.SecurityPolicyType.NoSecurity])
        idx = await server.register_namespace(NAMESPACE)
        obj = await server.nodes.objects.add_object(idx, "Plant")
        for name in SIGNALS:
            vt = ua.VariantType.Float if name in self.float_signals else ua.VariantType.Double
            nodeid = ua.NodeId(name, idx)
            var = await obj.add_variable(nodeid, name, ua.Variant(self._values()[name], vt))
            if name in self._mvs or name == "hb":
                await var.set_writable(True)
                server.set_attribute_value_setter(nodeid, self._opcua_mv_setter(name))
            # every read serves the process's value (an MV: the one it applies)
            server.set_attribute_value_callback(nodeid, self._opcua_reader(name, vt))
        for name, tname in self.output_types.items():
            vt = getattr(ua.VariantType, tname)
            nodeid = ua.NodeId(name, idx)
            initial = False if tname == "Boolean" else 0
            var = await obj.add_variable(nodeid, name, ua.Variant(initial, vt))
            await var.set_writable(True)
            server.set_attribute_value_setter(nodeid, self._opcua_output_setter(name))
        await server.start()
        self._opcua = server

    def _opcua_reader(self, name: str, vt: Any) -> Any:
        from asyncua import ua

        def read(nodeid: Any, attr: Any) -> Any:
            now = _dt.datetime.now(_dt.timezone.utc)
            if name == "pv" and self.stale:
                now -= _dt.timedelta(hours=1)
            value = ua.Variant(self._values()[name], vt)
            if (name == "pv" and not self.process.sensor_ok) or (
                name == "pv2" and not self.process.sensor2_ok
            ):
                return ua.DataValue(
                    value,
                    StatusCode=ua.StatusCode(ua.StatusCodes.BadSensorFailure),
                    SourceTimestamp=now,
                )
            return ua.DataValue(value, SourceTimestamp=now)

        return read

    def _opcua_mv_setter(self, name: str) -> Any:
        def write(node: Any, attr: Any, value: Any) -> None:
            node.attributes[attr].value = value
            try:
                u = float(value.Value.Value)
            except (TypeError, ValueError, AttributeError):
                return
            if name == "hb":
                self._heartbeat(u)
            else:
                self._mv_written(u, name)

        return write

    def _opcua_output_setter(self, name: str) -> Any:
        def write(node: Any, attr: Any, value: Any) -> None:
            node.attributes[attr].value = value
            self._output_written(name, getattr(value.Value, "Value", None))

        return write

    async def set_mv_writable(self, writable: bool) -> None:
        """Make the OPC UA ``mv`` variable writable or not (a rejected write for tests)."""
        from asyncua import ua

        if self._opcua is None:
            return
        idx = await self._opcua.get_namespace_index(NAMESPACE)
        node = self._opcua.get_node(ua.NodeId("mv", idx))
        await node.set_writable(writable)

    # -- Modbus -----------------------------------------------------------------------------

    async def _start_modbus(self) -> None:
        count = 2 * (len(SIGNALS) + len(self.output_types))
        self.modbus_port, self._modbus = await _serve_registers(
            self.host, self.modbus_port, count, self._modbus_action
        )

    async def _modbus_action(
        self,
        function_code: int,
        start_address: int,
        address: int,
        count: int,
        registers: list[int],
        set_values: list[int] | list[bool] | None,
    ) -> Any:
        from pymodbus.constants import ExcCodes

        from .modbus import float32_to_registers, registers_to_float32

        if self.delay > 0.0:
            await asyncio.sleep(self.delay)
        written = None
        base = 2 * len(SIGNALS)
        if set_values and address >= base:  # device outputs: whole FLOAT32 pairs only
            names = list(self.output_types)
            pairs = [int(v) for v in set_values]
            if (
                (address - base) % 2
                or len(pairs) % 2
                or address + len(pairs) > base + 2 * len(names)
            ):
                return ExcCodes.ILLEGAL_ADDRESS
            first = (address - base) // 2
            for j in range(0, len(pairs), 2):
                u = registers_to_float32(pairs[j : j + 2], self.word_order)
                self._output_written(names[first + j // 2], u)
            return None
        if set_values:
            lo, hi = address, address + len(set_values)
            writable = (*self._mvs, "hb")
            written = next(
                (n for n in writable if lo == MODBUS_REGISTERS[n] and hi == lo + 2), None
            )
            if written is None:  # only an MV or the heartbeat (both registers) is writable
                return ExcCodes.ILLEGAL_ADDRESS
            u = registers_to_float32([int(v) for v in set_values], self.word_order)
            if written == "hb":
                self._heartbeat(u)
            elif self.reject_mv:
                return ExcCodes.ILLEGAL_VALUE
            else:
                self._mv_written(u, written)
        values = self._values()
        if not self.process.sensor_ok:
            values["pv"] = math.nan
        for name, reg in MODBUS_REGISTERS.items():
            if name == written:
                continue  # written by this request
            v = values[name]
            i = reg - start_address
            registers[i], registers[i + 1] = float32_to_registers(v, self.word_order)
        return None


class PairServer:
    """``n`` independent first-order plants served over OPC UA and/or Modbus TCP (scale tests).

    Plant ``i``: ``y[k+1] = a y[k] + (1 - a) u[k]``, stepped on each write of
    its MV (lock-step, like ``PlantServer(sync="write")``).  OPC UA
    ``ns=2;s=pv{i}``, ``ns=2;s=mv{i}`` (Double) and ``ns=2;s=hb`` (a writable
    heartbeat); Modbus FLOAT32 holding registers ``pv{i}`` at ``2 i`` (the PVs
    are contiguous: a batched read takes 62 per request), ``mv{i}`` at
    ``2 n + 2 i``, the heartbeat at ``4 n``.  Bound to
    ``127.0.0.1`` by default.  ``heartbeats`` lists the heartbeat values
    written, ``writes`` counts the MV writes.  ``push=True`` stores each new PV
    in the OPC UA address space on the MV write instead of computing it on read,
    so that subscriptions see the change (the read-vs-subscription benchmark).
    """

    def __init__(
        self,
        n: int,
        *,
        a: float = 0.9,
        host: str = "127.0.0.1",
        opcua_port: int | None = 0,
        modbus_port: int | None = None,
        push: bool = False,
    ) -> None:
        self.n, self.a, self.host, self.push = n, a, host, push
        self.pv = [0.0] * n
        self.mv = [0.0] * n
        self.writes = 0
        self.heartbeats: list[float] = []
        self.opcua_port, self.modbus_port = opcua_port, modbus_port
        self.opcua_url = ""
        self._opcua: Any = None
        self._modbus: Any = None

    def _write(self, i: int, u: float) -> None:
        self.writes += 1
        self.mv[i] = u
        if math.isfinite(u):
            self.pv[i] = self.a * self.pv[i] + (1.0 - self.a) * u

    async def start(self) -> None:
        """Start the configured servers."""
        if self.opcua_port is not None:
            await self._start_opcua()
        if self.modbus_port is not None:
            await self._start_modbus()

    async def stop(self) -> None:
        """Stop the servers."""
        if self._modbus is not None:
            await self._modbus.shutdown()
            self._modbus = None
        if self._opcua is not None:
            await self._opcua.stop()
            self._opcua = None

    async def _start_opcua(self) -> None:
        from asyncua import Server, ua

        server = Server()
        await server.init()
        port = self.opcua_port or _free_port(self.host)
        self.opcua_port = port
        self.opcua_url = f"opc.tcp://{self.host}:{port}/ctrlblocks/pairs"
        server.set_endpoint(self.opcua_url)
        server.set_security_policy([ua.SecurityPolicyType.NoSecurity])
        idx = await server.register_namespace(NAMESPACE)
        obj = await server.nodes.objects.add_object(idx, "Pairs")

        def reader(i: int) -> Any:
            return lambda nodeid, attr: ua.DataValue(
                ua.Variant(self.pv[i], ua.VariantType.Double),
                SourceTimestamp=_dt.datetime.now(_dt.timezone.utc),
            )

        pv_ids = [ua.NodeId(f"pv{i}", idx) for i in range(self.n)]
        pushes: set[asyncio.Task[None]] = set()

        def setter(i: int | None) -> Any:
            def set_value(node: Any, attr: Any, value: Any) -> None:
                node.attributes[attr].value = value
                u = float(value.Value.Value)
                if i is None:
                    self.heartbeats.append(u)
                    return
                self._write(i, u)
                if self.push:  # into the address space: subscriptions see it
                    dv = ua.DataValue(ua.Variant(self.pv[i], ua.VariantType.Double))
                    task = asyncio.get_running_loop().create_task(
                        server.write_attribute_value(pv_ids[i], dv)
                    )
                    pushes.add(task)
                    task.add_done_callback(pushes.discard)

            return set_value

        for i, pv in enumerate(pv_ids):
            await obj.add_variable(pv, f"pv{i}", ua.Variant(0.0, ua.VariantType.Double))
            if not self.push:
                server.set_attribute_value_callback(pv, reader(i))
        for name, i in [*((f"mv{i}", i) for i in range(self.n)), ("hb", None)]:
            nid = ua.NodeId(name, idx)
            var = await obj.add_variable(nid, name, ua.Variant(0.0, ua.VariantType.Double))
            await var.set_writable(True)
            server.set_attribute_value_setter(nid, setter(i))
        await server.start()
        self._opcua = server

    async def _start_modbus(self) -> None:
        self.modbus_port, self._modbus = await _serve_registers(
            self.host, self.modbus_port, 4 * self.n + 2, self._modbus_action
        )

    async def _modbus_action(
        self,
        function_code: int,
        start_address: int,
        address: int,
        count: int,
        registers: list[int],
        set_values: list[int] | list[bool] | None,
    ) -> Any:
        from .modbus import float32_to_registers, registers_to_float32

        if set_values:
            vals = [int(v) for v in set_values]
            for j in range(0, len(vals) - 1, 2):
                reg = address + j
                u = registers_to_float32(vals[j : j + 2])
                if reg == 4 * self.n:
                    self.heartbeats.append(u)
                elif 2 * self.n <= reg < 4 * self.n:
                    self._write((reg - 2 * self.n) // 2, u)
            return None
        for i in range(self.n):
            r = 2 * i - start_address
            registers[r], registers[r + 1] = float32_to_registers(self.pv[i])
        return None


async def _serve_registers(host: str, port: int | None, count: int, action: Any) -> tuple[int, Any]:
    """A Modbus TCP server of ``count`` holding registers whose requests go to ``action``.

    Returns the port (a free one for ``port`` 0 or None) and the running server.
    """
    try:
        from pymodbus.server import ModbusTcpServer
        from pymodbus.simulator import DataType, SimData, SimDevice
    except ImportError as exc:  # pragma: no cover
        raise ImportError(
            "the Modbus server needs pymodbus: pip install 'ctrlblocks[runtime]'"
        ) from exc
    device = SimDevice(
        id=0,
        simdata=[SimData(0, count=count, values=0, datatype=DataType.REGISTERS)],
        action=action,
    )
    port = port or _free_port(host)
    server = ModbusTcpServer(device, address=(host, port))
    await server.serve_forever(background=True)
    return port, server


def _check_port(host: str, port: int) -> None:
    """Raise OSError when ``host:port`` cannot be bound (taken, or not an address here)."""
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((host, port))
        except OSError as exc:
            raise OSError(exc.errno, f"{host}:{port}: {exc.strerror}") from None


def _free_port(host: str) -> int:
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])
