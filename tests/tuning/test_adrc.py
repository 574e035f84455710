"""ADRC bandwidth tuning (Nowak et al. 2018, section 3.3) and the ready configuration."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from ctrlblocks.blocks.base import ErrorCode, ParameterError
from ctrlblocks.tuning import adrc_bandwidth, adrc_config, adrc_tuning
from ctrlblocks.tuning.adrc import MAX_OMEGA_O_TS, SETTLING_FACTOR, SETTLING_TIME_2PCT


@pytest.mark.parametrize("n", [1, 2, 3])
def test_documented_settling_times_are_those_of_the_ideal_closed_loop(n):
    # 1/(s + 1)^n by scipy: it is 0.98 at the documented time, and never again
    # more than 2 % from 1 after it (the response is monotone)
    sys = signal.lti([1.0], np.poly([-1.0] * n))
    x = SETTLING_TIME_2PCT[n]
    assert signal.step(sys, T=np.array([0.0, x]))[1][-1] == pytest.approx(0.98, abs=1e-10)
    t = np.linspace(0.0, 30.0, 3001)
    y = signal.step(sys, T=t)[1]
    assert np.all(np.abs(y[t > x] - 1.0) < 0.02)
    assert np.all(np.abs(y[t < x - 0.01] - 1.0) > 0.02)


def test_settling_factor_is_exact_value_clipped_to_the_seeds_3_to_5():
    assert pytest.approx({1: 3.912023, 2: 5.0, 3: 5.0}) == SETTLING_FACTOR


def test_bandwidths_from_settling_time():
    r = adrc_bandwidth(10.0, 2, 0.05)
    assert r.omega_c == pytest.approx(0.5)
    assert r.omega_o == pytest.approx(2.5)  # 5 x omega_c (Nowak et al. 2018, Table 2 ratio)
    assert r.settling_time_model == pytest.approx(5.83392170 / 0.5)
    assert r.warnings == []


def test_observer_too_fast_for_the_sample_time_is_lowered_with_a_warning():
    r = adrc_bandwidth(10.0, 2, 0.2)  # omega_o ts = 0.5 > 0.2
    assert r.omega_o == pytest.approx(MAX_OMEGA_O_TS / 0.2)
    assert any("too fast" in w for w in r.warnings)
    r = adrc_bandwidth(2.0, 2, 0.2)  # 2.5 x 0.2 > 0.2 -> 1.0 < 3 omega_c = 7.5
    assert any("only" in w for w in r.warnings)


def test_suggested_sample_time_is_a_round_number_with_omega_o_ts_at_most_0_1():
    r = adrc_bandwidth(16.95, 2)  # omega_o = 1.4749 -> 0.1/omega_o = 0.0678 -> 0.05
    assert r.ts == 0.05
    assert r.omega_o * r.ts <= 0.1


def test_factor_and_ratio_outside_the_seeds_ranges_warn():
    r = adrc_bandwidth(10.0, 1, 0.01, factor=8.0, observer_ratio=20.0)
    assert r.omega_c == pytest.approx(0.8) and r.omega_o == pytest.approx(16.0)
    assert len(r.warnings) == 2


def test_full_tuning_for_10b_third_order_uses_table1_b0_min():
    # a settling time of 15 s is unstable on the FOPDT (refused, see test_adrc_safe.py): forced
    r = adrc_tuning(0.73, 8.3, 3.0, 3, settling_time=15.0, ts=0.1, force=True)
    assert (round(r.b0, 4), round(r.b0_min, 4), round(r.b0_max, 4)) == (0.0236, 0.0236, 0.1022)
    assert r.omega_c == pytest.approx(5.0 / 15.0)
    assert r.omega_o == pytest.approx(5.0 * 5.0 / 15.0)


def test_default_settling_time_is_the_rules_tau_set_of_the_searched_bandwidth():
    r = adrc_tuning(0.56, 11.0, 3.3, 2, ts=0.1)
    assert r.settling_time == pytest.approx(SETTLING_FACTOR[2] / r.omega_c)
    assert r.ms_target == 1.6 and 0.98 * 1.6 <= r.margins.ms <= 1.6


def test_first_order_on_a_dead_time_process_warns():
    r = adrc_tuning(0.73, 8.3, 3.0, 1, ts=0.1)
    assert r.b0 == pytest.approx(0.73 / 8.3)
    assert any("prefer order 2" in w for w in r.warnings)


def test_config_has_exactly_the_adrc_constructor_keywords():
    cfg = adrc_config(0.73, 8.3, 3.0, 2, ts=0.1, u_min=0.0, u_max=5.0, t_ref=2.0)
    assert set(cfg) == {"order", "b0", "omega_c", "omega_o", "ts", "u_min", "u_max", "t_ref"}
    assert (cfg["u_min"], cfg["u_max"], cfg["t_ref"], cfg["ts"]) == (0.0, 5.0, 2.0, 0.1)


def test_bad_settling_time_or_order_is_refused():
    with pytest.raises(ParameterError) as info:
        adrc_bandwidth(-1.0, 2, 0.1)
    assert info.value.code == ErrorCode.BAD_TIME_CONSTANT
    with pytest.raises(ParameterError) as info:
        adrc_bandwidth(10.0, 4, 0.1)
    assert info.value.code == ErrorCode.BAD_ORDER


# --- with the ADRC block in the loop ---


def _closed_loop(cfg, k, taus, t_end=120.0):
    from ctrlblocks import ADRC
    from ctrlblocks.plants.linear import PTn

    ctrl = ADRC(**cfg)
    plant = PTn(k, taus, cfg["ts"])
    plant.reset(1.0)
    y0, ys = plant.y, []
    for _ in range(round(t_end / cfg["ts"])):
        plant.step(ctrl(y0 + 0.2, plant.y))
        ys.append(plant.y)
    e = np.abs(np.array(ys) - (y0 + 0.2))
    settle = (np.nonzero(e > 0.02 * 0.2)[0][-1] + 1) * cfg["ts"]
    return settle, (max(ys) - y0 - 0.2) / 0.2


@pytest.mark.parametrize(
    ("fopdt", "process"),
    [((0.56, 11.0, 3.3), (0.56, (9.5, 4.2))), ((0.73, 8.3, 3.0), (0.73, (7.3, 2.2, 1.4)))],
    ids=["10a", "10b"],
)
def test_default_second_order_tuning_settles_the_seeds_processes_near_the_design(fopdt, process):
    """The safe default (Ms <= 1.6 on the FOPDT, dead time exact) on the true lag processes.

    The FOPDT's dead time is harsher than the lags it stands for, so the true loop is
    slower than the rule's ideal settling time: about 1.3 times the loop on the model.
    """
    tun = adrc_tuning(*fopdt, 2, ts=0.1)
    cfg = adrc_config(*fopdt, 2, ts=0.1, u_min=0.0, u_max=5.0)
    settle, overshoot = _closed_loop(cfg, *process, t_end=1500.0)
    assert tun.settling_time_model < settle < 1.5 * tun.settling_time_loop
    assert overshoot < 0.02


def test_noise_limit_lowers_the_observer_bandwidth_until_mv_noise_is_acceptable():
    from ctrlblocks.tuning.adrc import mv_noise

    free = adrc_tuning(0.73, 8.3, 3.0, 2, ts=0.1)
    sd_free = mv_noise(2, free.b0, free.omega_c, free.omega_o, 0.1, 0.002)
    limited = adrc_tuning(0.73, 8.3, 3.0, 2, ts=0.1, noise_std=0.002, u_noise_max=0.6 * sd_free)
    assert limited.omega_o < free.omega_o
    assert mv_noise(2, limited.b0, limited.omega_c, limited.omega_o, 0.1, 0.002) <= 0.6 * sd_free
    hopeless = adrc_tuning(0.73, 8.3, 3.0, 2, ts=0.1, noise_std=0.002, u_noise_max=1e-6)
    assert hopeless.omega_o == pytest.approx(3.0 * hopeless.omega_c)
    assert any("even with" in w for w in hopeless.warnings)
    assert not math.isnan(sd_free)
