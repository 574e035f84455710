"""Process I/O behind one small interface, and the connection supervisor.

An :class:`Adapter` speaks one protocol: ``connect``, ``close``, ``read``
a list of addresses (a :class:`Reading` per address: value and quality) and
``write`` a list of ``(address, value)`` pairs (``None`` per accepted item, or
the reason it was rejected).  A connection-level failure raises
:class:`IOFault`.  Adapters: :class:`MemoryAdapter` (tests),
:class:`~ctrlblocks.runtime.opcua.OpcUaAdapter`,
:class:`~ctrlblocks.runtime.modbus.ModbusAdapter`.

A :class:`Connection` supervises one adapter for the loops:

* requests go one at a time (a lock); the connection's ``timeout`` bounds the
  request *on the wire*, from the moment it is sent, never the time spent
  waiting for the lock behind another request; a read that fails or times
  out returns bad readings (``ok`` false) *in the same call*, so the loop sets
  ``y_ok`` false in the cycle where the fault happens;
* connecting is bounded by ``connect_timeout`` (a session set-up takes
  several round trips: it is not held to the per-request ``timeout``);
* a non-finite value is never written: :meth:`Connection.write` refuses it
  per item (the loops replace a non-finite MV by their safe value before);
* a connection-level error drops the connection and a background task
  reconnects with exponential back-off (``reconnect_min`` doubling up to
  ``reconnect_max``); while it is down, reads return at once with bad
  quality, so other loops' cycles are not delayed;
* three read (or three write) timeouts in a row count as a lost connection.
"""

from __future__ import annotations

import abc
import asyncio
import contextlib
import dataclasses
import logging
import math
from collections.abc import Callable, Sequence
from typing import Any

from .config import ConnectionConfig

__all__ = ["Adapter", "Connection", "IOFault", "MemoryAdapter", "MemoryBus", "Reading", "describe"]

log = logging.getLogger(__name__)


class IOFault(Exception):
    """A connection-level I/O failure (connection lost or refused, protocol error)."""


@dataclasses.dataclass(frozen=True)
class Reading:
    """One value read from the process, with its quality.

    ``ok`` is false for a failed, timed-out, stale, non-finite or bad-quality
    read; ``reason`` says which.
    """

    value: float
    ok: bool
    reason: str = ""


def describe(exc: BaseException) -> str:
    """The message of ``exc``, or its type name when it has none (a bare ``TimeoutError``)."""
    return str(exc) or type(exc).__name__


def bad(reason: str) -> Reading:
    """A bad-quality reading."""
    return Reading(math.nan, False, reason)


