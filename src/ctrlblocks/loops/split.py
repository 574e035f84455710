"""Split range: one controller output driving two actuators, with a gap or an overlap.

The split-range structure (:class:`SplitRangeStructure`)
runs one controller whose output ``v`` covers the *combined* range
``[v_min, v_max]`` (the controller's own limits) and maps it to two
actuators by a static, continuous, piecewise-linear function: actuator A on
the low part, actuator B on the high part.  With the split point ``s`` and
the gap ``g`` (negative: an overlap of ``-g``) the two actuator ranges are ::

    A acts on [v_min, a_end],   a_end   = s - g/2
    B acts on [b_start, v_max], b_start = s + g/2

and the actuator values are linear interpolations, constant outside their
range::

    a(v) = a0 + (a1 - a0) clamp((v - v_min) / (a_end - v_min), 0, 1)
    b(v) = b0 + (b1 - b0) clamp((v - b_start) / (v_max - b_start), 0, 1)

``a = [a0, a1]`` is A's value at ``v_min`` and at ``a_end``; ``b = [b0, b1]``
B's value at ``b_start`` and at ``v_max``.  The defaults are a heat/cool
loop: A the cooler (100 % at ``v_min``, off from ``a_end`` on), B the heater
(off up to ``b_start``, 100 % at ``v_max``).  Two valves in sequence (a
small valve first, a large one next) are ``a = [0, 100]``, ``b = [0, 100]``.

Bumpless switching between the actuators
----------------------------------------
The controller's output is continuous (its own bumpless rules), and both
``a`` and ``b`` are continuous functions of it, so the actuator values are
continuous everywhere -- also at the split point, in the gap and in the
overlap (tests/loops/test_split_ratio.py evaluates them on both sides of every
breakpoint).  The controller therefore never switches: crossing the split
point changes which actuator moves, not the signal.

Anti-windup and the limit status of each actuator
-------------------------------------------------
The controller's limits are the combined range ``[v_min, v_max]`` (the
structure refuses a controller with other limits), so its anti-windup acts
exactly when *both* actuators can do no more: at ``v_min`` A is at its far
end (full cooling) and B idle, at ``v_max`` B at its far end and A idle.
An actuator held at its split-side end while the other one acts is *idle*,
not saturated: the controller is inside its range and does not wind up.
Each actuator reports one status (:meth:`SplitRange.status`):

=========  ====  =====================================================
status     code  meaning
=========  ====  =====================================================
active     0     ``v`` inside the actuator's range: it moves with ``v``
idle       1     at its split-side end (``a1`` / ``b0``): the other one acts
limit      2     at its far end (``a0`` at ``v <= v_min``, ``b1`` at
                 ``v >= v_max``): the controller is at its limit, AW active
=========  ====  =====================================================

In the gap both actuators are idle (the controller's integral action moves
``v`` through it); in the overlap both are active.  None of the sources
ctrlblocks implements treats split range: these rules are ctrlblocks'
design, stated here and tested.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from ..blocks.base import ErrorCode, ParameterError, require_finite
from ..blocks.signals import clamp
from .controller import is_controller
from .structure import ENTRY_KEYS, Structure
from .wiring import Loop, OutputStage, Wiring

__all__ = ["ACTIVE", "IDLE", "LIMIT", "STATUS_NAMES", "SplitOutput", "SplitRange",
           "SplitRangeStructure"]  # fmt: skip

ACTIVE, IDLE, LIMIT = 0, 1, 2
"""Limit status codes of an actuator (module docstring)."""

STATUS_NAMES = ("active", "idle", "limit")
"""The status names by code."""


@dataclasses.dataclass(frozen=True)
class SplitRange:
    """The split function of the module docstring (validated; immutable).

    Parameters
    ----------
    v_min, v_max : float
        The controller's output range (its limits) [controller output units, e.g. %].
    split : float, optional
        The split point ``s`` (default the middle of the range).
    gap : float
        Width of the dead zone around the split point where neither actuator
        moves (> 0), or of the overlap where both move (< 0).
    a : pair of float
        Actuator A's value at ``v_min`` and at ``a_end`` [A's units, e.g. %].
    b : pair of float
        Actuator B's value at ``b_start`` and at ``v_max`` [B's units].
    """

    v_min: float = 0.0
    v_max: float = 100.0
    split: float | None = None
    gap: float = 0.0
    a: tuple[float, float] = (100.0, 0.0)
    b: tuple[float, float] = (0.0, 100.0)

    def __post_init__(self) -> None:
        lo = require_finite("v_min", self.v_min, ErrorCode.BAD_LIMITS)
        hi = require_finite("v_max", self.v_max, ErrorCode.BAD_LIMITS)
        if not lo < hi:
            raise ParameterError(ErrorCode.BAD_LIMITS, "v_min", f"must be below v_max ({hi!r})")
        s = 0.5 * (lo + hi) if self.split is None else require_finite("split", self.split)
        g = require_finite("gap", self.gap)
        object.__setattr__(self, "split", s)
        for name in ("a", "b"):
            pair = getattr(self, name)
            if not (isinstance(pair, (tuple, list)) and len(pair) == 2):
                raise ParameterError(
                    ErrorCode.BAD_PARAMETER, name, f"must be a pair [start, end], got {pair!r}"
                )
            v0, v1 = (require_finite(name, x) for x in pair)
            if v0 == v1:
                raise ParameterError(ErrorCode.BAD_PARAMETER, name, "the two values must differ")
            object.__setattr__(self, name, (v0, v1))
        if not lo < s - g / 2 <= hi:
            raise ParameterError(
                ErrorCode.BAD_PARAMETER,
                "split",
                f"actuator A's range [v_min, split - gap/2] = [{lo:g}, {s - g / 2:g}] is empty "
                f"or leaves [{lo:g}, {hi:g}]",
            )
        if not lo <= s + g / 2 < hi:
            raise ParameterError(
                ErrorCode.BAD_PARAMETER,
                "split",
                f"actuator B's range [split + gap/2, v_max] = [{s + g / 2:g}, {hi:g}] is empty "
                f"or leaves [{lo:g}, {hi:g}]",
            )
        object.__setattr__(self, "v_min", lo)
        object.__setattr__(self, "v_max", hi)
        object.__setattr__(self, "gap", g)

    @classmethod
    def from_table(cls, table: dict[str, Any], v_min: float, v_max: float) -> SplitRange:
        """The split of a TOML table (``split``, ``gap``, ``a``, ``b``) on ``v_min..v_max``."""
        kw = dict(table)
        for name in ("a", "b"):
            if isinstance(kw.get(name), list):
                kw[name] = tuple(kw[name])
        return cls(v_min=v_min, v_max=v_max, **kw)

    @property
    def a_end(self) -> float:
        """Where actuator A's range ends (``split - gap/2``)."""
        return self.split - self.gap / 2  # type: ignore[operator]

    @property
    def b_start(self) -> float:
        """Where actuator B's range starts (``split + gap/2``)."""
        return self.split + self.gap / 2  # type: ignore[operator]

    def a_of(self, v: float) -> float:
        """Actuator A's value for the controller output ``v``."""
        t = clamp((v - self.v_min) / (self.a_end - self.v_min), 0.0, 1.0)
        return self.a[0] + (self.a[1] - self.a[0]) * t

    def b_of(self, v: float) -> float:
        """Actuator B's value for the controller output ``v``."""
        t = clamp((v - self.b_start) / (self.v_max - self.b_start), 0.0, 1.0)
        return self.b[0] + (self.b[1] - self.b[0]) * t

    def __call__(self, v: float) -> tuple[float, float]:
        """``(a(v), b(v))``; a non-finite ``v`` gives the split-side ends ``(a1, b0)``.

        The controllers never give a non-finite output (their contract), and
        the runtime's MV guard replaces one by the loop's safe value before
        the split, so the last case is a guard only.
        """
        if not math.isfinite(v):
            return self.a[1], self.b[0]
        return self.a_of(v), self.b_of(v)

    def status(self, v: float) -> tuple[int, int]:
        """The limit status codes of A and B at ``v`` (module docstring's table)."""
        if not math.isfinite(v):
            return IDLE, IDLE
        sa = LIMIT if v <= self.v_min else IDLE if v >= self.a_end else ACTIVE
        sb = LIMIT if v >= self.v_max else IDLE if v <= self.b_start else ACTIVE
        return sa, sb


