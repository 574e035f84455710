"""A seeded generator of hostile input sequences for the exported FBs and the float32 blocks.

:func:`hostile_trace` drives a ``precision="float32"`` block with, in every
sample and at random (a seeded :class:`numpy.random.Generator`):

* set points and measurements from a pool of plain values and hostile ones:
  NaN, +-inf, +-1.7e308 (inf as a REAL), +-3e38 (a REAL whose arithmetic
  overflows), denormals (1e-40, -1.4e-45), +-0.0, 1e30, 1e-30;
* the quality flag off, and the modes switched: MANUAL (with a hostile
  manual value), RST, TRACK (hostile tracking values), HOLD, AWIN, ENABLE
  (the ADRC: MANUAL, RST, TRACK, HOLD, AWIN; hostile FF values too);
* retunes through ``configure()`` of any tuning field, with random values
  (the ones the block refuses are dropped, as an operator's would be), new
  limits, the other algorithm or discretisation;
* a jittering cycle time ``dt`` (written to ``TS``), sometimes hostile itself
  (0, 1e-30, 1e30, NaN, negative);

and records what the FB gets written (only the inputs that change) and the
block's outputs.  The same trace then drives the compiled FB.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ctrlblocks import ADRC, PID, LeadLag, ParameterError
from ctrlblocks.blocks import plc_cycle as pc
from ctrlblocks.plc.specs import spec_for

HOSTILE = (math.nan, math.inf, -math.inf, 1.7e308, -1.7e308, 3e38, -3e38, 1e-40, -1.4e-45,
           0.0, -0.0, 1e30, 1e-30)  # fmt: skip
"""Process values that break a careless REAL implementation."""

BAD_DT = (0.0, 1e-30, 1e30, math.nan, -0.1)
"""Cycle times a broken task clock may give."""


STARTS: list[tuple[str, dict[str, Any]]] = [
    ("pid", {"kp": 1.5, "ti": 4.0, "td": 0.5, "ts": 0.1, "u_min": 0.0, "u_max": 100.0}),
    ("pid", {"kp": 2.0, "ti": 3.0, "algorithm": "velocity", "sp_filter": 1.0, "pv_filter": 0.5,
             "sp_rate": 10.0, "out_rate": 30.0, "ff_k": 1.0, "ff_t_lag": 2.0}),
    ("pid", {"kp": 1.0, "ti": 2.0, "deadband": 1.0, "t_stab": 1.0, "pv_range": (-50.0, 150.0),
             "anti_windup": "back_calc_real", "bumpless": "suppress_p_action"}),
    ("adrc", {"order": 2, "b0": 0.05, "omega_c": 0.5, "omega_o": 2.5, "ts": 0.1, "u_min": 0.0,
              "u_max": 100.0}),
    ("adrc", {"order": 3, "b0": 0.01, "omega_c": 0.3, "omega_o": 1.2, "discretisation": "exact",
              "t_ref": 1.0, "u_real_on": True}),
    ("adrc", {"order": 1, "b0": 0.5, "anti_backoff": True, "y_sat": 80.0, "y_sat_lo": -5.0,
              "reverse": True, "u_min": -50.0, "u_max": 50.0}),
    ("adrc", {"order": 2, "b0": 0.1, "omega_c": 0.5, "omega_o": 2.5, "pv_range": (-20.0, 180.0),
              "sp_filter": 1.0, "pv_filter": 0.5, "sp_rate": 10.0, "out_rate": 30.0}),
    ("adrc", {"order": 3, "b0": 0.01, "omega_c": 0.3, "omega_o": 1.2, "td_time": 1.5,
              "sp_filter": 0.5, "reverse": True}),
    ("leadlag", {"k": 1.5, "t_lead": 2.0, "t_lag": 1.0, "ts": 0.1}),
    ("leadlag", {"k": -0.5, "t_lead": 0.0, "t_lag": 0.3, "method": "euler", "out_min": -2.0,
                 "out_max": 3.0}),
]  # fmt: skip
"""Starting configurations of the hostile runs (each retuned at random on the way)."""


@dataclass
class Run:
    """Per sample: the FB inputs written, and the block's outputs by FB name."""

    inputs: list[dict[str, Any]] = field(default_factory=list)
    outputs: list[dict[str, Any]] = field(default_factory=list)