def checked(value: Any, reason_if_bad: str = "") -> Reading:
    """A reading of ``value``: good if it is a finite number, else bad ("not finite")."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        return bad(reason_if_bad or f"not a number: {value!r}")
    if not math.isfinite(x):
        return Reading(x, False, "not finite")
    return Reading(x, True)


class Adapter(abc.ABC):
    """One protocol client (see the module docstring)."""

    requests: dict[str, int]
    """Requests sent on the wire, by kind (``"read"``, ``"write"``): a test counts them."""

    def count(self, kind: str, n: int = 1) -> None:
        """Count ``n`` requests of ``kind`` sent on the wire."""
        if not hasattr(self, "requests"):
            self.requests = {"read": 0, "write": 0}
        self.requests[kind] = self.requests.get(kind, 0) + n

    @abc.abstractmethod
    async def connect(self) -> None:
        """Open the connection; raise :class:`IOFault` (or OSError) on failure."""

    @abc.abstractmethod
    async def close(self) -> None:
        """Close the connection (never raises)."""

    @abc.abstractmethod
    async def read(self, addresses: Sequence[str]) -> list[Reading]:
        """Read ``addresses`` in one request where the protocol allows it."""

    @abc.abstractmethod
    async def write(self, items: Sequence[tuple[str, float]]) -> list[str | None]:
        """Write the values; per item ``None`` (accepted) or the reason it was rejected."""


# ---------------------------------------------------------------------------
# The connection supervisor
# ---------------------------------------------------------------------------


class Connection:
    """An adapter with timeouts, fault detection and reconnection with back-off.

    Parameters
    ----------
    config : ConnectionConfig
        ``timeout`` [s] per call, ``reconnect_min``/``reconnect_max`` [s].
    adapter : Adapter
        The protocol client.
    sleep : callable, optional
        ``async sleep(seconds)`` for the back-off (the scheduler's clock).
    """

    MAX_TIMEOUTS = 3

    def __init__(
        self,
        config: ConnectionConfig,
        adapter: Adapter,
        sleep: Callable[[float], Any] | None = None,
    ) -> None:
        self.config = config
        self.name = config.name
        self.adapter = adapter
        self._sleep = sleep or asyncio.sleep
        self.connected = False
        self.last_error = ""
        self.reconnects = 0
        self._timeouts = {"read": 0, "write": 0}
        self._task: asyncio.Task[None] | None = None
        self._closing = False
        self._lock = asyncio.Lock()

    # -- life cycle ----------------------------------------------------------

    async def start(self) -> None:
        """Try to connect once; on failure the back-off task keeps trying."""
        try:
            await self._connect_once()
        except Exception as exc:  # any failure means "not connected yet"
            self._lost(exc)

    async def _connect_once(self) -> None:
        await asyncio.wait_for(self.adapter.connect(), self.config.connect_timeout)
        self.connected = True
        self._timeouts = {"read": 0, "write": 0}
        log.info("connection %s: connected", self.name)

    def _lost(self, exc: BaseException | str) -> None:
        msg = exc if isinstance(exc, str) else describe(exc)
        if self.connected:
            log.warning("connection %s lost: %s", self.name, msg)
        self.connected = False
        self.last_error = msg
        if not self._closing and (self._task is None or self._task.done()):
            self._task = asyncio.get_running_loop().create_task(self._reconnect())

    async def _reconnect(self) -> None:
        delay = self.config.reconnect_min
        with_close = True
        while not self._closing and not self.connected:
            if with_close:
                await self._close_adapter()
            await self._sleep(delay)
            if self._closing:
                return
            try:
                await self._connect_once()
                self.reconnects += 1
                return
            except Exception as exc:
                self.last_error = describe(exc)
                log.debug("connection %s: reconnect failed: %s", self.name, self.last_error)
                delay = min(2.0 * delay, self.config.reconnect_max)

    async def _close_adapter(self) -> None:
        try:
            await asyncio.wait_for(self.adapter.close(), 2.0)
        except Exception:  # closing a broken connection may fail
            log.debug("connection %s: close failed", self.name, exc_info=True)

    async def close(self) -> None:
        """Stop reconnecting and close the adapter."""
        self._closing = True
        if self._task is not None and not self._task.done():
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await self._task
        await self._close_adapter()
        self.connected = False

    # -- I/O -------------------------------------------------------------------

    def _timed_out(self, kind: str) -> bool:
        """Count a timeout; True when ``MAX_TIMEOUTS`` of this kind came in a row."""
        self._timeouts[kind] += 1
        return self._timeouts[kind] >= self.MAX_TIMEOUTS

    async def _request(
        self, kind: str, fn: Callable[[Any], Any], arg: Any, timeout: float | None = None
    ) -> tuple[Any, str]:
        """``fn(arg)`` under the lock, then the timeout: ``(result, "")`` or ``(None, failure)``.

        The timeout (default the connection's ``timeout``) starts when the lock
        is held, so it measures the request on the wire, not the wait behind
        other requests.  A timeout is counted (``MAX_TIMEOUTS`` in a row drop
        the connection); any other exception is a connection fault (the
        connection is dropped and reconnects in the background).
        """
        async with self._lock:  # one request at a time per connection
            if not self.connected:  # dropped while this request waited
                return None, f"not connected ({self.last_error})"
            return await self._timed(kind, fn, arg, timeout or self.config.timeout)

    async def _timed(
        self, kind: str, fn: Callable[[Any], Any], arg: Any, timeout: float
    ) -> tuple[Any, str]:
        try:
            res = await asyncio.wait_for(fn(arg), timeout)
        except asyncio.TimeoutError:
            if self._timed_out(kind):
                self._lost(f"{self.MAX_TIMEOUTS} {kind} timeouts in a row")
            return None, f"{kind} timeout"
        except Exception as exc:  # any protocol failure is a connection fault
            self._lost(exc)
            return None, f"{kind} failed: {describe(exc)}"
        self._timeouts[kind] = 0
        return res, ""

    async def read(self, addresses: Sequence[str]) -> list[Reading]:
        """Read ``addresses``; never raises (faults give bad readings)."""
        if not self.connected:
            return [bad(f"not connected ({self.last_error})")] * len(addresses)
        out, failure = await self._request("read", self.adapter.read, addresses)
        return [bad(failure)] * len(addresses) if failure else out

    async def write(
        self, items: Sequence[tuple[str, float]], timeout: float | None = None
    ) -> list[str | None]:
        """Write the values; never raises (per item: None or the failure).

        A non-finite value is refused here ("not finite: not written") and
        never reaches the adapter.  ``timeout`` [s] replaces the connection's
        (the final write of the stop values has its own).
        """
        res: list[str | None] = [None] * len(items)
        send: list[tuple[str, float]] = []
        where: list[int] = []
        for i, (a, v) in enumerate(items):
            if not (isinstance(v, (int, float)) and math.isfinite(v)):
                res[i] = f"{a}: {v!r} is not finite: not written"
            else:
                send.append((a, float(v)))
                where.append(i)
        if not send:
            return res
        if not self.connected:
            out: Any = None
            failure = f"not connected ({self.last_error})"
        else:
            out, failure = await self._request("write", self.adapter.write, send, timeout)
        for j, i in enumerate(where):
            res[i] = failure if failure else out[j]
        return res

    async def connect_now(self, timeout: float) -> bool:
        """One connection attempt now, bounded by ``timeout`` [s] (the stop uses it).

        Replaces the background reconnection's wait; True when connected.
        """
        if self.connected:
            return True
        if self._task is not None and not self._task.done():
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await self._task
        try:
            await asyncio.wait_for(self._connect_once(), timeout)
        except Exception as exc:  # still not connected
            self.last_error = describe(exc)
            return False
        self.reconnects += 1
        return True


# ---------------------------------------------------------------------------
# In-memory I/O (tests, demos)
# ---------------------------------------------------------------------------


class MemoryBus:
    """A shared table of process values with fault injection, for :class:`MemoryAdapter`.

    Attributes (set them from a test)
    ---------------------------------
    values : dict
        Address -> value.  Reading a missing address gives a bad reading.
    bad : set
        Addresses whose quality is bad (stale, sensor fault).
    reject : set
        Addresses whose writes are rejected.
    down : bool
        The "server" is unreachable: connect and every call raise :class:`IOFault`.
    on_write : callable or None
        Called as ``on_write(address, value)`` after each accepted write (a
        test plant steps here).
    on_read : callable or None
        Called before each read (a test advances a :class:`FakeClock` here to
        make a read slow).
    """

    def __init__(self, values: dict[str, float] | None = None) -> None:
        self.values: dict[str, float] = dict(values or {})
        self.bad: set[str] = set()
        self.reject: set[str] = set()
        self.down = False
        self.on_write: Callable[[str, float], None] | None = None
        self.on_read: Callable[[], Any] | None = None
        self.writes: list[tuple[str, float]] = []


class MemoryAdapter(Adapter):
    """In-memory process I/O on a :class:`MemoryBus`."""

    def __init__(self, bus: MemoryBus | None = None) -> None:
        self.bus = bus if bus is not None else MemoryBus()
        self.open = False

    @classmethod
    def from_config(cls, config: ConnectionConfig) -> MemoryAdapter:
        """An adapter on a bus of its own (the ``memory`` protocol of a configuration)."""
        return cls()

    async def connect(self) -> None:
        if self.bus.down:
            raise IOFault("memory bus is down")
        self.open = True

    async def close(self) -> None:
        self.open = False

    def _check(self) -> None:
        if self.bus.down or not self.open:
            self.open = False
            raise IOFault("memory bus is down")

    async def read(self, addresses: Sequence[str]) -> list[Reading]:
        self._check()
        self.count("read")
        if self.bus.on_read is not None:
            r = self.bus.on_read()
            if asyncio.iscoroutine(r):
                await r
        out = []
        for a in addresses:
            if a not in self.bus.values:
                out.append(bad(f"unknown address {a!r}"))
            elif a in self.bus.bad:
                out.append(Reading(self.bus.values[a], False, "bad quality"))
            else:
                out.append(checked(self.bus.values[a]))
        return out

    async def write(self, items: Sequence[tuple[str, float]]) -> list[str | None]:
        self._check()
        self.count("write")
        res: list[str | None] = []
        for a, v in items:
            if a in self.bus.reject:
                res.append("write rejected")
                continue
            self.bus.values[a] = v
            self.bus.writes.append((a, v))
            if self.bus.on_write is not None:
                self.bus.on_write(a, v)
            res.append(None)
        return res

