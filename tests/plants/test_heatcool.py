"""The heat/cool thermal process (HC) against its hand-evaluated solution."""

from __future__ import annotations

import math

import pytest

from ctrlblocks.plants import Actuator, HeatCool
from ctrlblocks.plants.heatcool import SecondInput


def test_steady_state_is_ambient_plus_heater_minus_cooler():
    p = HeatCool(k_heat=0.6, k_cool=0.4, t=60.0, ts=1.0, t_amb=20.0)
    p.set_second(50.0)
    p.reset(25.0)
    assert p.y == pytest.approx(20.0 + 0.6 * 50.0 - 0.4 * 25.0)
    assert p.steady_y(25.0, 50.0) == pytest.approx(40.0)


def test_heater_step_is_a_first_order_lag_with_the_dead_time():
    """T(t) = 20 + 0.6 * 50 (1 - exp(-(t - 5) / 60)) for t >= 5 s (exact at the samples)."""
    p = HeatCool(k_heat=0.6, k_cool=0.4, t=60.0, ts=1.0, t_amb=20.0, dead_time=5.0)
    p.reset(0.0)
    p.set_second(50.0)
    ys = [p.step(0.0) for _ in range(120)]
    for k in (3, 4, 10, 60, 119):  # ys[k] is T at t = k + 1
        t = k + 1.0
        want = 20.0 + 30.0 * (1.0 - math.exp(-max(t - 5.0, 0.0) / 60.0))
        assert ys[k] == pytest.approx(want, abs=1e-12)


def test_cooler_lowers_the_temperature_and_bad_inputs_hold():
    p = HeatCool(k_heat=0.6, k_cool=0.4, t=10.0, ts=1.0)
    for _ in range(200):
        p.step(50.0)
    assert p.y == pytest.approx(0.0, abs=1e-6)  # 20 - 0.4 * 50
    p.step(math.nan)
    p.set_second(math.inf)
    assert p.u == 50.0 and p.u2 == 0.0 and math.isfinite(p.y)


def test_second_input_takes_an_actuator_of_its_own():
    p = HeatCool(k_heat=1.0, k_cool=1.0, t=5.0, ts=1.0)
    heater = Actuator(SecondInput(p), u_min=0.0, u_max=100.0)
    cooler = Actuator(p, u_min=0.0, u_max=100.0)
    heater.reset(150.0)  # clamped to 100
    cooler.reset(30.0)
    assert p.u2 == 100.0 and p.y == pytest.approx(20.0 + 100.0 - 30.0)
    heater.step(-5.0)
    assert p.u2 == 0.0
    snap = p.snapshot()
    a = [cooler.step(10.0) for _ in range(3)]
    p.restore(snap)
    assert [cooler.step(10.0) for _ in range(3)] == a


def test_bad_parameters_are_refused():
    with pytest.raises(ValueError, match="k_heat"):
        HeatCool(k_heat=-1.0, k_cool=0.4, t=60.0, ts=1.0)
    with pytest.raises(ValueError):
        HeatCool(k_heat=1.0, k_cool=0.4, t=0.0, ts=1.0)
