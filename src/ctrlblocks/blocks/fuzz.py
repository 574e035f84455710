"""Fuzz campaign of the block contract over every exported block (docs/reliability.md).

One implementation of the actions and the checks (:class:`Driver`), used by two
drivers:

* the hypothesis state machine of ``tests/blocks/test_fuzz_campaign.py`` (short
  CI profile, shrinking), which picks every action and value itself;
* the plain seeded random driver of this module, for the long campaign::

      python -m ctrlblocks.blocks.fuzz --steps 10000000          # per block
      python -m ctrlblocks.blocks.fuzz --steps 100000 --block PID --seed 3

  It prints a progress line every ``--every`` seconds (also when stdout is not
  a terminal): steps, steps/s and the count per block, and exits with status
  1 on the first breach, printing the block, the seed, the step and the last
  actions as Python code (replay: the same command with ``--block``,
  ``--seed`` and ``--steps`` up to that step).

The checks after every action (:class:`Breach` names the broken promise):

1. no exception from process data (inputs, flags, ``dt``, modes, limits);
2. ``out`` finite and inside :meth:`~ctrlblocks.Block.output_limits`;
3. a refused ``configure`` raises :class:`~ctrlblocks.ParameterError` with an
   error code and leaves configuration and state (``snapshot()``) unchanged;
4. the per-call path (``block(...)``, fast lane where it applies) equals the
   two-phase path (``compute_output`` then ``update_state``) of a twin block
   driven with the same actions: same ``out`` (:data:`LANE_TOL`) and ``error_id``,
   and the same state (``snapshot()``, floats to :data:`LANE_TOL`), for every
   block with both paths (PID, ADRC, GainSchedule);
5. PID and ADRC: the first AUTO cycle after MANUAL/TRACK/HOLD/RESET, and the
   first good cycle after a bad input (``BAD_INPUT``, ``BAD_MEASUREMENT``,
   ``BAD_RESULT``), continue from the last output within :data:`BUMP_TOL`;
6. ``restore(snapshot())`` then the same step gives the same output and status;
7. the state stays finite: every float of ``snapshot()`` (and of the
   statistics a block reports, such as ``CycleMonitor.jitter_std``) is finite
   after every action -- a state that overflowed behind a finite output (an
   accumulator of an absurd ``dt``, an observer in MAN) is a breach even when
   the output is held;
8. a block's own oracle where it has one: the moving average is the mean of the
   window it holds (:func:`math.fsum`, to ``1e-9`` of the largest value in the
   window: a running sum that lost the small values after one huge sample
   left is a breach); the cycle monitor's flags follow the live condition
   unless latched, and ``acknowledge()`` sets them back to it.
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
import inspect
import math
import random
import sys
import time
import traceback
from collections.abc import Callable
from typing import Any

import numpy as np

from .base import Block, ErrorCode, Mode, ParameterError, live_snapshots

__all__ = ["BLOCKS", "BUMP_TOL", "LANE_TOL", "Breach", "Driver", "exported_blocks", "main"]

LANE_TOL = 1e-9
"""Per-call and two-phase outputs agree to ``LANE_TOL * max(1, |out|)`` (they run the
same operations, so in practice they are equal)."""

BUMP_TOL = 1e-9
"""A bumpless transfer moves the output by at most ``BUMP_TOL * scale``, ``scale`` =
``max(1, |u|, |P| + |I| + |D| + |FF|)`` (PID) or ``max(1, |u|, |u_raw|)`` (ADRC): the
rounding of re-solving the integrator (PID) or x4 (ADRC, Nowak et al. 2018, (11))."""

_MAX = sys.float_info.max
HOSTILE: tuple[Any, ...] = (
    math.nan, math.inf, -math.inf, -0.0, 5e-324, -5e-324, 1e-310, 1e300, -1e300, _MAX, -_MAX,
    10**400, -(10**400), np.float16(513), np.float16(-0.0), np.float16(65504), np.float32(3.3),
    np.float32(1e38), np.int64(7), np.int64(-(2**62)), np.bool_(True), True, False, 3, -2,
    None, "1", 1 + 1j,
)  # fmt: skip
"""Hostile process values: NaN, +-inf, -0.0, denormals, huge, max float, 10**400, numpy
scalars, ints, bools, and non-numbers."""

HOSTILE_DT: tuple[Any, ...] = (
    0.0, -0.1, math.nan, math.inf, -math.inf, 5e-324, 1e-300, 1e300, _MAX, 10**400,
    np.float32(0.05), np.float16(0.1), 1e-9, 3600.0, 2, True, "0.1",
)  # fmt: skip
"""Hostile per-call sample times: 0, negative, NaN, inf, tiny, huge and odd types."""

BAD_PARAMS: tuple[Any, ...] = (
    math.nan, math.inf, -math.inf, -1.0, 0.0, "1", None, True, 10**400, 5e-324, 1e308,
    -1e308, [1, 2], 7, np.float32(2.0), np.int64(3),
)  # fmt: skip
"""Values for random reconfigurations (most are refused, some accepted)."""

_FLAG_VALUES: tuple[Any, ...] = (True, False, np.bool_(True), np.bool_(False), 1, 0, None)


class Breach(AssertionError):
    """A broken promise of the block contract (the message names it)."""


# ---------------------------------------------------------------------------
# Block specifications: random valid configurations and one step
# ---------------------------------------------------------------------------


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
        from .transfer import lowpass, notch, tustin

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


@dataclasses.dataclass(frozen=True)
class Spec:
    """How the campaign makes and drives one block class."""

    name: str
    cls: type[Block]
    config: Callable[[random.Random], dict[str, Any]]
    controller: bool = False  # sp/pv block with modes, limits and a plant in the loop
    two_phase: bool = False  # has compute_output/update_state with __call__'s arguments


def exported_blocks() -> dict[str, type[Block]]:
    """Every :class:`~ctrlblocks.Block` subclass exported by ``ctrlblocks.blocks``.

    (``ctrlblocks`` exports the same blocks; the test of the campaign checks it.)
    """
    import ctrlblocks.blocks as package

    out = {}
    for name in package.__all__:
        obj = getattr(package, name)
        if inspect.isclass(obj) and issubclass(obj, Block) and obj is not Block:
            out[name] = obj
    return out


def _gain_schedule_config(r: random.Random) -> dict[str, Any]:
    return {"_pid": _pid_config(r), "kp": (_lu(r, 1e-2, 10.0), _lu(r, 1e-2, 10.0))}


def _specs() -> dict[str, Spec]:
    blocks = exported_blocks()
    configs = _simple_configs()
    configs["GainSchedule"] = _gain_schedule_config
    specs = {}
    for name, cls in blocks.items():
        if name not in configs:
            continue  # tests/blocks/test_fuzz_campaign.py fails: every block needs a generator
        specs[name] = Spec(
            name,
            cls,
            configs[name],
            controller=name in ("PID", "ADRC", "GainSchedule"),
            two_phase=name in ("PID", "ADRC", "GainSchedule"),
        )
    return specs


def _make(spec: Spec, cfg: dict[str, Any]) -> Block:
    if spec.name == "GainSchedule":
        from .pid import PID

        pid = PID(**cfg["_pid"])
        return spec.cls(pid, breakpoints=(0.0, 100.0), kp=cfg["kp"])  # type: ignore[arg-type]
    return spec.cls(**cfg)


BLOCKS: dict[str, Spec] = _specs()
"""The campaign's specification of every exported block, by name."""


