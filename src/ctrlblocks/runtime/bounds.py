"""Engineering bounds and units of a loop, as every command path checks them.

The loop's TOML gives them (``docs/faceplate.md``):

* ``sp_range = [lo, hi]``: setpoints an operator may give;
* ``mv_range = [lo, hi]``: the output limits (``u_min``, ``u_max``) and the
  manual value stay inside it; without the key, the block's configured
  limits when both are finite (limits may be narrowed, never widened);
* ``tuning_ranges = {NAME = [lo, hi]}``: per tuning parameter.  A tuning
  without an entry gets a range **derived from the loop** (:func:`derived_tuning_range`),
  so absurd values are refused without any configuration:

  ==================================  ==============================================
  parameter (what it is)              derived range
  ==================================  ==============================================
  gains ``kp``, ``b0``, ``ff_k``      1/100 .. 100 times the configured magnitude
                                      (kp: at most twice the ultimate gain of the
                                      loop's identified model, where one is known)
  times ``ti``, ``td``, filters,      ts/10 .. max(10^4 ts, 100 x configured) [s];
  ``t_ref``, ``td_time``, ...         0 where the block takes 0 (off)
  bandwidths ``omega_c``, ``omega_o`` 1/100 .. 100 times the configured value, and
                                      below the stability limit of the discretised
                                      chain at ts (Euler: omega ts < 2^((m+1)/m) - 2,
                                      m = n for the controller, n + 1 for the
                                      observer; exact: pi/ts, Nyquist)
  ``order``                           1, 2, 3
  ``n`` (derivative filter)           1 .. 100
  ``b``, ``c`` (set-point weights)    0 .. 2
  anything else numeric               the block's sign domain (probed with -1, 0 and
                                      the value in force), magnitude at most
                                      :data:`TUNING_MAGNITUDE`, +-inf where the block
                                      takes it (``y_sat = inf``: no limit)
  ==================================  ==============================================

  A value the block's own validation refuses is refused with the block's
  code; the ranges catch what the block would accept but no loop should run
  with (``ti = 1e-300`` turns a PID into an on/off controller, ``kp = 1e6``,
  ``omega_o`` above the observer's stability limit);
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

import dataclasses
import functools
import math
from collections.abc import Mapping
from typing import Any

from ..blocks.base import ErrorCode

__all__ = [
    "TUNING_MAGNITUDE",
    "LoopBounds",
    "Range",
    "derived_tuning_range",
    "stability_limit",
    "ultimate_gain",
]

TUNING_MAGNITUDE = 1e6
"""Largest magnitude of a finite tuning value without a configured or derived range."""

_GAINS = ("kp", "b0", "ff_k")
_TIMES = ("ti", "td", "sp_filter", "pv_filter", "t_stab", "ff_t_lead", "ff_t_lag", "t_ref",
          "tau_wait", "tt", "td_time")  # fmt: skip
_BANDWIDTHS = ("omega_c", "omega_o")
_FIXED = {"order": (1.0, 3.0, True), "n": (1.0, 100.0, False), "b": (0.0, 2.0, False),
          "c": (0.0, 2.0, False)}  # fmt: skip


@dataclasses.dataclass(frozen=True)
class Range:
    """An engineering range ``lo .. hi`` (``lo_open``: ``lo`` itself excluded).

    ``zero_ok``: 0 (off) is inside too; ``symmetric``: ``-hi .. -lo`` as well;
    ``integer``: whole numbers; ``generic``: only finite with magnitude at most
    :data:`TUNING_MAGNITUDE` (the sign domain is the block's); ``unit`` and
    ``why`` are what the faceplate shows.
    """

    lo: float
    hi: float
    lo_open: bool = False
    inf_ok: bool = False  # +-inf (a disabled limit) accepted
    derived: bool = False  # derived from the loop, not configured
    zero_ok: bool = False
    symmetric: bool = False
    integer: bool = False
    generic: bool = False
    unit: str = ""
    why: str = ""

    def refuses(self, x: float) -> str | None:
        """Why ``x`` is outside (None: inside)."""
        if math.isinf(x) and self.inf_ok:
            return None
        if self.generic:  # the sign domain is the block's to refuse (with its own code)
            if math.isfinite(x) and abs(x) <= TUNING_MAGNITUDE:
                return None
            return f"must be finite with magnitude <= {TUNING_MAGNITUDE:g}, got {x!r}"
        if x == 0.0 and self.zero_ok:
            return None
        v = abs(x) if self.symmetric else x
        inside = (self.lo < v if self.lo_open else self.lo <= v) and v <= self.hi
        if inside and self.integer and v != int(v):
            inside = False
        if inside:
            return None
        why = f" ({self.why})" if self.why else ""
        return f"outside the engineering range {self.text()}{why}, got {x!r}"

    def text(self) -> str:
        """``[0, 5]``, ``(0, 1e+06]``, ``0 or [0.01, 1000] s``."""
        core = f"{'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}]"
        if self.symmetric:
            core = f"+-{core}"
        if self.zero_ok and self.lo > 0:
            core = f"0 or {core}"
        return f"{core} {self.unit}".rstrip()

    def as_json(self) -> dict[str, Any]:
        return {
            "lo": self.lo,
            "hi": self.hi,
            "lo_open": self.lo_open,
            "inf_ok": self.inf_ok,
            "derived": self.derived,
            "zero_ok": self.zero_ok,
            "symmetric": self.symmetric,
            "integer": self.integer,
            "generic": self.generic,
            "unit": self.unit,
            "why": self.why,
        }


def _accepts(config: Any, name: str, value: float) -> bool:
    try:
        dataclasses.replace(config, **{name: value}).validate()
    except Exception:  # a ParameterError, or a type the field cannot take
        return False
    return True


def stability_limit(n: int, chain: str, discretisation: str, ts: float) -> float:
    """The largest bandwidth [rad/s] the ADRC's discretised ``chain`` is stable with at ``ts``.

    Euler (Nowak et al. 2018, (4a); the poles of its image ``P_m``,
    :mod:`ctrlblocks.blocks.adrc`): ``omega ts < 2^((m+1)/m) - 2`` with
    ``m = n`` for the controller (``chain = "controller"``) and ``n + 1`` for
    the observer; exact discretisation: the Nyquist frequency ``pi / ts``.
    """
    if discretisation == "exact":
        return math.pi / ts
    m = n + 1 if chain == "observer" else n
    return (2.0 ** ((m + 1) / m) - 2.0) / ts


def ultimate_gain(gain: float, time_constant: float, dead_time: float) -> float:
    """The ultimate gain of ``gain e^(-dead_time s) / (time_constant s + 1)``.

    The phase crossover ``atan(w T) + w L = pi`` is found by bisection;
    ``ku = sqrt(1 + (w T)^2) / |K|`` (inf without a dead time).
    """
    k, t, dl = abs(gain), max(time_constant, 0.0), max(dead_time, 0.0)
    if dl <= 0.0 or k == 0.0:
        return math.inf
    lo, hi = 0.0, math.pi / dl  # the phase is below pi at 0 and at least pi at pi/L
    for _ in range(200):
        w = 0.5 * (lo + hi)
        if math.atan(w * t) + w * dl < math.pi:
            lo = w
        else:
            hi = w
    w = 0.5 * (lo + hi)
    return math.sqrt(1.0 + (w * t) ** 2) / k


def _generic(config: Any, name: str, v: float) -> Range:
    m = TUNING_MAGNITUDE
    if _accepts(config, name, -1.0 if isinstance(v, float) else -1):
        lo, lo_open = -m, False
    else:
        lo, lo_open = 0.0, not _accepts(config, name, 0.0 if isinstance(v, float) else 0)
    inf_ok = (isinstance(v, float) and math.isinf(v)) or _accepts(config, name, math.inf)
    return Range(lo, m, lo_open, inf_ok=inf_ok, derived=True, generic=True)


def derived_tuning_range(
    config: Any, name: str, ts: float | None = None, model: Mapping[str, Any] | None = None
) -> Range | None:
    """The default range of numeric tuning ``name`` (module docstring; None: not a number).

    ``ts`` is the loop's sample time (default the block's), ``model`` an
    identified FOPDT (``gain``, ``time_constant``, ``dead_time``) where known.
    """
    v = getattr(config, name)
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    ts = float(ts if ts is not None else getattr(config, "ts", 0.1))
    if not math.isfinite(v):
        return _generic(config, name, v)
    a = abs(float(v))
    negative = _accepts(config, name, -1.0)
    if name in _FIXED:
        lo, hi, integer = _FIXED[name]
        lo, hi = min(lo, a), max(hi, a)  # the configured value stays inside
        return Range(lo, hi, derived=True, integer=integer, why="the usual range")
    if name in _GAINS and a > 0.0:
        lo, hi = a / 100.0, 100.0 * a
        why = "1/100 to 100 times the configured value"
        if name == "kp" and model is not None and model.get("kind", "FOPDT") == "FOPDT":
            ku = ultimate_gain(model["gain"], model["time_constant"], model["dead_time"])
            if math.isfinite(ku) and 2.0 * ku < hi:
                hi = max(2.0 * ku, a)
                why = "at most twice the ultimate gain of the identified model"
        return Range(lo, hi, derived=True, symmetric=negative, zero_ok=_accepts(config, name, 0.0),
                     why=why)  # fmt: skip
    if name in _TIMES:
        hi = max(1e4 * ts, 100.0 * a)
        return Range(ts / 10.0, hi, derived=True, zero_ok=_accepts(config, name, 0.0), unit="s",
                     why=f"a tenth of ts {ts:g} s to {hi:g} s")  # fmt: skip
    if name in _BANDWIDTHS and a > 0.0:
        n = int(getattr(config, "order", 2))
        chain = "observer" if name == "omega_o" else "controller"
        limit = stability_limit(n, chain, str(getattr(config, "discretisation", "euler")), ts)
        hi = min(100.0 * a, limit)
        why = "1/100 to 100 times the configured value"
        if hi == limit:
            why = f"below the {chain}'s stability limit {limit:.4g} rad/s at ts {ts:g} s"
        if hi == limit:
            hi = limit * (1.0 - 1e-9)  # the limit itself is not stable
        return Range(min(a / 100.0, hi), max(hi, a), derived=True, unit="rad/s", why=why)
    return _generic(config, name, v)


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
        self.ts = float(getattr(cfg, "ts", getattr(blk.config, "ts", 0.1)))
        self.model: Mapping[str, Any] | None = None  # an identified FOPDT (set_model)
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
        block's validation costs about a millisecond per loop).

        Derived from the configuration in force when first asked (the file's
        values), so retuning within a range does not move it.
        """
        config = self.block.config
        out: dict[str, Range] = {}
        for f in dataclasses.fields(config):
            if f.name in ("ts", "u_min", "u_max", "safe_value", "u_sf"):
                continue
            if f.name in self._explicit:
                out[f.name] = Range(*self._explicit[f.name])
            elif (r := derived_tuning_range(config, f.name, self.ts, self.model)) is not None:
                out[f.name] = r
        return out

    def set_model(self, model: Mapping[str, Any] | None) -> None:
        """An identified model of the loop's process (a live step test): the ranges follow it."""
        self.model = dict(model) if model else None
        self.__dict__.pop("tunings", None)

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
