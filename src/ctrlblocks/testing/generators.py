"""The fuzz specifications of the shipped blocks: random configurations and one step each.

One :class:`~.fuzz.FuzzSpec` per block :mod:`ctrlblocks.blocks` exports
(tests/blocks/test_fuzz_campaign.py fails for a block without one): a random
generator of its configuration over every option (log-uniform gains and time
constants, limits that may be infinite or a single value, the float32 PLC
cycle, huge gains now and then), and how one process step feeds it.  A new
block registers its spec here, in :func:`register_shipped`.
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable
from fractions import Fraction
from typing import Any

from .. import blocks as b
from .fuzz import FuzzSpec, register_fuzz

__all__ = ["register_shipped"]


def _lu(r: random.Random, lo: float, hi: float) -> float:
    """Log-uniform in [lo, hi]."""
    return math.exp(r.uniform(math.log(lo), math.log(hi)))


def _maybe(r: random.Random, p: float, value: Any, other: Any) -> Any:
    return value if r.random() < p else other


def _limits(r: random.Random, span: float = 100.0) -> tuple[float, float]:
    kind = r.random()
    if kind < 0.15:
        return -math.inf, math.inf
    lo = r.uniform(-span, span)
    if kind < 0.2:
        return lo, lo  # a single allowed value
    return lo, lo + _lu(r, 1e-3, 2 * span)


def _pid_config(r: random.Random) -> dict[str, Any]:
    u_min, u_max = _limits(r)
    c: dict[str, Any] = {
        "kp": _lu(r, 1e-3, 1e3) if r.random() > 0.02 else _lu(r, 1e100, 1e300),
        "ti": _maybe(r, 0.8, _lu(r, 1e-2, 1e3), 0.0),
        "td": _maybe(r, 0.4, _lu(r, 1e-3, 1e2), 0.0),
        "n": _lu(r, 1.0, 100.0),
        "b": r.uniform(0.0, 1.5),
        "c": r.choice((0.0, 0.0, 0.5, 1.0)),
        "ts": _lu(r, 1e-3, 10.0),
        "u_min": u_min,
        "u_max": u_max,
        "integral_method": r.choice(("forward", "backward", "tustin")),
        "derivative_method": r.choice(("forward", "backward", "tustin")),
        "form": r.choice(("isa", "isa", "parallel", "series")),
        "algorithm": r.choice(("positional", "positional", "velocity")),
        "reverse": r.random() < 0.3,
        "pv_range": _maybe(r, 0.2, (-50.0, 150.0), None),
        "sp_filter": _maybe(r, 0.2, _lu(r, 1e-2, 1e2), 0.0),
        "pv_filter": _maybe(r, 0.2, _lu(r, 1e-2, 1e2), 0.0),
        "sp_rate": _maybe(r, 0.3, _lu(r, 1e-2, 1e2), 0.0),
        "out_rate": _maybe(r, 0.2, _lu(r, 1e-2, 1e3), 0.0),
        "anti_windup": r.choice(("clamping", "back_calc_model", "back_calc_real")),
        "tt": _maybe(r, 0.3, _lu(r, 1e-3, 1e2), None),
        "bumpless": r.choice(("integrator", "integrator", "track_setpoint", "suppress_p_action")),
        "dev_tol": r.uniform(0.1, 50.0),
        "deadband": _maybe(r, 0.2, r.uniform(-3.0, 3.0), 0.0),
        "t_stab": _lu(r, 1e-2, 1e2),
        "reset_value": r.uniform(-100, 100),
        "safe_value": _maybe(r, 0.3, r.uniform(-100, 100), None),
        "ff_k": _maybe(r, 0.2, r.uniform(-3, 3), 0.0),
        "ff_t_lead": _maybe(r, 0.5, _lu(r, 1e-2, 1e2), 0.0),
        "ff_t_lag": _lu(r, 1e-2, 1e2),
    }
    if c["bumpless"] == "track_setpoint" and c["sp_rate"] == 0.0:
        c["sp_rate"] = 1.0
    if r.random() < 0.15:  # the PLC cycle in single precision: every option but the dead band
        c.update(precision="float32", deadband=0.0)
    return c


def _adrc_config(r: random.Random) -> dict[str, Any]:
    u_min, u_max = _limits(r, 10.0)
    wc = _lu(r, 1e-2, 1e2)
    lo_sat = r.uniform(-50, 50)
    cfg = {
        "order": r.choice((1, 2, 3)),
        "b0": _lu(r, 1e-3, 1e3),
        "omega_c": wc,
        "omega_o": wc * _lu(r, 1.0, 20.0),
        "ts": _lu(r, 1e-3, 1.0),
        "u_min": u_min,
        "u_max": u_max,
        "t_ref": _maybe(r, 0.3, _lu(r, 1e-2, 1e2), 0.0),
        "discretisation": r.choice(("euler", "euler", "exact")),
        "u_sf": r.uniform(-10, 10),
        "u0": r.uniform(-10, 10),
        "anti_windup": r.choice(("directional", "freeze", "off", True, False)),
        "u_real_on": r.random() < 0.2,
        "anti_backoff": r.random() < 0.3,
        "y_sat": lo_sat + _lu(r, 1e-2, 100.0),
        "y_sat_lo": lo_sat,
        "tau_wait": _maybe(r, 0.5, _lu(r, 1e-2, 10.0), 0.0),
        "precision": "float64",
    }
    if r.random() < 0.15:  # single-precision PLC cycle: every option
        cfg["precision"] = "float32"
    cfg["reverse"] = r.random() < 0.3
    if cfg["precision"] == "float64" and r.random() < 0.2:  # the ESO fed the delayed u
        cfg["input_delay"] = cfg["ts"] * r.randint(1, 40)
    if r.random() < 0.2:  # the output ramp
        cfg["out_rate"] = _lu(r, 1e-3, 1e3)
    if r.random() < 0.3:  # the PID's input stage: PV range, SP/PV filters, SP ramp
        lo = r.uniform(-100.0, 100.0)
        cfg["pv_range"] = _maybe(r, 0.5, (lo, lo + _lu(r, 1e-2, 1e3)), None)
        cfg["sp_filter"] = _maybe(r, 0.5, _lu(r, 1e-2, 1e2), 0.0)
        cfg["pv_filter"] = 0.0 if cfg["anti_backoff"] else _maybe(r, 0.5, _lu(r, 1e-2, 1e2), 0.0)
        cfg["sp_rate"] = _maybe(r, 0.5, _lu(r, 1e-2, 1e2), 0.0)
    if cfg["t_ref"] == 0.0 and r.random() < 0.3:  # the tracking differentiator (not with t_ref)
        cfg["td_time"] = _lu(r, 1e-3, 1e2)
    return cfg


def _ts(r: random.Random) -> float:
    return _lu(r, 1e-3, 10.0)


def _simple_configs() -> dict[str, Callable[[random.Random], dict[str, Any]]]:
    def scale(r: random.Random) -> dict[str, Any]:
        lo = r.uniform(-100, 100)
        olo = r.uniform(-100, 100)
        return {
            "in_lo": lo,
            "in_hi": lo + r.choice((-1.0, 1.0)) * _lu(r, 1e-3, 1e3),
            "out_lo": olo,
            "out_hi": olo + r.uniform(-1e3, 1e3),
            "clamp": r.random() < 0.5,
        }

    def leadlag(r: random.Random) -> dict[str, Any]:
        lo, hi = _limits(r)
        meth = r.choice(("tustin", "euler"))
        return {
            "k": r.uniform(-10, 10),
            "t_lead": _maybe(r, 0.6, _lu(r, 1e-3, 1e2), 0.0),
            "t_lag": _maybe(r, 0.9 if meth == "euler" else 1.0, _lu(r, 1e-3, 1e2), 0.0),
            "ts": _ts(r),
            "method": meth,
            "out_min": lo,
            "out_max": hi,
            "precision": _maybe(r, 0.15, "float32", "float64"),
        }

    def manual(r: random.Random) -> dict[str, Any]:
        lo, hi = _limits(r)
        return {
            "tm": _lu(r, 1e-2, 1e3),
            "tr": _maybe(r, 0.7, _lu(r, 1e-3, 1e2), 0.0),
            "span": _lu(r, 1e-2, 1e3),
            "t_accel": _lu(r, 1e-2, 1e2),
            "accel_max": r.uniform(1.0, 10.0),
            "out_min": lo,
            "out_max": hi,
            "ts": _ts(r),
            "y0": r.uniform(-100, 100),
        }

    def alarm(r: random.Random) -> dict[str, Any]:
        return {
            "limit": r.uniform(-100, 100),
            "kind": r.choice(("high", "low")),
            "deadband": _maybe(r, 0.6, _lu(r, 1e-3, 10.0), 0.0),
            "on_delay": _maybe(r, 0.5, _lu(r, 1e-3, 10.0), 0.0),
            "off_delay": _maybe(r, 0.5, _lu(r, 1e-3, 10.0), 0.0),
            "ts": _ts(r),
        }

    def loop_alarms(r: random.Random) -> dict[str, Any]:
        values = sorted(r.uniform(-100, 100) for _ in range(4))
        lims = zip(("ll", "l", "h", "hh"), values, strict=True)
        return {
            **{k: _maybe(r, 0.7, v, None) for k, v in lims},
            "dev": _maybe(r, 0.6, _lu(r, 1e-2, 1e2), None),
            "roc": _maybe(r, 0.6, _lu(r, 1e-2, 1e2), None),
            "roc_period": _maybe(r, 0.5, _lu(r, 1e-2, 1e2), 0.0),
            "deadband": _maybe(r, 0.6, _lu(r, 1e-3, 10.0), 0.0),
            "on_delay": _maybe(r, 0.5, _lu(r, 1e-3, 10.0), 0.0),
            "off_delay": _maybe(r, 0.5, _lu(r, 1e-3, 10.0), 0.0),
            "ts": _ts(r),
        }

    def monitor(r: random.Random) -> dict[str, Any]:
        ts = _ts(r)
        warn = _maybe(r, 0.5, ts * r.uniform(1.0, 3.0), None)
        return {
            "ts": ts,
            "warn_limit": warn,
            "alarm_limit": None if warn is None else warn * r.uniform(1.0, 3.0),
            "latch": r.random() < 0.5,
        }

    def pwm(r: random.Random) -> dict[str, Any]:
        ts = _lu(r, 1e-3, 1.0)
        period = ts * r.uniform(1.0, 100.0)
        lo = r.uniform(-100, 100)
        return {
            "period": period,
            "t_min_on": _maybe(r, 0.5, period * r.uniform(0, 1), 0.0),
            "t_min_off": _maybe(r, 0.5, period * r.uniform(0, 1), 0.0),
            "in_lo": lo,
            "in_hi": lo + _lu(r, 1e-2, 1e3),
            "ts": ts,
        }

    def two_point(r: random.Random) -> dict[str, Any]:
        return {
            "hysteresis": _maybe(r, 0.8, _lu(r, 1e-3, 10.0), 0.0),
            "reverse": r.random() < 0.5,
            "t_min_on": _maybe(r, 0.5, _lu(r, 1e-3, 10.0), 0.0),
            "t_min_off": _maybe(r, 0.5, _lu(r, 1e-3, 10.0), 0.0),
            "ts": _ts(r),
            "precision": _maybe(r, 0.2, "float32", "float64"),
        }

    def three_point(r: random.Random) -> dict[str, Any]:
        d = _maybe(r, 0.9, _lu(r, 1e-3, 10.0), 0.0)
        return {**two_point(r), "deadband": d, "hysteresis": r.uniform(0.0, 2.0 * d)}

    def transfer(r: random.Random) -> dict[str, Any]:
        from ..blocks.transfer import lowpass, notch, tustin

        ts = _ts(r)
        nyq = math.pi / ts
        sections: list[Any] = []
        while not sections or (len(sections) < 6 and r.random() < 0.4):
            kind = r.random()
            if kind < 0.4:
                sections += lowpass(nyq * r.uniform(1e-3, 0.95), ts, r.randint(1, 4))
            elif kind < 0.7:
                sections.append(notch(nyq * r.uniform(1e-3, 0.95), _lu(r, 0.5, 50.0), ts,
                                      _maybe(r, 0.5, r.uniform(0.0, 0.9), 0.0)))  # fmt: skip
            else:
                k, t = r.uniform(-100.0, 100.0), _lu(r, 1e-3, 1e3)
                sections.append(tustin([k], [t, 1.0], ts))
        lo, hi = _limits(r)
        return {"sections": tuple(sections[:8]), "ts": ts, "out_min": lo, "out_max": hi,
                "precision": _maybe(r, 0.2, "float32", "float64")}  # fmt: skip

    def setpoint(r: random.Random) -> dict[str, Any]:
        segs = tuple(
            (r.uniform(-100, 100), _maybe(r, 0.8, _lu(r, 1e-3, 1e2), 0.0),
             _maybe(r, 0.6, _lu(r, 1e-3, 1e2), 0.0))
            for _ in range(r.randint(1, 6))
        )  # fmt: skip
        return {
            "segments": segs,
            "start": r.uniform(-100, 100),
            "start_at_pv": r.random() < 0.3,
            "repeat": r.random() < 0.4,
            "holdback_ramp": _maybe(r, 0.4, _lu(r, 1e-2, 1e2), 0.0),
            "holdback_soak": _maybe(r, 0.4, _lu(r, 1e-2, 1e2), 0.0),
            "ts": _ts(r),
            "precision": _maybe(r, 0.2, "float32", "float64"),
        }

    def heat_cool(r: random.Random) -> dict[str, Any]:
        ts = _lu(r, 1e-2, 1.0)
        method = r.choice(("factor", "parameters"))
        return {
            "kp": _lu(r, 1e-2, 1e2),
            "ti": _maybe(r, 0.8, _lu(r, 1e-2, 1e3), 0.0),
            "td": _maybe(r, 0.3, _lu(r, 1e-2, 10.0), 0.0),
            "cool_method": method,
            "cool_factor": _lu(r, 1e-2, 1e2),
            "kp_cool": _maybe(r, 0.8, _lu(r, 1e-2, 1e2), 0.0),
            "ti_cool": _maybe(r, 0.8, _lu(r, 1e-2, 1e3), 0.0),
            "switch_hysteresis": r.uniform(0.0, 10.0),
            "deadzone": _maybe(r, 0.5, r.uniform(0.0, 20.0), 0.0),
            "pwm_period": _maybe(r, 0.4, ts * r.uniform(1.0, 50.0), 0.0),
            "ts": ts,
        }

    def regulator(r: random.Random) -> dict[str, Any]:
        lo = r.uniform(-100, 100)
        slo = r.uniform(-100, 100)
        return {
            "kp": _lu(r, 1e-2, 1e2),
            "ti": _maybe(r, 0.8, _lu(r, 1e-2, 1e3), 0.0),
            "td": _maybe(r, 0.3, _lu(r, 1e-2, 10.0), 0.0),
            "u_min": lo,
            "u_max": lo + _lu(r, 1e-2, 1e3),
            "sp_min": slo,
            "sp_max": slo + _lu(r, 1e-2, 1e3),
            "tm_sp": _lu(r, 1e-1, 1e3),
            "tm_out": _lu(r, 1e-1, 1e3),
            "tr": _maybe(r, 0.5, _lu(r, 1e-3, 10.0), 0.0),
            "sp0": r.uniform(-100, 100),
            "u0": r.uniform(-100, 100),
            "ts": _ts(r),
            "precision": _maybe(r, 0.2, "float32", "float64"),
        }

    return {
        "TwoPoint": two_point,
        "ThreePoint": three_point,
        "TransferFunction": transfer,
        "SetpointProgram": setpoint,
        "HeatCoolPID": heat_cool,
        "Regulator": regulator,
        "PT1": lambda r: {
            "t": _maybe(r, 0.8, _lu(r, 1e-3, 1e3), 0.0),
            "ts": _ts(r),
            "gain": r.uniform(-1e3, 1e3),
            "method": r.choice(("exact", "euler")),
            "y0": r.uniform(-100, 100),
        },
        "RateLimiter": lambda r: {
            "rate_up": _maybe(r, 0.8, _lu(r, 1e-3, 1e3), 0.0),
            "rate_down": _maybe(r, 0.8, _lu(r, 1e-3, 1e3), 0.0),
            "ts": _ts(r),
            "y0": r.uniform(-100, 100),
        },
        "DeadBand": lambda r: {"width": r.uniform(-10, 10)},
        "Scale": scale,
        "MovingAverage": lambda r: {"n": r.randint(1, 200)},
        "SteadyStateDetector": lambda r: {
            "tolerance": _lu(r, 1e-3, 10.0),
            "t_stab": _lu(r, 1e-2, 1e2),
            "ts": _ts(r),
        },
        "Saturation": lambda r: dict(zip(("lo", "hi"), _limits(r), strict=True)),
        "MinSelector": lambda r: {},
        "MaxSelector": lambda r: {},
        "LeadLag": leadlag,
        "JumpAndRate": lambda r: {
            "jlow": -_maybe(r, 0.9, _lu(r, 1e-3, 1e2), 0.0),
            "jhigh": _maybe(r, 0.9, _lu(r, 1e-3, 1e2), 0.0),
            "rlow": -_maybe(r, 0.9, _lu(r, 1e-3, 1e2), 0.0),
            "rhigh": _maybe(r, 0.9, _lu(r, 1e-3, 1e2), 0.0),
            "ts": _ts(r),
        },
        "ManualStation": manual,
        "CycleMonitor": monitor,
        "Alarm": alarm,
        "LoopAlarms": loop_alarms,
        "PulseWidth": pwm,
        "StepController": lambda r: {
            "travel_time": _lu(r, 1e-1, 1e3),
            "min_pulse": _maybe(r, 0.7, _lu(r, 1e-3, 10.0), 0.0),
            "min_pause": _maybe(r, 0.7, _lu(r, 1e-3, 10.0), 0.0),
            "deadband": _maybe(r, 0.7, _lu(r, 1e-3, 10.0), 0.0),
            "span": _lu(r, 1.0, 1e3),
            "ts": _ts(r),
        },
        "PID": _pid_config,
        "ADRC": _adrc_config,
    }


def _gain_schedule_config(r: random.Random) -> dict[str, Any]:
    return {"_pid": _pid_config(r), "kp": (_lu(r, 1e-2, 10.0), _lu(r, 1e-2, 10.0))}


def _moving_average_oracle(b: Any) -> str | None:
    """The moving average is the mean of the window it holds (:func:`math.fsum`, to
    ``1e-9`` of the largest value in it: a running sum that lost the small values after
    one huge sample left is a breach)."""
    n = b.config.n
    st = b.snapshot(copy=False)
    count = st["_count"]
    if count == 0:
        return None
    window = [st["_buf"][(st["_idx"] - count + j) % n] for j in range(count)]
    try:
        exact = math.fsum(v / count for v in window)
    except OverflowError:  # the quotients' roundings past the range: the exact mean
        exact = float(sum(Fraction(v) for v in window) / count)
    big = max(abs(v) for v in window)
    if not abs(b.out - exact) <= 1e-9 * big:
        return f"out {b.out!r} is not the mean {exact!r} of its window (largest |value| {big:.3g})"
    return None


def _cycle_monitor_oracle(b: Any) -> str | None:
    """The cycle monitor's statistics are finite and its flags follow the live
    condition unless latched."""
    if not -math.inf < b.jitter_std < math.inf:
        return f"jitter_std = {b.jitter_std!r}"
    live = b.count > 0 and b.out > b.warn_limit, b.count > 0 and b.out > b.alarm_limit
    flags = (b.warning, b.alarm)
    missed = any(now and not f for f, now in zip(flags, live, strict=True))
    if (not b.config.latch and flags != live) or missed:
        return f"flags (warning, alarm) = {flags} against the live condition {live}"
    return None



# the state that is not finite by design: the moving average's running sums while the
# window's sum exceeds the float range (inf, or NaN after its compensated resum; its mean,
# finite, then comes from the window itself; its oracle checks it), and the PWM's time in
# the period, +inf for "a period starts now";
# the alarm blocks' state records the process values as they came (NaN included)


# ---------------------------------------------------------------------------
# one process step of the blocks the default step does not fit
# ---------------------------------------------------------------------------


def _pid_step(blk: Any, two_phase: bool, vals: list[Any], dt: Any, flags: list[Any],
              y: float) -> Any:  # fmt: skip
    """The PID with its feed-forward ``ff`` and lead-lag input ``dv``."""
    sp, pv = vals[0], (vals[1] if vals[1] is not None else y)
    kw = {"ff": vals[2], "dv": vals[3], "dt": dt, "pv_ok": flags[0]}
    if two_phase:
        v = blk.compute_output(sp, pv, **kw)
        blk.update_state(v)
        return v
    return blk(sp, pv, **kw)


def _adrc_step(blk: Any, two_phase: bool, vals: list[Any], dt: Any, flags: list[Any],
               y: float) -> Any:  # fmt: skip
    """The ADRC with its feed-forward ``ff``, its older flag name ``y_ok`` and the measured
    ``u_real`` (one call)."""
    sp, pv = vals[0], (vals[1] if vals[1] is not None else y)
    kw: dict[str, Any] = {"ff": vals[3], "y_ok": flags[0], "dt": dt}
    if two_phase:
        v = blk.compute_output(sp, pv, **kw)
        blk.update_state(v)
        return v
    kw["u_real"] = vals[2] if flags[1] else None
    return blk(sp, pv, **kw)


def _schedule_step(blk: Any, two_phase: bool, vals: list[Any], dt: Any, flags: list[Any],
                   y: float) -> Any:  # fmt: skip
    """The gain schedule with its scheduling variable ``w``."""
    args = (vals[0], vals[1] if vals[1] is not None else y, vals[4])
    if two_phase:
        v = blk.compute_output(*args, dt=dt, pv_ok=flags[0])
        blk.update_state(v)
        return v
    return blk(*args, dt=dt, pv_ok=flags[0])


def _step(fn: Callable[[Any, list[Any], Any, list[Any]], Any]) -> Callable[..., Any]:
    """A one-call step ``fn(block, vals, dt, flags)``."""

    def step(blk: Any, two_phase: bool, vals: list[Any], dt: Any, flags: list[Any],
             y: float) -> Any:  # fmt: skip
        return fn(blk, vals, dt, flags)

    return step


def _acknowledged(blk: Any) -> str | None:
    """After ``acknowledge()`` the cycle monitor's flags are the live condition."""
    live = (blk.count > 0 and blk.out > blk.warn_limit,
            blk.count > 0 and blk.out > blk.alarm_limit)  # fmt: skip
    if (blk.warning, blk.alarm) != live:
        return f"(warning, alarm) = {(blk.warning, blk.alarm)} against the live condition {live}"
    return None


