"""A seeded differential campaign: the compiled lane against the Python path on generated scenarios.

The promise of :mod:`ctrlblocks.sim.dispatch`: every signal, metric and claim
of a run the compiled lane does equals the Python path's (the reference) to
1e-12.  The hand-written tests (test_dispatch*.py) check it on chosen
scenarios; this campaign writes scenario TOML texts from a seeded generator
(:func:`scenario_text`) across the lane's whole domain -- every wiring
(``single`` with a PID or an ADRC of order 1..3, ``cascade``, ``override``,
``feedforward``, ``smith``), linear plants of order 1..3 with and without dead
time and the three-tank process, actuator range and rate, sensor range and
seeded noise, setpoint steps and ramps, loads, mode and manual-value events,
``limits`` events (refused pairs too), faults of ``y`` and ``y2`` (``ok``,
``nan``, overlapping), the warm-up, the PID's forms, discretisations,
anti-windup methods, setpoint weights and filter, the ADRC's orders,
bandwidths and options -- with hostile but accepted values: tiny and huge
gains, observers far faster than the sample rate, ``ts`` near the plant's time
constants, events at t = 0, at the last sample and at the same instant, runs of
one or two samples, and gains that drive a block into its output guard (a
non-finite law result, ``BAD_RESULT``).  Some options the lane does not cover
are drawn on purpose (the run must then fall back and say why).

Each case runs with ``engine="auto"`` and ``engine="python"``: every run of
``auto`` took the lane or logged its reason (logger
``ctrlblocks.sim.dispatch``), all signals agree to 1e-12 with NaN at the same
places, the metrics and the claims are equal; and at least 30 % of each
chunk's runs must take the lane (about 72 % do), so that the campaign does not
test the fallback only.

Size: ``CASES`` cases in chunks of ``CHUNK`` (one test each); the environment
variable ``CTRLBLOCKS_LANE_CASES`` runs more (``CTRLBLOCKS_LANE_SEED``: the
first seed), e.g. ``CTRLBLOCKS_LANE_CASES=3000 pytest -n 2
tests/sim/test_dispatch_campaign.py``.
"""

from __future__ import annotations

import logging
import math
import os
import random
from typing import Any

import numpy as np
import pytest

from ctrlblocks import ADRC, PID
from ctrlblocks.fast._jit import HAVE_NUMBA
from ctrlblocks.sim import parse_scenario, run_scenario

from ..toml_text import toml_table

pytestmark = pytest.mark.skipif(not HAVE_NUMBA, reason="the compiled lane needs numba")

CASES = int(os.environ.get("CTRLBLOCKS_LANE_CASES", "160"))
FIRST_SEED = int(os.environ.get("CTRLBLOCKS_LANE_SEED", "0"))
CHUNK = 20
LANE_SHARE = 0.3
"""The least share of each chunk's runs that must take the lane (about 72 % do)."""


# ---------------------------------------------------------------------------
# the generator
# ---------------------------------------------------------------------------


def _log_uniform(rng: random.Random, lo: float, hi: float) -> float:
    return math.exp(rng.uniform(math.log(lo), math.log(hi)))


def _gain(rng: random.Random, typical: float) -> float:
    """A gain near ``typical``, now and then tiny or huge."""
    r = rng.random()
    if r < 0.06:
        return rng.choice([1e-9, 1e-6, 1e-3, 1e-300])
    if r < 0.12:
        return rng.choice([1e3, 1e6, 1e9])
    if r < 0.15:  # the law's result overflows: the blocks' output guard (BAD_RESULT)
        return rng.choice([1e200, 1e300, 1e308])
    return round(typical * _log_uniform(rng, 0.2, 5.0), 6)


