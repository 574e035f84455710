"""The exported FUNCTION_BLOCKs compute what the blocks compute in REAL arithmetic.

Each test closes a loop with a ``precision="float32"`` block over a long trace
(setpoint steps, PV noise, limits hit, MAN/AUTO, RESET, NaN/inf, PV_OK false,
a bad setpoint, retuning and new limits mid-run), exports the block's starting
configuration to CODESYS ST, runs that ST in the blark-based interpreter with
the same inputs, and compares every sample.

Bound: at most 1 ulp per sample is the requirement; what is reached is 0 ulp
(bit-identical).  Both sides round every +, -, *, / of the same operands in
the same order to the nearest float32 (IEEE 754), the translator keeps
Python's evaluation order (left-associative, explicit parentheses), and the
one transcendental function (EXP, for the ADRC reference filter) is the one
defined for the float32 cycle on both sides, ``float32(exp(float64(x)))``
(``ctrlblocks.blocks.precision.real_exp``).  On a real PLC, EXP/LN/SQRT of the
vendor's library may differ from it by an ulp; only ``T_REF > 0`` uses them.
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


@pytest.mark.parametrize(
    "config",
    [
        {"integral_method": "forward", "derivative_method": "tustin", "c": 0.5, "b": 0.7,
         "anti_windup": "back_calc_model", "tt": 1.0, "reverse": True},
        {"integral_method": "backward", "derivative_method": "forward", "td": 2.0,
         "ti": 0.0, "safe_value": 12.5, "reset_value": 25.0},
    ],
)  # fmt: skip
def test_pid_fb_equals_float32_block_for_other_options(config):
    block, trace = pid_trace(400, seed=2, **config)
    assert _compare(block, trace, "CB_PID", "MV", "LIMITS_ACTIVE") == 0


@pytest.mark.parametrize("config", PID_OPTIONS, ids=lambda c: ",".join(c))
def test_pid_fb_equals_float32_block_for_velocity_filters_ramps_ff_and_modes(config):
    """Velocity form, filters, ramps, lead-lag FF, PV scaling, TRACK/HOLD/AWIN, every
    anti-windup and bumpless method: bit-identical over a trace with all the events."""
    block, trace = pid_trace(900, seed=30, modes=True, **config)
    assert {e for _u, e, _f in trace.outputs} >= {0, 0x8101, 0x8102, 0x8103}  # 8103: overflow
    assert _compare(block, trace, "CB_PID", "MV", "LIMITS_ACTIVE") == 0


@pytest.mark.parametrize("config", DB_OPTIONS, ids=lambda c: ",".join(c))
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


@pytest.mark.parametrize(
    "config",
    [
        {"order": 1, "b0": 0.5, "anti_windup": "freeze", "t_ref": 2.0, "u_sf": 7.0},
        {"order": 3, "b0": 0.01, "omega_c": 0.3, "omega_o": 1.2, "anti_windup": "off"},
    ],
)
def test_adrc_fb_equals_float32_block_for_every_order(config):
    block, trace = adrc_trace(400, seed=4, **config)
    assert _compare(block, trace, "CB_ADRC", "MV", "AWOUT") == 0


@pytest.mark.parametrize("config", ADRC_OPTIONS, ids=lambda c: ",".join(c))
def test_adrc_fb_equals_float32_block_for_exact_u_real_anti_backoff_and_awin(config):
    """The exact (ZOH) observer, U_REAL, the anti-backoff action at a saturating sensor,
    AWIN and the 16#8301 warning: bit-identical over a trace with all the events."""
    block, trace = adrc_trace(900, seed=50, modes=True, **config)
    # 16#8103: the law overflowed REAL (not with a saturating sensor: the spike is clipped)
    expected = {0, 0x8101, 0x8102} | (set() if config.get("anti_backoff") else {0x8103})
    assert {e for _u, e, _f in trace.outputs} >= expected
    assert _compare(block, trace, "CB_ADRC", "MV", "AWOUT") == 0


@pytest.mark.parametrize("method", ["tustin", "euler"])
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
