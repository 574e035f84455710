"""The soft-controller runtime: loops on absolute deadlines, I/O supervision, historian, stop.

Scheduling: the loops of one sample time that share connections form a
:class:`~ctrlblocks.runtime.scan.Scan` (:func:`~ctrlblocks.runtime.scan.scan_groups`),
and each scan runs on an asyncio task of its own: loops on different
connections never wait for each other, so a slow or dead device delays only
the loops that use it.  The task's k-th cycle is due at ``t0 + k ts``
(absolute deadlines, so delays do not accumulate) and runs the scan -- one
I/O image per connection: one batched read of every input, waited for until
the connection's input deadline (later inputs are *late*: their loops hold
or run on their last good inputs), the loops compute, one batched write of
every MV (and the connection's heartbeat).  A cycle that ends after the next
deadline skips the missed deadlines (the phase is kept); the loop's
:class:`~ctrlblocks.blocks.monitor.CycleMonitor` sees the long period and
flags the overrun, and the block gets the time since its last step as ``dt``
(within ``max_dt``; :mod:`ctrlblocks.runtime.loop`).  Overruns, late inputs,
stretched periods and the loops' other conditions are alarms: in the state,
on the faceplate and in the audit table (one row when one comes, one when it
goes).

In-process API (for a faceplate, a test, a notebook; all on the event loop
of the runtime):

* :meth:`Runtime.loop_names`, :meth:`Runtime.state` (SP, PV, MV, mode,
  error, limits, tunings, I/O status, cycle statistics of a loop),
  :meth:`Runtime.states`;
* :meth:`Runtime.command` -- mode, manual value, setpoint, limits, tunings,
  validated by the loop and the block (refused changes leave everything as it
  was), each one written to the historian's audit table with who sent it,
  and to the retain file at once;
* :meth:`Runtime.execute` -- a command that returns once the change is in
  the retain file, fsync'd (what a front end confirms; :mod:`.retain`);
* :meth:`Runtime.submit` -- :meth:`execute` from another thread
  (:attr:`Runtime.event_loop` tells which loop the runtime runs on);
* :meth:`Runtime.audit` -- an audit row for what a front end does (logins,
  logouts, refused attempts), next to the commands;
* :attr:`Runtime.tuning` -- live auto-tuning of a loop (step or relay test,
  result, accept or reject; :mod:`ctrlblocks.runtime.autotune`); a command to
  a loop under test ends the test first.

Stop (:meth:`Runtime.request_stop`, SIGINT/SIGTERM in ``ctrlblocks serve``):
the cycles end, every MV is written to its stop value (``stop_value``, else
``safe_value``) in one final batched write per connection with the
connection's own ``stop_timeout`` (a connection that is down gets one
connection attempt first; the items that fail are retried once), the
loops whose stop value could not be written are named in one log line and
in the audit table, the historian flushes and the connections close.

Garbage collection: after the start the runtime moves every object that
exists then (configuration, blocks, libraries) out of the collector's view
(``gc.freeze``) and raises the generation-0 threshold, so the periodic full
collections that stalled the cycles for 200-300 ms (docs/performance.md)
scan only what the cycles allocate.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import functools
import gc
import logging
import math
import sqlite3
from collections.abc import Callable, Mapping
from typing import Any

from .adapters import make_adapter
from .audit import RefusalBudget, bounded
from .autotune import LiveTuning
from .clock import Clock, MonotonicClock
from .config import RuntimeConfig, RuntimeConfigError, require_packages
from .health import HealthMonitor
from .historian import Historian
from .io import Adapter, Connection
from .loop import CommandError, ControlLoop, Sample
from .retain import RetainStore, encode_state
from .scan import Heartbeat, Scan, scan_groups
from .writer import ProcessHistorian, open_historian

__all__ = ["AUDIT_REFUSALS", "Runtime"]

log = logging.getLogger(__name__)

AUDIT_REFUSALS = (10, 60.0)
"""Audit rows of refused commands per user and window [s]: beyond them a refusal is counted,
and the count is written with the next row let through; a refused command's values are
cut (:func:`ctrlblocks.runtime.audit.bounded`)."""

_SYSTEM = ("runtime", "historian")
"""Writers of audit rows about the runtime itself (never bounded)."""


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
    retain : RetainStore, "config" or None
        The retentive state file: ``"config"`` (default) from ``[retain]``,
        a :class:`~ctrlblocks.runtime.retain.RetainStore`, or None (cold starts).
    """

    def __init__(
        self,
        config: RuntimeConfig,
        *,
        clock: Clock | None = None,
        adapters: Mapping[str, Adapter] | None = None,
        historian: Historian | str | None = "config",
        on_sample: Callable[[Sample], None] | None = None,
        retain: RetainStore | str | None = "config",
    ) -> None:
        self.config = config
        self.clock: Clock = clock or MonotonicClock()
        adapters = dict(adapters or {})
        require_packages(config, [n for n in config.connections if n not in adapters])
        self.connections: dict[str, Connection] = {
            name: Connection(c, adapters.get(name) or make_adapter(c), self._sleep)
            for name, c in config.connections.items()
        }
        sides = config.build_sides()
        self.loops: dict[str, ControlLoop] = {
            lc.name: ControlLoop(lc, sides[lc.name], self.connections) for lc in config.loops
        }
        self._historian_arg = historian
        if retain == "config":
            rc = config.retain
            retain = RetainStore(rc.path) if rc.enabled else None
        self.retain: RetainStore | None = retain  # type: ignore[assignment]
        self.retain_failures = 0  # consecutive failed saves of the retain file (0: it is saved)
        self._retain_pool: concurrent.futures.ThreadPoolExecutor | None = None  # one writer
        self._retained: dict[str, str] = {}  # the newest encoded state of every loop
        self._commanded: dict[str, asyncio.Future[None]] = {}  # loop -> its durable save
        self.historian: Historian | None = None
        self.on_sample = on_sample
        self._stop = asyncio.Event()
        self._cycle_end = asyncio.Event()  # set when a cycle has written and recorded
        self._tasks: list[asyncio.Task[None]] = []
        self._loop: asyncio.AbstractEventLoop | None = None
        self.running = False
        self.stopped = asyncio.Event()
        self.heartbeats: dict[str, Heartbeat] = {}
        self.scans: list[Scan] = []
        self.gc_freeze = True  # see the module docstring; a benchmark turns it off to compare
        # True: the historian flushes right after a cycle's writes, in the idle rest of the
        # period, instead of at any time (a benchmark's switch, docs/performance.md)
        self.flush_after_cycle = False
        self._gc_thresholds: tuple[int, int, int] | None = None
        self.stop_failures: dict[str, str] = {}  # loop -> why its stop value was not written
        self.refusals = RefusalBudget(*AUDIT_REFUSALS)  # refusal rows per user (bounded)
        self.tuning = LiveTuning(self)  # live auto-tuning of the loops (runtime.autotune)
        # alarms and live assessment of the loops with [loops.alarms] / [loops.assess]
        self.health = HealthMonitor(
            ((lc.name, lc.ts, lc.health) for lc in config.loops), self._audit
        )
        for lc in config.loops:  # the alarms' states go out with the loop's MV
            if lc.alarm_outputs:
                keys = tuple(lc.alarm_outputs)
                self.loops[lc.name].alarm_values = functools.partial(
                    self.health.output_values, lc.name, keys
                )

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
        if self.retain is not None:
            await self._check_retain()
        await asyncio.gather(*(c.start() for c in self.connections.values()))
        if self.retain is not None:
            await self._restore_retained()
        self.scans = self._scans()
        self._tasks = [
            asyncio.create_task(self._cycles(scan.ts, scan), name=f"ctrlblocks-scan-{i}")
            for i, scan in enumerate(self.scans)
        ]
        if self.historian is not None:
            self._tasks.append(asyncio.create_task(self._flusher(), name="ctrlblocks-historian"))
        if self.retain is not None:
            self._tasks.append(asyncio.create_task(self._retainer(), name="ctrlblocks-retain"))
        self.running = True
        if self.gc_freeze and self._gc_thresholds is None:
            self._gc_thresholds = freeze_garbage_collector()
        log.info("runtime %s: %d loop(s) started", self.config.name, len(self.loops))

    def _scans(self) -> list[Scan]:
        """One :class:`Scan` per sample time and group of connections (:func:`scan_groups`).

        A connection's heartbeat goes with the fastest scan that uses it.
        """
        by_ts: dict[float, list[ControlLoop]] = {}
        for lp in self.loops.values():
            by_ts.setdefault(lp.ts, []).append(lp)
        scans = [
            Scan(group, self.connections, clock=self.clock, ts=ts)
            for ts in sorted(by_ts)
            for group in scan_groups(by_ts[ts])
        ]
        for name, conn in self.connections.items():
            if conn.config.heartbeat is None or not scans:
                continue
            using = [sc for sc in scans if any(name in lp.config.connections() for lp in sc.loops)]
            hb = self.heartbeats[name] = Heartbeat(conn.config.heartbeat, conn.config.heartbeat_max)
            (using or scans)[0].heartbeats[name] = hb  # sorted by ts: the fastest first
        return scans

    def request_stop(self) -> None:
        """Ask the runtime to stop after the current cycle (safe to call from a signal handler)."""
        self._stop.set()

    async def stop(self) -> None:
        """Stop: end the cycles, write stop values, flush the historian, close connections."""
        self._stop.set()
        self._cycle_end.set()  # a flusher waiting for the end of a cycle goes on
        for scan in self.scans:
            scan.cancel_reads()  # a cycle waiting for a late read ends now
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
        if self._gc_thresholds is not None:
            thaw_garbage_collector(self._gc_thresholds)
            self._gc_thresholds = None
        if self._retain_pool is not None:
            self._retain_pool.shutdown(wait=True)
            self._retain_pool = None
        self.running = False
        self.stopped.set()

    async def run(self) -> None:
        """Start, run until :meth:`request_stop`, then stop gracefully."""
        await self.start()
        try:
            await self._stop.wait()
        finally:
            await self.stop()

    # -- retentive state ---------------------------------------------------------------

    async def _check_retain(self) -> None:
        """Refuse to start when the retain file cannot be written (closing what is open)."""
        assert self.retain is not None
        try:
            await self.retain_call(self.retain.check)
        except (OSError, sqlite3.OperationalError) as exc:
            if self.historian is not None and self._historian_arg == "config":
                await asyncio.to_thread(self.historian.close)
            self.historian = None
            raise RuntimeConfigError(
                self.config.file, "retain.path", f"{self.retain.path}: cannot write it ({exc})"
            ) from None

    async def _restore_retained(self) -> None:
        """Restore the retained loops; their first cycle reads the MV back (bumpless restart)."""
        assert self.retain is not None
        states = await self.retain_call(self.retain.load)
        restored = [lp for n, lp in self.loops.items() if n in states]
        for lp in restored:
            lp.restore_retained(states[lp.name])
        if restored:
            log.info("runtime %s: %d loop(s) restored from %s", self.config.name,
                     len(restored), self.retain.path)  # fmt: skip

    async def retain_call(self, fn: Callable[..., Any], *args: Any) -> Any:
        """Run ``fn(*args)`` on the retain file's one writer thread (in order) and await it."""
        if self._retain_pool is None:
            self._retain_pool = concurrent.futures.ThreadPoolExecutor(1, "ctrlblocks-retain")
        return await asyncio.get_running_loop().run_in_executor(self._retain_pool, fn, *args)

    async def save_retained(self) -> None:
        """Write every loop's retentive state now (also done every interval and on stop)."""
        if self.retain is None:
            return
        self._retained = {n: encode_state(lp.retained()) for n, lp in self.loops.items()}
        await self._save_retained(dict(self._retained))

    def _retain_loop(self, name: str) -> asyncio.Future[None] | None:
        """Start writing loop ``name``'s state to the retain file now (a command's change)."""
        if self.retain is None or self._loop is None:
            return None
        text = self._retained[name] = encode_state(self.loops[name].retained())
        fut = asyncio.ensure_future(self.retain_call(self.retain.save_loop, name, text))
        self._commanded[name] = fut
        fut.add_done_callback(lambda f: f.cancelled() or f.exception())  # never unretrieved
        return fut

    async def durable(self, loop: str) -> bool:
        """Wait until the last change to ``loop`` is in the retain file (False: no retain file).

        Raises the write's error (``OSError``, ``sqlite3.Error``) when it failed.
        """
        fut = self._commanded.get(loop)
        if fut is None:
            return self.retain is not None
        await asyncio.shield(fut)
        return True

    async def _save_retained(self, states: dict[str, str]) -> None:
        assert self.retain is not None
        try:
            await self.retain_call(self.retain.save, states)
        except Exception as exc:  # the loops go on; the next save retries
            # one line and one audit entry per streak of failures (a full disk fails every
            # interval: a traceback each time would bury the log), one when it recovers
            self.retain_failures += 1
            if self.retain_failures == 1:
                msg = f"retain file {self.retain.path}: save failed ({exc}); retrying every save"
                log.error("%s", msg)
                self._audit("runtime", "", "retain", None, None, False, msg)
            else:
                log.debug("retain file %s: save failed again (%s)", self.retain.path, exc)
            return
        if self.retain_failures:
            msg = (f"retain file {self.retain.path}: saved again after "
                   f"{self.retain_failures} failed saves")  # fmt: skip
            log.warning("%s", msg)
            self._audit("runtime", "", "retain", None, None, True, msg)
            self.retain_failures = 0

    async def _retainer(self) -> None:
        """Save the retentive state every ``interval``, collected a few loops at a time.

        Each loop's state is taken between two of its cycles (consistent in
        itself) and encoded at once, 10 loops per step, the steps spread over
        the interval; the full set then goes to the file in one transaction.
        Taking and encoding 1,000 loops at once cost about 0.1 s of the event
        loop plus 0.15 s of a thread holding the GIL, and delayed the cycles
        every interval (docs/performance.md).
        """
        interval = self.config.retain.interval
        loops = list(self.loops.values())
        chunks = [loops[i : i + 10] for i in range(0, len(loops), 10)] or [[]]
        step = interval / len(chunks)
        states = self._retained  # (a command updates its loop's entry at once)
        t = self.clock.now()
        while True:
            for chunk in chunks:
                t += step
                if not await self._wait_until(t):
                    return
                for lp in chunk:
                    states[lp.name] = encode_state(lp.retained())
            await self._save_retained(dict(states))

    async def _shutdown(self) -> None:
        await self.save_retained()  # the operating state, before the stop values go out
        by_conn: dict[str, list[ControlLoop]] = {}
        for lp in self.loops.values():
            by_conn.setdefault(lp.config.mv.connection or "", []).append(lp)
        results = await asyncio.gather(
            *(self._write_stop_values(n, lps) for n, lps in by_conn.items())
        )
        failures = {k: v for r in results for k, v in r.items()}
        self.stop_failures = failures
        for lp in self.loops.values():
            err = failures.get(lp.name)
            self._audit(
                "runtime", lp.name, "stop", {"mv": None}, {"mv": lp.mv}, err is None, err or ""
            )
        if failures:
            log.error(
                "runtime %s: %d stop value(s) NOT written: %s",
                self.config.name,
                len(failures),
                "; ".join(f"{n} ({e})" for n, e in sorted(failures.items())),
            )
        if self.historian is not None:
            try:
                await asyncio.to_thread(self.historian.close)
            except Exception:  # the connections still close
                log.exception("historian close failed")
        await asyncio.gather(*(c.close() for c in self.connections.values()))
        log.info("runtime %s: stopped", self.config.name)

    async def _write_stop_values(self, conn_name: str, loops: list[ControlLoop]) -> dict[str, str]:
        """The final batched write of the stop values on one connection; loop -> failure."""
        conn = self.connections.get(conn_name)
        if conn is None:
            return {lp.name: f"no connection {conn_name!r}" for lp in loops}
        timeout = conn.config.stop_timeout
        if not conn.connected:
            await conn.connect_now(timeout)
        pending = list(loops)
        errors: dict[str, str] = {}
        for _ in range(2):  # the final write, retried once for the loops whose write failed
            items = [(lp, item) for lp in pending for item in lp.writes(lp.stop_value)]
            res = await conn.write([item for _, item in items], timeout=timeout)
            outcome: dict[ControlLoop, str | None] = {}
            for (lp, _), err in zip(items, res, strict=True):
                outcome[lp] = outcome.get(lp) or err
            errors = {}
            again = []
            for lp, err in outcome.items():
                lp.mv = lp.stop_value
                lp.written(err)
                if err is not None:
                    errors[lp.name] = err
                    again.append(lp)
            pending = again
            if not pending:
                break
            if not conn.connected:
                await conn.connect_now(timeout)
        return errors

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

    async def _cycles(self, ts: float, scan: Scan) -> None:
        clock = self.clock
        t0 = clock.now()
        k = 0
        last: float | None = None
        while await self._wait_until(t0 + k * ts):
            t = clock.now()
            period = ts if last is None else t - last
            last = t
            for s in await scan.run(t, period):
                self._record(s)
            self._cycle_end.set()  # a flush may run now (_flusher, flush_after_cycle)
            for lp in scan.loops:
                self._report(lp)
            k += 1
            late = clock.now() - (t0 + k * ts)
            if late >= 0.0:  # overrun: skip the missed deadlines, keep the phase
                k += math.floor(late / ts) + 1

    def _report(self, lp: ControlLoop) -> None:
        """Audit what the loop's last cycle raised: the conditions that came or went."""
        events = lp.conditions.events
        while events:
            raised, c = events.pop(0)
            action = "alarm" if raised else "alarm-cleared"
            msg = f"{c.code}: {c.text}"
            if raised and c.severity == "alarm":
                log.warning("loop %s: %s", lp.name, msg)
            self._audit("runtime", lp.name, action, None, {"code": c.code,
                        "severity": c.severity}, not raised, msg)  # fmt: skip

    def _record(self, s: Sample) -> None:
        if self.historian is not None:
            self.historian.record(s)
        if self.health:
            try:
                self.health.observe(s)
            except Exception:  # the alarms never stop the loops
                log.exception("alarm or assessment of loop %s failed", s.loop)
        if self.on_sample is not None:
            try:
                self.on_sample(s)
            except Exception:  # a viewer never stops the loops
                log.exception("on_sample callback failed")

    async def _flusher(self) -> None:
        h = self.historian
        assert h is not None
        if isinstance(h, ProcessHistorian):  # hand the records to the writer process
            while not self._stop.is_set():
                h.send()  # never blocks
                await asyncio.sleep(0.05)
            return
        interval = self.config.historian.flush_interval
        batch = self.config.historian.batch
        longest = max((lc.ts for lc in self.config.loops), default=interval)
        while not self._stop.is_set():
            waited = 0.0
            while waited < interval and h.pending < batch and not self._stop.is_set():
                await asyncio.sleep(min(0.05, interval))
                waited += min(0.05, interval)
            if self.flush_after_cycle:
                # in the idle rest of a period: the flush thread holds the GIL while it
                # binds the rows, and a cycle it overlaps waits for it
                self._cycle_end.clear()
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(self._cycle_end.wait(), timeout=longest)
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
            old = self.tuning.command(lp, user, changes)  # a command ends a live test
        except CommandError as exc:
            self._audit(user, loop, action, None, changes, False, str(exc), bound=True)
            raise
        self._audit(user, loop, action, old, changes, True, "")
        self._retain_loop(loop)
        return old

    async def execute(self, loop: str, *, user: str, **changes: Any) -> dict[str, Any]:
        """:meth:`command`, returning once the change is durable (in the retain file, fsync'd).

        What a front end confirms to a person: a ``kill -9`` after the return
        keeps the change.  Raises :class:`~ctrlblocks.runtime.loop.CommandError`
        (refused, nothing changed) or the retain file's error (``OSError``,
        ``sqlite3.Error``: the change is in force but not retained).  Call it
        on the runtime's event loop.
        """
        old = self.command(loop, user=user, **changes)
        await self.durable(loop)
        return old

    def submit(self, loop: str, *, user: str, **changes: Any) -> concurrent.futures.Future:
        """:meth:`execute` from another thread; returns a future with its result."""
        if self._loop is None:
            raise RuntimeError("the runtime is not started")
        return asyncio.run_coroutine_threadsafe(
            self.execute(loop, user=user, **changes), self._loop
        )

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
        bound: bool = False,
    ) -> None:
        """Write one row to the historian's audit table (nothing without a historian).

        For what happens around the commands, e.g. a faceplate's logins
        (``action="login"``, ``ok`` False for a wrong password), logouts and
        refused attempts.  ``bound``: a refusal of ``who``'s request, bounded
        as the runtime bounds refused commands (:data:`AUDIT_REFUSALS`); a
        front end that bounds its own rows (per client address) leaves it off.
        A failed write is logged, never raised.
        """
        self._audit(who, loop, action, old, new, ok, message, bound=bound)

    def _audit(
        self,
        who: str,
        loop: str,
        action: str,
        old: Any,
        new: Any,
        ok: bool,
        message: str = "",
        *,
        bound: bool = False,
    ) -> None:
        """One audit row; ``bound``: a user's refusal, bounded in size and number."""
        if self.historian is None:
            return
        if bound and not ok and who not in _SYSTEM:
            suffix = self.refusals.admit(who)
            if suffix is None:
                return
            old, new, message = bounded(old), bounded(new), str(message)[:300] + suffix
        try:
            self.historian.audit(who, loop, action, old, new, ok, message)
        except Exception:  # the audit must not break a command
            log.exception("audit write failed")


def freeze_garbage_collector(threshold0: int = 50_000) -> tuple[int, int, int]:
    """Move every object alive now out of the collector's view and raise its first threshold.

    After the start, nearly every long-lived object exists (configuration,
    blocks, libraries, the asyncio machinery).  ``gc.freeze()`` puts them in
    the permanent generation, so a full collection no longer walks them, and
    a generation-0 threshold of ``threshold0`` allocations (default 700)
    makes collections rarer; reference counting frees the cycles' own
    short-lived objects anyway.  Measured effect: docs/performance.md.
    Returns the previous thresholds (for :func:`thaw_garbage_collector`).
    """
    old = gc.get_threshold()
    gc.collect()
    gc.freeze()
    gc.set_threshold(threshold0, old[1], old[2])
    return old


def thaw_garbage_collector(thresholds: tuple[int, int, int]) -> None:
    """Undo :func:`freeze_garbage_collector` (the runtime's stop)."""
    gc.unfreeze()
    gc.set_threshold(*thresholds)