def _adrc_twin(ctl: Any) -> bool:
    # u_real_on applies the measured u_real in __call__ only; the precision="float32" PLC
    # cycle is a per-call cycle (its two-phase form is float64)
    return not ctl.config.u_real_on and ctl.config.precision == "float64"


def _make_schedule(cfg: dict[str, Any]) -> Any:
    return b.GainSchedule(b.PID(**cfg["_pid"]), breakpoints=(0.0, 100.0), kp=cfg["kp"])


def _heat_cool_step(blk: Any, vals: list[Any], dt: Any, flags: list[Any]) -> Any:
    blk.manual = flags[2]
    return blk(0.0 if vals[1] is None else vals[1], vals[0], pv_ok=flags[0], dt=dt)


def _regulator_step(blk: Any, vals: list[Any], dt: Any, flags: list[Any]) -> Any:
    blk.auto, blk.remote = flags[1], flags[2]
    sp = 0.0 if vals[1] is None else vals[1]
    return blk(vals[0], sp, sp_inc=flags[0], out_dec=flags[1], pv_ok=flags[0], dt=dt)


def _on_off_step(blk: Any, vals: list[Any], dt: Any, flags: list[Any]) -> Any:
    return blk(0.0 if vals[1] is None else vals[1], vals[0], pv_ok=flags[0], enable=flags[1],
               dt=dt)  # fmt: skip