def _value(rng: np.random.Generator, plain: float, p_hostile: float,
           pool: tuple[float, ...] = HOSTILE) -> float:  # fmt: skip
    if rng.random() < p_hostile:
        return float(pool[rng.integers(len(pool))])
    return plain


_PID_RETUNES: dict[str, Any] = {
    "kp": lambda r: float(r.uniform(0.05, 8.0)),
    "ti": lambda r: float(r.choice([0.0, r.uniform(0.2, 60.0)])),
    "td": lambda r: float(r.choice([0.0, r.uniform(0.05, 5.0)])),
    "n": lambda r: float(r.uniform(2.0, 20.0)),
    "b": lambda r: float(r.uniform(0.0, 1.0)),
    "c": lambda r: float(r.uniform(0.0, 1.0)),
    "reverse": lambda r: bool(r.integers(2)),
    "integral_method": lambda r: str(r.choice(["forward", "backward", "tustin"])),
    "derivative_method": lambda r: str(r.choice(["forward", "backward", "tustin"])),
    "anti_windup": lambda r: str(r.choice(["clamping", "back_calc_model", "back_calc_real"])),
    "algorithm": lambda r: str(r.choice(["positional", "velocity"])),
    "tt": lambda r: float(r.uniform(0.1, 10.0)),
    "sp_filter": lambda r: float(r.choice([0.0, r.uniform(0.05, 5.0)])),
    "pv_filter": lambda r: float(r.choice([0.0, r.uniform(0.05, 5.0)])),
    "sp_rate": lambda r: float(r.choice([0.0, r.uniform(0.5, 50.0)])),
    "out_rate": lambda r: float(r.choice([0.0, r.uniform(0.5, 50.0)])),
    "ff_k": lambda r: float(r.choice([0.0, r.uniform(-2.0, 2.0)])),
    "ff_t_lead": lambda r: float(r.uniform(0.0, 3.0)),
    "ff_t_lag": lambda r: float(r.uniform(0.1, 3.0)),
    "bumpless": lambda r: str(r.choice(["integrator", "track_setpoint", "suppress_p_action"])),
    "dev_tol": lambda r: float(r.uniform(0.1, 5.0)),
    "reset_value": lambda r: float(r.uniform(-10.0, 110.0)),
    "safe_value": lambda r: float(r.uniform(0.0, 100.0)),
    "limits": lambda r: sorted(float(x) for x in r.uniform(-20.0, 120.0, 2)),
    "pv_range": lambda r: (float(r.uniform(-100.0, 0.0)), float(r.uniform(50.0, 300.0))),
}
_ADRC_RETUNES: dict[str, Any] = {
    "order": lambda r: int(r.integers(1, 4)),
    "b0": lambda r: float(10 ** r.uniform(-2.5, 0.5)),
    "omega_c": lambda r: float(r.uniform(0.1, 3.0)),
    "omega_o": lambda r: float(r.uniform(0.5, 12.0)),
    "t_ref": lambda r: float(r.choice([0.0, r.uniform(0.1, 5.0)])),
    "u_sf": lambda r: float(r.uniform(0.0, 100.0)),
    "anti_windup": lambda r: str(r.choice(["off", "freeze", "directional"])),
    "discretisation": lambda r: str(r.choice(["euler", "exact"])),
    "u_real_on": lambda r: bool(r.integers(2)),
    "reverse": lambda r: bool(r.integers(2)),
    "tau_wait": lambda r: float(r.uniform(0.0, 3.0)),
    "limits": lambda r: sorted(float(x) for x in r.uniform(-20.0, 120.0, 2)),
    "out_rate": lambda r: float(r.choice([0.0, r.uniform(0.5, 50.0)])),
    "u0": lambda r: float(r.uniform(-10.0, 110.0)),
    "pv_range": lambda r: None if r.integers(2) else (float(r.uniform(-100.0, 0.0)),
                                                        float(r.uniform(50.0, 300.0))),
    "sp_filter": lambda r: float(r.choice([0.0, r.uniform(0.05, 5.0)])),
    "pv_filter": lambda r: float(r.choice([0.0, r.uniform(0.05, 5.0)])),
    "sp_rate": lambda r: float(r.choice([0.0, r.uniform(0.5, 50.0)])),
    "td_time": lambda r: float(r.choice([0.0, r.uniform(0.05, 5.0)])),
}
_LL_RETUNES: dict[str, Any] = {
    "k": lambda r: float(r.uniform(-3.0, 3.0)),
    "t_lead": lambda r: float(r.uniform(0.0, 5.0)),
    "t_lag": lambda r: float(r.uniform(0.05, 5.0)),
    "method": lambda r: str(r.choice(["tustin", "euler"])),
    "limits": lambda r: sorted(float(x) for x in r.uniform(-10.0, 10.0, 2)),
}
_LIMIT_FIELDS = {"pid": ("u_min", "u_max"), "adrc": ("u_min", "u_max"),
                 "leadlag": ("out_min", "out_max")}  # fmt: skip
