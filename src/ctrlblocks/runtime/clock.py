"""Clocks for the scheduler: the real monotonic clock and a fake one for tests.

Only the runtime's scheduler reads a clock (DESIGN: "time is an input"); it
does so through this small interface, so tests can run the same scheduler on
virtual time without sleeping.
"""

from __future__ import annotations

import asyncio
import heapq
import itertools
import time
from typing import Protocol

__all__ = ["Clock", "FakeClock", "MonotonicClock"]


class Clock(Protocol):
    """What the scheduler needs from a clock (seconds, monotonic)."""

    def now(self) -> float:
        """The current time [s]."""

    async def sleep_until(self, t: float) -> None:
        """Return at (or just after) time ``t`` [s]; at once if ``t`` has passed."""


class MonotonicClock:
    """The real clock: ``time.monotonic`` and ``asyncio.sleep``."""

    def now(self) -> float:
        return time.monotonic()

    async def sleep_until(self, t: float) -> None:
        delay = t - time.monotonic()
        await asyncio.sleep(max(delay, 0.0))


class FakeClock:
    """Virtual time for tests: sleepers wake in deadline order when the test advances time.

    ``await clock.run_until(t)`` advances the time to ``t``, waking every
    ``sleep_until`` whose deadline is reached, in order, and letting the woken
    tasks run until they sleep again.  ``clock.advance(dt)`` moves the time
    forward at once (a slow I/O call in a test adapter uses it to make a cycle
    take longer than its period).
    """

    def __init__(self, t0: float = 0.0, settle_steps: int = 200) -> None:
        self._now = float(t0)
        self._heap: list[tuple[float, int, asyncio.Future[None]]] = []
        self._seq = itertools.count()
        self._settle_steps = settle_steps

    def now(self) -> float:
        return self._now

    def advance(self, dt: float) -> None:
        """Move the time forward by ``dt`` [s] without waking anyone."""
        self._now += dt

    @property
    def sleepers(self) -> int:
        """How many tasks wait in :meth:`sleep_until` now.

        A test whose runtime does real I/O (a server on loopback) waits until
        the scheduler sleeps again before it advances the time, so a cycle
        never ends after its next deadline because of the test's own stepping.
        """
        return sum(1 for *_, fut in self._heap if not fut.done())

    async def sleep_until(self, t: float) -> None:
        if t <= self._now:
            await asyncio.sleep(0)
            return
        fut: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        heapq.heappush(self._heap, (t, next(self._seq), fut))
        await fut

    async def settle(self) -> None:
        """Let every runnable task run until it waits again (bounded number of loop turns)."""
        for _ in range(self._settle_steps):
            await asyncio.sleep(0)

    async def run_until(self, t_end: float) -> None:
        """Advance virtual time to ``t_end``, waking sleepers in deadline order."""
        await self.settle()
        while self._heap and self._heap[0][0] <= t_end:
            t, _, fut = heapq.heappop(self._heap)
            self._now = max(self._now, t)
            if not fut.done():
                fut.set_result(None)
            await self.settle()
        self._now = max(self._now, t_end)
