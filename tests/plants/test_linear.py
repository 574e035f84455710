"""Linear plants and dead time against python-control, scipy and hand-evaluated formulas."""

from __future__ import annotations

import math

import control
import numpy as np
import pytest

from ctrlblocks.blocks.base import ErrorCode, ParameterError
from ctrlblocks.plants import (
    FOPDT,
    IT1,
    PT1,
    PT2,
    DeadTime,
    LinearPlant,
    PT2Osc,
    PTn,
    split_dead_time,
)

TS = 0.1


def _run(plant, u):
    """Outputs y[0..N]: y[0] before the first step, y[k+1] = plant.step(u[k])."""
    ys = [plant.y]
    ys.extend(plant.step(float(uk)) for uk in u)
    return np.array(ys)


def _reference(num, den, u, ts=TS, delay_samples=0):
    """python-control: exact ZOH sampling + forced response from the zero state.

    The transfer function is realised in state space (python-control's own
    realisation) before sampling: sampling the polynomial form directly loses
    about 1e-10 at 0.01 s for (10b).
    """
    sysd = control.sample_system(control.ss(control.tf(num, den)), ts, method="zoh")
    uu = np.concatenate([np.zeros(delay_samples), u, [0.0]])[: len(u) + 1]
    t = np.arange(len(uu)) * ts
    return np.asarray(control.forced_response(sysd, T=t, U=uu).outputs)


def _rand_input(n, seed=1):
    rng = np.random.default_rng(seed)
    return rng.uniform(-1.0, 1.0, n)


@pytest.mark.parametrize(
    ("make", "num", "den"),
    [
        (lambda: PT1(2.0, 5.0, TS), [2.0], [5.0, 1.0]),
        (lambda: PT2(1.5, 4.0, 1.0, TS), [1.5], [4.0, 5.0, 1.0]),
        (lambda: PT2Osc(1.0, 2.0, 0.3, TS), [1.0], [4.0, 1.2, 1.0]),
        (
            lambda: PTn(0.73, (7.3, 2.2, 1.4), TS),
            [0.73],
            np.poly([-1 / 7.3, -1 / 2.2, -1 / 1.4]) / (1 / 7.3 / 2.2 / 1.4),
        ),
        (lambda: IT1(0.5, 3.0, TS), [0.5], [3.0, 1.0, 0.0]),
        (
            lambda: LinearPlant([1.0, 2.0], [1.0, 3.0, 2.5, 1.0], ts=TS),
            [1.0, 2.0],
            [1.0, 3.0, 2.5, 1.0],
        ),
    ],
    ids=["PT1", "PT2", "PT2Osc", "PTn-10b", "IT1", "TF-with-zero"],
)
def test_plant_equals_python_control_on_random_input(make, num, den):
    u = _rand_input(400)
    y = _run(make(), u)
    ref = _reference(num, den, u)
    scale = max(1.0, float(np.max(np.abs(ref))))
    assert np.max(np.abs(y - ref)) <= 1e-12 * scale


def test_state_space_plant_equals_python_control():
    a = np.array([[-0.5, 1.0, 0.0], [0.0, -1.0, 2.0], [-0.2, 0.0, -3.0]])
    b = np.array([[0.0], [1.0], [0.5]])
    c = np.array([[1.0, 0.0, 0.3]])
    p = LinearPlant(A=a, B=b, C=c, D=0.0, ts=TS)
    u = _rand_input(300, seed=2)
    y = _run(p, u)
    sysd = control.sample_system(control.ss(a, b, c, 0.0), TS, method="zoh")
    uu = np.concatenate([u, [0.0]])
    ref = control.forced_response(sysd, T=np.arange(len(uu)) * TS, U=uu).outputs
    assert np.max(np.abs(y - ref)) <= 1e-12


def test_pt1_step_response_equals_exponential():
    # k (1 - exp(-t/T)) at the sample instants, exact for a ZOH step
    p = PT1(2.0, 5.0, TS)
    y = _run(p, np.ones(50))
    t = np.arange(51) * TS
    assert np.max(np.abs(y - 2.0 * (1.0 - np.exp(-t / 5.0)))) <= 1e-13