# ---------------------------------------------------------------------------
# The driver: actions and checks (one implementation for both drivers)
# ---------------------------------------------------------------------------


_USER_INPUTS = {"u_man", "manual_value", "track_value"}
"""Inputs a user writes that the snapshot keeps (the manual and track values): a NaN
there is a bad input the block reports and holds against, not a state it computed."""


def _non_finite(x: Any, path: str = "") -> str | None:
    """The path of the first non-finite float in a snapshot (dicts, sequences, arrays), or None.

    The float32 cycle's state (``_plc_state``) holds infinite limits as +-REAL_MAX,
    so it is finite too; ``None`` (no state yet) is fine.
    """
    if isinstance(x, float | np.floating):
        return None if -math.inf < x < math.inf else path or "value"
    if isinstance(x, dict):
        for k, v in x.items():
            if k in _USER_INPUTS:
                continue
            bad = _non_finite(v, f"{path}.{k}" if path else str(k))
            if bad:
                return bad
    elif isinstance(x, list | tuple):
        for i, v in enumerate(x):
            bad = _non_finite(v, f"{path}[{i}]")
            if bad:
                return bad
    elif isinstance(x, np.ndarray) and x.dtype.kind == "f" and not np.isfinite(x).all():
        return path
    return None


def _moving_average_oracle(b: Any) -> str | None:
    n = b.config.n
    count = b._count
    if count == 0:
        return None
    window = [b._buf[(b._idx - count + j) % n] for j in range(count)]
    exact = math.fsum(v / count for v in window)
    big = max(abs(v) for v in window)
    if not abs(b.out - exact) <= 1e-9 * big:
        return f"out {b.out!r} is not the mean {exact!r} of its window (largest |value| {big:.3g})"
    return None


def _cycle_monitor_oracle(b: Any) -> str | None:
    if not -math.inf < b.jitter_std < math.inf:
        return f"jitter_std = {b.jitter_std!r}"
    live = b.count > 0 and b.out > b.warn_limit, b.count > 0 and b.out > b.alarm_limit
    flags = (b.warning, b.alarm)
    missed = any(now and not f for f, now in zip(flags, live, strict=True))
    if (not b.config.latch and flags != live) or missed:
        return f"flags (warning, alarm) = {flags} against the live condition {live}"
    return None