def _plant(rng: random.Random, ts: float, *, inner: bool = False) -> tuple[dict[str, Any], bool]:
    """A plant table and whether it has a finite, non-zero static gain (``initial.y``)."""
    k = rng.choice([1.0, 0.5, 2.0, -1.5, round(rng.uniform(0.1, 3.0), 3)])

    def tc() -> float:
        if rng.random() < 0.3:  # near the sample time
            return round(ts * rng.choice([0.5, 1.0, 1.01, 2.0, 3.0]), 9)
        return round(_log_uniform(rng, 0.5, 20.0), 4)

    def dead() -> dict[str, float]:
        r = rng.random()
        if r < 0.4:
            return {}
        if r < 0.6:  # whole samples, half samples, one sample
            return {"dead_time": round(ts * rng.choice([0.5, 1.0, 1.5, 3.0]), 9)}
        return {"dead_time": round(rng.uniform(0.0, 5.0), 3)}

    kind = rng.choice(["PT1", "FOPDT", "PT2", "PTn", "PT2Osc", "LinearPlant", "IT1"]
                      + ([] if inner else ["ThreeTank"]))  # fmt: skip
    if kind == "PT1":
        return {"type": "PT1", "k": k, "t": tc(), **dead()}, True
    if kind == "FOPDT":
        return {"type": "FOPDT", "k": k, "t": tc(), "dead_time": round(rng.uniform(0, 4), 3)}, True
    if kind == "PT2":
        return {"type": "PT2", "k": k, "t1": tc(), "t2": tc(), **dead()}, True
    if kind == "PTn":
        t = [tc() for _ in range(rng.randint(1, 3))]
        return {"type": "PTn", "k": k, "t": t, **dead()}, True
    if kind == "PT2Osc":
        zeta = rng.choice([0.0, 0.1, 0.7, 1.0, 2.0])
        return {"type": "PT2Osc", "k": k, "t": tc(), "zeta": zeta, **dead()}, zeta > 0
    if kind == "IT1":  # integrating: no steady state for initial.y
        return {"type": "IT1", "k": k, "t": tc(), **dead()}, False
    if kind == "LinearPlant":
        order = rng.randint(1, 3)
        poles = [1.0 / tc() for _ in range(order)]
        den = [1.0]
        for p in poles:  # (s + p) products
            den = [a + p * b for a, b in zip([*den, 0.0], [0.0, *den], strict=True)]
        num = [k * den[-1]] if rng.random() < 0.6 else [round(rng.uniform(0.1, 2), 3), k * den[-1]]
        if len(num) > order:
            num = num[-order:]
        return {"type": "LinearPlant", "num": num, "den": den, **dead()}, True
    return {"type": "ThreeTank", **({"outlet": "b"} if rng.random() < 0.3 else {})}, True


def _limits(rng: random.Random) -> tuple[float, float]:
    r = rng.random()
    if r < 0.15:
        return -math.inf, math.inf
    if r < 0.25:
        return 0.0, round(rng.uniform(0.01, 0.5), 3)  # narrow: at its limit a lot
    lo = rng.choice([0.0, -1.0, -10.0, -100.0])
    return lo, lo + rng.choice([1.0, 5.0, 10.0, 100.0, 200.0])


