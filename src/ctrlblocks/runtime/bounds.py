"""Engineering bounds and units of a loop, as every command path checks them.

The loop's TOML gives them (``docs/faceplate.md``):

* ``sp_range = [lo, hi]``: setpoints an operator may give;
* ``mv_range = [lo, hi]``: the output limits (``u_min``, ``u_max``) and the
  manual value stay inside it; without the key, the block's configured
  limits when both are finite (limits may be narrowed, never widened);
* ``tuning_ranges = {NAME = [lo, hi]}``: per tuning parameter.  A tuning
  without an entry gets a range *derived from the block's validation*: its
  sign domain as the block's ``validate`` accepts it (probed with -1, 0 and
  the value in force), magnitude at most :data:`TUNING_MAGNITUDE`, and
  +-inf only where the block itself accepts it (``y_sat = inf``: no limit).
  Inside the sign domain the block's own check (and its error code) decides;
  the magnitude cap catches what the block would accept but cannot compute
  with (``kp = 1e308`` makes the MV NaN, ``omega_o = 1e308`` overflows);
* ``unit = {pv, sp, mv}`` for the page and the CSV export.

A command outside a range is refused by the loop itself
(:meth:`ctrlblocks.runtime.loop.ControlLoop.command` raises a ``CommandError``
naming the field, with the code of :meth:`LoopBounds.check`), whichever way it
comes -- the faceplate (422), ``Runtime.command`` from Python, the live tuner
-- and the old value stays in force.  The faceplate shows every range next to
its input and asks before a step larger than ``[web] confirm_step`` of the
range.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import math
from collections.abc import Mapping
from typing import Any

from ..blocks.base import ErrorCode

__all__ = ["TUNING_MAGNITUDE", "LoopBounds", "Range", "derived_tuning_range"]

TUNING_MAGNITUDE = 1e6
"""Largest magnitude of a finite tuning value without a configured range."""


@dataclasses.dataclass(frozen=True)
class Range:
    """An engineering range ``lo .. hi`` (``lo_open``: ``lo`` itself excluded)."""

    lo: float
    hi: float
    lo_open: bool = False
    inf_ok: bool = False  # +-inf (a disabled limit) accepted
    derived: bool = False  # from the block's validation, not the configuration

    def refuses(self, x: float) -> str | None:
        """Why ``x`` is outside (None: inside)."""
        if math.isinf(x) and self.inf_ok:
            return None
        if self.derived:  # the sign domain is the block's to refuse (with its own code)
            if math.isfinite(x) and abs(x) <= TUNING_MAGNITUDE:
                return None
            return f"must be finite with magnitude <= {TUNING_MAGNITUDE:g}, got {x!r}"
        inside = (self.lo < x if self.lo_open else self.lo <= x) and x <= self.hi
        return None if inside else f"outside the engineering range {self.text()}, got {x!r}"

    def text(self) -> str:
        """``[0, 5]``, ``(0, 1e+06]``."""
        return f"{'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}]"

    def as_json(self) -> dict[str, Any]:
        return {
            "lo": self.lo,
            "hi": self.hi,
            "lo_open": self.lo_open,
            "inf_ok": self.inf_ok,
            "derived": self.derived,
        }


def _accepts(config: Any, name: str, value: float) -> bool:
    try:
        dataclasses.replace(config, **{name: value}).validate()
    except Exception:  # a ParameterError, or a type the field cannot take
        return False
    return True


def derived_tuning_range(config: Any, name: str) -> Range | None:
    """The default range of numeric tuning ``name`` from the block's ``validate`` (or None)."""
    v = getattr(config, name)
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    m = TUNING_MAGNITUDE
    if _accepts(config, name, -1.0 if isinstance(v, float) else -1):
        lo, lo_open = -m, False
    else:
        lo, lo_open = 0.0, not _accepts(config, name, 0.0 if isinstance(v, float) else 0)
    inf_ok = (isinstance(v, float) and math.isinf(v)) or _accepts(config, name, math.inf)
    return Range(lo, m, lo_open, inf_ok=inf_ok, derived=True)