def test_fractional_dead_time_is_exact_for_a_zoh_step():
    # FOPDT k e^(-theta s)/(T s + 1), theta = 0.37 s = 3.7 samples:
    # y(t) = k (1 - exp(-(t - theta)/T)) for t >= theta, 0 before
    p = FOPDT(1.3, 2.0, 0.37, TS)
    assert (p.dead_samples, p.dead_fraction) == (3, pytest.approx(0.07, abs=1e-15))
    y = _run(p, np.ones(60))
    t = np.arange(61) * TS
    ref = np.where(t >= 0.37, 1.3 * (1.0 - np.exp(-(t - 0.37) / 2.0)), 0.0)
    assert np.max(np.abs(y - ref)) <= 1e-13
    assert y[3] == 0.0 and y[4] == pytest.approx(1.3 * (1 - math.exp(-0.03 / 2.0)), abs=1e-15)


def test_fractional_dead_time_equals_fine_grid_reference_on_random_input():
    # A ZOH input delayed by 0.37 s is piecewise constant on a 0.01 s grid:
    # sample the plant exactly at 0.01 s, delay by 37 fine samples, keep every 10th.
    num, den = [0.73], np.polymul(np.polymul([7.3, 1.0], [2.2, 1.0]), [1.4, 1.0])
    u = _rand_input(200, seed=3)
    p = PTn(0.73, (7.3, 2.2, 1.4), TS, dead_time=0.37)
    y = _run(p, u)
    fine = np.repeat(u, 10)
    ref_fine = _reference(num, den, fine, ts=0.01, delay_samples=37)
    ref = ref_fine[::10]
    assert np.max(np.abs(y - ref)) <= 1e-12


def test_whole_sample_dead_time_shifts_exactly():
    u = _rand_input(100, seed=4)
    y0 = _run(PT2(1.0, 3.0, 1.0, TS), u)
    y5 = _run(PT2(1.0, 3.0, 1.0, TS, dead_time=0.5), u)
    assert split_dead_time(0.5, TS) == (5, 0.0)
    assert np.array_equal(y5[5:], y0[:-5])
    assert np.all(y5[:5] == 0.0)


def test_dead_time_is_continuous_in_its_fraction():
    # 0.3 s + 1e-9 s must give (almost) the same response as 0.3 s
    u = _rand_input(100, seed=5)
    a = _run(PT1(1.0, 1.0, TS, dead_time=0.3), u)
    b = _run(PT1(1.0, 1.0, TS, dead_time=0.3 + 1e-7), u)
    assert np.max(np.abs(a - b)) < 2e-6


def test_split_dead_time_treats_near_whole_ratio_as_whole():
    assert split_dead_time(0.3, 0.1) == (3, 0.0)
    assert split_dead_time(0.7, 0.1) == (7, 0.0)
    d, eps = split_dead_time(0.35, 0.1)
    assert d == 3 and eps == pytest.approx(0.05, abs=1e-15)


@pytest.mark.parametrize(
    ("plant", "gain"),
    [
        (PT1(2.0, 5.0, TS), 2.0),
        (PT2(-1.5, 4.0, 1.0, TS, dead_time=0.25), -1.5),
        (PTn(0.73, (7.3, 2.2, 1.4), TS, dead_time=3.0), 0.73),
        (LinearPlant([1.0, 2.0], [1.0, 3.0, 2.5, 1.0], ts=TS), 2.0),
    ],
    ids=["PT1", "PT2-dead", "PTn-dead", "TF"],
)
def test_reset_gives_steady_state_dc_gain_times_u0(plant, gain):
    plant.reset(0.8)
    assert plant.dc_gain == pytest.approx(gain, rel=1e-12)
    assert plant.y == pytest.approx(gain * 0.8, rel=1e-12)
    y = _run(plant, np.full(50, 0.8))
    assert np.max(np.abs(y - gain * 0.8)) <= 1e-12


