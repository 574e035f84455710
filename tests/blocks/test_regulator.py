"""The complete regulator of Åström 1987, Fig. 4.6: two switches, both bumpless."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ctrlblocks import ErrorCode, ParameterError, Regulator


def _plant(u: float, y: float) -> float:
    return 0.9 * y + 0.1 * 0.8 * u  # a first-order process, gain 0.8


def test_auto_to_manual_and_back_are_bumpless_at_any_error() -> None:
    reg = Regulator(kp=3.0, ti=8.0, td=1.0, sp0=40.0, u0=10.0, ts=0.5)
    y, outs, switches = 0.0, [], []
    for k in range(400):
        if k in (60, 140, 230, 310):
            reg.auto = not reg.auto
            switches.append(k)
        u = reg(y, out_inc=(k % 40 < 10), out_dec=(k % 50 > 45))
        outs.append(u)
        y = _plant(u, y)
    for k in switches:
        assert outs[k] == pytest.approx(outs[k - 1], abs=1e-9), k


def test_manual_buttons_move_the_output_at_the_station_rate() -> None:
    # range 0..100 % in tm_out = 20 s: 5 %/s without acceleration (accel_max = 1)
    reg = Regulator(u0=10.0, tm_out=20.0, accel_max=1.0, ts=0.1)
    reg.auto = False
    for _ in range(10):
        u = reg(0.0, out_inc=True)
    assert u == pytest.approx(15.0, abs=1e-9)


def test_remote_to_local_keeps_the_setpoint_and_local_buttons_move_it() -> None:
    reg = Regulator(kp=1.0, ti=5.0, sp0=20.0, sp_min=0.0, sp_max=100.0, tm_sp=100.0,
                    accel_max=1.0, ts=1.0)  # fmt: skip
    reg.remote = True
    for _ in range(5):
        reg(10.0, 63.5)
    assert reg.sp == 63.5
    reg.remote = False
    reg(10.0)
    assert reg.sp == 63.5  # the local setpoint tracked the remote one
    reg(10.0, sp_inc=True)
    assert reg.sp == pytest.approx(64.5)  # 100 units in 100 s: 1 a second


def test_a_bad_remote_setpoint_holds_the_setpoint() -> None:
    reg = Regulator(kp=1.0, ti=5.0, ts=1.0)
    reg.remote = True
    reg(10.0, 30.0)
    reg(10.0, math.nan)
    assert reg.sp == 30.0 and reg.error_id == ErrorCode.BAD_INPUT
    reg(10.0, 31.0)
    assert reg.sp == 31.0 and reg.error_id == ErrorCode.NO_ERROR


def test_anti_windup_in_automatic_is_the_pids() -> None:
    reg = Regulator(kp=2.0, ti=5.0, u_max=50.0, sp0=100.0, ts=1.0)
    y = 0.0
    for _ in range(200):
        y = _plant(reg(y), y)
    assert reg.out == 50.0
    assert reg.pid.i <= 50.0 + 1e-9  # the integrator did not wind up beyond the limit


def test_snapshot_restore_replays_the_same_outputs() -> None:
    reg = Regulator(kp=2.0, ti=5.0, sp0=30.0, ts=1.0)
    y = 0.0
    for _ in range(20):
        y = _plant(reg(y), y)
    snap, y0 = reg.snapshot(), y
    a = []
    for _ in range(20):
        a.append(reg(y))
        y = _plant(a[-1], y)
    reg.restore(snap)
    y, b = y0, []
    for _ in range(20):
        b.append(reg(y))
        y = _plant(b[-1], y)
    np.testing.assert_array_equal(a, b)


def test_bad_configuration_is_refused_with_the_old_one_kept() -> None:
    reg = Regulator(kp=1.0)
    with pytest.raises(ParameterError) as e:
        reg.configure(u_min=10.0, u_max=0.0)
    assert e.value.code == ErrorCode.BAD_LIMITS
    with pytest.raises(ParameterError) as e:
        reg.configure(tr=-1.0)
    assert e.value.code == ErrorCode.BACK_CALC_T
    assert reg.config == Regulator(kp=1.0).config
