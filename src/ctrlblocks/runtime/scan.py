"""The I/O image of one cycle, as a PLC scans it: read, compute, write -- with deadlines.

A :class:`Scan` serves the loops that are due together: the loops of one
sample time that share connections (:func:`scan_groups`: loops on different
connections are in different scans, each on its own task and deadlines, so a
slow or dead device only delays the loops that use it).  Each cycle:

1. **inputs** -- one batched read per connection of every address the loops
   need (an address two loops read is read once; on the first cycle, after a
   reconnection or a long hold also the MVs, read back for a bumpless start);
   the read runs as its own task, at most one per connection and scan.  The
   cycle waits for it until the connection's **input deadline** (``deadline``
   of the connection, default half the cycle); a read that is not back by then
   is *late*: its loops hold (or run on their last good inputs, ``on_late``),
   the read goes on, and its result is the next cycle's input (no new read is
   sent while it is pending or unused);
2. **compute** -- every loop's :meth:`~ctrlblocks.runtime.loop.ControlLoop.cycle`
   on that image (no I/O);
3. **outputs** -- one batched write per connection of every MV (a split-range
   loop's two, :meth:`~ctrlblocks.runtime.loop.ControlLoop.writes`, and the
   connection's heartbeat, :class:`Heartbeat`); failed items are retried at
   once, as often as their loop's ``write_retries`` allow, in one request;
   a loop's write fails when one of its items does.

The connection serialises the requests of all scans that use it and its
``timeout`` measures each one on the wire
(:class:`~ctrlblocks.runtime.io.Connection`).
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from .io import Connection, Reading, bad
from .loop import ControlLoop, Sample

__all__ = ["Heartbeat", "Scan", "scan_groups"]

log = logging.getLogger(__name__)


class Heartbeat:
    """A counter written to the device every cycle, so the device can detect a dead runtime.

    The value counts 1, 2, ..., ``maximum``, then 0, 1, ... (one step per
    cycle of the fastest loops on the connection); a device that sees it
    unchanged for longer than its timeout goes to its own safe state
    (docs/runtime.md, "Device watchdog"; the plant server's ``--watchdog``).
    """

    def __init__(self, address: str, maximum: int = 65535) -> None:
        self.address = address
        self.maximum = maximum
        self.value = 0
        self.error = ""

    def next(self) -> float:
        """The value to write this cycle."""
        self.value = 0 if self.value >= self.maximum else self.value + 1
        return float(self.value)

    def written(self, err: str | None, connection: str) -> None:
        """Log a failed heartbeat write once per episode."""
        if err is not None and err != self.error:
            log.warning("connection %s: heartbeat write failed: %s", connection, err)
        self.error = err or ""


def scan_groups(loops: Iterable[ControlLoop]) -> list[list[ControlLoop]]:
    """The loops split into groups that share no connection (each group one :class:`Scan`).

    Loops of one sample time that use a common connection (directly or
    through a third loop) are one group, in configuration order.
    """
    loops = list(loops)
    parent = list(range(len(loops)))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    first: dict[str, int] = {}
    for i, lp in enumerate(loops):
        for c in sorted(lp.config.connections()):
            j = first.setdefault(c, i)
            parent[root(i)] = root(j)
    groups: dict[int, list[ControlLoop]] = {}
    for i, lp in enumerate(loops):
        groups.setdefault(root(i), []).append(lp)
    return list(groups.values())


class _Input:
    """One connection's input side of a scan: the read in flight and the last image."""

    __slots__ = ("addresses", "back", "done_at", "image", "new", "ready", "task")

    def __init__(self, addresses: list[str]) -> None:
        self.addresses = addresses
        self.task: asyncio.Task[list[Reading]] | None = None
        self.back: list[tuple[ControlLoop, int]] = []  # read-backs of the read in flight
        self.image: list[Reading] | None = None  # the last completed read (its addresses)
        self.new = False  # completed and not yet used by a cycle
        self.ready = 0.0  # the first cycle time that may use it
        self.done_at = 0.0


class Scan:
    """The batched cycle of ``loops`` over ``connections`` (see the module docstring).

    Parameters
    ----------
    loops : sequence of ControlLoop
        The loops due together.
    connections : mapping
        Connection name -> :class:`~ctrlblocks.runtime.io.Connection`.
    heartbeats : mapping, optional
        Connection name -> :class:`Heartbeat` written with this scan's outputs.
    clock : Clock, optional
        The scheduler's clock (the input deadlines); without one a read is
        waited for until it ends.
    ts : float, optional
        The loops' sample time [s] (default the first loop's): the default
        input deadline is ``ts / 2``.
    """

    def __init__(
        self,
        loops: Sequence[ControlLoop],
        connections: Mapping[str, Connection],
        heartbeats: Mapping[str, Heartbeat] | None = None,
        *,
        clock: Any = None,
        ts: float | None = None,
    ) -> None:
        self.loops = list(loops)
        self.connections = connections
        self.heartbeats = dict(heartbeats or {})
        self.clock = clock
        self.ts = ts if ts is not None else (self.loops[0].ts if self.loops else 0.1)
        # connection -> the addresses to read (each once), and per loop: signal -> (conn, index)
        self.reads: dict[str, list[str]] = {}
        index: dict[tuple[str, str], int] = {}
        self._where: list[dict[str, tuple[str, int]]] = []
        for lp in self.loops:
            w = {}
            for sig, b in lp.inputs().items():
                conn = b.connection or ""
                k = (conn, b.address)
                if k not in index:
                    addrs = self.reads.setdefault(conn, [])
                    index[k] = len(addrs)
                    addrs.append(b.address)
                w[sig] = (conn, index[k])
            self._where.append(w)
        # every MV's connection too: the MVs are read back from it at a (re)start
        for lp in self.loops:
            if lp.config.mv.connection is not None:
                self.reads.setdefault(lp.config.mv.connection, [])
        self._in = {c: _Input(a) for c, a in self.reads.items()}
        self._reconnects = {
            n: self.connections[n].reconnects for n in self._used() if n in self.connections
        }
        self.late_reads = 0  # reads not back by their deadline (all connections)

    def _used(self) -> set[str]:
        return {c for lp in self.loops for c in lp.config.connections()} | set(self.heartbeats)

    # -- inputs ------------------------------------------------------------------------

    def deadline(self, conn_name: str) -> float:
        """How long a cycle waits for ``conn_name``'s inputs [s] (``deadline``, else ts/2)."""
        conn = self.connections.get(conn_name)
        d = conn.config.deadline if conn is not None else None
        return d if d is not None else 0.5 * self.ts

    async def _read(self, conn_name: str, addresses: list[str]) -> list[Reading]:
        conn = self.connections.get(conn_name)
        if conn is None:
            res = [bad(f"no connection {conn_name!r}")] * len(addresses)
        else:
            res = await conn.read(addresses)
        inp = self._in[conn_name]
        inp.done_at = self.clock.now() if self.clock is not None else 0.0
        return res

    def _watch_reconnects(self) -> None:
        """A connection that (re)connected since the last cycle: its loops start bumplessly."""
        for name, seen in self._reconnects.items():
            conn = self.connections[name]
            if conn.connected and conn.reconnects != seen:
                for lp in self.loops:
                    if name in lp.config.connections():
                        lp.resync("reconnect")
                self._reconnects[name] = conn.reconnects

    def _start_reads(self) -> None:
        for name, inp in self._in.items():
            if inp.task is not None or inp.new:
                continue  # one read at a time; an unused result is this cycle's input
            addresses = list(inp.addresses)
            inp.back = []
            for lp in self.loops:
                mv = lp.readback_address()
                if mv is not None and lp.config.mv.connection == name:
                    inp.back.append((lp, len(addresses)))
                    addresses.append(mv)
            if addresses:
                inp.task = asyncio.ensure_future(self._read(name, addresses))

    async def _wait_inputs(self, t: float) -> set[str]:
        """Wait for the reads until their deadlines; the connections whose inputs are in.

        A read that came back after its deadline (on the clock) is kept, unused,
        for the next cycle, as is one that is still on its way.
        """
        pending = sorted((t + self.deadline(n), n) for n, i in self._in.items() if i.task)
        for due, name in pending:
            task = self._in[name].task
            assert task is not None
            if not task.done():
                await self._until(task, due)
        for due, name in pending:
            inp = self._in[name]
            task = inp.task
            assert task is not None
            if not task.done():
                self.late_reads += 1
                continue
            if task.cancelled():  # the runtime stops: this cycle holds
                inp.task, inp.back = None, []
                continue
            res = task.result()
            inp.image, inp.new, inp.task = res[: len(inp.addresses)], True, None
            for lp, i in inp.back:
                lp.read_back(res[i])
            inp.back = []
            inp.ready = t
            if self.clock is not None and inp.done_at > due + 1e-9:
                self.late_reads += 1
                inp.ready = due + 1e-9  # from the next cycle on
        return {n for n, i in self._in.items() if i.new and i.ready <= t}

    async def _until(self, task: asyncio.Future[Any], t: float) -> None:
        """Wait for ``task`` until ``t`` on the scheduler's clock (for ever without a clock)."""
        if self.clock is None:
            await asyncio.wait({task})
            return
        sleeper = asyncio.ensure_future(self.clock.sleep_until(t))
        try:
            await asyncio.wait({task, sleeper}, return_when=asyncio.FIRST_COMPLETED)
        finally:
            sleeper.cancel()

    # -- the cycle -----------------------------------------------------------------------

    async def run(self, t: float, period: float) -> list[Sample]:
        """One cycle at time ``t`` [s] after a measured ``period`` [s]; the loops' samples."""
        self._watch_reconnects()
        self._start_reads()
        fresh = await self._wait_inputs(t)
        # a device that came back during this cycle (after _watch_reconnects): its read
        # carried no MV read-back, so its loops hold this cycle; the next one resyncs them
        # and starts from the device's MV (a loop that cycled on the fresh PV from its safe
        # value recorded that value though nothing was written -- loopback, under load)
        back = {n for n, seen in self._reconnects.items()
                if self.connections[n].reconnects != seen}  # fmt: skip
        outputs: dict[str, list[tuple[ControlLoop, float]]] = {}
        for lp, where in zip(self.loops, self._where, strict=True):
            if back and back & set(lp.config.connections()):
                continue
            conns = {c for c, _ in where.values()}
            on_time = conns <= fresh
            inputs: dict[str, Reading] | None = None
            if on_time or lp.config.on_late == "last_good":
                images = {c: self._in[c].image for c in conns}
                if all(img is not None for img in images.values()):
                    inputs = {sig: images[c][i] for sig, (c, i) in where.items()}  # type: ignore[index]
            u = lp.cycle(t, period, inputs, late=not on_time)
            if u is not None:  # None: held, or the cycle failed (nothing to write)
                outputs.setdefault(lp.config.mv.connection or "", []).append((lp, u))
        for name in fresh:
            self._in[name].new = False
        await asyncio.gather(
            *(self._write(n, outputs.get(n, [])) for n in set(outputs) | set(self.heartbeats))
        )
        # a loop that has not had its first inputs yet has nothing to record
        return [lp.sample(t) for lp in self.loops if lp.has_inputs]

    async def _write(self, conn_name: str, items: list[tuple[ControlLoop, float]]) -> None:
        """One batched write of the MVs (and the heartbeat); failed items retried together."""
        conn = self.connections.get(conn_name)
        if conn is None:
            for lp, _ in items:
                lp.written(f"no connection {conn_name!r}")
            return
        if conn.reconnects != self._reconnects.get(conn_name, conn.reconnects):
            # the device came back during this cycle: its loops' MVs were computed without
            # it (a safe value, a held MV); the next cycle reads its MV back and starts
            # from it, so nothing is written over the MV it holds (issue 36, point 3)
            items = []
        hb = self.heartbeats.get(conn_name)
        batch: list[tuple[ControlLoop | None, str, float]] = [
            (lp, a, v) for lp, u in items for a, v in lp.writes(u)
        ]
        if hb is not None:
            batch.append((None, hb.address, hb.next()))
        attempt = 0
        outcome: dict[ControlLoop, str | None] = {}  # a loop's first failure, else None
        while batch:
            res = await conn.write([(a, v) for _, a, v in batch])
            attempt += 1
            again = []
            for (lp, a, v), err in zip(batch, res, strict=True):
                if lp is None:
                    hb.written(err, conn_name)  # type: ignore[union-attr]
                elif err is None or attempt > lp.config.write_retries:
                    outcome[lp] = outcome.get(lp) or err
                else:
                    again.append((lp, a, v))
            batch = again
        for lp, err in outcome.items():
            lp.written(err)

    def cancel_reads(self) -> None:
        """Cancel the reads in flight (the runtime's stop: a late read must not hold it up)."""
        for inp in self._in.values():
            if inp.task is not None and not inp.task.done():
                inp.task.cancel()
