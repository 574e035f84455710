"""The figures of the assessment against hand-evaluated numbers and independent computations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ctrlblocks.health import figures as fg
from ctrlblocks.health.assess import Model, ultimate_period


def test_service_factors_weigh_each_sample_by_its_hold_time() -> None:
    t = np.arange(10.0)
    u = np.array([0, 0, 5, 5, 10, 10, 10, 5, 5, 5], dtype=float)
    mode = ["AUTO"] * 6 + ["MANUAL"] * 4
    ok = np.array([True] * 9 + [False])
    sf = fg.service_factors(t, u, mode, ok, 0.0, 10.0)
    # 10 samples of 1 s: 2 at 0, 3 at 10, 4 in MAN, 1 bad
    assert (sf.at_low, sf.at_high) == (0.2, 0.3)
    assert sf.modes == {"AUTO": 0.6, "MANUAL": 0.4}
    assert sf.bad_pv == 0.1


def test_limits_from_data_count_only_where_the_mv_stays() -> None:
    t = np.arange(8.0)
    u = np.array([1, 9, 1, 9, 9, 9, 9, 3], dtype=float)  # touches 1 twice, sits at 9
    sf = fg.service_factors(t, u, None, np.ones(8, bool))
    assert sf.limits_from_data and (sf.u_min, sf.u_max) == (1.0, 9.0)
    assert sf.at_low == 0.0
    assert sf.at_high == pytest.approx(4 / 8)  # samples 3..6: a run at 9; 1 (alone) does not count


def test_valve_wear_travel_and_reversals_by_hand() -> None:
    t = np.arange(7.0) * 600.0  # 7 samples of 10 min: 70 min = 7/6 h
    u = np.array([0, 10, 5, 5.2, 20, 19.9, 0])
    w = fg.valve_wear(t, u, deadband=1.0)
    assert w.travel == pytest.approx(10 + 5 + 0.2 + 14.8 + 0.1 + 19.9)
    # turning points beyond 1: 10 -> 5 (down), 5 -> 20 (up), 20 -> 0 (down)
    assert w.reversals == 3
    assert w.reversals_per_hour == pytest.approx(3 / (7 / 6))
    u2 = np.array([0, 10, 5, 5.5, 5.2, 20, 19.9, 19.95, 0])
    t2 = np.arange(9.0)
    assert fg.valve_wear(t2, u2, deadband=0.0).reversals == 7  # every turn
    assert fg.valve_wear(t2, u2, deadband=1.0).reversals == 3  # 10 -> 5, 5 -> 20, 20 -> 0


def test_hagglund_iae_limit_is_that_of_a_sine_half_period() -> None:
    # IAE of a |sin| half period: int_0^{pi/w} a |sin(w t)| dt = 2a/w = a Tu / pi
    a, tu = 0.7, 40.0
    t = np.linspace(0.0, tu / 2, 200001)
    iae = np.trapezoid(np.abs(a * np.sin(2 * np.pi * t / tu)), t)
    res = fg.oscillation(np.arange(100.0), np.zeros(100), a, tu)
    assert res.iae_lim == pytest.approx(iae, rel=1e-6)
    assert not res.detected


def test_a_sustained_sine_is_detected_with_its_period_and_amplitude() -> None:
    h, period, amp = 0.5, 30.0, 2.0
    t = np.arange(0.0, 3600.0, h)
    e = amp * np.sin(2 * np.pi * t / period + 0.3)
    res = fg.oscillation(t, e, a=0.5, tu=period, filter_time=0.0)
    assert res.detected
    assert res.period == pytest.approx(period, abs=2 * h)
    assert res.amplitude == pytest.approx(amp, rel=0.02)
    # a load every half period, x -> 1/(1 - gamma^(T/2h)): first above 10 after 11 loads
    assert res.spans[0][0] == pytest.approx(t[0] + 10 * period / 2, abs=period / 2 + 2 * h)


def test_an_oscillation_below_the_acceptable_amplitude_is_not_one() -> None:
    t = np.arange(0.0, 3600.0, 0.5)
    e = 0.3 * np.sin(2 * np.pi * t / 30.0)
    assert not fg.oscillation(t, e, a=0.5, tu=30.0, filter_time=0.0).detected


def test_harris_index_of_a_moving_average_error_is_its_first_d_terms() -> None:
    # e_t = eps_t + 0.5 eps_{t-1} + 0.8 eps_{t-2}: with d = 2, sigma_mv^2 = (1 + 0.25) s^2,
    # sigma_y^2 = (1 + 0.25 + 0.64) s^2 -> eta = 1.25 / 1.89
    rng = np.random.default_rng(7)
    eps = rng.normal(0.0, 1.0, 200_000)
    e = eps.copy()
    e[1:] += 0.5 * eps[:-1]
    e[2:] += 0.8 * eps[:-2]
    res = fg.harris_index(e, delay=2, order=30)
    assert res.index == pytest.approx(1.25 / 1.89, rel=0.02)
    assert fg.harris_index(e, delay=3, order=30).index == pytest.approx(1.0, abs=0.02)
    assert fg.harris_index(e, delay=1, order=30).index == pytest.approx(1 / 1.89, rel=0.02)


def test_harris_index_of_an_ar1_against_the_closed_form() -> None:
    # e_t = 0.9 e_{t-1} + eps_t: psi_j = 0.9^j, var = 1/(1 - 0.81); d = 3
    rng = np.random.default_rng(3)
    eps = rng.normal(0.0, 1.0, 200_000)
    from scipy.signal import lfilter

    e = lfilter([1.0], [1.0, -0.9], eps)
    want = (1 + 0.81 + 0.9**4) * (1 - 0.81)
    assert fg.harris_index(e, delay=3, order=5).index == pytest.approx(want, rel=0.03)


def test_horch_says_even_for_opposed_signals_and_odd_for_a_quarter_period() -> None:
    h, period = 1.0, 60.0
    t = np.arange(0.0, 3000.0, h)
    y = np.sin(2 * np.pi * t / period)
    even = fg.horch_stiction(-y, y, h, period)
    assert even.verdict == "no stiction" and abs(even.asymmetry) < 0.05
    assert even.tau_r == pytest.approx(period / 4, abs=h) and even.tau_l == pytest.approx(
        -period / 4, abs=h
    )
    # a triangle (the integral of a square wave) against the square wave: 90 deg apart
    sq = np.sign(np.sin(2 * np.pi * t / period))
    tri = -np.cumsum(sq) * h
    odd = fg.horch_stiction(tri, sq, h, period)
    assert odd.verdict == "stiction" and abs(odd.asymmetry) > 0.9


def test_horch_asymmetry_is_the_phase_offset_from_opposition() -> None:
    rng = np.random.default_rng(1)
    t = np.arange(2000.0)
    u = np.sin(2 * np.pi * t / 50) + 0.1 * rng.normal(size=t.size)
    y = -np.sin(2 * np.pi * t / 50 + 0.4) + 0.1 * rng.normal(size=t.size)
    r = fg.horch_stiction(u, y, 1.0, 50.0)
    k = int(np.flatnonzero(r.lags == 0)[0])
    # independent: the phase of y against u is 180 + 0.4 rad -> asymmetry = -0.4 / (pi/2)
    assert r.asymmetry == pytest.approx(-0.4 / (math.pi / 2), abs=0.06)
    assert r.ccf[k] < -0.8


def test_ultimate_period_of_an_fopdt_solves_the_phase_crossover() -> None:
    m = Model(1.0, 10.0, 2.0)
    w = 2 * math.pi / ultimate_period(m)
    assert math.atan(w * 10.0) + w * 2.0 == pytest.approx(math.pi)
    import control

    g = control.tf([1.0], [10.0, 1.0]) * control.tf(*control.pade(2.0, 12))
    _, _, wpc, _ = control.margin(g)  # wpc: the phase crossover frequency
    assert w == pytest.approx(wpc, rel=1e-3)


def test_setpoint_steps_are_changes_beyond_the_threshold() -> None:
    sp = np.array([1.0, 1.0, 1.05, 2.0, 2.0, 0.5])
    assert fg.setpoint_steps(np.arange(6.0), sp, 0.1) == [3, 5]