def _number(x: Any) -> float | None:
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        return None
    return float(x)


class LoopBounds:
    """The engineering bounds, units and confirmation step of one loop of a runtime.

    Parameters
    ----------
    loop : ControlLoop
        The runtime's loop (its ``config`` and ``block``).
    confirm_step : float
        Fraction of a range above which the page asks before sending a step.
    """

    def __init__(self, loop: Any, confirm_step: float = 0.1) -> None:
        cfg = loop.config
        blk = self.block = loop.block
        self.units: dict[str, str] = {
            s: str(getattr(cfg, "units", {}).get(s, "")) for s in ("pv", "sp", "mv")
        }
        self.sp = Range(*cfg.sp_range) if getattr(cfg, "sp_range", None) else None
        mv = getattr(cfg, "mv_range", None)
        if mv is None and math.isfinite(blk.u_min) and math.isfinite(blk.u_max):
            mv = (float(blk.u_min), float(blk.u_max)) if blk.u_min < blk.u_max else None
        self.mv = Range(*mv) if mv else None
        self.confirm_step = float(confirm_step)
        self._explicit = dict(getattr(cfg, "tuning_ranges", {}))

    @functools.cached_property
    def tunings(self) -> dict[str, Range]:
        """The range of each numeric tuning (made at the first use: probing the
        block's validation costs about a millisecond per loop)."""
        config = self.block.config
        out: dict[str, Range] = {}
        for f in dataclasses.fields(config):
            if f.name in ("ts", "u_min", "u_max", "safe_value", "u_sf"):
                continue
            if f.name in self._explicit:
                out[f.name] = Range(*self._explicit[f.name])
            elif (r := derived_tuning_range(config, f.name)) is not None:
                out[f.name] = r
        return out

    def with_confirm_step(self, confirm_step: float) -> LoopBounds:
        """The same bounds with another confirmation step (the faceplate's ``[web]`` one)."""
        other = copy.copy(self)
        other.confirm_step = float(confirm_step)
        return other

    def check(self, changes: Mapping[str, Any]) -> tuple[str, str, int] | None:
        """The first change outside its range as ``(field, message, code)`` (None: all inside).

        Only numbers are checked; anything else is left to the loop and the
        block, which refuse it with their own codes -- so are tunings the
        block's own validation refuses (its code tells more than a range).
        """
        for key, rng, code in (
            ("sp", self.sp, ErrorCode.BAD_PARAMETER),
            ("manual_value", self.mv, ErrorCode.BAD_PARAMETER),
            ("u_min", self.mv, ErrorCode.BAD_LIMITS),
            ("u_max", self.mv, ErrorCode.BAD_LIMITS),
        ):
            x = _number(changes.get(key))
            if rng is not None and x is not None and (why := rng.refuses(x)):
                return key, f"{why} {self.unit_of(key)}".rstrip(), int(code)
        tun = changes.get("tunings")
        if isinstance(tun, Mapping) and self._valid_for_block(tun):
            for k, v in tun.items():
                x, rng = _number(v), self.tunings.get(str(k))
                if rng is not None and x is not None and (why := rng.refuses(x)):
                    return f"tunings.{k}", why, int(ErrorCode.BAD_PARAMETER)
        return None

    def _valid_for_block(self, tunings: Mapping[str, Any]) -> bool:
        try:
            dataclasses.replace(self.block.config, **dict(tunings)).validate()
        except Exception:  # ParameterError, or TypeError for an unknown name
            return False
        return True

    def unit_of(self, key: str) -> str:
        """The unit of a command's value (SP: the SP's, manual value and limits: the MV's)."""
        return self.units["sp"] if key == "sp" else self.units["mv"]

    def as_json(self) -> dict[str, Any]:
        """What the page shows (ranges, units, the confirmation step)."""
        return {
            "units": dict(self.units),
            "sp_range": None if self.sp is None else self.sp.as_json(),
            "mv_range": None if self.mv is None else self.mv.as_json(),
            "tuning_ranges": {k: r.as_json() for k, r in self.tunings.items()},
            "confirm_step": self.confirm_step,
        }
