"""Every block settles for any measured period the runtime can pass: dt from ts/10 to 20 ts.

The runtime passes a stretched period as ``dt`` up to ``max_dt`` (at most 20 ts,
``MAX_DT_TS``); here the PID's derivative, the lead-lag, the PT1 (both
discretisations), the rate limiter and the heat/cool split-range PID; the
ADRC's observer is covered in test_adrc_handover.py.  Found
by this test: a PID with ``derivative_method = "forward"`` (Åström 1987, (2.10))
given a period beyond 2 Td/N had its derivative pole at ``1 - h/Tf`` outside the
unit circle (the state grew to 1e229, the output banged between its limits).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ctrlblocks.blocks import PID, LeadLag
from ctrlblocks.blocks.leadlag import leadlag_coefficients
from ctrlblocks.blocks.pid import derivative_coefficients
from ctrlblocks.runtime.config.model import MAX_DT_TS

TS = 0.1


def periods(seed: int, n: int) -> list[float]:
    rng = np.random.default_rng(seed)
    return [TS * float(rng.uniform(0.1, MAX_DT_TS)) for _ in range(n)]


@settings(max_examples=60, deadline=None)
@given(method=st.sampled_from(("forward", "backward", "tustin")),
       tf_ts=st.floats(0.51, 5.0), seed=st.integers(0, 2**16))  # fmt: skip
def test_a_pids_derivative_dies_out_for_periods_from_ts_over_10_to_20_ts(method, tf_ts, seed):
    td = 1.0
    pid = PID(kp=1.0, ti=1e6, td=td, n=td / (tf_ts * TS), ts=TS, derivative_method=method,
              u_min=-1e3, u_max=1e3)  # fmt: skip
    for k, dt in enumerate(periods(seed, 200)):  # a PV that moves: the derivative works
        out = pid(0.0, math.sin(0.7 * k), dt=dt)
        assert abs(out) < 1e3  # never at a limit: |D| stays of the order of kd |dw|/Tf
    outs = [pid(0.0, 0.0, dt=dt) for dt in periods(seed + 1, 300)]  # the PV still
    assert outs[-1] == pytest.approx(outs[-2], abs=1e-9)  # what is left is the integral


@pytest.mark.parametrize("method", ["forward", "backward", "tustin"])
@pytest.mark.parametrize("h_tf", [0.1, 1.0, 1.99, 2.0, 20.0, 400.0])
def test_the_derivative_pole_is_inside_the_unit_circle_for_any_period(method, h_tf):
    a, bd = derivative_coefficients(1.0, 1.0, h_tf, ("forward", "backward", "tustin").index(method))
    assert abs(a) < 1.0 and bd > 0.0
    if method == "forward" and h_tf < 2.0:  # (2.10) where it is stable: as written
        assert (a, bd) == (1.0 - h_tf, 1.0)
    if method == "forward" and h_tf >= 2.0:  # beyond: the backward difference (2.11)
        assert (a, bd) == pytest.approx((1.0 / (1.0 + h_tf), 1.0 / (1.0 + h_tf)))


@settings(max_examples=40, deadline=None)
@given(method=st.sampled_from(("tustin", "euler")), t_lead=st.floats(0.0, 10.0),
       t_lag=st.floats(0.01, 10.0), seed=st.integers(0, 2**16))  # fmt: skip
def test_a_lead_lag_settles_on_k_x_for_periods_from_ts_over_10_to_20_ts(method, t_lead, t_lag,
                                                                       seed):  # fmt: skip
    ll = LeadLag(k=2.0, t_lead=t_lead, t_lag=t_lag, ts=TS, method=method)
    bound = 0.0  # |y[k]| <= (|b0| + |b1|) max|x| + |a1| |y[k-1]|, |a1| < 1 for every period
    for k, dt in enumerate(periods(seed, 100)):
        b0, b1, a1 = leadlag_coefficients(2.0, t_lead, t_lag, dt, method == "tustin")
        assert abs(a1) < 1.0
        bound = abs(b0) + abs(b1) + abs(a1) * bound
        assert abs(ll(math.sin(0.7 * k), dt=dt)) <= bound * (1 + 1e-12)
    for dt in periods(seed + 1, 2000):
        out = ll(1.0, dt=dt)
    assert out == pytest.approx(2.0, abs=1e-6)


@settings(max_examples=40, deadline=None)
@given(method=st.sampled_from(("exact", "euler")), t=st.floats(0.0, 10.0),
       gain=st.floats(-5.0, 5.0), seed=st.integers(0, 2**16))  # fmt: skip
def test_a_pt1_moves_toward_k_u_and_settles_there_for_periods_from_ts_over_10_to_20_ts(
    method, t, gain, seed
):
    """Both discretisations (exact pole exp(-h/T), backward Euler T/(T + h)) give every new
    output between the last one and K u, for any h: no overshoot, no sign change of the error."""
    from ctrlblocks.blocks import PT1

    f = PT1(t=t, ts=TS, gain=gain, method=method)
    for k, dt in enumerate(periods(seed, 100)):
        u = math.sin(0.7 * k)
        prev = f.out
        out = f(u, dt=dt)
        lo, hi = sorted((prev, gain * u))
        assert lo - 1e-12 <= out <= hi + 1e-12, (prev, gain * u, out, dt)
    for dt in periods(seed + 1, 3000):
        out = f(1.0, dt=dt)
    assert out == pytest.approx(gain, abs=1e-6)


@settings(max_examples=40, deadline=None)
@given(rate=st.floats(0.01, 10.0), seed=st.integers(0, 2**16))
def test_a_rate_limiter_moves_at_most_rate_dt_for_periods_from_ts_over_10_to_20_ts(rate, seed):
    from ctrlblocks.blocks import RateLimiter

    rl = RateLimiter(rate_up=rate, rate_down=rate, ts=TS)
    prev = rl(0.0)
    for k, dt in enumerate(periods(seed, 200)):
        out = rl(5.0 * math.sin(0.3 * k), dt=dt)
        assert abs(out - prev) <= rate * dt * (1 + 1e-12) + 1e-12
        prev = out
    for dt in periods(seed + 1, 200):
        out = rl(1.0, dt=dt)
    assert out == 1.0


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**16), deadzone=st.floats(0.0, 5.0))
def test_a_heat_cool_pid_settles_for_periods_from_ts_over_10_to_20_ts(seed, deadzone):
    """The split-range PID on a first-order process sampled at random periods: the outputs stay
    in 0..100 % and the PV reaches the set point (its PID takes any period, test above)."""
    from ctrlblocks.blocks import HeatCoolPID

    blk = HeatCoolPID(kp=2.0, ti=5.0, ts=TS, deadzone=deadzone)
    y, sp = 20.0, 30.0
    for dt in periods(seed, 1500):
        v = blk(sp, y, dt=dt)
        assert 0.0 <= blk.heat <= 100.0 and 0.0 <= blk.cool <= 100.0 and math.isfinite(v)
        y_ss = 20.0 + 0.5 * (blk.heat - blk.cool)  # K = 0.5 K/%, T = 4 s, exact in dt
        y = y_ss + (y - y_ss) * math.exp(-dt / 4.0)
    assert abs(y - sp) < 0.5
