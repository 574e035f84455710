"""The ADRC's input stage and RESET mode, as the PID's (issue 34, point 1).

The PID's input stage (controltheplant 2024, sections 2.3.4 scaling, 2.3.7
filters, 2.3.8 rate limit) runs before the ADRC's cycle
(:func:`ctrlblocks.blocks.adrc.input_stage`): SP and PV scaled to 0..100 % of a
PV range, the SP and PV filters (PT1, exact pole), the setpoint ramp.  Each is
checked against an oracle that does not use the block's stage:

* scaling is a change of units: an ADRC on % of the range with ``b0`` in %
  gives the same u as the ADRC on engineering units (hypothesis, any range);
* the PV filter is a PT1 in front of the ADRC: the block with ``pv_filter``
  gives the u of a plain ADRC fed ``scipy.signal.lfilter`` of the PV;
* the SP filter and ramp likewise, against lfilter and a numpy ramp;
* the margins of a loop with a PV filter are those of the plain controller
  times the filter's frequency response (the filter is part of the loop);
* RESET: u0 at once (past the output ramp), priority over every mode, and
  the return to AUTO without a bump; a PV range changed while running, too.

The float32 cycle and the exported FB are the block over the PLC traces
(``tests/plc/traces.py``: the stage among ADRC_OPTIONS, RESET in the mode
traces, the range changed mid-run).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal

from ctrlblocks import ADRC
from ctrlblocks.blocks.base import ErrorCode, Mode, ParameterError
from ctrlblocks.tuning.margins import controller_ss

A, K, TS = 0.5, 2.0, 0.1
E = math.exp(-A * TS)


def plant(y: float, u: float, d: float = 0.0) -> float:
    """One exact ZOH step of ``y' = -a y + k u + d``."""
    return E * y + (1.0 - E) * (K * u + d) / A


def adrc(**kw) -> ADRC:
    return ADRC(**{"order": 1, "b0": K, "omega_c": 1.0, "omega_o": 5.0, "ts": TS,
                   "u_min": -10.0, "u_max": 10.0, **kw})  # fmt: skip


