"""Noise, sensor, actuator and loads: each checked against numbers computed by hand or numpy."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ctrlblocks.blocks.base import ErrorCode, ParameterError
from ctrlblocks.plants import PT1, PT2, Actuator, DeadTime, Noise, Sensor, process

TS = 0.1


# --- Noise ---------------------------------------------------------------------


def test_uniform_noise_is_the_seeded_numpy_sequence_within_the_range():
    n = Noise(0.05, kind="uniform", seed=42)
    got = np.array([n.sample() for _ in range(700)])  # crosses the 256-value blocks
    ref = np.random.default_rng(42).uniform(-0.05, 0.05, 700)
    assert np.array_equal(got, ref)
    assert got.min() >= -0.05 and got.max() < 0.05


def test_gaussian_noise_is_the_seeded_numpy_sequence():
    n = Noise(0.02, kind="gaussian", seed=7)
    got = np.array([n.sample() for _ in range(600)])
    assert np.array_equal(got, np.random.default_rng(7).normal(0.0, 0.02, 600))


def test_noise_reset_restarts_and_snapshot_continues():
    n = Noise(1.0, kind="gaussian", t_corr=0.5, ts=TS, seed=3)
    first = [n.sample() for _ in range(300)]
    n.reset()
    assert [n.sample() for _ in range(300)] == first
    snap = n.snapshot()
    a = [n.sample() for _ in range(300)]
    n.restore(snap)
    assert [n.sample() for _ in range(300)] == a


def test_coloured_noise_follows_the_first_order_recursion():
    # (N1): n[k+1] = a n[k] + sqrt(1 - a^2) w[k], n[0] = w[0], a = exp(-ts/t_corr)
    n = Noise(0.1, kind="uniform", t_corr=1.0, ts=TS, seed=5)
    got = [n.sample() for _ in range(300)]
    w = np.random.default_rng(5).uniform(-0.1, 0.1, 300)
    a = math.exp(-0.1)
    ref = [w[0]]
    for k in range(1, 300):
        ref.append(a * ref[-1] + math.sqrt(1 - a * a) * w[k])
    assert np.max(np.abs(np.array(got) - ref)) <= 1e-15


def test_coloured_noise_keeps_the_white_variance_and_has_correlation_a():
    n = Noise(1.0, kind="gaussian", t_corr=0.5, ts=TS, seed=11)
    x = np.array([n.sample() for _ in range(60000)])
    a = math.exp(-0.2)
    assert x.std() == pytest.approx(1.0, rel=0.05)
    assert np.corrcoef(x[:-1], x[1:])[0, 1] == pytest.approx(a, abs=0.01)


def test_white_uniform_noise_has_the_uniform_variance():
    n = Noise(0.3, seed=2)
    x = np.array([n.sample() for _ in range(40000)])
    assert x.std() == pytest.approx(0.3 / math.sqrt(3.0), rel=0.02)
    assert abs(np.corrcoef(x[:-1], x[1:])[0, 1]) < 0.02


@pytest.mark.parametrize(
    ("kwargs", "code"),
    [
        ({"level": -1.0}, ErrorCode.BAD_PARAMETER),
        ({"level": 1.0, "kind": "pink"}, ErrorCode.BAD_PARAMETER),
        ({"level": 1.0, "t_corr": 1.0}, ErrorCode.NO_CYCLE),
        ({"level": 1.0, "t_corr": -1.0, "ts": 0.1}, ErrorCode.BAD_TIME_CONSTANT),
    ],
)
def test_bad_noise_configuration_is_refused(kwargs, code):
    with pytest.raises(ParameterError) as exc:
        Noise(**kwargs)
    assert exc.value.code == code


# --- Actuator ----------------------------------------------------------------------


def test_actuator_rate_limit_gives_the_exact_ramp():
    act = Actuator(PT1(1.0, 1.0, TS), rate=2.0)  # 2 units/s = 0.2 per sample
    applied = []
    for _ in range(7):
        act.step(1.0)
        applied.append(act.u)
    assert applied == pytest.approx([0.2, 0.4, 0.6, 0.8, 1.0, 1.0, 1.0], abs=1e-15)
    assert act.limited is False  # reached the command


def test_actuator_clamps_and_adds_input_load_before_the_limits():
    ref = PT1(2.0, 1.0, TS)
    act = Actuator(PT1(2.0, 1.0, TS), u_min=0.0, u_max=5.0, load=0.5)
    ref.reset(0.5)  # the actuator starts in the steady state for command 0 + load
    assert act.y == ref.y == pytest.approx(1.0, rel=1e-12)
    for u in (1.0, 4.8, 7.0, -3.0, 2.0):
        act.step(u)
        ref.step(min(max(u + 0.5, 0.0), 5.0))
        assert act.y == ref.y
    assert act.u == 2.5
    act.step(4.8)
    assert act.u == 5.0 and act.limited


def test_actuator_load_change_acts_on_the_next_sample():
    act = Actuator(PT1(1.0, 1.0, TS))
    act.reset(1.0)
    act.load = -0.4
    act.step(1.0)
    assert act.u == pytest.approx(0.6)


def test_actuator_holds_the_command_on_nan_and_keeps_limits_on_a_bad_pair():
    act = Actuator(PT1(1.0, 1.0, TS), u_min=0.0, u_max=1.0)
    act.step(0.7)
    act.step(math.nan)
    assert act.u == 0.7 and act.u_cmd == 0.7
    with pytest.raises(ParameterError) as exc:
        act.set_limits(2.0, 1.0)
    assert exc.value.code == ErrorCode.BAD_LIMITS
    assert (act.u_min, act.u_max) == (0.0, 1.0)
    with pytest.raises(ParameterError) as exc:
        act.rate = -1.0
    assert exc.value.code == ErrorCode.BAD_RATE


# --- Sensor ----------------------------------------------------------------------


def test_sensor_saturates_at_y_max_and_flags_it():
    # PT1 k = 3 driven by 1: y_true = 3 (1 - exp(-t)), sensor saturates at 1.9
    # (Nowak et al. 2018, Fig. 1)
    s = Sensor(PT1(3.0, 1.0, TS), y_max=1.9)
    ys, sat = [], []
    for k in range(1, 31):
        ys.append(s.step(1.0))
        sat.append(s.saturated)
        expected = 3.0 * (1.0 - math.exp(-k * TS))
        assert s.y_true == pytest.approx(expected, abs=1e-13)
        assert ys[-1] == pytest.approx(min(expected, 1.9), abs=1e-13)
    # 3 (1 - e^-t) = 1.9 at t = ln(3/1.1) = 1.0033 s: first saturated sample is k = 11
    assert sat.index(True) == 10 and all(sat[10:]) and not any(sat[:10])


def test_sensor_output_load_and_fault_act_at_once():
    s = Sensor(PT1(1.0, 1.0, TS))
    s.reset(2.0)
    assert s.y == pytest.approx(2.0, abs=1e-12)
    s.load = 0.25
    assert s.y == pytest.approx(2.25, abs=1e-12)
    s.fault = math.nan
    assert math.isnan(s.y)
    s.fault = None
    assert s.y == pytest.approx(2.25, abs=1e-12)


def test_sensor_noise_is_added_once_per_sample():
    s = Sensor(PT2(1.0, 2.0, 1.0, TS), noise=Noise(0.01, seed=9))
    w = np.random.default_rng(9).uniform(-0.01, 0.01, 51)
    assert s.y - s.y_true == pytest.approx(w[0], abs=1e-15)
    for k in range(1, 51):
        s.step(0.5)
        assert s.y == s.y  # reading twice gives the same value
        assert s.y - s.y_true == pytest.approx(w[k], abs=1e-15)


# --- chains ------------------------------------------------------------------------


def test_process_chain_steady_state_includes_both_loads():
    chain = process(PT1(2.0, 5.0, TS), u_min=0.0, u_max=10.0, load_in=0.5, load_out=0.1)
    chain.reset(1.0)
    assert chain.y == pytest.approx(2.0 * 1.5 + 0.1, rel=1e-12)
    assert chain.u == 1.5
    for _ in range(20):
        chain.step(1.0)
    assert chain.y == pytest.approx(3.1, rel=1e-12)


def test_find_reaches_the_parts_of_a_chain():
    plant = PT1(1.0, 1.0, TS)
    chain = process(plant, rate=1.0)
    assert chain.find(PT1) is plant
    assert chain.find(Sensor) is chain
    assert chain.find(Actuator).rate == 1.0
    assert chain.find(DeadTime) is None
    assert plant.find(PT1) is plant and plant.find(DeadTime) is None


def test_chain_snapshot_restore_reproduces_noise_and_state():
    chain = process(
        PT2(1.0, 2.0, 1.0, TS, dead_time=0.25),
        rate=3.0,
        noise=Noise(0.02, kind="gaussian", t_corr=0.3, ts=TS, seed=1),
    )
    for k in range(40):
        chain.step(math.sin(0.2 * k))
    snap = chain.snapshot()
    a = [chain.step(math.cos(0.1 * k)) for k in range(40)]
    chain.restore(snap)
    b = [chain.step(math.cos(0.1 * k)) for k in range(40)]
    assert a == b


def test_wrapper_refuses_a_non_plant():
    with pytest.raises(TypeError):
        Sensor(object())  # type: ignore[arg-type]