def _pid(rng: random.Random, ts: float) -> dict[str, Any]:
    lo, hi = _limits(rng)
    d: dict[str, Any] = {"type": "PID", "kp": _gain(rng, 1.0)}
    if rng.random() < 0.85:
        d["ti"] = 0.0 if rng.random() < 0.05 else _gain(rng, 5.0)
    if rng.random() < 0.5:
        d["td"] = _gain(rng, 1.0)
        if rng.random() < 0.5:
            d["n"] = rng.choice([1.0, 5.0, 10.0, 100.0, 1e6])
    for key, choices in (("form", ["isa", "parallel", "series"]),
                         ("integral_method", ["forward", "backward", "tustin"]),
                         ("derivative_method", ["forward", "backward", "tustin"]),
                         ("anti_windup", ["clamping", "back_calc_model", "clamping",
                                          "back_calc_model", "back_calc_real"])):  # fmt: skip
        if rng.random() < 0.6:
            d[key] = rng.choice(choices)
    if max(d["kp"], d.get("ti", 0.0), d.get("td", 0.0)) >= 1e200:
        # a P controller (kp h/ti or kp td/tf would overflow: refused), its law overflowing
        d = {"type": "PID", "kp": max(d["kp"], 1e200)}
    tf = d.get("td", 0.0) / d.get("n", 10.0)
    if d.get("derivative_method") == "forward" and (tf <= ts or d.get("form", "isa") != "isa"):
        # refused where Td/N <= ts/2 (unstable); the other forms scale Td
        d["derivative_method"] = "backward"
    if d.get("anti_windup") == "back_calc_model" and rng.random() < 0.5:
        d["tt"] = rng.choice([ts, 0.5, 3.0, 1e-6])
    if rng.random() < 0.4:
        d["b"] = rng.choice([0.0, 0.5, 1.0, 1.5])
    if rng.random() < 0.3:
        d["c"] = rng.choice([0.0, 0.5, 1.0])
    if rng.random() < 0.15:
        d["reverse"] = True
    if rng.random() < 0.25:
        d["safe_value"] = round(rng.uniform(-5, 50), 3)
    if rng.random() < 0.04:  # not covered by the kernel: the run falls back
        d[rng.choice(["sp_filter", "pv_filter", "out_rate", "deadband"])] = 1.0
    if rng.random() < 0.04:
        d["precision"] = "float32"
    if lo > -math.inf:
        d["u_min"] = lo
    if hi < math.inf:
        d["u_max"] = hi
    if lo == -math.inf:
        d["u_min"] = -math.inf
    if hi == math.inf:
        d["u_max"] = math.inf
    return d


def _adrc(rng: random.Random, ts: float) -> dict[str, Any]:
    lo, hi = _limits(rng)
    oc = _log_uniform(rng, 0.05, 3.0)
    r = rng.random()
    if r < 0.15:  # an observer far faster than the sample rate
        oo = rng.choice([10.0, 100.0, 1e4]) / ts
    else:
        oo = oc * rng.choice([2.0, 3.0, 5.0, 10.0])
    d: dict[str, Any] = {"type": "ADRC", "order": rng.randint(1, 3), "b0": _gain(rng, 0.5),
                         "omega_c": round(oc, 6), "omega_o": round(oo, 6),
                         "u_min": lo, "u_max": hi}  # fmt: skip
    if rng.random() < 0.3:
        d["t_ref"] = rng.choice([0.0, ts, 2.0])
    if rng.random() < 0.3:
        d["u_sf"] = round(rng.uniform(-1, 5), 3)
    if rng.random() < 0.3:
        d["anti_windup"] = rng.choice(["directional", "freeze", "off"])
    if rng.random() < 0.15:
        d["y_sat"] = round(rng.uniform(0.5, 3.0), 3)
        d["y_sat_lo"] = -d["y_sat"]
    if rng.random() < 0.1:
        d["tau_wait"] = rng.choice([ts, 1.0])
    if rng.random() < 0.05:  # not covered by the kernel: the run falls back
        d[rng.choice(["u_real_on", "anti_backoff"])] = True
    if rng.random() < 0.04:
        d["discretisation"] = "exact"
    if rng.random() < 0.04:  # a reverse-acting ADRC: not in the kernels either
        d["reverse"] = True
    if rng.random() < 0.04:
        d["precision"] = "float32"
    return d


def _accepted(d: dict[str, Any], ts: float) -> dict[str, Any]:
    """``d``, or a plain PI with its limits where the block refuses the draw (a gain
    whose coefficient overflows: ``kp = 1e-300`` in the parallel form with ``td = 1e9``)."""
    try:
        (PID if d["type"] == "PID" else ADRC)(**{k: v for k, v in d.items() if k != "type"},
                                              ts=ts)  # fmt: skip
    except ValueError:  # ParameterError
        return {"type": "PID", "kp": 1.0, "ti": 5.0, "u_min": d["u_min"], "u_max": d["u_max"]}
    return d


def _block(rng: random.Random, ts: float, adrc_share: float = 0.35) -> dict[str, Any]:
    return _accepted(_adrc(rng, ts) if rng.random() < adrc_share else _pid(rng, ts), ts)


