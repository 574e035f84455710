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
one transcendental function (EXP, for the ADRC reference filter) is numpy's
float32 exp on both sides.  On a real PLC, EXP/LN/SQRT of the vendor's
library may differ from numpy's by an ulp; only ``T_REF > 0`` uses them.
"""

from __future__ import annotations

import pytest

from ctrlblocks import plc

from .st_interpreter import Interpreter
from .traces import ADRC_OPTIONS, PID_OPTIONS, adrc_trace, leadlag_trace, pid_trace, replay, ulps

pytest.importorskip("blark")


def _compare(block, trace, fb_name: str, mv: str, flag: str | None) -> int:
    fb = Interpreter(plc.export(block, "codesys")).instance(fb_name)
    got = replay(fb, trace, mv, flag)
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
