"""Pure dead time of whole samples (controltheplant 2024, ``LSim_Lagging``).

"Time delay of the input signal" (controltheplant 2024).

``y[k] = u[k - n]`` with ``n >= 1`` samples, kept in a ring buffer.

Dead time that is not a multiple of ``ts``
------------------------------------------
A dead time ``tau`` applied to a zero-order-hold signal and sampled at the
instants ``k ts`` gives ``u(k ts - tau) = u[k - ceil(tau/ts)]``: the held value
that was current ``tau`` seconds ago.  :class:`DeadTime` therefore uses
``n = ceil(tau / ts)`` samples, which is exact *at the sample instants* (a
ratio within 1e-9 of a whole number counts as whole, so 0.3 s at 0.1 s is 3
samples, not 4).  What it cannot represent is the part of a sample during which
the delayed signal still has its older value; for a dead time in front of a
dynamic model use ``LinearPlant(..., dead_time=tau)`` (:mod:`.linear`), which
integrates both parts exactly (modified z-transform).
"""

from __future__ import annotations

import math
from typing import Any

from ..blocks.base import ErrorCode, ParameterError, require_positive
from .base import Plant
from .linear import require_dead_time, split_dead_time

__all__ = ["DeadTime"]


class DeadTime(Plant):
    """Pure dead time ``y[k] = u[k - n]``, ``n = ceil(dead_time / ts) >= 1``.

    Parameters
    ----------
    dead_time : float
        Dead time [s], > 0.
    ts : float
        Sample time [s], > 0.

    Attributes
    ----------
    n : int
        Dead time in whole samples.
    u : float
        Last input.

    Examples
    --------
    >>> dt = DeadTime(0.3, ts=0.1)
    >>> dt.reset(0.0)
    >>> [dt.step(u) for u in (1.0, 2.0, 3.0, 4.0)]
    [0.0, 0.0, 1.0, 2.0]
    """

    def __init__(self, dead_time: float, ts: float) -> None:
        self.ts = require_positive("ts", ts, ErrorCode.NO_CYCLE)
        self.dead_time = require_positive("dead_time", dead_time, ErrorCode.BAD_TIME_CONSTANT)
        require_dead_time(self.dead_time, self.ts)  # a buffer that fits in memory
        d, eps = split_dead_time(self.dead_time, self.ts)
        self.n = d + (1 if eps > 0.0 else 0)
        if self.n < 1:  # pragma: no cover - dead_time > 0 guarantees n >= 1
            raise ParameterError(ErrorCode.BAD_WINDOW, "dead_time", "must be >= one sample")
        self.reset(0.0)

    @property
    def y(self) -> float:
        """The input of ``n`` samples ago."""
        return self._buf[self._pos]

    def step(self, u: float) -> float:
        """Push ``u`` (a non-finite value repeats the last input); return the new ``y``."""
        if not math.isfinite(u):
            u = self.u
        self.u = float(u)
        self._buf[self._pos] = self.u
        self._pos = (self._pos + 1) % self.n
        return self._buf[self._pos]

    def reset(self, u0: float = 0.0) -> None:
        """Fill the buffer with ``u0``."""
        u0 = float(u0) if math.isfinite(u0) else 0.0
        self.u = u0
        self._buf = [u0] * self.n
        self._pos = 0

    def snapshot(self) -> dict[str, Any]:
        """A copy of the buffer and position."""
        return {"buf": list(self._buf), "pos": self._pos, "u": self.u}

    def restore(self, snap: dict[str, Any]) -> None:
        """Put back a state taken by :meth:`snapshot`."""
        if len(snap["buf"]) != self.n:
            raise ValueError("snapshot does not belong to this dead time")
        self._buf = [float(v) for v in snap["buf"]]
        self._pos = int(snap["pos"])
        self.u = float(snap["u"])

    def __repr__(self) -> str:
        return f"DeadTime(dead_time={self.dead_time!r}, ts={self.ts!r}) <n={self.n}>"