_PID_MODES = ("manual", "track", "hold", "reset_active", "awin")
_PID_VALUES = {"manual": "manual_value", "track": "track_value"}


def register_shipped() -> None:
    """Register the :class:`~.fuzz.FuzzSpec` of every shipped block."""
    configs = _simple_configs()
    for spec in (
        FuzzSpec("PID", b.PID, _pid_config, step=_pid_step, modes=_PID_MODES,
                 mode_values=_PID_VALUES, float32=True),
        FuzzSpec("ADRC", b.ADRC, _adrc_config, step=_adrc_step, twin_ok=_adrc_twin,
                 modes=("manual", "track", "hold", "reset_active", "awin"),
                 mode_values={"manual": "manual_value", "track": "track_value"}, float32=True),
        FuzzSpec("GainSchedule", b.GainSchedule, _gain_schedule_config, step=_schedule_step,
                 make=_make_schedule, controller=True, bumpless=False, modes=_PID_MODES,
                 mode_values=_PID_VALUES, inner=lambda blk: blk.controller, configurable=False),
        FuzzSpec("MinSelector", b.MinSelector, configs["MinSelector"], step=_step(
            lambda blk, v, dt, f: blk(*v[: 1 + int(f[0] is True) + int(f[1] is True)]))),
        FuzzSpec("MaxSelector", b.MaxSelector, configs["MaxSelector"], step=_step(
            lambda blk, v, dt, f: blk(*v[: 1 + int(f[0] is True) + int(f[1] is True)]))),
        FuzzSpec("LeadLag", b.LeadLag, configs["LeadLag"], step=_step(
            lambda blk, v, dt, f: blk(v[0], enable=f[0], dt=dt)),
            limit_fields=("out_min", "out_max")),
        FuzzSpec("ManualStation", b.ManualStation, configs["ManualStation"], step=_step(
            lambda blk, v, dt, f: blk(inc=f[0], dec=f[1], track=v[0] if f[2] else None, dt=dt)),
            limit_fields=("out_min", "out_max")),
        FuzzSpec("CycleMonitor", b.CycleMonitor, configs["CycleMonitor"], step=_step(
            lambda blk, v, dt, f: blk(dt if dt is not None else v[0])),
            acknowledge=_acknowledged, oracle=_cycle_monitor_oracle),
        FuzzSpec("Alarm", b.Alarm, configs["Alarm"], step=_step(
            lambda blk, v, dt, f: blk(v[0], ok=f[0], suppress=f[1], dt=dt)), records_inputs=True),
        FuzzSpec("LoopAlarms", b.LoopAlarms, configs["LoopAlarms"], step=_step(
            lambda blk, v, dt, f: blk(0.0 if v[1] is None else v[1], v[0], pv_ok=f[0],
                                      manual=f[1], dt=dt)), records_inputs=True),
        FuzzSpec("StepController", b.StepController, configs["StepController"], step=_step(
            lambda blk, v, dt, f: blk(v[0], dt=dt, open_limit=f[0], close_limit=f[1],
                                      feedback=v[1] if f[2] else None))),
        FuzzSpec("MovingAverage", b.MovingAverage, configs["MovingAverage"],
                 oracle=_moving_average_oracle, nonfinite_state=("_sum", "_spread", "_mag")),
        FuzzSpec("PulseWidth", b.PulseWidth, configs["PulseWidth"], limit_fields=("in_lo", "in_hi"),
                 nonfinite_state=("t_in",)),
        FuzzSpec("TwoPoint", b.TwoPoint, configs["TwoPoint"], step=_step(_on_off_step),
                 controller=False),
        FuzzSpec("ThreePoint", b.ThreePoint, configs["ThreePoint"], step=_step(_on_off_step),
                 controller=False),
        FuzzSpec("TransferFunction", b.TransferFunction, configs["TransferFunction"],
                 step=_step(lambda blk, v, dt, f: blk(v[0], init=f[0])),
                 limit_fields=("out_min", "out_max")),
        FuzzSpec("SetpointProgram", b.SetpointProgram, configs["SetpointProgram"], step=_step(
            lambda blk, v, dt, f: blk(v[0], pv_ok=f[0], run=f[1], reset=f[2], dt=dt)),
            controller=False),
        FuzzSpec("HeatCoolPID", b.HeatCoolPID, configs["HeatCoolPID"],
                 step=_step(_heat_cool_step), controller=False),
        FuzzSpec("Regulator", b.Regulator, configs["Regulator"], step=_step(_regulator_step),
                 controller=False, limit_fields=("u_min", "u_max")),
        FuzzSpec("Saturation", b.Saturation, configs["Saturation"], limit_fields=("lo", "hi")),
        FuzzSpec("Scale", b.Scale, configs["Scale"], limit_fields=("out_lo", "out_hi")),
        *(FuzzSpec(n, getattr(b, n), configs[n]) for n in (
            "PT1", "RateLimiter", "SteadyStateDetector", "JumpAndRate", "DeadBand")),
    ):  # fmt: skip
        register_fuzz(spec)