def test_it1_ramp_equals_hand_formula():
    # k/(s (T s + 1)), step u: y(t) = k u (t - T (1 - exp(-t/T)))
    p = IT1(0.5, 3.0, TS)
    assert p.integrating and p.dc_gain == math.inf
    p.reset(0.0)
    y = _run(p, np.full(100, 2.0))
    t = np.arange(101) * TS
    assert np.max(np.abs(y - 1.0 * (t - 3.0 * (1.0 - np.exp(-t / 3.0))))) <= 1e-12


def test_it1_reset_is_zero_state_with_input_held():
    p = IT1(0.5, 3.0, TS, dead_time=0.2)
    p.reset(2.0)
    assert p.y == 0.0 and p.u == 2.0
    p.step(2.0)
    # the held input (also inside the dead time) drives the ramp at once
    assert p.y > 0.0


def test_non_finite_input_holds_previous_input():
    a, b = PT2(1.0, 2.0, 1.0, TS), PT2(1.0, 2.0, 1.0, TS)
    for k in range(20):
        a.step(0.7)
        b.step(0.7 if k < 10 else (math.nan if k % 2 else math.inf))
    assert b.y == a.y and math.isfinite(b.y)


def test_snapshot_restore_reproduces_the_run():
    p = PT2(1.0, 2.0, 1.0, TS, dead_time=0.33)
    u = _rand_input(60, seed=6)
    for uk in u[:30]:
        p.step(float(uk))
    snap = p.snapshot()
    first = [p.step(float(uk)) for uk in u[30:]]
    p.restore(snap)
    second = [p.step(float(uk)) for uk in u[30:]]
    assert first == second


def test_set_state_sets_output():
    p = LinearPlant(A=[[-1.0, 0.0], [0.0, -2.0]], B=[1.0, 1.0], C=[1.0, 2.0], ts=TS)
    p.set_state([1.0, 0.5])
    assert p.y == 2.0 and p.state == [1.0, 0.5]


@pytest.mark.parametrize(
    ("make", "code"),
    [
        (lambda: LinearPlant([1.0, 1.0], [1.0, 1.0], ts=TS), ErrorCode.BAD_PARAMETER),
        (lambda: LinearPlant([1.0], [1.0, 1.0], ts=0.0), ErrorCode.NO_CYCLE),
        (lambda: LinearPlant([1.0], [1.0, 1.0], ts=TS, dead_time=-1), ErrorCode.BAD_TIME_CONSTANT),
        (lambda: LinearPlant(A=[[-1.0]], B=[1.0], C=[1.0], D=1.0, ts=TS), ErrorCode.BAD_PARAMETER),
        (lambda: LinearPlant(ts=TS), ErrorCode.BAD_PARAMETER),
        (lambda: PT1(1.0, 0.0, TS), ErrorCode.BAD_TIME_CONSTANT),
        (lambda: PT1(math.nan, 1.0, TS), ErrorCode.BAD_PARAMETER),
        (lambda: PTn(1.0, (), TS), ErrorCode.BAD_TIME_CONSTANT),
        (lambda: DeadTime(0.0, TS), ErrorCode.BAD_TIME_CONSTANT),
    ],
    ids=["improper", "ts0", "neg-dead", "D", "nothing", "t0", "k-nan", "no-lags", "dead0"],
)
def test_bad_configuration_is_refused_with_code(make, code):
    with pytest.raises(ParameterError) as exc:
        make()
    assert exc.value.code == code


# --- DeadTime ---------------------------------------------------------------


def test_dead_time_block_delays_by_whole_samples():
    d = DeadTime(0.3, TS)
    assert d.n == 3
    u = _rand_input(50, seed=7)
    y = _run(d, u)
    assert np.array_equal(y[3:], u[:-2]) and np.all(y[:3] == 0.0)


def test_dead_time_block_rounds_a_fraction_up_like_a_sampler():
    # 0.25 s at 0.1 s: the delayed ZOH signal at t = k ts is u[k - 3]
    d = DeadTime(0.25, TS)
    assert d.n == 3
    d.reset(1.0)
    assert [d.step(v) for v in (5.0, 6.0, 7.0, 8.0)] == [1.0, 1.0, 5.0, 6.0]


