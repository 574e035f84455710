"""The soft-controller runtime: loops on absolute deadlines, I/O supervision, historian, stop.

Scheduling: loops with the same sample time share one asyncio task; the
task's k-th cycle is due at ``t0 + k ts`` (absolute deadlines, so delays do
not accumulate), and the loops of a cycle run concurrently.  A cycle that
ends after the next deadline skips the missed deadlines (the phase is kept);
the loop's :class:`~ctrlblocks.blocks.monitor.CycleMonitor` sees the long
period, flags the overrun, and the next block call uses the measured period
as ``dt``.

In-process API (for a faceplate, a test, a notebook; all on the event loop
of the runtime):

* :meth:`Runtime.loop_names`, :meth:`Runtime.state` (SP, PV, MV, mode,
  error, limits, tunings, I/O status, cycle statistics of a loop),
  :meth:`Runtime.states`;
* :meth:`Runtime.command` -- mode, manual value, setpoint, limits, tunings,
  validated by the loop and the block (refused changes leave everything as it
  was), each one written to the historian's audit table with who sent it;
* :meth:`Runtime.submit` -- the same from another thread
  (:attr:`Runtime.event_loop` tells which loop the runtime runs on);
* :meth:`Runtime.audit` -- an audit row for what a front end does (logins,
  logouts, refused attempts), next to the commands.

Stop (:meth:`Runtime.request_stop`, SIGINT/SIGTERM in ``ctrlblocks serve``):
the cycles end, every MV is written to its stop value (``stop_value``, else
``safe_value``), the historian flushes and the connections close.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import logging
import math
from collections.abc import Callable, Mapping
from typing import Any

from .adapters import make_adapter
from .clock import Clock, MonotonicClock
from .config import RuntimeConfig
from .historian import Historian, open_historian
from .io import Adapter, Connection
from .loop import CommandError, ControlLoop, Sample

__all__ = ["Runtime"]

log = logging.getLogger(__name__)


class Runtime:
    """Runs the loops of a :class:`~ctrlblocks.runtime.config.RuntimeConfig`.

    Parameters
    ----------
    config : RuntimeConfig
        The loaded configuration.
    clock : Clock, optional
        Default the monotonic clock; tests pass a
        :class:`~ctrlblocks.runtime.clock.FakeClock`.
    adapters : mapping, optional
        Connection name -> adapter, replacing the one the configuration
        describes (tests use in-memory adapters).
    historian : Historian, "config" or None
        ``"config"`` (default): from ``[historian]``; an open
        :class:`~ctrlblocks.runtime.historian.Historian`; or None (no history).
    on_sample : callable, optional
        Called with every :class:`~ctrlblocks.runtime.loop.Sample` (live views).
    """

    def __init__(
        self,
        config: RuntimeConfig,
        *,
        clock: Clock | None = None,
        adapters: Mapping[str, Adapter] | None = None,
        historian: Historian | str | None = "config",
        on_sample: Callable[[Sample], None] | None = None,
    ) -> None:
        self.config = config
        self.clock: Clock = clock or MonotonicClock()
        adapters = dict(adapters or {})
        self.connections: dict[str, Connection] = {
            name: Connection(c, adapters.get(name) or make_adapter(c), self._sleep)
            for name, c in config.connections.items()
        }
        sides = config.build_sides()
        self.loops: dict[str, ControlLoop] = {
            lc.name: ControlLoop(lc, sides[lc.name], self.connections) for lc in config.loops
        }
        self._historian_arg = historian
        self.historian: Historian | None = None
        self.on_sample = on_sample
        self._stop = asyncio.Event()
        self._tasks: list[asyncio.Task[None]] = []
        self._loop: asyncio.AbstractEventLoop | None = None
        self.running = False
        self.stopped = asyncio.Event()

    @property
    def event_loop(self) -> asyncio.AbstractEventLoop | None:
        """The asyncio event loop the runtime runs on (None before :meth:`start`).

        :meth:`command` is called on this loop; from any other thread use
        :meth:`submit`.
        """
        return self._loop

    async def _sleep(self, seconds: float) -> None:
        await self.clock.sleep_until(self.clock.now() + seconds)

    # -- life cycle ----------------------------------------------------------------

    async def start(self) -> None:
        """Open the historian, connect (failures retry in the background), start the cycles."""
        self._loop = asyncio.get_running_loop()
        if self._historian_arg == "config":
            self.historian = await asyncio.to_thread(
                open_historian, self.config.historian, name=self.config.name
            )
        else:
            self.historian = self._historian_arg  # type: ignore[assignment]
        await asyncio.gather(*(c.start() for c in self.connections.values()))
        groups: dict[float, list[ControlLoop]] = {}
        for lp in self.loops.values():
            groups.setdefault(lp.ts, []).append(lp)
        self._tasks = [
            asyncio.create_task(self._cycles(ts, lps), name=f"ctrlblocks-ts-{ts:g}")
            for ts, lps in sorted(groups.items())
        ]
        if self.historian is not None:
            self._tasks.append(asyncio.create_task(self._flusher(), name="ctrlblocks-historian"))
        self.running = True
        log.info("runtime %s: %d loop(s) started", self.config.name, len(self.loops))

    def request_stop(self) -> None:
        """Ask the runtime to stop after the current cycle (safe to call from a signal handler)."""
        self._stop.set()

    async def stop(self) -> None:
        """Stop: end the cycles, write stop values, flush the historian, close connections."""
        self._stop.set()
        for t in self._tasks:
            try:
                await t
            except asyncio.CancelledError:
                pass
            except Exception:
                log.exception("runtime task failed")
        self._tasks = []
        if self.running:
            await self._shutdown()
        self.running = False
        self.stopped.set()

    async def run(self) -> None:
        """Start, run until :meth:`request_stop`, then stop gracefully."""
        await self.start()
        try:
            await self._stop.wait()
        finally:
            await self.stop()

    async def _shutdown(self) -> None:
        results = await asyncio.gather(
            *(lp.write_stop_value() for lp in self.loops.values()), return_exceptions=True
        )
        for lp, ok in zip(self.loops.values(), results, strict=True):
            written = ok is True
            if not written:
                log.error("loop %s: could not write the stop value (%s)", lp.name, lp.write_error)
            self._audit(
                "runtime",
                lp.name,
                "stop",
                {"mv": None},
                {"mv": lp.mv},
                written,
                "" if written else lp.write_error,
            )
        if self.historian is not None:
            try:
                await asyncio.to_thread(self.historian.close)
            except Exception:  # the connections still close
                log.exception("historian close failed")
        await asyncio.gather(*(c.close() for c in self.connections.values()))
        log.info("runtime %s: stopped", self.config.name)

    # -- the scheduler ----------------------------------------------------------------

    async def _wait_until(self, t: float) -> bool:
        """Sleep until ``t``; return False when a stop was requested meanwhile."""
        if self._stop.is_set():
            return False
        sleeper = asyncio.ensure_future(self.clock.sleep_until(t))
        stopper = asyncio.ensure_future(self._stop.wait())
        done, _ = await asyncio.wait({sleeper, stopper}, return_when=asyncio.FIRST_COMPLETED)
        for f in (sleeper, stopper):
            if f not in done:
                f.cancel()
        return not self._stop.is_set()

    async def _cycles(self, ts: float, loops: list[ControlLoop]) -> None:
        clock = self.clock
        t0 = clock.now()
        k = 0
        last: float | None = None
        while await self._wait_until(t0 + k * ts):
            t = clock.now()
            period = ts if last is None else t - last
            last = t
            samples = await asyncio.gather(*(lp.cycle(t, period) for lp in loops))
            for s in samples:
                self._record(s)
            k += 1
            late = clock.now() - (t0 + k * ts)
            if late >= 0.0:  # overrun: skip the missed deadlines, keep the phase
                k += math.floor(late / ts) + 1

    def _record(self, s: Sample) -> None:
        if self.historian is not None:
            self.historian.record(s)
        if self.on_sample is not None:
            try:
                self.on_sample(s)
            except Exception:  # a viewer never stops the loops
                log.exception("on_sample callback failed")

    async def _flusher(self) -> None:
        h = self.historian
        assert h is not None
        interval = self.config.historian.flush_interval
        batch = self.config.historian.batch
        while not self._stop.is_set():
            waited = 0.0
            while waited < interval and h.pending < batch and not self._stop.is_set():
                await asyncio.sleep(min(0.05, interval))
                waited += min(0.05, interval)
            try:
                await asyncio.to_thread(h.flush)
            except Exception:  # retried at the next flush
                log.exception("historian flush failed (rows kept for the next try)")

    # -- in-process API ----------------------------------------------------------------

    def loop_names(self) -> list[str]:
        """Names of the loops, in configuration order."""
        return list(self.loops)

    def state(self, loop: str) -> dict[str, Any]:
        """The faceplate view of one loop (see :meth:`ControlLoop.state`), plus its connections."""
        lp = self._get(loop)
        st = lp.state()
        names = {b.connection for b in lp.config.bindings().values() if b.is_io}
        st["connections"] = {
            n: {
                "connected": self.connections[n].connected,
                "last_error": self.connections[n].last_error,
                "reconnects": self.connections[n].reconnects,
            }
            for n in sorted(names)
        }
        return st

    def states(self) -> list[dict[str, Any]]:
        """:meth:`state` of every loop."""
        return [self.state(n) for n in self.loops]

    def _get(self, loop: str) -> ControlLoop:
        try:
            return self.loops[loop]
        except KeyError:
            raise CommandError(
                "loop", f"unknown loop {loop!r}; loops: {list(self.loops)}"
            ) from None

    def command(self, loop: str, *, user: str, **changes: Any) -> dict[str, Any]:
        """Send an operator command to ``loop`` as ``user`` (see :meth:`ControlLoop.command`).

        Returns the old values of what changed; raises
        :class:`~ctrlblocks.runtime.loop.CommandError` when refused.  Both
        outcomes are written to the audit table.  Call it on the runtime's
        event loop (from another thread use :meth:`submit`).
        """
        lp = self._get(loop)
        action = ",".join(sorted(changes))
        try:
            old = lp.command(**changes)
        except CommandError as exc:
            self._audit(user, loop, action, None, changes, False, str(exc))
            raise
        self._audit(user, loop, action, old, changes, True, "")
        return old

    def submit(self, loop: str, *, user: str, **changes: Any) -> concurrent.futures.Future:
        """:meth:`command` from another thread; returns a future with its result."""
        if self._loop is None:
            raise RuntimeError("the runtime is not started")

        async def call() -> dict[str, Any]:
            return self.command(loop, user=user, **changes)

        return asyncio.run_coroutine_threadsafe(call(), self._loop)

    def audit(
        self,
        who: str,
        action: str,
        *,
        loop: str = "",
        old: Any = None,
        new: Any = None,
        ok: bool = True,
        message: str = "",
    ) -> None:
        """Write one row to the historian's audit table (nothing without a historian).

        For what happens around the commands, e.g. a faceplate's logins
        (``action="login"``, ``ok`` False for a wrong password), logouts and
        refused attempts.  A failed write is logged, never raised.
        """
        self._audit(who, loop, action, old, new, ok, message)

    def _audit(self, *args: Any) -> None:
        if self.historian is None:
            return
        try:
            self.historian.audit(*args)
        except Exception:  # the audit must not break a command
            log.exception("audit write failed")
