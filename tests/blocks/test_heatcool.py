"""HeatCoolPID: the split, the cooling factor, parameter switching, PWM on both outputs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ctrlblocks import ErrorCode, HeatCoolPID, ParameterError
from ctrlblocks.blocks.heatcool import heat_cool_split
from ctrlblocks.plants import HeatCool


@pytest.mark.parametrize("v, dz, f, heat, cool", [
    (30.0, 0.0, 1.0, 30.0, 0.0), (-30.0, 0.0, 2.0, 0.0, 60.0), (3.0, 10.0, 1.0, 0.0, 0.0),
    (-4.9, 10.0, 3.0, 0.0, 0.0), (15.0, 10.0, 1.0, 10.0, 0.0), (-15.0, 10.0, 3.0, 0.0, 30.0),
    (105.0, 10.0, 1.0, 100.0, 0.0), (-40.0, 10.0, 3.0, 0.0, 100.0),
])  # fmt: skip
def test_split_by_hand(v: float, dz: float, f: float, heat: float, cool: float) -> None:
    assert heat_cool_split(v, dz, f) == pytest.approx((heat, cool), abs=1e-12)


@pytest.mark.parametrize("f, dz", [(1.0, 0.0), (3.0, 0.0), (0.5, 8.0)])
def test_each_output_reaches_100_exactly_at_the_pid_limits(f: float, dz: float) -> None:
    hc = HeatCoolPID(kp=1.0, cool_factor=f, deadzone=dz)
    lo, hi = hc.pid.u_min, hc.pid.u_max
    assert heat_cool_split(hi, dz, f) == pytest.approx((100.0, 0.0), abs=1e-12)
    assert heat_cool_split(lo, dz, f) == pytest.approx((0.0, 100.0), abs=1e-12)
    # the PID saturates there: a huge error cannot ask for more than 100 %
    hc.configure(ti=10.0)
    for _ in range(50):
        hc(0.0, 1e6)
    assert hc.cool == pytest.approx(100.0) and hc.demand == pytest.approx(lo)


def test_demand_for_inverts_the_split() -> None:
    hc = HeatCoolPID(kp=1.0, cool_factor=3.0, deadzone=6.0)
    for net in (-90.0, -10.0, 0.0, 25.0, 100.0):
        h, c = heat_cool_split(hc.demand_for(net), 6.0, 3.0)
        assert h - c == pytest.approx(net, abs=1e-12)


def test_parameter_switching_is_bumpless_and_uses_the_cooling_tunings() -> None:
    hc = HeatCoolPID(kp=2.0, ti=20.0, cool_method="parameters", kp_cool=6.0, ti_cool=10.0,
                     switch_hysteresis=2.0, ts=1.0)  # fmt: skip
    # a constant error of -0.5 K: the demand integrates down through -2 %, where the
    # cooling set takes over; its P part is 6 x 0.5 = 3 % against the heating set's 1 %
    outs, kps = [], []
    for _ in range(60):
        outs.append(hc(20.0, 20.5))
        kps.append(hc.pid.config.kp)
    k = kps.index(6.0)
    assert 0 < k < 59 and set(kps[k:]) == {6.0}
    steps = np.abs(np.diff(outs[1:]))
    # no step of the P part's change (2 %): the steps are the integral's, 0.05 .. 0.3 %/sample
    assert steps.max() <= 6.0 / 10.0 * 0.5 + 1e-12
    assert steps[: k - 2].max() == pytest.approx(2.0 / 20.0 * 0.5, abs=1e-12)


def test_pwm_outputs_are_on_off_and_never_together() -> None:
    hc = HeatCoolPID(kp=8.0, ti=30.0, pwm_period=5.0, t_min_on=1.0, ts=0.5)
    rng = np.random.default_rng(4)
    heats, cools = [], []
    for k in range(4000):
        sp = 20.0 + (10.0 if (k // 400) % 2 else -10.0)
        hc(sp, 20.0 + rng.normal())
        heats.append(hc.heat)
        cools.append(hc.cool)
    h, c = np.array(heats), np.array(cools)
    assert set(np.unique(h)) <= {0.0, 100.0} and set(np.unique(c)) <= {0.0, 100.0}
    assert not np.any((h > 0) & (c > 0))
    assert h.max() == 100.0 and c.max() == 100.0


def test_cooling_factor_gives_the_heating_loop_in_cooling() -> None:
    """On HeatCool with k_heat = 3 k_cool, factor 3 makes the cooling step the heating one."""

    def step_response(f: float, sp: float) -> np.ndarray:
        proc = HeatCool(k_heat=0.6, k_cool=0.2, t=60.0, t_amb=20.0, ts=1.0)
        hc = HeatCoolPID(kp=4.0, ti=40.0, cool_factor=f, ts=1.0)
        ys = []
        for _ in range(300):
            u = hc(sp, proc.y)
            proc.set_second(max(0.0, u))
            proc.step(max(0.0, -u))
            ys.append(proc.y - 20.0)
        return np.array(ys)

    heat = step_response(3.0, 22.0)  # +2 K, small: nothing saturates
    cool_f3 = step_response(3.0, 18.0)
    cool_f1 = step_response(1.0, 18.0)
    np.testing.assert_allclose(cool_f3, -heat, atol=1e-9)  # a linear loop, the same gain
    assert np.max(np.abs(cool_f1 + heat)) > 0.2  # without the factor: another loop


def test_bad_configurations_are_refused_with_the_old_one_kept() -> None:
    hc = HeatCoolPID(kp=1.0)
    for bad, code in (({"cool_factor": 0.0}, ErrorCode.BAD_PARAMETER),
                      ({"deadzone": -1.0}, ErrorCode.BAD_LIMITS),
                      ({"ti": -1.0}, ErrorCode.BAD_PID_COEFFS),
                      ({"pwm_period": 0.5, "ts": 1.0}, ErrorCode.BAD_TIME_CONSTANT)):  # fmt: skip
        with pytest.raises(ParameterError) as e:
            hc.configure(**bad)
        assert e.value.code == code
        assert hc.config == HeatCoolPID(kp=1.0).config


def test_snapshot_restore_includes_the_pid_and_the_pwms() -> None:
    hc = HeatCoolPID(kp=3.0, ti=20.0, pwm_period=4.0, ts=1.0)
    for k in range(30):
        hc(25.0, 20.0 + 0.1 * k)
    snap = hc.snapshot()
    a = [hc(25.0, 21.0) for _ in range(20)]
    hc.restore(snap)
    b = [hc(25.0, 21.0) for _ in range(20)]
    assert a == b


def test_a_bad_measurement_is_the_pids_business() -> None:
    hc = HeatCoolPID(kp=3.0, ti=20.0, ts=1.0)
    u = hc(25.0, 20.0)
    assert hc(25.0, math.nan) == u and hc.error_id == ErrorCode.BAD_INPUT
    assert hc(25.0, 20.0, pv_ok=False) == u and hc.error_id == ErrorCode.BAD_MEASUREMENT


def test_float32_lane_follows_the_float64_block() -> None:
    def run(precision: str) -> np.ndarray:
        proc = HeatCool(k_heat=0.6, k_cool=0.2, t=60.0, t_amb=20.0, ts=1.0)
        hc = HeatCoolPID(kp=4.0, ti=40.0, cool_factor=3.0, ts=1.0, precision=precision)
        ys = []
        for k in range(400):
            u = hc(30.0 if k < 200 else 10.0, proc.y)
            proc.set_second(max(0.0, u))
            proc.step(max(0.0, -u))
            ys.append(proc.y)
        return np.array(ys)

    y64, y32 = run("float64"), run("float32")
    assert np.max(np.abs(y64 - y32)) < 1e-3  # single-precision rounding only
    assert np.max(np.abs(y64 - y32)) > 0.0
