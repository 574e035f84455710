"""Engineering bounds, units and ``[web]``: the keys the faceplate reads.

::

    [[loops]]
    unit = { pv = "bar", mv = "bar" }          # sp: the PV's unit unless given; or unit = "bar"
    sp_range = [0.0, 5.0]                      # setpoints an operator may give
    mv_range = [0.0, 5.0]                      # output limits and manual value stay inside
    tuning_ranges = { b0 = [0.01, 1.0] }       # per tuning; others: derived from the loop

    [web]
    public_view = false                        # true: live state without a login
    confirm_step = 0.1                         # the page asks before a bigger step [range]
    trusted_proxies = ["10.0.0.5"]             # reverse proxies whose X-Forwarded-For counts

The ranges are enforced by :class:`~ctrlblocks.runtime.bounds.LoopBounds`.
"""

from __future__ import annotations

import ipaddress
import math
from collections.abc import Mapping
from typing import Any

from ...loops.structures import ControllerSide
from .model import Binding, LoopConfig, WebConfig

__all__ = ["ENGINEERING_KEYS", "UNIT_SIGNALS", "check_tuning_ranges", "engineering", "web"]

ENGINEERING_KEYS = ("unit", "sp_range", "mv_range", "tuning_ranges")
"""Loop keys of the engineering bounds and units (``docs/faceplate.md``)."""

UNIT_SIGNALS = ("pv", "sp", "mv")
"""Signals that carry a ``unit``."""


def _range(p: Any, raw: Any, key: str) -> tuple[float, float]:
    """``[lo, hi]``: two finite numbers, lo < hi."""
    ok = isinstance(raw, list) and len(raw) == 2
    ok = ok and all(not isinstance(v, bool) and isinstance(v, (int, float)) for v in raw)
    if not ok or not all(math.isfinite(float(v)) for v in raw):
        raise p.fail(key, f"must be [low, high], two finite numbers, got {raw!r}")
    lo, hi = float(raw[0]), float(raw[1])
    if not lo < hi:
        raise p.fail(key, f"low {lo!r} must be below high {hi!r}")
    return lo, hi


def engineering(
    p: Any, raw: Mapping[str, Any], key: str, sp: Binding, manual: Binding | None
) -> dict[str, Any]:
    """The loop's ``unit``, ``sp_range``, ``mv_range`` and ``tuning_ranges`` (LoopConfig fields)."""
    out: dict[str, Any] = {}
    for name in ("sp_range", "mv_range"):
        out[name] = _range(p, raw[name], f"{key}.{name}") if name in raw else None
    for name, b, r in (("sp", sp, out["sp_range"]), ("manual_value", manual, out["mv_range"])):
        if b is not None and not b.is_io and r is not None and not r[0] <= b.value <= r[1]:
            raise p.fail(f"{key}.{name}", f"{b.value!r} is outside [{r[0]!r}, {r[1]!r}]")
    t = p.table(raw, "tuning_ranges", f"{key}.tuning_ranges", required=False)
    out["tuning_ranges"] = {n: _range(p, v, f"{key}.tuning_ranges.{n}") for n, v in t.items()}
    u = raw.get("unit", {})
    if isinstance(u, str):
        u = {"pv": u}
    u = p.as_table(u, f"{key}.unit")
    p.check_keys(u, set(UNIT_SIGNALS), f"{key}.unit")
    units = {s: p.string(u, s, f"{key}.unit.{s}", default="") for s in UNIT_SIGNALS}
    for s, text in units.items():
        if len(text) > 16 or any(c in text for c in '<>&"\n'):
            raise p.fail(f"{key}.unit.{s}", f"a unit of at most 16 plain characters, got {text!r}")
    units["sp"] = units["sp"] or units["pv"]
    out["units"] = units
    return out


def check_tuning_ranges(p: Any, lc: LoopConfig, side: ControllerSide) -> None:
    """Refuse a ``tuning_ranges`` entry that is not a numeric tuning or excludes the value."""
    cfg = side.main.config
    for n, (lo, hi) in lc.tuning_ranges.items():
        k = f"{lc.key}.tuning_ranges.{n}"
        if not hasattr(cfg, n) or n in ("ts", "u_min", "u_max"):
            raise p.fail(k, f"{n!r} is not a tuning of the {lc.block_type} block")
        v = getattr(cfg, n)
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise p.fail(k, f"{n!r} is not a number (got {v!r}): it has no range")
        if not lo <= v <= hi:
            raise p.fail(k, f"the configured {n} = {v!r} is outside [{lo!r}, {hi!r}]")


def web(p: Any, w: dict[str, Any]) -> WebConfig:
    """The ``[web]`` table."""
    p.check_keys(w, {"public_view", "confirm_step", "trusted_proxies"}, "web")
    public = w.get("public_view", False)
    if not isinstance(public, bool):
        raise p.fail("web.public_view", f"must be true or false, got {public!r}")
    step = p.number(w, "confirm_step", "web.confirm_step", 0.1, positive=True)
    if step > 1.0:
        raise p.fail("web.confirm_step", f"a fraction of the range in (0, 1], got {step!r}")
    proxies = w.get("trusted_proxies", [])
    if not isinstance(proxies, list) or not all(isinstance(x, str) for x in proxies):
        raise p.fail("web.trusted_proxies", f"must be a list of addresses, got {proxies!r}")
    for i, x in enumerate(proxies):
        try:
            ipaddress.ip_network(x, strict=False)
        except ValueError:
            raise p.fail(
                f"web.trusted_proxies[{i}]", f"not an IP address or network: {x!r}"
            ) from None
    return WebConfig(public, step, tuple(proxies))