def test_dead_time_block_snapshot_and_nan():
    d = DeadTime(0.2, TS)
    d.step(1.0)
    snap = d.snapshot()
    assert d.step(math.nan) == 1.0  # NaN repeats the last input
    d.restore(snap)
    assert d.step(2.0) == 1.0 and d.step(0.0) == 2.0


# --- run-time parameter changes ------------------------------------------------


def test_gain_change_keeps_the_output_and_reaches_the_new_steady_state():
    # gain at the input: after k 2 -> 3 the output moves as 2 + (3-2)(1 - e^(-t/T)) for PT1
    p = PT1(2.0, 5.0, TS)
    p.reset(1.0)
    p.set_parameter("k", 3.0)
    assert p.y == pytest.approx(2.0, rel=1e-12)
    y = _run(p, np.ones(50))
    t = np.arange(51) * TS
    assert np.max(np.abs(y - (2.0 + 1.0 * (1.0 - np.exp(-t / 5.0))))) <= 1e-12


def test_time_constant_change_equals_a_fresh_model_from_the_same_state():
    u = _rand_input(80, seed=8)
    a = PT2(1.0, 3.0, 1.0, TS)
    for uk in u[:40]:
        a.step(float(uk))
    x = a.state
    a.set_parameter("t1", 6.0)
    b = PT2(1.0, 6.0, 1.0, TS)
    b.set_state(x)
    assert [a.step(float(uk)) for uk in u[40:]] == [b.step(float(uk)) for uk in u[40:]]
    assert a.t1 == 6.0 and "t1=6.0" in repr(a)


def test_ptn_time_constants_change_keeps_their_number():
    p = PTn(0.73, (7.3, 2.2, 1.4), TS)
    p.set_parameter("t", (6.0, 2.0, 1.0))
    assert p.t == (6.0, 2.0, 1.0)
    with pytest.raises(ParameterError) as exc:
        p.set_parameter("t", (6.0, 2.0))
    assert exc.value.code == ErrorCode.BAD_PARAMETER
    assert p.t == (6.0, 2.0, 1.0)  # the old value stays


def test_dead_time_change_keeps_the_input_history():
    # inputs 1..10, then the dead time grows from 0.2 s to 0.4 s: the next outputs
    # of a pure-delay-like PT1 use the inputs of 4 samples ago, which were kept
    a = PT1(1.0, 1.0, TS, dead_time=0.2)
    b = PT1(1.0, 1.0, TS, dead_time=0.4)
    for v in range(1, 11):
        a.step(float(v))
        b.step(float(v))
    a.set_state(b.state)
    a.set_parameter("dead_time", 0.4)
    assert a.dead_samples == 4
    assert [a.step(0.0) for _ in range(6)] == [b.step(0.0) for _ in range(6)]


@pytest.mark.parametrize(
    ("name", "value", "code"),
    [
        ("t", -1.0, ErrorCode.BAD_TIME_CONSTANT),
        ("k", math.inf, ErrorCode.BAD_PARAMETER),
        ("dead_time", -0.1, ErrorCode.BAD_TIME_CONSTANT),
        ("colour", 1.0, ErrorCode.BAD_PARAMETER),
    ],
)
def test_bad_run_time_parameter_is_refused_and_the_model_kept(name, value, code):
    p = PT1(2.0, 5.0, TS)
    p.reset(1.0)
    with pytest.raises(ParameterError) as exc:
        p.set_parameter(name, value)
    assert exc.value.code == code
    assert (p.k, p.t, p.dead_time) == (2.0, 5.0, 0.0)
    assert p.step(1.0) == pytest.approx(2.0, rel=1e-12)


def test_generic_linear_plant_accepts_only_dead_time_at_run_time():
    p = LinearPlant([1.0], [1.0, 1.0], ts=TS)
    p.set_parameter("dead_time", 0.3)
    assert p.dead_samples == 3
    with pytest.raises(ParameterError):
        p.set_parameter("k", 2.0)