def _sub(name: str, d: dict[str, Any]) -> str:
    return toml_table(name, **d)


def _controllers(rng: random.Random, structure: str, ts: float) -> str:
    out = []
    for i in range(rng.randint(1, 3)):
        name = f"c{i}"
        if structure == "single":
            out.append(toml_table("[controllers]", name=name, **_block(rng, ts)))
        elif structure == "cascade":
            head = {"name": name}
            if rng.random() < 0.3:
                head["aw_handshake"] = rng.random() < 0.5
            out.append(toml_table("[controllers]", **head)
                       + _sub("controllers.primary", _block(rng, ts))
                       + _sub("controllers.secondary", _block(rng, ts)))  # fmt: skip
        elif structure == "override":
            text = toml_table("[controllers]", name=name,
                              selector=rng.choice(["min", "max"]))  # fmt: skip
            for j in range(rng.randint(2, 4)):
                b = _block(rng, ts)
                b["measure"] = "y" if j == 0 else rng.choice(["y", "y2"])
                if j > 0 and rng.random() < 0.7:
                    b["sp"] = round(rng.uniform(0.0, 2.0), 3)
                text += _sub("[controllers.blocks]", b)
            out.append(text)
        elif structure == "feedforward":
            main = _accepted(_pid(rng, ts), ts)
            ff: dict[str, Any] = {"type": "LeadLag", "k": round(rng.uniform(-2, 2), 3),
                                  "t_lead": rng.choice([0.0, 0.5, 2.0, ts]),
                                  "t_lag": rng.choice([0.0, 1.0, 3.0, ts]),
                                  "method": rng.choice(["euler", "tustin"])}  # fmt: skip
            if ff["t_lag"] == 0.0:  # a static gain (Tustin would put the pole at z = -1)
                ff["t_lead"], ff["method"] = 0.0, "euler"
            out.append(toml_table("[controllers]", name=name) + _sub("controllers.main", main)
                       + _sub("controllers.feedforward", ff))  # fmt: skip
        else:  # smith
            main = _block(rng, ts)
            model = {"type": "FOPDT", "k": round(rng.uniform(0.5, 2.0), 3),
                     "t": round(_log_uniform(rng, 0.5, 10.0), 3),
                     "dead_time": round(rng.uniform(0.0, 3.0), 3)}  # fmt: skip
            out.append(toml_table("[controllers]", name=name) + _sub("controllers.main", main)
                       + _sub("controllers.model", model))  # fmt: skip
    return "".join(out)


def _times(rng: random.Random, duration: float, ts: float, k: int) -> list[float]:
    """``k`` event times: anywhere, at 0, at the last sample, on top of each other."""
    out: list[float] = []
    for _ in range(k):
        r = rng.random()
        if r < 0.12:
            t = 0.0
        elif r < 0.22:
            t = duration
        elif r < 0.3:
            t = max(0.0, duration - ts)
        elif r < 0.45 and out:
            t = rng.choice(out)
        else:
            t = round(rng.uniform(0.0, duration), 6)
        out.append(min(t, duration))
    return out


