"""Bounded audit rows: what a refused request may leave in the audit table, and how often.

The audit table records every command with its user, accepted or refused.  A
refused command is someone's mistake -- or someone trying: its row must not
let a client fill the disk.  :func:`bounded` cuts the values a refused
command carries (at most :data:`MAX_FIELDS` fields, strings of at most
:data:`MAX_TEXT` characters, one level of nesting), and
:class:`SlidingWindow` counts the rows per key and window, so that each user
leaves at most ``limit`` refusal rows per window (the rest is counted, and
the count goes with the next row let through).  The faceplate bounds
anonymous refusals per client address the same way (:mod:`ctrlblocks.web.defences`).
"""

from __future__ import annotations

import collections
import time
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["MAX_FIELDS", "MAX_TEXT", "RefusalBudget", "SlidingWindow", "bounded"]

MAX_FIELDS = 8
"""Most fields (and list items) a bounded value keeps per level."""

MAX_TEXT = 64
"""Longest string a bounded value keeps [characters] (longer ones are cut)."""


def bounded(x: Any, depth: int = 2) -> Any:
    """``x`` cut to :data:`MAX_FIELDS` items per level, :data:`MAX_TEXT` characters, ``depth``."""
    if isinstance(x, str):
        return x if len(x) <= MAX_TEXT else x[:MAX_TEXT] + "..."
    if isinstance(x, Mapping):
        if depth <= 0:
            return f"{{{len(x)} field(s)}}"
        items = list(x.items())
        out = {bounded(str(k), 0): bounded(v, depth - 1) for k, v in items[:MAX_FIELDS]}
        if len(items) > MAX_FIELDS:
            out["..."] = f"{len(items) - MAX_FIELDS} more field(s)"
        return out
    if isinstance(x, (list, tuple)):
        if depth <= 0:
            return f"[{len(x)} item(s)]"
        return [bounded(v, depth - 1) for v in x[:MAX_FIELDS]]
    if x is None or isinstance(x, (bool, int, float)):
        return x
    return bounded(str(x), 0)


class SlidingWindow:
    """At most ``limit`` events per ``window`` seconds per key.

    Parameters
    ----------
    limit : int
        Events admitted per key and window.
    window : float
        Length of the window [s].
    clock : callable
        Time source [s] (default :func:`time.monotonic`; tests inject one).
    max_keys : int
        Keys remembered at most; when full, keys with no event in the window
        are forgotten first, then the oldest key.
    """

    def __init__(
        self,
        limit: int,
        window: float,
        clock: Callable[[], float] = time.monotonic,
        max_keys: int = 10_000,
    ) -> None:
        self.limit, self.window = int(limit), float(window)
        self.clock, self.max_keys = clock, max_keys
        self._events: dict[str, collections.deque[float]] = {}

    def _recent(self, key: str, now: float) -> collections.deque[float]:
        q = self._events.get(key)
        if q is None:
            if len(self._events) >= self.max_keys:
                self._forget(now)
            q = self._events[key] = collections.deque()
        while q and now - q[0] >= self.window:
            q.popleft()
        return q

    def _forget(self, now: float) -> None:
        for k in [k for k, q in self._events.items() if not q or now - q[-1] >= self.window]:
            del self._events[k]
        while len(self._events) >= self.max_keys:
            del self._events[next(iter(self._events))]

    def full(self, key: str) -> bool:
        """True when ``key`` has used its ``limit`` in the current window."""
        return len(self._recent(key, self.clock())) >= self.limit

    def hit(self, key: str) -> bool:
        """Count one event of ``key``; False (and not counted) when its limit is used up."""
        q = self._recent(key, self.clock())
        if len(q) >= self.limit:
            return False
        q.append(self.clock())
        return True

    def give_back(self, key: str) -> None:
        """Undo the newest event of ``key`` (a check that turned out to be a good login)."""
        q = self._events.get(key)
        if q:
            q.pop()

    def clear(self, key: str) -> None:
        """Forget every event of ``key``."""
        self._events.pop(key, None)

    def __len__(self) -> int:
        return len(self._events)


class RefusalBudget:
    """At most ``limit`` audit rows of refusals per key and ``window`` seconds (module docstring).

    :meth:`admit` says whether a refusal's row is written, and what its
    message gets added: the count of the rows left out since the last one.
    """

    def __init__(
        self, limit: int, window: float, clock: Callable[[], float] = time.monotonic
    ) -> None:
        self.window = SlidingWindow(limit, window, clock)
        self.left: dict[str, int] = {}  # key -> refusals not written since its last row

    def admit(self, key: str) -> str | None:
        """None: leave this row out (it is counted); else the suffix for its message."""
        if not self.window.hit(key):
            self.left[key] = self.left.get(key, 0) + 1
            if len(self.left) > 10_000:
                self.left.clear()
            return None
        n = self.left.pop(key, 0)
        return f" ({n} more not recorded)" if n else ""