def closed_loop(block: ADRC, n: int, sp, y0: float = 0.0, noise: float = 0.0, seed: int = 0):
    """The loop on the first-order plant; the PV the block saw (with noise) and its u."""
    rng = np.random.default_rng(seed)
    y, pvs, us = y0, [], []
    for k in range(n):
        pv = y + noise * rng.standard_normal()
        u = block(sp(k), pv)
        pvs.append(pv)
        us.append(u)
        y = plant(y, u, 0.3 if k > n // 2 else 0.0)
    return np.array(pvs), np.array(us)


def replay(block: ADRC, sps, pvs) -> np.ndarray:
    return np.array([block(float(s), float(p)) for s, p in zip(sps, pvs, strict=True)])


@settings(max_examples=40, deadline=None)
@given(lo=st.floats(-50.0, 50.0), span=st.floats(0.5, 500.0), order=st.sampled_from([1, 2]),
       disc=st.sampled_from(["euler", "exact"]), reverse=st.booleans())  # fmt: skip
def test_scaling_is_a_change_of_units(lo, span, order, disc, reverse):
    hi = lo + span
    g = 100.0 / span  # % per PV unit
    cfg = {"order": order, "discretisation": disc, "reverse": reverse, "u_min": -50.0,
           "u_max": 50.0}  # fmt: skip
    sgn = -1.0 if reverse else 1.0
    eng = adrc(**cfg)
    pvs, us = closed_loop(eng, 400, lambda k: sgn * (1.0 if k > 20 else 0.0), noise=0.01)
    sps = [sgn * (1.0 if k > 20 else 0.0) for k in range(400)]
    pct = adrc(**cfg, b0=K * g, pv_range=(lo, hi))
    got = replay(pct, sps, pvs)
    np.testing.assert_allclose(got, us, rtol=1e-7, atol=1e-7 * (1.0 + np.max(np.abs(us))))
    # its e, y and y_ref are in % of the range, its ESO's first state too
    assert pct.y == pytest.approx((pvs[-1] - lo) * g, rel=1e-9, abs=1e-9)
    assert pct.e == pytest.approx(eng.e * g, rel=1e-6, abs=1e-6)
    assert pct.sp_w == pytest.approx((sps[-1] - lo) * g, rel=1e-12, abs=1e-9)


def test_the_pv_filter_is_a_pt1_in_front_of_the_adrc():
    t_f = 0.4
    a = math.exp(-TS / t_f)
    block = adrc(pv_filter=t_f, order=2, b0=1.0, omega_c=0.8, omega_o=4.0)
    pvs, us = closed_loop(block, 600, lambda k: 1.0 if k > 10 else 0.0, noise=0.05, seed=3)
    # the oracle: scipy's IIR filter of the PV (started at rest on the first sample)
    zi = signal.lfilter_zi([1.0 - a], [1.0, -a]) * pvs[0]
    filtered, _ = signal.lfilter([1.0 - a], [1.0, -a], pvs, zi=zi)
    plain = adrc(order=2, b0=1.0, omega_c=0.8, omega_o=4.0)
    want = replay(plain, [1.0 if k > 10 else 0.0 for k in range(600)], filtered)
    np.testing.assert_allclose(us, want, rtol=1e-9, atol=1e-9)
    assert block.y == pytest.approx(filtered[-1], rel=1e-12)
    # the filter is in the loop: the u it gives moves less with the noise than without it
    _pv0, us0 = closed_loop(plain.__class__(plain.config), 600, lambda k: 1.0, noise=0.05, seed=3)
    _pv1, us1 = closed_loop(block.__class__(block.config), 600, lambda k: 1.0, noise=0.05, seed=3)
    assert np.std(np.diff(us1[300:])) < 0.5 * np.std(np.diff(us0[300:]))


def test_the_sp_filter_and_ramp_shape_the_setpoint_the_law_sees():
    t_f, rate = 1.5, 0.8
    n = 200
    sps = np.where(np.arange(n) >= 5, 2.0, 0.0)
    block = adrc(sp_filter=t_f, sp_rate=rate)
    pvs, us = closed_loop(block, n, lambda k: float(sps[k]))
    # the oracle: lfilter of the setpoint (at rest on the first one), then a numpy ramp
    a = math.exp(-TS / t_f)
    sp_f, _ = signal.lfilter([1.0 - a], [1.0, -a], sps, zi=[a * sps[0]])
    ramp = np.empty(n)
    w = sp_f[0]
    for k in range(n):
        w += np.clip(sp_f[k] - w, -rate * TS, rate * TS)
        ramp[k] = w
    want = replay(adrc(), ramp, pvs)
    np.testing.assert_allclose(us, want, rtol=1e-9, atol=1e-9)
    assert block.sp_w == pytest.approx(ramp[-1], rel=1e-12)
    steps = np.diff(ramp)
    assert steps.max() == pytest.approx(rate * TS, rel=1e-12)  # the ramp really limited


def test_a_setpoint_first_valid_after_the_pv_ramps_from_the_pv():
    block = adrc(sp_rate=1.0)
    block(math.nan, 3.0)  # the ESO starts on the PV; the setpoint chain starts there too
    assert block.error_id == ErrorCode.BAD_INPUT and block.sp_w == 3.0
    block(5.0, 3.0)
    assert block.sp_w == pytest.approx(3.0 + 1.0 * TS)


def test_margins_include_the_pv_filter():
    t_f = 0.5
    a = math.exp(-TS / t_f)
    w = np.logspace(-2, math.log10(math.pi / TS) - 0.01, 60)
    cfg = {"order": 2, "b0": 1.0, "omega_c": 0.8, "omega_o": 4.0}
    plain = controller_ss(adrc(**cfg)).response(w)[:, 0, 1]
    filt = controller_ss(adrc(**cfg, pv_filter=t_f)).response(w)[:, 0, 1]
    z = np.exp(1j * w * TS)
    f = (1.0 - a) * z / (z - a)  # y_f[k] = a y_f[k-1] + (1 - a) y[k]
    np.testing.assert_allclose(filt, plain * f, rtol=1e-7)
    # scaling: the controller in % with b0 in % is the controller in units
    scaled = controller_ss(adrc(**{**cfg, "b0": 100.0 / 20.0}, pv_range=(-5.0, 15.0)))
    np.testing.assert_allclose(scaled.response(w), controller_ss(adrc(**cfg)).response(w),
                               rtol=1e-7)  # fmt: skip
    with pytest.raises(ParameterError, match="sp_rate"):
        controller_ss(adrc(**cfg, sp_rate=1.0))


def test_reset_gives_u0_at_once_and_returns_without_a_bump():
    block = adrc(u0=2.5, out_rate=1.0)
    y = 0.0
    for _ in range(300):
        u = block(1.0, y)
        y = plant(y, u)
    block.reset_active = True
    block.track = block.manual = True  # RESET has priority over every other mode
    assert block.mode == Mode.RESET
    assert block(1.0, y) == 2.5  # at once, past the 0.1-a-cycle output ramp
    y = plant(y, 2.5)
    block.reset_active = block.track = block.manual = False
    u = block(1.0, y)
    assert abs(u - 2.5) <= 1.0 * TS  # back to AUTO: from the reset value, on the ramp
    free = adrc(u0=2.5)  # without the ramp the first AUTO output is the reset value too
    for _ in range(300):
        free(1.0, 0.0)  # at the limit, u_raw far beyond it
    free.reset_active = True
    free(1.0, 0.0)
    free.reset_active = False
    assert free(1.0, 0.0) == pytest.approx(2.5, abs=1e-9)


def test_a_new_pv_range_while_running_is_bumpless():
    block = adrc(pv_range=(0.0, 10.0), b0=K * 10.0)
    y, us = 0.0, []
    for k in range(400):
        if k == 200:
            block.configure(pv_range=(-5.0, 20.0), b0=K * 4.0)
        u = block(1.0, y)
        us.append(u)
        y = plant(y, u)
    steps = np.abs(np.diff(us))
    assert steps[199] <= 1e-9 + 2.0 * np.max(steps[150:199])  # no bump at the change
    assert y == pytest.approx(1.0, abs=1e-3)  # and it still controls


def test_bad_configuration_is_refused_and_the_old_one_stays():
    block = adrc(pv_filter=0.2)
    for bad, code in (
        ({"pv_range": (1.0, 1.0)}, ErrorCode.BAD_LIMITS),
        ({"pv_range": (0.0, math.inf)}, ErrorCode.BAD_LIMITS),
        ({"pv_range": (-1e308, 1e308)}, ErrorCode.BAD_LIMITS),  # the span overflows
        ({"pv_range": "0..100"}, ErrorCode.BAD_LIMITS),
        ({"sp_filter": -1.0}, ErrorCode.BAD_TIME_CONSTANT),
        ({"pv_filter": math.nan}, ErrorCode.BAD_TIME_CONSTANT),
        ({"sp_rate": -0.1}, ErrorCode.BAD_RATE),
        ({"anti_backoff": True, "y_sat": 3.0}, ErrorCode.BAD_PARAMETER),  # with pv_filter
    ):
        with pytest.raises(ParameterError) as err:
            block.configure(**bad)
        assert err.value.code == code, bad
        assert block.config.pv_filter == 0.2 and block.config.pv_range is None


def test_compute_output_is_idempotent_with_the_stage():
    block = adrc(pv_filter=0.3, sp_filter=0.5, sp_rate=2.0, pv_range=(-1.0, 3.0), b0=50.0)
    for k in range(50):
        u1 = block.compute_output(1.0, 0.1 * k)
        u2 = block.compute_output(1.0, 0.1 * k)
        assert u1 == u2
        block.update_state(u1)


def test_a_snapshot_of_before_the_stage_restores_its_chains_at_the_pv_and_setpoint():
    block = adrc()
    for _ in range(20):
        block(2.0, 0.5)
    snap = block.snapshot()
    for name in ("_sp_f", "_pv_f", "_sp_w", "sp_w"):
        del snap[name]
    fresh = adrc(pv_filter=1.0, sp_filter=1.0)
    fresh.restore(snap)
    assert fresh._pv_f == 0.5 and fresh._sp_f == fresh._sp_w == 2.0
    assert fresh(2.0, 0.5) == pytest.approx(block(2.0, 0.5), rel=1e-12)


def test_the_compiled_kernels_refuse_the_stage_and_reset():
    for kw in ({"pv_range": (0.0, 1.0)}, {"sp_filter": 1.0}, {"pv_filter": 1.0},
               {"sp_rate": 1.0}):  # fmt: skip
        assert next(iter(kw)) in adrc(**kw).fast_path_blockers()
    block = adrc()
    block.reset_active = True
    assert "reset_active" in block.fast_path_blockers()
