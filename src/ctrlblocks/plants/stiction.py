"""A control valve with stiction: Choudhury et al.'s two-parameter data-driven model.

Choudhury et al. (2005) describe a sticky valve by two numbers, in % of
the valve span: ``S``, the deadband plus the stickband, and ``J``, the slip jump.
While the valve moves, its position follows the controller output ``x`` with the
offset of half the dead zone::

    y = x - d (S - J) / 2                                          (C1)

(``d = +1`` moving up, ``-1`` moving down).  When ``x`` stops or reverses, the
valve sticks at the input ``x_ss`` of that moment and holds its position.  It
breaks away when the input has moved far enough from ``x_ss``:

* in the opposite direction to its last movement: ``|x - x_ss| > S`` (deadband
  and stickband to cross);
* in the same direction (the input stopped and goes on): ``|x - x_ss| > J``;

and then jumps to (C1): at breakaway the position moves by the slip jump ``J``
in one sample (plus what the input moved past the threshold).  ``J = 0`` is a
pure deadband (backlash) of width ``S``; ``S = J = 0`` a linear valve.  The
input is first limited to the valve's range ``[u_min, u_max]``.

The sticking direction is kept as the direction of the valve's last movement,
as Kano et al. (2004) do for this model: the published flowchart of Choudhury
et al. (2005) compares a restart from rest with ``S`` in its first sample and
with ``J`` afterwards.

The valve is a wrapper plant: ``StictionValve(FOPDT(...), s=5.0, j=1.0)``
between a controller and its process.  ``position`` is the valve position
applied to the process, ``u`` the same.
"""

from __future__ import annotations

import math
from typing import Any

from ..blocks.base import ErrorCode, ParameterError, require_limits, require_nonnegative
from ..blocks.signals import clamp
from .base import Plant
from .wrappers import _Wrapper

__all__ = ["StictionValve"]


class StictionValve(_Wrapper):
    """A sticky control valve in front of ``plant`` (see the module docstring).

    Parameters
    ----------
    plant : Plant
        The process the valve feeds.
    s : float
        Deadband plus stickband ``S`` [input units, % of span for 0..100] >= 0.
    j : float
        Slip jump ``J`` [input units] >= 0.
    u_min, u_max : float
        Range of the valve (finite).

    Examples
    --------
    >>> from ctrlblocks.plants import PT1
    >>> v = StictionValve(PT1(k=1.0, t=10.0, ts=1.0), s=4.0, j=1.0)
    >>> v.reset(50.0)
    >>> [v.valve(x) for x in (50.5, 51.0, 51.5, 52.0, 49.0, 48.0, 47.5)]
    [50.0, 50.0, 50.0, 50.5, 50.5, 50.5, 49.0]
    """

    def __init__(
        self, plant: Plant, *, s: float, j: float, u_min: float = 0.0, u_max: float = 100.0
    ) -> None:
        super().__init__(plant)
        self.s = require_nonnegative("s", s)
        self.j = require_nonnegative("j", j)
        self._lo, self._hi = require_limits(
            "u_min", u_min, "u_max", u_max, allow_infinite=False
        )
        if self.s > self._hi - self._lo:
            raise ParameterError(ErrorCode.BAD_PARAMETER, "s", "is wider than the valve's range")
        self.reset(0.0)

    @property
    def y(self) -> float:
        """The plant's output."""
        return self.inner.y

    @property
    def position(self) -> float:
        """Valve position [input units], applied to the plant."""
        return self.u

    @property
    def stuck(self) -> bool:
        """True while the valve sticks."""
        return not self._moving

    def valve(self, u: float) -> float:
        """One sample of the valve alone: the position for the controller output ``u``."""
        x = clamp(u, self._lo, self._hi)
        dx = x - self._x_prev
        if self._moving and (dx == 0.0 or (dx > 0.0) != (self._d > 0.0)):
            self._moving = False  # stops or reverses: sticks where the input turned
            self._x_ss = self._x_prev
        if not self._moving:
            travel = self._d * (x - self._x_ss)
            if travel < -self.s:  # the other way: deadband and stickband crossed
                self._d = -self._d
                self._moving = True
            elif travel > self.j:  # on the same way: the stickband crossed
                self._moving = True
        if self._moving:
            self.u = clamp(x - self._d * (self.s - self.j) / 2.0, self._lo, self._hi)
        self._x_prev = x
        return self.u

    def step(self, u: float) -> float:
        """Move the valve for the controller output ``u``; the plant runs one sample."""
        if not math.isfinite(u):
            u = self._x_prev
        self.u_cmd = float(u)
        return self.inner.step(self.valve(self.u_cmd))

    def reset(self, u0: float = 0.0) -> None:
        """At rest, stuck at the position ``u0`` (limited), the plant steady there."""
        u0 = clamp(float(u0) if math.isfinite(u0) else self._lo, self._lo, self._hi)
        self.u = self.u_cmd = self._x_prev = self._x_ss = u0
        self._d = 1.0
        self._moving = False
        self.inner.reset(u0)

    def snapshot(self) -> dict[str, Any]:
        """Own state plus the inner plant's."""
        return {
            "u": self.u, "u_cmd": self.u_cmd, "x_prev": self._x_prev, "x_ss": self._x_ss,
            "d": self._d, "moving": self._moving, "inner": self.inner.snapshot(),
        }  # fmt: skip

    def restore(self, snap: dict[str, Any]) -> None:
        """Put back a state taken by :meth:`snapshot`."""
        self.u, self.u_cmd = float(snap["u"]), float(snap["u_cmd"])
        self._x_prev, self._x_ss = float(snap["x_prev"]), float(snap["x_ss"])
        self._d, self._moving = float(snap["d"]), bool(snap["moving"])
        self.inner.restore(snap["inner"])

    def __repr__(self) -> str:
        return f"StictionValve({self.inner!r}, s={self.s!r}, j={self.j!r})"
