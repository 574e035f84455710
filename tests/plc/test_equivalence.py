"""The ST interpreter runs the exported FBs with the checks a C compiler does not make.

The real compiler is MATIEC (``test_matiec.py``): every configuration
compiled strictly and run bit for bit against the ``precision="float32"``
block over all the traces and the hostile sequences.  This interpreter
(blark's parser, :mod:`.st_interpreter`) is kept -- behind ``-m slow``, as
blark's Earley parse costs 5 to 40 s per exported file -- for what compiled
C cannot show: it *poisons* VAR_TEMP and a FUNCTION's locals and outputs at
every call, so translated code that reads a variable before writing it in
the same call fails (MATIEC's C zeroes them: such a read passes there and
depends on the target elsewhere); it checks ARRAY subscripts against the
bounds (C does not); it refuses reading an instance's VAR from outside the
FB (CODESYS refuses it, C does not); and it counts the operations of
``test_cost.py``.  It runs one long trace per block kind, one option-rich PID
(velocity, back-calculation on the actuator position, setpoint tracking,
filters), the exact ADRC and the dead band's ARRAY case: bit-identical, as
MATIEC's build is.  The sweeps over every trace are MATIEC's alone.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ctrlblocks import PID, ParameterError, plc

from .st_interpreter import Interpreter
from .traces import (
    ADRC_OPTIONS,
    DB_OPTIONS,
    PID_OPTIONS,
    adrc_trace,
    leadlag_trace,
    pid_trace,
    replay,
    ulps,
)

pytest.importorskip("blark")
pytestmark = pytest.mark.slow  # blark's parser and long traces: the long campaign (pytest -m slow)


def _compare(block, trace, fb_name: str, mv: str, flag: str | None, watch: str = "") -> int:
    """Worst ulp distance of the FB's output from the block's over ``trace`` (asserted <= 1);
    ``watch``: a BOOL variable of the FB whose TRUE samples are counted in ``_compare.seen``."""
    fb = Interpreter(plc.export(block, "codesys")).instance(fb_name)
    seen = []
    got = replay(fb, trace, mv, flag, lambda: seen.append(bool(fb[watch])) if watch else None)
    _compare.seen = sum(seen)  # type: ignore[attr-defined]
    worst = 0
    for k, (g, ref) in enumerate(zip(got, trace.outputs, strict=True)):
        d = ulps(g[0], ref[0])
        worst = max(worst, d)
        assert d <= 1, f"sample {k}: FB {g[0]!r} vs block {ref[0]!r} ({d} ulp)"
        assert g[1] == ref[1], f"sample {k}: ERROR_ID 16#{g[1]:04X} vs 16#{ref[1]:04X}"
        assert g[2] == ref[2], f"sample {k}: flag {g[2]} vs {ref[2]}"
    return worst


def test_pid_fb_equals_float32_block_over_a_long_trace():
    block, trace = pid_trace(1500, seed=1)
    assert {e for _u, e, _f in trace.outputs} >= {0, 0x8101, 0x8102}  # the events happened
    assert any(f for _u, _e, f in trace.outputs)  # the limits were hit
    assert _compare(block, trace, "CB_PID", "MV", "LIMITS_ACTIVE") == 0


@pytest.mark.parametrize("config", PID_OPTIONS[5:6], ids=lambda c: ",".join(c))
def test_pid_fb_equals_float32_block_for_velocity_filters_ramps_ff_and_modes(config):
    """Velocity form, filters, ramps, lead-lag FF, PV scaling, TRACK/HOLD/AWIN, every
    anti-windup and bumpless method: bit-identical over a trace with all the events."""
    block, trace = pid_trace(900, seed=30, modes=True, **config)
    assert {e for _u, e, _f in trace.outputs} >= {0, 0x8101, 0x8102, 0x8103}  # 8103: overflow
    assert _compare(block, trace, "CB_PID", "MV", "LIMITS_ACTIVE") == 0


@pytest.mark.parametrize("config", DB_OPTIONS[1:2], ids=lambda c: ",".join(c))
def test_pid_fb_with_the_adaptive_dead_band_equals_float32_block_retuned_mid_run(config):
    """The dead band's moving average (an ARRAY ring sized from t_stab/ts at export, a
    running sum re-summed by a FOR loop once per window) and steady-state detector, as
    FUNCTION_BLOCK instances in CB_PID: bit-identical over a trace in which the band holds
    and releases the output many times and T_STAB and TS are retuned (windows 10, 5, 2,
    5, 9 samples)."""
    block, trace = pid_trace(1000, seed=60, **config)
    assert _compare(block, trace, "CB_PID", "MV", "LIMITS_ACTIVE", watch="db_active") == 0
    assert _compare.seen > 50  # the band held the output (and released it: MV moved again)


def test_adrc_fb_equals_float32_block_over_a_long_trace():
    block, trace = adrc_trace(1500, seed=3)
    assert {e for _u, e, _f in trace.outputs} >= {0, 0x8101, 0x8102}
    assert any(f for _u, _e, f in trace.outputs)  # u beyond a limit
    assert _compare(block, trace, "CB_ADRC", "MV", "AWOUT") == 0


@pytest.mark.parametrize("config", ADRC_OPTIONS[5:6], ids=lambda c: ",".join(c))
def test_adrc_fb_with_the_exact_observer_equals_float32_block(config):
    """The exact observer, U_REAL, the anti-backoff action, the reference filter, AWIN."""
    block, trace = adrc_trace(900, seed=50, modes=True, **config)
    assert _compare(block, trace, "CB_ADRC", "MV", "AWOUT") == 0


@pytest.mark.parametrize("method", ["tustin"])
def test_leadlag_fb_equals_float32_block(method):
    block, trace = leadlag_trace(600, seed=5, method=method)
    assert _compare(block, trace, "CB_LEADLAG", "OUT", None) == 0


def test_a_dead_band_window_beyond_the_exported_array_is_refused_as_the_float32_block_does():
    """The ARRAY holds round(t_stab/ts) of the exported configuration (10 here): a T_STAB
    whose window is longer, or T_STAB <= 0, sets 16#8209 and keeps the window in force --
    in the FB and in the float32 block alike (the float64 block would take the new one)."""
    cfg = {"kp": 1.0, "ti": 2.0, "deadband": 1.0, "t_stab": 1.0, "ts": 0.1}
    pid = PID(**cfg, precision="float32")
    fb = Interpreter(plc.export(PID(**cfg), "codesys")).instance("CB_PID")
    codes = []
    for k in range(90):
        new = {30: 5.0, 50: -1.0, 70: 0.3}.get(k)
        if new is not None and new > 0.0:
            pid.configure(t_stab=new)
        elif new is not None:  # the block refuses it (the PLC cannot): it keeps 5 s, 16#8209
            with pytest.raises(ParameterError):
                pid.configure(t_stab=new)
        pv = 50.0 + 0.2 * math.sin(k / 3.0)
        u = pid(50.0, pv)
        fb(SP=50.0, PV=pv, **({"T_STAB": new} if new is not None else {}))
        assert ulps(fb["MV"], u) == 0 and fb["ERROR_ID"] == int(pid.error_id), k
        codes.append(int(pid.error_id))
        if k in (40, 60):
            assert fb["db_win"] == 10 and fb["db_t"] == np.float32(1.0)
    assert codes[29] == 0 and set(codes[30:70]) == {0x8209} and codes[70:] == [0] * 20
    assert fb["db_win"] == 3


@pytest.mark.parametrize("kind", ["pid", "adrc", "leadlag"])
def test_limits_written_with_a_bad_ts_keep_the_held_output_inside_them_as_in_the_block(kind):
    """The MATIEC campaign's find: new limits that exclude the output, written in a cycle whose
    TS is bad (NaN). The cycle does not run, but the block's output guard limits the held
    output -- to the REAL limit, as the FB has it (``precision.block_limits``; it was the
    float64 limit, no REAL). The FB's hold branch now limits the held MV the same way."""
    from ctrlblocks import ADRC, ErrorCode, LeadLag

    make, fb_name, out, lo_hi = {
        "pid": (lambda **k: PID(kp=1.0, ti=5.0, u_min=0.0, u_max=100.0, **k), "CB_PID", "MV",
                ("u_min", "u_max")),
        "adrc": (lambda **k: ADRC(order=1, b0=1.0, u_min=0.0, u_max=100.0, **k), "CB_ADRC",
                 "MV", ("u_min", "u_max")),
        "leadlag": (lambda **k: LeadLag(k=2.0, t_lead=1.0, t_lag=2.0, out_min=-100.0,
                                        out_max=100.0, **k), "CB_LEADLAG", "OUT",
                    ("out_min", "out_max")),
    }[kind]  # fmt: skip
    block = make(precision="float32")
    fb = Interpreter(plc.export(make(), "codesys")).instance(fb_name)
    call = {"pid": lambda b, dt: b(50.0, 40.0, dt=dt), "adrc": lambda b, dt: b(50.0, 40.0, dt=dt),
            "leadlag": lambda b, dt: b(10.0, dt=dt)}[kind]  # fmt: skip
    proc = {"pid": {"SP": 50.0, "PV": 40.0}, "adrc": {"SP": 50.0, "PV": 40.0},
            "leadlag": {"IN": 10.0}}[kind]  # fmt: skip
    for _ in range(5):
        call(block, None)
        fb(**proc, TS=0.1)
    assert ulps(fb[out], block.out) == 0
    new = (65.08519646342809, 66.94845581054688)  # no REAL: the FB gets it rounded
    block.configure(**dict(zip(lo_hi, new, strict=True)))
    u = call(block, math.nan)
    fb(**proc, TS=math.nan, **{n.upper(): np.float32(v) for n, v in zip(lo_hi, new, strict=True)})
    assert u == float(np.float32(new[0])) and ulps(fb[out], u) == 0
    assert fb["ERROR_ID"] == int(block.error_id) == int(ErrorCode.NO_CYCLE)