def _events(rng: random.Random, structure: str, duration: float, ts: float, *, y2: bool,
            tank: bool, roles: list[str], header: str = "[events]") -> str:  # fmt: skip
    kinds = ["setpoint", "setpoint", "load", "mode", "manual_value", "limits", "sensor"]
    if tank:
        kinds.append("plant")
    if rng.random() < 0.05:  # events the lane does not cover (a load between plants that
        # are not there is ignored by the Python path, with a warning)
        series = structure in ("cascade", "override")
        kinds.append("set" if series or rng.random() < 0.5 else "load inner")
    n = rng.choice([0, 1, 3, 6, 10, 20])
    dense = rng.random() < 0.15  # all in the first few samples: many in one sample
    evs = []
    for t in _times(rng, min(duration, 3 * ts) if dense else duration, ts, n):
        kind = rng.choice(kinds)
        e: dict[str, Any] = {"t": t, "do": kind.split()[0]}
        if kind == "setpoint":
            e["value"] = round(rng.uniform(-1.0, 3.0), 3)
            if rng.random() < 0.4:
                e["ramp"] = rng.choice([0.01, 0.5, 1e3])
        elif kind == "load":
            at = ["input", "output"] + (["inner"] if structure in ("cascade", "override") else [])
            e["value"] = round(rng.uniform(-1.0, 1.0), 3)
            if rng.random() < 0.7:
                e["at"] = rng.choice(at)
        elif kind == "mode":
            e["mode"] = rng.choice(["manual", "auto"])
            if rng.random() < 0.4:
                e["manual_value"] = round(rng.uniform(-1.0, 5.0), 3)
            if rng.random() < 0.05:
                e["target"] = rng.choice(roles)
        elif kind == "manual_value":
            e["value"] = round(rng.uniform(-1.0, 5.0), 3)
        elif kind == "limits":
            lo = round(rng.uniform(-2.0, 2.0), 3)
            hi = round(lo + rng.uniform(-0.5, 4.0), 3)  # now and then reversed: refused
            e["u_min"], e["u_max"] = lo, hi
            if rng.random() < 0.4:
                e["target"] = rng.choice(roles)
        elif kind == "sensor":
            if y2 and rng.random() < 0.5:
                e["target"] = "y2"
            for f in ("ok", "nan"):
                if rng.random() < 0.6:
                    e[f] = rng.random() < 0.4
        elif kind == "plant":  # the three-tank's outlet valve
            e["param"], e["value"] = "outlet", rng.choice(["a", "b"])
        elif kind == "set":  # not covered by the lane: the run falls back
            e.update(attr="u_min", value=-1000.0)
        else:
            e.update(value=0.1, at="inner")
        evs.append(e)
    return "".join(toml_table(header, **e) for e in evs)