class SplitOutput(OutputStage):
    """The split of the controller output: signals ``u_a``, ``u_b`` and their status codes.

    The MV stays the controller output (the split is the structure's
    :meth:`SplitRangeStructure.actuator_values`); the controller tracks it.
    """

    def shape(self, side, v, m):
        split: SplitRange = side.spec.options["split"]
        a, b = split(v)
        sa, sb = split.status(v)
        return v, {"u_a": a, "u_b": b, "a_status": float(sa), "b_status": float(sb)}


class SplitRangeStructure(Structure):
    """One controller, two actuators by a static split of its output (module docstring).

    The entry has the controller table ``main`` and the split table ``split``
    (``split``, ``gap``, ``a``, ``b`` of :class:`SplitRange`); the split's
    combined range is the controller's limits ``u_min..u_max`` (its
    anti-windup acts when both actuators are at their far ends).  The
    controller output ``v`` is continuous and the MVs ``u_a = a(v)``,
    ``u_b = b(v)`` are continuous functions of it: no bump when the active
    actuator changes.  Signals: ``u_a``, ``u_b`` and their limit status
    codes ``a_status``, ``b_status`` (0 active, 1 idle, 2 limit).
    """

    name = "split_range"
    roles = ("main",)
    options = ("split",)
    actuators = 2
    wiring = Wiring((Loop("main"),), output=SplitOutput())

    def parse(self, r, e, key, ts, tune):
        r.check_keys(e, {*ENTRY_KEYS, "main", "split"}, key)
        main = r.role(e, "main", key, ts, tune)
        block = r.build(main, ts, kind="block")
        lo, hi = (block.u_min, block.u_max) if is_controller(block) else (math.nan, math.nan)
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise r.fail(
                f"{key}.main.u_min",
                "the split range needs the controller's finite limits u_min and u_max "
                "(they are the two actuators' combined range)",
            )
        table = r.table(e, "split", f"{key}.split", False)
        r.check_keys(table, {"split", "gap", "a", "b"}, f"{key}.split")
        try:
            split = SplitRange.from_table(table, float(lo), float(hi))
        except ParameterError as exc:
            raise r.fail(f"{key}.split.{exc.field}", exc.message) from None
        except TypeError as exc:  # pragma: no cover - keys are checked above
            raise r.fail(f"{key}.split", str(exc)) from None
        return {"main": main}, {"split": split}

    def actuator_values(self, spec, u):
        return spec.options["split"](u)
