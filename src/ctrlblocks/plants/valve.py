"""A motorised valve: the summing device of a three-point step controller.

The motor runs at constant speed while a command is on: ``+1`` opens, ``-1``
closes, ``0`` stops.  The position ``x`` [% of travel] is the integral of the
command, limited by the end stops::

    x[k+1] = min(max(x[k] + c[k] h span / travel_time, 0), span)

(exact for a command held over the sample).  ``open_limit`` / ``close_limit``
are the end switches a real valve reports.  Its position is the input of the
process model behind it; together they test a :class:`~ctrlblocks.StepController`.
"""

from __future__ import annotations

import math
from typing import Any

from ..blocks.base import ErrorCode, require_finite, require_positive
from .base import Plant

__all__ = ["MotorValve"]


class MotorValve(Plant):
    """Motorised valve without position feedback (see the module docstring).

    Parameters
    ----------
    travel_time : float
        Travel time from closed to open [s].
    ts : float
        Sample time [s].
    span : float
        Travel [%], 100 by default.
    x0 : float
        Initial position [%].
    """

    def __init__(self, travel_time: float, ts: float, span: float = 100.0, x0: float = 0.0) -> None:
        self.travel_time = require_positive("travel_time", travel_time, ErrorCode.BAD_TIME_CONSTANT)
        self.ts = require_positive("ts", ts, ErrorCode.NO_CYCLE)
        self.span = require_positive("span", span)
        self.x0 = require_finite("x0", x0)
        self.reset()

    @property
    def y(self) -> float:
        """Valve position [%]."""
        return self._x

    @property
    def open_limit(self) -> bool:
        """End switch: fully open."""
        return self._x >= self.span

    @property
    def close_limit(self) -> bool:
        """End switch: fully closed."""
        return self._x <= 0.0

    def step(self, u: float) -> float:
        """Hold the motor command ``u`` (+1, -1 or 0; its sign counts) for one sample."""
        if not math.isfinite(u):
            u = self.u
        self.u = float(u)
        c = (u > 0) - (u < 0)
        self._x = min(max(self._x + c * self.ts * self.span / self.travel_time, 0.0), self.span)
        return self._x

    def reset(self, u0: float = 0.0) -> None:
        """Stop the motor at the initial position ``x0`` (a valve has no steady state of ``u0``)."""
        self.u = 0.0
        self._x = min(max(self.x0, 0.0), self.span)

    def snapshot(self) -> dict[str, Any]:
        return {"x": self._x, "u": self.u}

    def restore(self, snap: dict[str, Any]) -> None:
        self._x, self.u = snap["x"], snap["u"]

    def __repr__(self) -> str:
        return f"MotorValve(travel_time={self.travel_time}, ts={self.ts}, x={self._x:.3f})"