def scenario_text(seed: int) -> str:
    """A valid scenario (TOML) for the seed: the campaign's case number ``seed``."""
    rng = random.Random(seed)
    structure = rng.choice(["single", "single", "single", "cascade", "override", "feedforward",
                            "smith"])  # fmt: skip
    ts = rng.choice([0.01, 0.05, 0.1, 0.1, 0.2, 0.5, 1.0])
    r = rng.random()
    n = rng.choice([1, 2]) if r < 0.08 else rng.randint(3, 60) if r < 0.3 else rng.randint(60, 400)
    duration = round(n * ts, 9)
    plant, static = _plant(rng, ts)
    tank = plant["type"] == "ThreeTank"
    head: dict[str, Any] = {}
    if rng.random() < 0.15:  # the runs cut short (check_case runs quick)
        head["quick_duration"] = round(rng.randint(1, n) * ts, 9)
    if rng.random() < 0.1:
        head["metrics"] = {"band": rng.choice([0.05, 0.5]), "windows": rng.random() < 0.5}
    text = toml_table("scenario", name=f"lane{seed}", title="campaign", source="test",
                      structure=structure, ts=ts, duration=duration,
                      seed=rng.randint(0, 2**31),
                      **{k: v for k, v in head.items() if k != "metrics"})  # fmt: skip
    if "metrics" in head:
        text += toml_table("metrics", **head["metrics"])
    text += toml_table("plant", **plant)
    inner_static = True
    if structure in ("cascade", "override"):
        inner, inner_static = _plant(rng, ts, inner=True)
        text += toml_table("inner_plant", **inner)
    if rng.random() < 0.6:
        act: dict[str, Any] = {}
        if rng.random() < 0.7:
            act["u_min"], act["u_max"] = (0.0, 5.0) if tank else _limits(rng)
        if rng.random() < 0.4:
            act["rate"] = rng.choice([0.01, 1.0, 10.0, 1e6])
        text += toml_table("actuator", **act)
    if rng.random() < 0.7:
        sen: dict[str, Any] = {}
        if rng.random() < 0.4:
            sen["y_min"], sen["y_max"] = rng.choice([(0.0, 2.0), (-1.0, 1.0), (0.5, 0.6)])
        if rng.random() < 0.6:
            sen["noise"] = rng.choice([0.0, 1e-3, 0.05, 0.5])
            if rng.random() < 0.4:
                sen["noise_kind"] = rng.choice(["uniform", "gaussian"])
            if rng.random() < 0.3:
                sen["noise_t_corr"] = rng.choice([0.0, ts, 2.0])
        text += toml_table("sensor", **sen)
    ini: dict[str, Any] = {}
    series = structure in ("cascade", "override")
    if tank and not series:
        ini["y"] = rng.choice([1.0, 1.5, 2.0])
    elif tank:  # through an inner plant of any gain: the tank's input
        ini["u"] = round(rng.uniform(0.5, 3.0), 3)
    elif static and inner_static and rng.random() < 0.6:
        ini["y"] = round(rng.uniform(-1.0, 2.0), 3) or 0.5
    elif rng.random() < 0.7:
        ini["u"] = round(rng.uniform(-1.0, 2.0), 3)
    if rng.random() < 0.3:
        ini["sp"] = round(rng.uniform(0.0, 2.0), 3)
    if rng.random() < 0.2:
        ini["load"] = round(rng.uniform(-0.5, 0.5), 3)
    if rng.random() < 0.5:
        ini["warmup"] = rng.choice([ts, 2 * ts, 1.0, 5.0])
    if rng.random() < 0.15:
        ini["mode"] = "manual"
    if ini:
        text += toml_table("initial", **ini)
    ctrl_text = _controllers(rng, structure, ts)
    n_ctrl = ctrl_text.count("[[controllers]]")
    text += ctrl_text
    roles = {"single": ["main"], "cascade": ["primary", "secondary"],
             "override": ["blocks[0]", "blocks[1]"], "feedforward": ["main"],
             "smith": ["main"]}[structure]  # fmt: skip
    y2 = structure == "cascade" or (structure == "override" and 'measure = "y2"' in text)
    text += _events(rng, structure, duration, ts, y2=y2, tank=tank, roles=roles)
    cases = ["main"]
    if rng.random() < 0.2:  # several cases: the lane's arrays are kept per case
        cases = [f"k{i}" for i in range(rng.randint(1, 3))]
        for name in cases:
            dur = round(rng.randint(1, n) * ts, 9) if rng.random() < 0.6 else duration
            text += toml_table("[cases]", name=name, duration=dur)
            text += _events(rng, structure, dur, ts, y2=y2, tank=tank, roles=roles,
                            header="[cases.events]")  # fmt: skip
    for _ in range(rng.choice([0, 0, 1, 3])):
        text += _claim(rng, n_ctrl, cases)
    return text


def _claim(rng: random.Random, n_ctrl: int, cases: list[str]) -> str:
    """A claim on a metric or a signal statistic of the runs (checked on both engines)."""
    c: dict[str, Any] = {"text": "claim", "case": rng.choice(cases)}
    c["metric"] = rng.choice(["iae", "ise", "overshoot", "settling_time", "tv_u", "jump_u"])
    if rng.random() < 0.3:
        c["signal"] = rng.choice(["u", "ym", "y"])
        c["metric"] = rng.choice(["max", "min", "final", "mean", "max_step"])
    if rng.random() < 0.3:
        c["window"] = rng.randint(0, 2)
    kind = rng.choice(["below", "above", "between", "approx", "less", "best"])
    if kind in ("less", "best") and n_ctrl < 2:
        kind = "below"
    if kind == "less":
        c["less"] = ["c0", f"c{rng.randint(1, n_ctrl - 1)}"]
    elif kind == "best":
        c["best"] = f"c{rng.randrange(n_ctrl)}"
    else:
        c["controller"] = f"c{rng.randrange(n_ctrl)}"
        c[kind] = [0.0, 1.0] if kind == "between" else rng.choice([0.1, 1.0, 1e6])
        if kind == "approx":
            c["tol"] = 0.5
    return toml_table("[claims]", **c)