def _tuning(block: Any) -> dict[str, Any]:
    """The FB's tuning inputs (PLC name -> value) for the block's configuration (as REALs
    for a float32 block, as they are for a float64 one)."""
    spec = spec_for(block)
    tuning = [v for v in spec.inputs if v.st not in spec.process]
    vals = {v.py: spec.values[v.py] for v in tuning}
    if block.config.precision == "float32":
        vals = pc.real_args(vals)  # limits: +-REAL_MAX
    return {v.st: (x.item() if isinstance(x := vals[v.py], np.generic) else x) for v in tuning}


def _retune(block: Any, kind: str, rng: np.random.Generator) -> bool:
    table = {"pid": _PID_RETUNES, "adrc": _ADRC_RETUNES, "leadlag": _LL_RETUNES}[kind]
    name = list(table)[rng.integers(len(table))]
    value = table[name](rng)
    change = dict(zip(_LIMIT_FIELDS[kind], value, strict=True)) if name == "limits" else {
        name: value}  # fmt: skip
    try:
        block.configure(**change)
    except ParameterError:
        return False  # refused: the old configuration stays, nothing is written to the FB
    return True


def hostile_trace(kind: str, n: int, seed: int, jitter: bool = False,
                  p_hostile: float = 0.04, precision: str = "float32",
                  pool: tuple[float, ...] = HOSTILE, **config: Any) -> tuple[Any, Run]:  # fmt: skip
    """``n`` hostile samples for a ``precision`` (float32: the FB's REAL) ``kind`` block
    (``"pid"``, ``"adrc"``, ``"leadlag"``) configured with ``config``, its process values
    drawn from ``pool`` with probability ``p_hostile``: (the starting block to export, the
    run)."""
    rng = np.random.default_rng(seed)
    make = {"pid": PID, "adrc": ADRC, "leadlag": LeadLag}[kind]
    block = make(**config, precision=precision)
    start = make(**config)
    written: dict[str, Any] = _tuning(block)
    run = Run()
    sp, pv, x = 50.0, 40.0, 0.0
    modes: dict[str, bool] = {}
    for _k in range(n):
        inp: dict[str, Any] = {}
        if rng.random() < 0.02 and _retune(block, kind, rng):
            for name, v in _tuning(block).items():
                if name not in written or not _same(written[name], v):
                    inp[name] = written[name] = v
        dt = None
        if jitter:
            ts = block.config.ts
            dt = float(BAD_DT[rng.integers(len(BAD_DT))]) if rng.random() < 0.01 else float(
                ts * rng.uniform(0.5, 1.5))  # fmt: skip
            inp["TS"] = dt
            written["TS"] = dt
        sp = sp + float(rng.normal(0.0, 2.0)) if rng.random() < 0.05 else sp
        pv = pv + 0.2 * (x - pv) * 0.1 + float(rng.normal(0.0, 0.3))
        if not math.isfinite(pv) or abs(pv) > 1e6:
            pv = 40.0
        spv, pvv = _value(rng, sp, p_hostile, pool), _value(rng, pv, p_hostile, pool)
        ok = rng.random() > 0.02
        if kind == "pid":
            for mode, attr in (("MANUAL", "manual"), ("RST", "reset_active"), ("TRACK", "track"),
                               ("HOLD", "hold"), ("AWIN", "awin")):  # fmt: skip
                if rng.random() < (0.01 if not modes.get(mode) else 0.08):
                    modes[mode] = not modes.get(mode, False)
                    setattr(block, attr, modes[mode])
                    inp[mode] = modes[mode]
            if rng.random() < 0.03:
                block.manual_value = inp["MAN_VALUE"] = _value(rng, float(rng.uniform(0, 100)),
                                                               0.3, pool)  # fmt: skip
            if rng.random() < 0.03:
                block.track_value = inp["TRACK_VALUE"] = _value(rng, float(rng.uniform(0, 100)),
                                                                0.3, pool)  # fmt: skip
            block.actuator_pos = inp["ACTUATOR_POS"] = _value(rng, x, p_hostile / 2, pool)
            ff = _value(rng, float(rng.normal(0.0, 1.0)), p_hostile / 2, pool)
            dv = _value(rng, float(np.sin(_k / 20.0)), p_hostile / 2, pool)
            inp.update(SP=spv, PV=pvv, FF=ff, DV=dv, PV_OK=ok)
            x = block(spv, pvv, ff=ff, dv=dv, pv_ok=ok, dt=dt)
            out = {"MV": x, "ERROR_ID": int(block.error_id),
                   "LIMITS_ACTIVE": bool(block.limits_active), "P": block.p,
                   "I_TERM": block.i, "D_TERM": block.d,
                   "MAN_VALUE": block.manual_value}  # fmt: skip
        elif kind == "adrc":
            for mode, attr in (("MANUAL", "manual"), ("RST", "reset_active"), ("TRACK", "track"),
                               ("HOLD", "hold"), ("AWIN", "awin")):  # fmt: skip
                if rng.random() < (0.01 if not modes.get(mode) else 0.08):
                    modes[mode] = not modes.get(mode, False)
                    setattr(block, attr, modes[mode])
                    inp[mode] = modes[mode]
            if rng.random() < 0.03:
                block.u_man = inp["MAN_VALUE"] = _value(rng, float(rng.uniform(0, 100)), 0.3,
                                                        pool)  # fmt: skip
            if rng.random() < 0.03:
                block.track_value = inp["TRACK_VALUE"] = _value(rng, float(rng.uniform(0, 100)),
                                                                0.3, pool)  # fmt: skip
            u_real = _value(rng, x, p_hostile / 2, pool)
            ff = _value(rng, float(rng.normal(0.0, 1.0)), p_hostile / 2, pool)
            inp.update(SP=spv, PV=pvv, FF=ff, PV_OK=ok, U_REAL=u_real)
            x = block(spv, pvv, ff=ff, y_ok=ok, u_real=u_real, dt=dt)
            x1, x2, x3, x4 = block.x
            out = {"MV": x, "ERROR_ID": int(block.error_id), "AWOUT": bool(block.awout),
                   "U_RAW": block.u_raw, "MAN_VALUE": block.u_man,
                   # the outputs of Nowak et al. 2018, Fig. 2
                   "E": block.e, "Y": block.y, "Y_REF": block.y_ref, "X1": x1, "X2": x2,
                   "X3": x3, "DISTURBANCE": x4}  # fmt: skip
        else:
            if rng.random() < (0.01 if modes.get("ENABLE", True) else 0.1):
                modes["ENABLE"] = not modes.get("ENABLE", True)
            enable = modes.get("ENABLE", True)
            inp.update(IN=spv, ENABLE=enable)
            x = block(spv, enable=enable, dt=dt)
            out = {"OUT": x, "ERROR_ID": int(block.error_id)}
        if not math.isfinite(x):
            raise AssertionError(f"the float32 {kind} block output {x!r}")
        run.inputs.append(inp)
        run.outputs.append(out)
    return start, run


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return bool(a == b) and type(a) is type(b)
