"""The I/O image of one cycle, as a PLC scans: read everything, compute, write everything.

A :class:`Scan` serves the loops that are due together (the loops of one
sample time).  Each cycle:

1. **inputs** -- one batched read per connection of every address the loops
   need (an address two loops read is read once); the adapters send it as
   one OPC UA Read service call (chunked to the server's ``MaxNodesPerRead``)
   or as coalesced Modbus register ranges;
2. **compute** -- every loop's :meth:`~ctrlblocks.runtime.loop.ControlLoop.compute`
   on that image (no I/O: a slow loop cannot delay another one's request);
3. **outputs** -- one batched write per connection of every MV (a split-range
   loop's two, :meth:`~ctrlblocks.runtime.loop.ControlLoop.writes`, and the
   connection's heartbeat, :class:`Heartbeat`); failed items are retried at
   once, as often as their loop's ``write_retries`` allow, in one request;
   a loop's write fails when one of its items does.

Loops with another sample time have their own :class:`Scan` on their own
deadlines; the connection serialises the requests and its timeout measures
each one on the wire (:class:`~ctrlblocks.runtime.io.Connection`).
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Mapping, Sequence

from .io import Connection, Reading, bad
from .loop import ControlLoop, Sample

__all__ = ["Heartbeat", "Scan"]

log = logging.getLogger(__name__)


class Heartbeat:
    """A counter written to the device every cycle, so the device can detect a dead runtime.

    The value counts 1, 2, ..., ``maximum``, then 0, 1, ... (one step per
    cycle of the fastest loops on the connection); a device that sees it
    unchanged for longer than a few cycles goes to its own safe state
    (docs/runtime.md shows the PLC side).
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
    """

    def __init__(
        self,
        loops: Sequence[ControlLoop],
        connections: Mapping[str, Connection],
        heartbeats: Mapping[str, Heartbeat] | None = None,
    ) -> None:
        self.loops = list(loops)
        self.connections = connections
        self.heartbeats = dict(heartbeats or {})
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

    async def _read(self, conn_name: str, addresses: list[str]) -> list[Reading]:
        conn = self.connections.get(conn_name)
        if conn is None:
            return [bad(f"no connection {conn_name!r}")] * len(addresses)
        return await conn.read(addresses)

    async def run(self, t: float, period: float) -> list[Sample]:
        """One cycle at time ``t`` [s] after a measured ``period`` [s]; the loops' samples."""
        names = list(self.reads)
        read = await asyncio.gather(*(self._read(n, self.reads[n]) for n in names))
        images = dict(zip(names, read, strict=True))
        # compute every loop on the image
        outputs: dict[str, list[tuple[ControlLoop, float]]] = {}
        for lp, where in zip(self.loops, self._where, strict=True):
            inputs = {sig: images[c][i] for sig, (c, i) in where.items()}
            u = lp.compute(t, period, inputs)
            if u is None:  # the cycle failed: nothing to write
                continue
            outputs.setdefault(lp.config.mv.connection or "", []).append((lp, u))
        await asyncio.gather(
            *(self._write(n, outputs.get(n, [])) for n in set(outputs) | set(self.heartbeats))
        )
        return [lp.sample(t) for lp in self.loops]

    async def _write(self, conn_name: str, items: list[tuple[ControlLoop, float]]) -> None:
        """One batched write of the MVs (and the heartbeat); failed items retried together."""
        conn = self.connections.get(conn_name)
        if conn is None:
            for lp, _ in items:
                lp.written(f"no connection {conn_name!r}")
            return
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