# ---------------------------------------------------------------------------
# the oracle
# ---------------------------------------------------------------------------


class _Fallbacks(logging.Handler):
    """The dispatcher's DEBUG lines "scenario / controller / case: Python path (reason)"."""

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.lines.append(record.getMessage())


def _same_value(a: Any, b: Any) -> bool:
    """Equal, NaN equal to NaN, through dicts and lists (metrics, claims)."""
    if isinstance(a, dict):
        return (
            isinstance(b, dict) and a.keys() == b.keys() and all(_same_value(a[k], b[k]) for k in a)
        )
    if isinstance(a, list | tuple):
        return (isinstance(b, list | tuple) and len(a) == len(b)
                and all(_same_value(x, y) for x, y in zip(a, b, strict=True)))  # fmt: skip
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a):
        return math.isnan(b)
    return bool(a == b)


def check_case(text: str) -> tuple[int, int, list[str]]:
    """Run ``text`` on both engines; ``(runs, runs on the lane, fallback lines)``.

    Raises AssertionError (naming the run and the signal) where they differ.
    """
    sc = parse_scenario(text)
    log = logging.getLogger("ctrlblocks.sim.dispatch")
    handler, level = _Fallbacks(), log.level
    log.addHandler(handler)
    log.setLevel(logging.DEBUG)
    try:
        auto = run_scenario(sc, quick=True)
    finally:
        log.removeHandler(handler)
        log.setLevel(level)
    ref = run_scenario(sc, quick=True, engine="python")
    keys = [(r.controller, r.case) for r in ref.runs]
    assert [(r.controller, r.case) for r in auto.runs] == keys
    fell = set()
    for line in handler.lines:
        where, sep, why = line.partition(": Python path (")
        assert sep and why.endswith(")") and len(why) > 1, line  # a reason is given
        _sc, ctrl, case = where.split(" / ")
        fell.add((ctrl, case))
    assert fell <= set(keys)
    for ra, rb in zip(auto.runs, ref.runs, strict=True):
        run = f"{ra.controller} / {ra.case}"
        assert list(ra.signals) == list(rb.signals), run
        for name, x in ra.signals.items():
            y = rb.signals[name]
            assert x.shape == y.shape, (run, name)
            np.testing.assert_allclose(x, y, rtol=0.0, atol=1e-12, equal_nan=True,
                                       err_msg=f"{run}: {name}")  # fmt: skip
        assert ra.events == rb.events and ra.duration == rb.duration, run
    assert _same_value(auto.metrics, ref.metrics), "metrics differ"
    assert len(auto.claims) == len(ref.claims)
    for ca, cb in zip(auto.claims, ref.claims, strict=True):
        assert _same_value(vars(ca), vars(cb)), (ca, cb)
    return len(keys), len(keys) - len(fell), handler.lines


# ---------------------------------------------------------------------------
# the tests
# ---------------------------------------------------------------------------

_CHUNKS = [range(s, min(s + CHUNK, FIRST_SEED + CASES))
           for s in range(FIRST_SEED, FIRST_SEED + CASES, CHUNK)]  # fmt: skip


# the first two chunks in the default run, the rest with the long campaigns (pytest -m slow)
@pytest.mark.parametrize(
    "seeds",
    [c if i < 2 else pytest.param(c, marks=pytest.mark.slow) for i, c in enumerate(_CHUNKS)],
    ids=lambda r: f"seeds{r.start}-{r.stop - 1}",
)
def test_the_lane_equals_the_python_path_on_generated_scenarios(seeds):
    runs = lane = 0
    for seed in seeds:
        try:
            n, k, _lines = check_case(scenario_text(seed))
        except AssertionError as exc:
            raise AssertionError(f"seed {seed}:\n{scenario_text(seed)}\n{exc}") from None
        runs, lane = runs + n, lane + k
    assert lane >= LANE_SHARE * runs, f"only {lane} of {runs} runs took the lane"