_NON_FINITE_BY_DESIGN: dict[str, tuple[str, ...]] = {
    "MovingAverage": ("_sum", "_err", "_mag"),
    "PulseWidth": ("t_in",),
}

_RECORDS_INPUTS = {"Alarm", "LoopAlarms"}
"""Blocks whose state records the process values as they came (the alarm blocks' last
value and transition log, NaN included): promise 6 (finite state) does not apply to them."""
"""State that is +inf by design: the moving average's running sums while the window's sum
exceeds the float range (its mean, finite, then comes from the window itself; promise 8
checks it), and the PWM's time in the period, +inf for "a period starts now"."""

_ORACLES: dict[str, Callable[[Any], str | None]] = {
    "MovingAverage": _moving_average_oracle,
    "CycleMonitor": _cycle_monitor_oracle,
}


def _same(a: float, b: float, tol: float) -> bool:
    if a == b:
        return True
    return abs(a - b) <= tol * max(1.0, abs(a), abs(b))


def _snap_equal(a: Any, b: Any, tol: float = 0.0) -> bool:
    """Equality of snapshots that treats NaN as equal to NaN; floats to ``tol`` (relative)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_snap_equal(a[k], b[k], tol) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        if type(a) is list and type(b) is list and _plain_equal(a, b):
            return True  # a moving average's buffer: compared at C speed
        return len(a) == len(b) and all(_snap_equal(x, y, tol) for x, y in zip(a, b, strict=True))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return _arrays_equal(np.asarray(a), np.asarray(b), tol)
    if a != a and b != b:  # NaN, also a numpy NaN (the float32 cycle's state)
        return True
    if tol and type(a) is float and type(b) is float:
        return _same(a, b, tol)
    return bool(a == b)


def _arrays_equal(a: np.ndarray, b: np.ndarray, tol: float) -> bool:
    """:func:`_snap_equal` for arrays (the float32 PLC cycle's dead-band window):
    same shape, NaN equal to NaN, floats to ``tol`` (relative)."""
    if a.shape != b.shape:
        return False
    if a.dtype.kind not in "fc" or b.dtype.kind not in "fc":
        return bool(np.array_equal(a, b))
    x, y = a.astype(np.float64), b.astype(np.float64)
    both_nan = np.isnan(x) & np.isnan(y)
    with np.errstate(invalid="ignore", over="ignore"):
        close = (x == y) | (np.abs(x - y) <= tol * np.maximum(1.0, np.maximum(abs(x), abs(y))))
    return bool(np.all(close | both_nan))


def _plain_equal(a: Any, b: Any) -> bool:
    """``a == b`` at C speed, for containers of plain numbers (False where that cannot
    decide: NaN, tolerance and numpy arrays are :func:`_snap_equal`'s)."""
    try:
        return bool(a == b)
    except (TypeError, ValueError):  # numpy arrays inside
        return False


def _snap_diff(a: dict[str, Any], b: dict[str, Any], tol: float) -> str:
    """The first state variables in which two snapshots differ (for the breach report)."""
    keys = [k for k in a if k not in b or not _snap_equal(a[k], b[k], tol)]
    return ", ".join(f"{k}: {a.get(k)!r} vs {b.get(k)!r}" for k in keys[:4])


_BAD_DATA = (ErrorCode.BAD_INPUT, ErrorCode.BAD_MEASUREMENT, ErrorCode.BAD_RESULT)
_GOOD = (ErrorCode.NO_ERROR, ErrorCode.WARN_DISCRETISATION)


class Driver:
    """One block (and, for two-phase blocks, its twin) under the campaign's actions.

    Each ``act_*`` method performs one action with explicit values and then runs
    the checks; it raises :class:`Breach` when a promise is broken.  ``log``
    keeps the last actions as Python code for the reproducer.
    """

    def __init__(self, spec: Spec, cfg: dict[str, Any], log_len: int = 40) -> None:
        self.spec = spec
        # the last actions, formatted only for a report (formatting costs more than a step)
        self.log: collections.deque[tuple[Any, ...]] = collections.deque(maxlen=log_len)
        self.log.append(("new", cfg))
        try:
            self.block = _make(spec, cfg)
            self.twin = _make(spec, cfg) if self._twin_ok() else None
        except ParameterError:
            raise
        except Exception as exc:  # a valid-looking configuration must not crash the constructor
            raise Breach(f"{spec.name}({cfg!r}) raised {exc!r}") from exc
        self.y = 0.0  # plant output for controllers
        self.steps = 0
        self._check_out(self.block, "construction")

    # -- helpers ---------------------------------------------------------------

    def _ctl(self, b: Block) -> Any:
        return b.controller if self.spec.name == "GainSchedule" else b  # type: ignore[attr-defined]

    def _twin_ok(self) -> bool:
        # ADRC with u_real_on applies the measured u_real in __call__ only; the
        # precision="float32" PLC cycle is a per-call cycle (its two-phase form is float64)
        c = self._ctl(self.block).config
        return (
            self.spec.two_phase
            and not getattr(c, "u_real_on", False)
            and getattr(c, "precision", "float64") == "float64"
        )

    def _check_out(self, b: Block, what: str) -> None:
        y = b.out
        lo, hi = self._ctl(b).output_limits()
        if not (isinstance(y, float) and -math.inf < y < math.inf):
            raise Breach(f"{self.spec.name}: out = {y!r} is not a finite float after {what}")
        if not lo <= y <= hi:
            raise Breach(f"{self.spec.name}: out = {y!r} outside [{lo!r}, {hi!r}] after {what}")
        if not isinstance(b.error_id, int):
            raise Breach(f"{self.spec.name}: error_id {b.error_id!r} is not an int")

    def _check_state(self, b: Block, what: str) -> None:
        """Promises 7 and 8: a finite state, and the block's own oracle."""
        with live_snapshots():
            snap = {} if self.spec.name in _RECORDS_INPUTS else b.snapshot()
            sentinels = _NON_FINITE_BY_DESIGN.get(self.spec.name, ())
            bad = _non_finite({k: v for k, v in snap.items() if k not in sentinels})
        if bad:
            raise Breach(f"{self.spec.name}: state {bad} is not finite after {what}")
        oracle = _ORACLES.get(self.spec.name)
        why = oracle(b) if oracle is not None else None
        if why:
            raise Breach(f"{self.spec.name}: {why} after {what}")

    def act_acknowledge(self) -> None:
        """``acknowledge()`` of a block with alarm flags (the cycle monitor)."""
        self.log.append(("acknowledge",))
        self._both("acknowledge", lambda b: b.acknowledge())
        self._check_state(self.block, "acknowledge")
        b: Any = self.block
        live = b.count > 0 and b.out > b.warn_limit, b.count > 0 and b.out > b.alarm_limit
        if (b.warning, b.alarm) != live:
            raise Breach(
                f"{self.spec.name}: acknowledge() left (warning, alarm) = "
                f"{(b.warning, b.alarm)} against the live condition {live}"
            )

    def _guarded(self, what: str, fn: Callable[[], Any]) -> Any:
        try:
            return fn()
        except Breach:
            raise
        except Exception as exc:
            raise Breach(f"{self.spec.name}: {what} raised {exc!r}") from exc

    def _both(self, what: str, fn: Callable[[Any], Any]) -> None:
        self._guarded(what, lambda: fn(self.block))
        if self.twin is not None:
            self._guarded(what + " (twin)", lambda: fn(self.twin))

    def _compare_twin(self, what: str) -> None:
        t = self.twin
        if t is None:
            return
        a, b = self.block, t
        if not _same(a.out, b.out, LANE_TOL) or a.error_id != b.error_id:
            raise Breach(
                f"{self.spec.name}: per-call and two-phase paths differ after {what}: "
                f"out {a.out!r} vs {b.out!r}, error_id {a.error_id!r} vs {b.error_id!r}"
            )
        # the states too, after every action: a divergence behind an output held at a
        # limit shows in the output only later or never (docs/reliability.md); read in
        # place, not copied (a copy per action made the PID's run 2x slower)
        with live_snapshots():
            sa, sb = a.snapshot(), b.snapshot()
            if not (_plain_equal(sa, sb) or _snap_equal(sa, sb, LANE_TOL)):
                raise Breach(
                    f"{self.spec.name}: per-call and two-phase states differ after {what}: "
                    + _snap_diff(sa, sb, LANE_TOL)
                )

    # -- one process step ------------------------------------------------------

    def _call(self, b: Any, two_phase: bool, vals: list[Any], dt: Any, flags: list[Any]) -> Any:
        n = self.spec.name
        if self.spec.controller:
            sp = vals[0]
            pv = vals[1] if vals[1] is not None else self.y
            if n == "PID":
                kw = {"ff": vals[2], "dv": vals[3], "dt": dt, "pv_ok": flags[0]}
            elif n == "ADRC":
                kw = {"y_ok": flags[0], "dt": dt}
                if not two_phase:
                    kw["u_real"] = vals[2] if flags[1] else None
            else:
                kw = {"dt": dt, "pv_ok": flags[0]}
            args = (sp, pv, vals[4]) if n == "GainSchedule" else (sp, pv)
            if two_phase:
                v = b.compute_output(*args, **kw)
                b.update_state(v)
                return v
            return b(*args, **kw)
        v = vals[0]
        if n in ("PT1", "RateLimiter", "SteadyStateDetector", "JumpAndRate", "PulseWidth"):
            return b(v, dt=dt)
        if n in ("DeadBand", "Scale", "MovingAverage", "Saturation"):
            return b(v)
        if n in ("MinSelector", "MaxSelector"):
            return b(*vals[: 1 + int(flags[0] is True) + int(flags[1] is True)])
        if n == "LeadLag":
            return b(v, enable=flags[0], dt=dt)
        if n == "ManualStation":
            return b(inc=flags[0], dec=flags[1], track=v if flags[2] else None, dt=dt)
        if n == "CycleMonitor":
            return b(dt if dt is not None else v)
        if n == "Alarm":
            return b(v, ok=flags[0], suppress=flags[1], dt=dt)
        if n == "LoopAlarms":
            return b(0.0 if vals[1] is None else vals[1], v, pv_ok=flags[0], manual=flags[1], dt=dt)
        if n in ("TwoPoint", "ThreePoint"):
            return b(0.0 if vals[1] is None else vals[1], v, pv_ok=flags[0], enable=flags[1], dt=dt)
        if n == "TransferFunction":
            return b(v, init=flags[0])
        if n == "SetpointProgram":
            return b(v, pv_ok=flags[0], run=flags[1], reset=flags[2], dt=dt)
        if n == "HeatCoolPID":
            b.manual = flags[2]
            return b(0.0 if vals[1] is None else vals[1], v, pv_ok=flags[0], dt=dt)
        if n == "Regulator":
            b.auto, b.remote = flags[1], flags[2]
            sp = 0.0 if vals[1] is None else vals[1]
            return b(v, sp, sp_inc=flags[0], out_dec=flags[1], pv_ok=flags[0], dt=dt)
        if n == "StepController":
            fb = vals[1] if flags[2] else None
            return b(v, dt=dt, open_limit=flags[0], close_limit=flags[1], feedback=fb)
        raise RuntimeError(f"no step for {n}")

    def act_step(self, vals: list[Any], dt: Any, flags: list[Any]) -> None:
        """One process step with these values (``vals[1] = None``: the plant's output)."""
        self.log.append(("step", vals, dt, flags, self.y))
        a = self.block
        ctl = self._ctl(a)
        prev_out, prev_err = a.out, a.error_id
        bump = self.spec.name in ("PID", "ADRC")
        prev_mode = ctl.mode if bump else None
        scale = self._scale(ctl) if bump else 1.0
        self._guarded("step", lambda: self._call(a, False, vals, dt, flags))
        self._check_out(a, "step")
        self._check_state(a, "step")
        if self.twin is not None:
            self._guarded("two-phase step", lambda: self._call(self.twin, True, vals, dt, flags))
            self._check_out(self.twin, "two-phase step")
            self._compare_twin("step")
        if bump:
            self._check_bumpless(ctl, prev_out, prev_err, prev_mode, scale, dt)
        if self.spec.controller:
            self._plant(a.out)
        self.steps += 1

    def _plant(self, u: float) -> None:
        # a first-order process in the loop, so that controllers meet limits and windup
        self.y = 0.95 * self.y + 0.05 * max(-1e6, min(1e6, u))

    def _scale(self, ctl: Block) -> float:
        terms = [getattr(ctl, n, 0.0) for n in ("out", "p", "i", "d", "ff", "u_raw")]
        return max([1.0] + [abs(t) for t in terms if isinstance(t, float) and math.isfinite(t)])

    def _check_bumpless(
        self, ctl: Block, prev_out: float, prev_err: int, prev_mode: Any, scale: float, dt: Any
    ) -> None:
        """Promise 5 (PID and ADRC only)."""
        mode = getattr(ctl, "mode", None)
        if mode != Mode.AUTO or ctl.error_id not in (*_GOOD, ErrorCode.BAD_LIMITS):
            return
        if dt is not None or getattr(ctl, "awin", False):
            return
        if getattr(ctl.config, "precision", "float64") != "float64":
            return  # float32: bumpless to single-precision rounding only (docs/reliability.md)
        was_manual = prev_mode is not None and prev_mode != Mode.AUTO
        # (ADRC with u_real_on: a missing u_real is BAD_INPUT while the law runs on its own u)
        was_bad = prev_err in _BAD_DATA and not getattr(ctl.config, "u_real_on", False)
        if not (was_manual or was_bad) or not self._clean:
            return
        if abs(ctl.out - prev_out) > BUMP_TOL * max(scale, self._scale(ctl)):
            why = "MAN->AUTO" if was_manual else f"recovery from {ErrorCode(prev_err).name}"
            raise Breach(
                f"{self.spec.name}: {why} is not bumpless: {prev_out!r} -> {ctl.out!r} "
                f"(tolerance {BUMP_TOL} x {scale:.3g})"
            )

    @property
    def _clean(self) -> bool:
        """No configuration or limit change since the last step (bumpless applies)."""
        return not self._dirty

    _dirty = False

    def step_done(self) -> None:
        self._dirty = False

    # -- other actions -----------------------------------------------------------

    def act_mode(self, name: str, value: Any) -> None:
        """Set a mode input of a controller (``manual``, ``track``, ``hold``, ...)."""
        self.log.append(("set", name, value))
        self._both(f"mode {name}", lambda b: setattr(self._ctl(b), name, value))

    def act_limits(self, lo: Any, hi: Any) -> None:
        """Write output limits at run time (``set_limits``) or by configure."""
        self.log.append(("limits", lo, hi))
        self._dirty = True
        if hasattr(self._ctl(self.block), "set_limits"):
            self._both("set_limits", lambda b: self._ctl(b).set_limits(lo, hi))
            self._check_out(self.block, "set_limits")
        else:
            self.act_configure(self._limit_fields(lo, hi))

    def _limit_fields(self, lo: Any, hi: Any) -> dict[str, Any]:
        names = {
            "Saturation": ("lo", "hi"),
            "LeadLag": ("out_min", "out_max"),
            "ManualStation": ("out_min", "out_max"),
            "Scale": ("out_lo", "out_hi"),
            "PulseWidth": ("in_lo", "in_hi"),
            "TransferFunction": ("out_min", "out_max"),
            "Regulator": ("u_min", "u_max"),
            "GainSchedule": (),
        }.get(self.spec.name, ())
        return dict(zip(names, (lo, hi), strict=True)) if names else {}

    def act_configure(self, changes: dict[str, Any]) -> None:
        """Reconfigure: accepted (then the outputs are checked) or refused (promise 3)."""
        if not changes:
            return
        self.log.append(("configure", changes))
        self._dirty = True
        blocks = [self.block] + ([self.twin] if self.twin is not None else [])
        outcomes: list[ErrorCode | str | None] = []
        for b in blocks:
            cfg = b.config
            snap = self._guarded("snapshot", b.snapshot)
            try:
                b.configure(**changes)
                outcomes.append(None)
            except ParameterError as err:
                if not isinstance(err.code, ErrorCode) or err.code == ErrorCode.NO_ERROR:
                    raise Breach(
                        f"{self.spec.name}: refused configure without a code: {err}"
                    ) from err
                if b.config != cfg:
                    raise Breach(
                        f"{self.spec.name}: refused {changes!r} changed the config"
                    ) from err
                if not _snap_equal(b.snapshot(), snap):
                    raise Breach(
                        f"{self.spec.name}: refused {changes!r} changed the state"
                    ) from err
                outcomes.append(err.code)
            except TypeError as err:
                if "has no parameter" not in str(err):
                    raise Breach(
                        f"{self.spec.name}: configure({changes!r}) raised {err!r}"
                    ) from err
                outcomes.append("unknown")
            except Exception as exc:
                raise Breach(f"{self.spec.name}: configure({changes!r}) raised {exc!r}") from exc
            self._check_out(b, f"configure({changes!r})")
        if len(set(map(str, outcomes))) > 1:
            raise Breach(f"{self.spec.name}: block and twin disagree on configure {changes!r}")
        if self.twin is not None and not self._twin_ok():
            self.twin = None

    def act_snapshot_restore(self, vals: list[Any], dt: Any, flags: list[Any]) -> None:
        """``restore(snapshot())`` then the same step twice gives the same result (promise 6)."""
        self.log.append(("snapshot/step/restore/step", vals, dt, flags, self.y))
        a = self.block
        snap = self._guarded("snapshot", a.snapshot)
        y_saved = self.y
        self._guarded("step", lambda: self._call(a, False, vals, dt, flags))
        out1, err1 = a.out, a.error_id
        self._guarded("restore", lambda: a.restore(snap))
        self._check_out(a, "restore")
        self._guarded("step", lambda: self._call(a, False, vals, dt, flags))
        if not (_snap_equal(out1, a.out) and err1 == a.error_id):
            raise Breach(
                f"{self.spec.name}: the same step after restore() differs: "
                f"{out1!r}/{err1!r} vs {a.out!r}/{a.error_id!r}"
            )
        self.y = y_saved
        if self.twin is not None:
            self._guarded("two-phase step", lambda: self._call(self.twin, True, vals, dt, flags))
            self._compare_twin("snapshot/restore")
        self._dirty = True

    def act_reset(self) -> None:
        """``reset()``: back to the initial state; outputs checked."""
        self.log.append(("reset",))
        self._dirty = True
        self._both("reset", lambda b: b.reset())
        self._check_out(self.block, "reset")
        self._compare_twin("reset")

    def reproducer(self) -> str:
        """The last actions, one a line (for the breach report)."""
        lines = []
        for kind, *args in self.log:
            if kind == "new":
                lines.append(f"b = {self.spec.name}(**{args[0]!r})")
            elif kind in ("step", "snapshot/step/restore/step"):
                vals, dt, flags, y = args
                lines.append(f"{kind}: vals={vals!r} dt={dt!r} flags={flags!r} plant y={y!r}")
            elif kind == "set":
                lines.append(f"b.{args[0]} = {args[1]!r}")
            elif kind == "limits":
                lines.append(f"limits {args[0]!r}, {args[1]!r}")
            elif kind == "configure":
                lines.append(f"b.configure(**{args[0]!r})")
            elif kind == "acknowledge":
                lines.append("b.acknowledge()")
            else:
                lines.append(f"b.{kind}()")
        return "\n".join(line if len(line) < 400 else line[:400] + " ..." for line in lines)


# ---------------------------------------------------------------------------
# The plain random driver (long campaign)
# ---------------------------------------------------------------------------

_MODES = ("manual", "track", "hold", "reset_active", "awin")


class RandomRun:
    """Draws the actions of :class:`Driver` from a seeded ``random.Random``."""

    def __init__(self, spec: Spec, seed: int) -> None:
        self.spec = spec
        self.r = random.Random(seed)
        self.driver = self._new_driver()

    def _new_driver(self) -> Driver:
        for _ in range(200):
            cfg = self.spec.config(self.r)
            try:
                return Driver(self.spec, cfg)
            except ParameterError:
                continue
        raise RuntimeError(f"no valid random configuration for {self.spec.name}")

    def _value(self, center: float, spread: float) -> Any:
        r = self.r
        x = r.random()
        if x < 0.04:
            return r.choice(HOSTILE)
        return center + spread * (r.random() - 0.5) * 2.0

    def _inputs(self) -> tuple[list[Any], Any, list[Any]]:
        r = self.r
        if self.spec.controller:
            sp = self._value(r.choice((0.0, 20.0, 50.0)), 60.0) if r.random() < 0.2 else 30.0
            pv = None if r.random() < 0.9 else self._value(30.0, 60.0)
            ff = 0.0 if r.random() < 0.8 else self._value(0.0, 5.0)
            dv = 0.0 if r.random() < 0.8 else self._value(0.0, 5.0)
            w = self._value(50.0, 60.0)
            vals = [sp, pv, ff, dv, w]
        else:
            vals = [self._value(0.0, 120.0) for _ in range(3)]
        dt = None if r.random() < 0.9 else r.choice(HOSTILE_DT)
        flags = [
            r.random() < 0.97 if r.random() < 0.97 else r.choice(_FLAG_VALUES),
            r.random() < 0.5,
            r.random() < 0.5,
        ]
        return vals, dt, flags

    def step(self) -> None:
        r, d = self.r, self.driver
        x = r.random()
        if x < 0.93:
            vals, dt, flags = self._inputs()
            d.act_step(vals, dt, flags)
            d.step_done()
        elif x < 0.95 and self.spec.controller:
            name = r.choice(_MODES if self.spec.name != "ADRC" else ("manual", "awin"))
            value = r.random() < 0.5 if r.random() < 0.95 else r.choice(_FLAG_VALUES)
            d.act_mode(name, value)
            if name in ("manual", "track") and r.random() < 0.5:
                attr = "manual_value" if name == "manual" else "track_value"
                d.act_mode(attr, self._value(30.0, 100.0))
        elif x < 0.96:
            lo = r.uniform(-100.0, 100.0)
            hi = lo + r.uniform(0.0, 100.0) if r.random() < 0.8 else r.uniform(-100.0, 100.0)
            if r.random() < 0.1:
                lo, hi = (r.choice(HOSTILE), hi) if r.random() < 0.5 else (lo, r.choice(HOSTILE))
            d.act_limits(lo, hi)
        elif x < 0.975:
            fields = [f.name for f in dataclasses.fields(d.block.config)]
            if self.spec.name == "GainSchedule":
                fields = []
            changes = {}
            if fields and r.random() < 0.5:  # a valid random value for one or more fields
                new = self.spec.config(r)
                for name in r.sample(fields, min(len(fields), r.randint(1, 3))):
                    if name in new:
                        changes[name] = new[name]
            elif fields:
                changes[r.choice(fields)] = r.choice(BAD_PARAMS)
            d.act_configure(changes)
        elif x < 0.985:
            vals, dt, flags = self._inputs()
            d.act_snapshot_restore(vals, dt, flags)
        elif x < 0.99:
            if self.spec.name == "CycleMonitor" and r.random() < 0.5:
                d.act_acknowledge()
            else:
                d.act_reset()
        elif x < 0.9905:
            self.driver = self._new_driver()  # a fresh random configuration
        else:
            vals, dt, flags = self._inputs()
            d.act_step(vals, dt, flags)
            d.step_done()


def run(
    names: list[str],
    steps: int,
    seed: int,
    every: float = 30.0,
    out: Any = None,
    minutes: float | None = None,
) -> int:
    """Run up to ``steps`` actions per block; return 0, or 1 on a breach.

    The blocks take turns in slices of equal CPU time (about 0.1 s), so a cheap
    block is not held back by an expensive one; ``minutes`` stops the campaign
    after that wall time with the counts reached (still 0 on no breach).
    """
    out = out or sys.stdout
    runs: dict[str, RandomRun] = {}
    done = dict.fromkeys(names, 0)
    t0 = last = time.monotonic()
    deadline = math.inf if minutes is None else t0 + 60.0 * minutes
    pending = list(names)
    stopped = False
    while pending and not stopped:
        for n in list(pending):
            t_slice = time.monotonic() + 0.1
            try:
                rr = runs.get(n) or runs.setdefault(n, RandomRun(BLOCKS[n], seed + names.index(n)))
                while done[n] < steps:
                    for _ in range(min(50, steps - done[n])):
                        rr.step()
                        done[n] += 1
                    if time.monotonic() >= t_slice:
                        break
            except Breach as exc:
                s = seed + names.index(n)
                print(f"BREACH in {n} (seed {s}, step {done[n]}): {exc}", file=out)
                print(
                    f"reproduce: python -m ctrlblocks.blocks.fuzz --block {n} --seed {s} "
                    f"--steps {done[n] + 1}",
                    file=out,
                )
                if exc.__cause__ is not None:  # where the block raised, for the fix
                    tb = traceback.format_exception(exc.__cause__)
                    print("".join(tb[-6:]).rstrip(), file=out)
                if n in runs:
                    print("last actions:\n" + runs[n].driver.reproducer(), file=out, flush=True)
                return 1
            if done[n] >= steps:
                pending.remove(n)
        now = time.monotonic()
        stopped = now >= deadline
        if now - last >= every or not pending or stopped:
            last = now
            total = sum(done.values())
            rate = total / max(now - t0, 1e-9)
            counts = " ".join(f"{n}={done[n]}" for n in names)
            print(
                f"[{now - t0:8.0f} s] steps {total} ({rate:,.0f} steps/s) {counts}",
                file=out,
                flush=True,
            )
    total = sum(done.values())
    how = "stopped at the time budget" if stopped and pending else "done"
    print(
        f"{how}: {total} steps, {min(done.values())} to {max(done.values())} per block, 0 breaches",
        file=out,
        flush=True,
    )
    return 0


def traces(steps: int, seeds: int, float32_seeds: int = 0) -> dict[str, Any]:
    """What every block outputs along the campaign's seeded actions, for comparing builds.

    For each exported block and seed ``0 .. seeds-1`` (and, for PID and ADRC,
    the first ``float32_seeds`` seeds from 1000 on whose block starts in
    ``precision="float32"``): after each of ``steps`` actions of
    :class:`RandomRun`, ``repr(out)`` (bit for bit) and the error code.
    Returns ``{"traces": {"NAME/seed": [...]}, "float32": actions in float32}``.
    Used to hold the compiled build to the interpreted blocks
    (``ctrlblocks.compiled``).
    """

    def f32_seeds(spec: Spec) -> list[int]:
        found: list[int] = []
        seed = 1000
        while len(found) < float32_seeds:
            if getattr(RandomRun(spec, seed).driver.block.config, "precision", "") == "float32":
                found.append(seed)
            seed += 1
        return found

    out: dict[str, Any] = {"traces": {}, "float32": 0}
    for name, spec in sorted(BLOCKS.items()):
        extra = f32_seeds(spec) if name in ("PID", "ADRC") else []
        for seed in [*range(seeds), *extra]:
            run = RandomRun(spec, seed)
            trace = []
            for _ in range(steps):
                run.step()
                b = run.driver.block
                trace.append((repr(b.out), int(b.error_id)))
                out["float32"] += getattr(b.config, "precision", "") == "float32"
            out["traces"][f"{name}/{seed}"] = trace
    return out


def main(argv: list[str] | None = None) -> int:
    """Command line of the long campaign (see the module docstring)."""
    ap = argparse.ArgumentParser(prog="python -m ctrlblocks.blocks.fuzz", description=__doc__
                                 .split("\n")[0])  # fmt: skip
    ap.add_argument("--steps", type=int, default=100_000, help="actions per block")
    ap.add_argument("--seed", type=int, default=0, help="seed of the first block's run")
    ap.add_argument("--block", action="append", choices=sorted(BLOCKS), help="only this block")
    ap.add_argument("--every", type=float, default=30.0, help="seconds between progress lines")
    ap.add_argument("--minutes", type=float, default=None, help="stop after this wall time")
    a = ap.parse_args(argv)
    names = a.block or sorted(BLOCKS)
    return run(names, a.steps, a.seed, a.every, minutes=a.minutes)


if __name__ == "__main__":
    sys.exit(main())
