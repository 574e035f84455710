"""Long input traces for the PLC equivalence tests, and the code that replays them.

A trace is made by closing the loop with the ``precision="float32"`` block
(a simple plant in float64), while the events of a plant day happen:
setpoint steps, PV noise, limits hit, MAN/AUTO switches, RESET, NaN and inf
measurements, PV_OK false, a bad setpoint, retuning and new limits mid-run.
Each sample records the FB inputs that changed and the block's outputs; the
replay feeds the same inputs to the interpreted FUNCTION_BLOCK.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ctrlblocks import ADRC, PID, LeadLag

NAN, INF = math.nan, math.inf
REAL_SPIKE = 3e38
"""A PV inside the REAL range whose P term is not: the law overflows REAL (16#8103)."""


@dataclass
class Trace:
    """Per sample: FB inputs to write, and the block's (MV, ERROR_ID, flag)."""

    inputs: list[dict[str, Any]] = field(default_factory=list)
    outputs: list[tuple[float, int, bool]] = field(default_factory=list)


def ulps(a: float, b: float) -> int:
    """Distance in units in the last place between two float32 values (0 for equal NaNs)."""
    x, y = np.float32(a), np.float32(b)
    if np.isnan(x) and np.isnan(y):
        return 0
    ix, iy = (int(v.view(np.int32)) for v in (x, y))
    ix = ix if ix >= 0 else -(ix & 0x7FFFFFFF)
    iy = iy if iy >= 0 else -(iy & 0x7FFFFFFF)
    return abs(ix - iy)


DB_RETUNES = ((0.52, "T_STAB", 0.5), (0.75, "TS", 0.2), (0.88, "TS", 0.1), (0.9, "T_STAB", 0.9))
"""(fraction of the trace, FB input, value): windows 5, 2 (0.5/0.2 = 2.5, a tie: to even),
5 and 9 samples, all within the array the export sized from the starting configuration."""

PID_MODES = {"MANUAL": "manual", "MAN_VALUE": "manual_value", "RST": "reset_active",
             "TRACK": "track", "TRACK_VALUE": "track_value", "HOLD": "hold", "AWIN": "awin",
             "ACTUATOR_POS": "actuator_pos"}  # fmt: skip
"""FB inputs of the PID that are block attributes (the others are call arguments or tunings)."""


PID_OPTIONS = [
    {"algorithm": "velocity"},
    {"algorithm": "velocity", "ti": 0.0, "out_rate": 20.0, "integral_method": "forward"},
    {"sp_filter": 1.0, "pv_filter": 0.5, "sp_rate": 10.0, "out_rate": 30.0},
    {"ff_k": 2.0, "ff_t_lead": 1.0, "ff_t_lag": 3.0, "pv_range": (-50.0, 150.0), "c": 0.5},
    {"anti_windup": "back_calc_real", "tt": 1.0, "derivative_method": "tustin"},
    {"algorithm": "velocity", "anti_windup": "back_calc_real", "bumpless": "track_setpoint",
     "sp_rate": 5.0, "pv_filter": 0.3},
    {"bumpless": "suppress_p_action", "dev_tol": 2.0, "out_rate": 50.0, "reverse": True},
    {"algorithm": "velocity", "ff_k": -1.0, "ff_t_lead": 0.0, "ff_t_lag": 0.5, "b": 0.5,
     "anti_windup": "back_calc_model", "sp_filter": 2.0},
]  # fmt: skip
"""PID options beyond the positional law of ``pid_step``: velocity form, filters, ramps,
feed-forward, PV scaling, every anti-windup and bumpless method."""


DB_OPTIONS = [
    {"deadband": 1.0, "t_stab": 1.0},
    {"deadband": -0.8, "t_stab": 2.0, "algorithm": "velocity", "out_rate": 20.0, "td": 0.0},
    {"deadband": 1.5, "t_stab": 1.5, "sp_filter": 0.5, "bumpless": "suppress_p_action",
     "dev_tol": 2.0},
]  # fmt: skip
"""PID options with the adaptive dead band (a negative width acts as its absolute value)."""


def pid_trace(n: int, seed: int, modes: bool = False, **config: Any) -> tuple[PID, Trace]:
    """A closed-loop day of a float32 PID on ``y' = (2 u/100 - y)/5`` (y in % of range).

    With a ``deadband``, the stabilisation time and the sample time are retuned
    mid-run (a shorter window, a window that rounds a tie to even, and back).

    ``modes`` adds TRACK, HOLD and AWIN stretches, a DV signal (for the lead-lag
    feed-forward), a measured actuator position lagging the output, and two PV
    spikes near the end that overflow the law in float64 (1.7e308: inf as a REAL,
    so a bad input for the FB) and in REAL (:data:`REAL_SPIKE`).
    """
    cfg = {"kp": 1.5, "ti": 4.0, "td": 0.5, "ts": 0.1, "u_min": 0.0, "u_max": 100.0, **config}
    pid = PID(**cfg, precision="float32")
    rng = np.random.default_rng(seed)
    tr = Trace()
    y, sp = 20.0, 30.0
    pos = 0.0
    for k in range(n):
        inp: dict[str, Any] = {}
        f = k / n
        if modes:
            for at, name, value in ((0.2, "TRACK", True), (0.22, "TRACK", False),
                                    (0.25, "HOLD", True), (0.27, "HOLD", False),
                                    (0.65, "AWIN", True), (0.68, "AWIN", False)):  # fmt: skip
                if k == int(at * n):
                    inp[name] = value
            if k == int(0.2 * n):
                inp["TRACK_VALUE"] = 42.0
            if k == int(0.21 * n):
                inp["TRACK_VALUE"] = NAN  # a bad tracking value holds the output
            if k == int(0.215 * n):
                inp["TRACK_VALUE"] = 47.5
            inp["ACTUATOR_POS"] = pos
            inp["DV"] = 2.0 * math.sin(k / 25.0) + (NAN if k == int(0.33 * n) else 0.0)
            for name, value in inp.items():
                if name in PID_MODES:
                    setattr(pid, PID_MODES[name], value)
        if k in (int(0.15 * n), int(0.55 * n)):
            sp = 90.0 if k < 0.5 * n else 40.0  # a large step: the output hits a limit
        if k == int(0.3 * n):
            pid.manual = True
            pid.manual_value = 35.0
            inp["MANUAL"], inp["MAN_VALUE"] = True, 35.0
        if k == int(0.36 * n):
            pid.manual = False
            inp["MANUAL"] = False
        if k == int(0.4 * n):
            pid.reset_active = True
            inp["RST"] = True
        if k == int(0.41 * n):
            pid.reset_active = False
            inp["RST"] = False
        if k == int(0.45 * n):
            pid.configure(kp=2.5, ti=2.0)  # retune mid-run (bumpless)
            inp["K"], inp["TI"] = 2.5, 2.0
        if k == int(0.7 * n):
            pid.configure(u_min=10.0, u_max=60.0)  # new limits at run time
            inp["U_MIN"], inp["U_MAX"] = 10.0, 60.0
        if "deadband" in config:
            for at, name, value in DB_RETUNES:
                if k == int(at * n):
                    pid.configure(**{name.lower(): value})
                    inp[name] = value
        pv_ok = not (0.6 * n <= k < 0.62 * n)
        pv = y + 0.3 * rng.standard_normal()
        if int(0.5 * n) <= k < int(0.5 * n) + 3:
            pv = NAN
        if k == int(0.8 * n):
            pv = INF
        spk = NAN if k == int(0.85 * n) else sp
        if modes and k in (int(0.93 * n), int(0.97 * n)):
            pv = REAL_SPIKE if k == int(0.97 * n) else 1.7e308  # overflows LREAL, then REAL
        ff = 5.0 if f > 0.9 else 0.0
        inp.update({"SP": spk, "PV": pv, "FF": ff, "PV_OK": pv_ok})
        u = pid(spk, pv, ff=ff, pv_ok=pv_ok, dv=inp.get("DV", 0.0))
        pos += 0.3 * (u - pos)  # the actuator follows the output with a lag
        tr.inputs.append(inp)
        tr.outputs.append((u, int(pid.error_id), bool(pid.limits_active)))
        y += 0.1 * (2.0 * u / 100.0 * 50.0 - y) / 5.0
    return PID(**cfg), tr  # the configuration the trace started from (to export)


ADRC_OPTIONS = [
    {"discretisation": "exact"},
    {"discretisation": "exact", "order": 1, "b0": 0.5, "t_ref": 2.0, "anti_windup": "freeze"},
    {"discretisation": "exact", "order": 3, "b0": 0.01, "omega_c": 0.3, "omega_o": 1.2},
    {"u_real_on": True, "anti_windup": "off"},
    {"anti_backoff": True, "y_sat": 3.0, "y_sat_lo": -0.5, "tau_wait": 1.0},
    {"discretisation": "exact", "u_real_on": True, "anti_backoff": True, "y_sat": 3.0,
     "y_sat_lo": -0.5, "t_ref": 1.0},
    {"omega_o": 5.0},  # omega_o ts = 0.5: beyond the trusted Euler range, 16#8301
    {"reverse": True},  # a reverse-acting process (the trace's plant gain negated)
    {"reverse": True, "discretisation": "exact", "anti_backoff": True, "y_sat": 0.5,
     "y_sat_lo": -3.0, "u_real_on": True},
    {"out_rate": 5.0},  # the output ramp (5 %/s: the trace's set-point step ramps)
    # the input stage: PV range (b0 in % of it), SP and PV filters, SP ramp
    {"pv_range": (-2.0, 8.0), "b0": 0.5, "sp_filter": 1.0, "pv_filter": 0.3, "sp_rate": 20.0},
    {"pv_range": (-1.0, 4.0), "b0": 1.0, "anti_backoff": True, "y_sat": 3.0, "y_sat_lo": -0.5,
     "sp_rate": 10.0, "reverse": True},
    # the tracking differentiator (its time constant halved mid-run), alone and behind the
    # input stage, with the exact observer, a reverse-acting process, the anti-backoff
    {"td_time": 2.0},
    {"td_time": 1.0, "order": 3, "b0": 0.01, "omega_c": 0.3, "omega_o": 1.2,
     "discretisation": "exact", "reverse": True, "sp_filter": 0.5, "sp_rate": 20.0},
    {"td_time": 0.5, "order": 1, "b0": 0.5, "anti_backoff": True, "y_sat": 3.0,
     "y_sat_lo": -0.5},
]  # fmt: skip
"""ADRC options beyond the Euler law of ``adrc_step``: the exact discretisation, u_real,
the anti-backoff action (with a sensor that saturates), a warned discretisation, a
reverse-acting process, the output ramp, the input stage (PV range, filters, SP ramp;
the range changed mid-run), the tracking differentiator (retuned mid-run)."""


def adrc_trace(n: int, seed: int, modes: bool = False, **config: Any) -> tuple[ADRC, Trace]:
    """A closed-loop day of a float32 ADRC on ``y'' = -0.5 y' + 0.05 u`` (plus a load).

    ``modes`` adds an AWIN stretch, a TRACK (with a NaN tracking value), a RESET and a
    HOLD stretch, a measured actuator value ``U_REAL`` lagging
    u (with a NaN sample), the feed-forward ``FF`` of the measured load (with a NaN
    sample), the two overflowing PV spikes of :func:`pid_trace`, and
    makes the plant self-regulating (``- 0.1 y``); with
    ``anti_backoff`` the PV saturates at ``y_sat``.  With ``reverse`` the plant's
    gain and the set points are negated (a reverse-acting process).  With
    ``pv_range`` the range widens mid-run (the ESO restarts, bumplessly); with
    ``td_time`` the tracking differentiator's time constant is halved mid-run.
    """
    cfg = {"order": 2, "b0": 0.05, "omega_c": 0.5, "omega_o": 2.5, "ts": 0.1,
           "u_min": 0.0, "u_max": 100.0, **config}  # fmt: skip
    adrc = ADRC(**cfg, precision="float32")
    rng = np.random.default_rng(seed)
    tr = Trace()
    sgn = -1.0 if cfg.get("reverse") else 1.0
    y, dy, sp = 0.0, 0.0, sgn * 1.0
    u_act = 0.0
    for k in range(n):
        inp: dict[str, Any] = {}
        if modes:
            if k in (int(0.65 * n), int(0.68 * n)):
                adrc.awin = inp["AWIN"] = k == int(0.65 * n)
            inp["U_REAL"] = NAN if k == int(0.4 * n) else u_act
        if k == int(0.2 * n):
            sp = sgn * 4.0  # saturates the output for a while
        if k == int(0.3 * n):
            adrc.manual = True
            adrc.u_man = 20.0
            inp["MANUAL"], inp["MAN_VALUE"] = True, 20.0
        if k == int(0.35 * n):
            adrc.manual = False
            inp["MANUAL"] = False
        if modes and k in (int(0.55 * n), int(0.57 * n)):  # TRACK a value, with a NaN in it
            adrc.track = inp["TRACK"] = k == int(0.55 * n)
            adrc.track_value = inp["TRACK_VALUE"] = 35.0
        if modes and k == int(0.56 * n):
            adrc.track_value = inp["TRACK_VALUE"] = NAN
        if modes and k in (int(0.63 * n), int(0.64 * n)):  # HOLD
            adrc.hold = inp["HOLD"] = k == int(0.63 * n)
        if modes and k in (int(0.58 * n), int(0.59 * n)):  # RESET: u0 at once
            adrc.reset_active = inp["RST"] = k == int(0.58 * n)
        if "pv_range" in cfg and k == int(0.47 * n):  # a wider range: new units
            lo, hi = cfg["pv_range"][0] - 1.0, cfg["pv_range"][1] + 1.0
            adrc.configure(pv_range=(lo, hi))
            inp["PV_LO"], inp["PV_HI"] = lo, hi
        if cfg.get("td_time") and k == int(0.23 * n):  # in the set-point step's transient
            adrc.configure(td_time=cfg["td_time"] / 2.0)
            inp["TD_TIME"] = cfg["td_time"] / 2.0
        if k == int(0.45 * n):
            adrc.configure(omega_c=0.8, omega_o=3.0)  # retune mid-run (bumpless by (11))
            inp["OMEGA_C"], inp["OMEGA_O"] = 0.8, 3.0
        if k == int(0.7 * n):
            adrc.set_limits(5.0, 60.0)
            inp["U_MIN"], inp["U_MAX"] = 5.0, 60.0
        y_ok = not (0.6 * n <= k < 0.62 * n)
        pv = y + 0.01 * rng.standard_normal()
        if int(0.5 * n) <= k < int(0.5 * n) + 3:
            pv = NAN
        spk = NAN if k == int(0.85 * n) else sp
        if modes and k in (int(0.93 * n), int(0.97 * n)):
            pv = REAL_SPIKE if k == int(0.97 * n) else 1.7e308  # overflows LREAL, then REAL
        if cfg.get("anti_backoff"):
            pv = min(max(pv, cfg["y_sat_lo"]), cfg["y_sat"])  # the sensor saturates
        load = -0.05 if k > 0.75 * n else 0.0
        ff = 0.0
        if modes:  # the measured load fed forward (-load/b0), a NaN sample among it
            ff = inp["FF"] = NAN if k == int(0.8 * n) else -sgn * load / 0.05
        inp.update({"SP": spk, "PV": pv, "PV_OK": y_ok})
        u = adrc(spk, pv, ff=ff, y_ok=y_ok, u_real=inp.get("U_REAL"))
        u_act += 0.5 * (u - u_act)  # the actuator follows u with a lag
        tr.inputs.append(inp)
        tr.outputs.append((u, int(adrc.error_id), bool(adrc.awout)))
        ddy = -0.5 * dy + sgn * 0.05 * u + load
        if modes:
            ddy -= 0.1 * y  # a self-regulating plant: the loop works in both directions
        y += 0.1 * dy
        dy += 0.1 * ddy
    return ADRC(**cfg), tr


def leadlag_trace(n: int, seed: int, **config: Any) -> tuple[LeadLag, Trace]:
    """A float32 lead-lag fed with steps, noise, NaN, a disabled stretch, limits and a retune."""
    cfg = {"k": 1.5, "t_lead": 2.0, "t_lag": 1.0, "ts": 0.1, **config}
    ll = LeadLag(**cfg, precision="float32")
    rng = np.random.default_rng(seed)
    tr = Trace()
    for k in range(n):
        inp: dict[str, Any] = {}
        x = (1.0 if k > 0.1 * n else 0.0) + (3.0 if k > 0.5 * n else 0.0)
        x += 0.05 * rng.standard_normal()
        if k in (int(0.3 * n), int(0.3 * n) + 1):
            x = NAN
        enable = not (0.4 * n <= k < 0.45 * n)
        if k == int(0.6 * n):
            ll.configure(t_lead=0.5, out_min=-1.0, out_max=4.0)
            inp["T_LEAD"], inp["OUT_MIN"], inp["OUT_MAX"] = 0.5, -1.0, 4.0
        inp.update({"IN": x, "ENABLE": enable})
        out = ll(x, enable=enable)
        tr.inputs.append(inp)
        tr.outputs.append((out, int(ll.error_id), False))
    return LeadLag(**cfg), tr


def replay(
    fb: Any, trace: Trace, mv: str, flag: str | None, each: Any = None
) -> list[tuple[float, int, bool]]:
    """Call the interpreted FB instance with the trace's inputs; its (MV, ERROR_ID, flag).

    ``each()`` is called after every sample (to look at the FB's state)."""
    out = []
    for inp in trace.inputs:
        fb(**inp)
        if each is not None:
            each()
        out.append((float(fb[mv]), int(fb["ERROR_ID"]), bool(fb[flag]) if flag else False))
    return out
