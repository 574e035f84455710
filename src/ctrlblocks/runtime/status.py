"""What an operator must see of a loop at a glance: its conditions, with words and a severity.

A loop's :class:`Conditions` hold what is wrong or noteworthy *now* (a bad
PV, the safe value, late I/O, an oscillating MV, ...), each with the time it
became active; the faceplate shows them as coloured words, the historian's
audit table gets one row when a condition of severity ``alarm`` or
``warning`` comes and one when it goes.  Conditions that flicker with the
cycle (late I/O, a stretched period, an overrun) stay active for
:data:`OFF_DELAY` cycles after their last occurrence, so one episode is one
pair of rows, not one per cycle.

Anything may add its own condition with :meth:`Conditions.set` (a code, a
severity, a text): the faceplate and the audit show it like the runtime's
own.  :class:`SwingDetector` is the runtime's own check for an MV that swings
back and forth (the MV reverses by more than a tenth of its range again and
again); a loop-performance assessment can say more.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator

__all__ = [
    "OFF_DELAY",
    "SEVERITIES",
    "WORDS",
    "Condition",
    "Conditions",
    "SwingDetector",
]

SEVERITIES = ("alarm", "warning", "info")
"""Severities, highest first: ``alarm`` (red), ``warning`` (amber), ``info`` (blue)."""

OFF_DELAY = 10
"""Cycles a flickering condition (late I/O, stretched period, overrun) stays active after its
last occurrence."""

WORDS: dict[str, tuple[str, str]] = {
    # code: (severity, the words an operator reads)
    "connection_down": ("alarm", "connection down"),
    "bad_pv": ("alarm", "bad PV"),
    "safe_value": ("alarm", "on safe value"),
    "write_failed": ("alarm", "MV not written"),
    "block_error": ("alarm", "block error"),
    "holding": ("warning", "holding"),
    "late_io": ("warning", "late I/O"),
    "oscillating": ("warning", "oscillating"),
    "overrun": ("warning", "cycle overrun"),
    "stretched": ("warning", "stretched period"),
    "held_long": ("warning", "held beyond max_dt"),
    "input_error": ("warning", "input error"),
    "mv_limit": ("info", "MV at limit"),
    "tuning": ("info", "tuning test"),
}
"""The runtime's conditions: code -> (severity, words)."""


@dataclasses.dataclass
class Condition:
    """One active condition."""

    code: str
    severity: str
    text: str
    since: float
    last: float  # the cycle time it was last seen
    cycles_off: int = 0

    def as_json(self) -> dict[str, object]:
        return {"code": self.code, "severity": self.severity, "text": self.text,
                "since": self.since}  # fmt: skip


class Conditions:
    """The active conditions of one loop and the changes not yet reported (module docstring)."""

    def __init__(self) -> None:
        self.active: dict[str, Condition] = {}
        self.events: list[tuple[bool, Condition]] = []  # (raised, condition), for the audit
        self.changed = False  # something came, went or changed its text since the last state

    def set(
        self,
        code: str,
        on: bool,
        text: str = "",
        t: float = 0.0,
        *,
        severity: str | None = None,
        off_delay: int = 0,
    ) -> None:
        """Set condition ``code`` on or off at cycle time ``t`` [s].

        ``severity`` defaults to the one of :data:`WORDS` (``warning`` for an
        unknown code); ``off_delay``: cycles it stays on after the last ``on``.
        """
        c = self.active.get(code)
        if on:
            if c is None:
                sev = severity or WORDS.get(code, ("warning", code))[0]
                c = self.active[code] = Condition(code, sev, text, t, t)
                self.changed = True
                if sev != "info":
                    self.events.append((True, c))
            else:
                if text and c.text != text:
                    c.text = text
                    self.changed = True
                c.last, c.cycles_off = t, 0
        elif c is not None:
            c.cycles_off += 1
            if c.cycles_off > off_delay:
                del self.active[code]
                self.changed = True
                if c.severity != "info":
                    self.events.append((False, c))

    def __contains__(self, code: str) -> bool:
        return code in self.active

    def __iter__(self) -> Iterator[Condition]:
        """The active conditions, highest severity first, then in the order they came."""
        rank = {s: i for i, s in enumerate(SEVERITIES)}
        return iter(sorted(self.active.values(), key=lambda c: (rank.get(c.severity, 1), c.since)))

    def codes(self) -> list[str]:
        """The codes of :meth:`__iter__` (the faceplate's state words in that order)."""
        return [c.code for c in self]

    def as_json(self) -> list[dict[str, object]]:
        return [c.as_json() for c in self]


class SwingDetector:
    """An MV that reverses by more than ``band`` of its range, again and again.

    A reversal is counted when the MV, after moving one way, moves back by
    more than ``band`` times the MV range (hysteresis: noise smaller than that
    never counts); the MV *swings* while ``reversals`` of them (two periods)
    fall within the last ``window`` cycles.  The band needs a finite range
    (the MV limits, else the engineering ``mv_range``); without one the
    detector stays quiet.
    """

    def __init__(self, band: float = 0.1, reversals: int = 4, window: int = 100) -> None:
        self.band, self.reversals, self.window = band, reversals, window
        self._k = 0
        self._at: list[int] = []  # cycle numbers of the recent reversals
        self.reset()

    def reset(self) -> None:
        """Forget the history (a mode change, a re-initialisation)."""
        self._dir = 0  # +1 rising, -1 falling, 0 not known yet
        self._hi = self._lo = math.nan  # the extremes (while the direction is not known)
        self._at = []

    @property
    def recent(self) -> int:
        """The reversals counted in the window now."""
        return len(self._at)

    def update(self, u: float, span: float) -> bool:
        """Take this cycle's MV ``u`` and the MV range ``span``; True while it swings."""
        self._k += 1
        if math.isfinite(u) and math.isfinite(span) and span > 0:
            h = self.band * span
            if self._dir == 0:
                self._hi = u if math.isnan(self._hi) else max(self._hi, u)
                self._lo = u if math.isnan(self._lo) else min(self._lo, u)
                if u <= self._hi - h:
                    self._dir, self._lo = -1, u
                elif u >= self._lo + h:
                    self._dir, self._hi = 1, u
            elif self._dir > 0:
                if u > self._hi:
                    self._hi = u
                elif u <= self._hi - h:
                    self._dir, self._lo = -1, u
                    self._at.append(self._k)
            elif u < self._lo:
                self._lo = u
            elif u >= self._lo + h:
                self._dir, self._hi = 1, u
                self._at.append(self._k)
        while self._at and self._at[0] <= self._k - self.window:
            self._at.pop(0)
        return len(self._at) >= self.reversals
