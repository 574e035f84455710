"""Relay-feedback auto-tuning and bump-test pre-tuning against simulated plants."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import optimize, signal

from ctrlblocks.plants.linear import FOPDT as FOPDTPlant
from ctrlblocks.plants.linear import PTn
from ctrlblocks.tuning import amigo, relay_autotune, step_pretune, ziegler_nichols_closed


def exact_ultimate_point(num, den, dead_time=0.0):
    """(ku, pu) where the phase of num/den e^{-L s} crosses -180 deg (scipy freqresp + brentq)."""
    sys = signal.lti(num, den)

    def phase(w):  # unwrapped along a log grid from nearly zero frequency
        h = signal.freqresp(sys, w=np.geomspace(1e-4, w, 400))[1]
        return np.unwrap(np.angle(h))[-1] - w * dead_time

    w180 = optimize.brentq(lambda w: phase(w) + np.pi, 1e-3, 20.0, xtol=1e-14)
    mag = abs(signal.freqresp(sys, w=[w180])[1][0])
    return 1.0 / mag, 2.0 * np.pi / w180


DEN_10B = np.polymul(np.polymul([7.3, 1.0], [2.2, 1.0]), [1.4, 1.0])


def test_exact_ultimate_point_of_10b():
    ku, pu = exact_ultimate_point([0.73], DEN_10B)
    assert (round(ku, 2), round(pu, 2)) == (18.13, 9.02)


@pytest.mark.parametrize(
    ("plant", "num", "den", "dead_time"),
    [
        (lambda: PTn(0.73, (7.3, 2.2, 1.4), 0.05), [0.73], DEN_10B, 0.0),
        (lambda: FOPDTPlant(1.5, 10.0, 2.0, 0.02), [1.5], [10.0, 1.0], 2.0),
        (lambda: PTn(1.0, (5.0, 1.0), 0.02, dead_time=0.5), [1.0], [5.0, 6.0, 1.0], 0.5),
    ],
    ids=["10b", "fopdt", "sopdt"],
)
def test_relay_finds_ultimate_gain_and_period_within_5pct(plant, num, den, dead_time):
    ku, pu = exact_ultimate_point(num, den, dead_time)
    r = relay_autotune(plant(), 0.5, u0=1.0)
    assert r.ku == pytest.approx(ku, rel=0.05)
    assert r.pu == pytest.approx(pu, rel=0.05)
    assert r.warnings == []
    zn = ziegler_nichols_closed(r.ku, r.pu)
    assert (r.pid.kp, r.pid.ti, r.pid.td) == (zn.kp, zn.ti, zn.td)


def test_harmonic_estimate_beats_the_describing_function_on_10b():
    ku, pu = exact_ultimate_point([0.73], DEN_10B)
    h = relay_autotune(PTn(0.73, (7.3, 2.2, 1.4), 0.05), 0.5, u0=1.0)
    df = relay_autotune(PTn(0.73, (7.3, 2.2, 1.4), 0.05), 0.5, u0=1.0, estimate="df")
    assert abs(h.ku / ku - 1) < 0.02 and abs(h.pu / pu - 1) < 0.015  # measured -1.5 %, +1.1 %
    assert df.ku / ku - 1 == pytest.approx(-0.062, abs=0.005)  # the classic 4d/(pi a) is 6 % low
    assert df.pu == pytest.approx(9.3)  # the cycle period itself
    assert df.ku == df.ku_df == h.ku_df


def test_negative_process_gain_gives_negative_ku_and_reverse_pid():
    ku, pu = exact_ultimate_point([1.5], [10.0, 1.0], 2.0)
    r = relay_autotune(FOPDTPlant(-1.5, 10.0, 2.0, 0.02), 0.5, u0=3.0, gain_sign=-1)
    assert r.ku == pytest.approx(-ku, rel=0.05)
    assert r.pu == pytest.approx(pu, rel=0.05)
    assert r.pid.as_kwargs()["reverse"] is True


def test_hysteresis_moves_the_cycle_to_the_describing_function_phase():
    # eps = 0.02 is 16 % of the PV amplitude: the cycle sits at about
    # -180 + asin(eps/a) = -170 deg.  The describing function then misses the
    # ultimate point by 10 %; the harmonic estimate corrects most of it.
    ku, pu = exact_ultimate_point([1.5], [10.0, 1.0], 2.0)
    r = relay_autotune(FOPDTPlant(1.5, 10.0, 2.0, 0.02), 0.5, u0=1.0, hysteresis=0.02)
    assert r.phase == pytest.approx(-180.0 + np.degrees(np.arcsin(0.02 / r.amplitude)), abs=1.5)
    assert abs(r.ku_df / ku - 1) == pytest.approx(0.10, abs=0.01)
    assert abs(r.ku / ku - 1) < 0.05 and abs(r.pu / pu - 1) < 0.05  # measured -4.3 %, +4.6 %


def test_relay_without_a_steady_cycle_raises():
    with pytest.raises(RuntimeError, match="no steady relay limit cycle"):
        relay_autotune(PTn(0.73, (7.3, 2.2, 1.4), 0.05), 0.5, max_time=10.0)


def test_step_pretune_identifies_the_plant_and_applies_amigo():
    plant = FOPDTPlant(1.5, 10.0, 2.0, 0.05)
    r = step_pretune(plant, 0.5, u0=1.0)
    m = r.model
    assert (m.gain, m.time_constant, m.dead_time) == pytest.approx((1.5, 10.0, 2.0), rel=1e-6)
    ref = amigo(1.5, 10.0, 2.0)
    assert (r.pid.kp, r.pid.ti, r.pid.td) == pytest.approx((ref.kp, ref.ti, ref.td), rel=1e-6)
    # the automatic test length stops near steady state
    assert abs(r.y[-1] - r.y[0] - 0.75) < 0.005 * 0.75


# -- noisy plants (the three-tank rig with 1 mbar of measurement noise) ---------------------------


def _three_tank(seed=None):
    from ctrlblocks.plants import Noise, ThreeTank, process

    tank = ThreeTank(ts=0.1)
    noise = None if seed is None else Noise(0.001, kind="gaussian", seed=seed)
    return process(tank, u_min=0.0, u_max=5.0, noise=noise), tank.u_for_y(1.5)


def test_the_noise_is_measured_from_first_differences_whatever_the_drift():
    from ctrlblocks.tuning.relay import noise_sigma

    rng = np.random.default_rng(7)
    y = 0.002 * rng.standard_normal(400) + np.linspace(0.0, 0.5, 400)  # a ramp under it
    assert noise_sigma(y) == pytest.approx(0.002, rel=0.1)
    assert noise_sigma(np.full(50, 3.0)) == 0.0


@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
def test_relay_on_the_noisy_three_tank_finds_the_cycle_of_the_clean_one(seed):
    """The issue's rig: 'no steady relay limit cycle' after 240 s (a 1 % test on one
    cycle); now the noise-sized hysteresis and a cycle judged over several periods."""
    clean, u0 = _three_tank()
    ref = relay_autotune(clean, 0.5, u0=u0, setpoint=1.5)
    noisy, _ = _three_tank(seed)
    r = relay_autotune(noisy, 0.5, u0=u0, setpoint=1.5, hysteresis="auto", max_time=240.0)
    assert r.t[-1] < 120.0
    # the 3 mbar hysteresis itself moves ku by +7 % and pu by -1 % on this plant
    assert -0.02 < r.ku / ref.ku - 1 < 0.15 and abs(r.pu / ref.pu - 1) < 0.05


def test_the_auto_hysteresis_is_three_noise_sigmas_measured_at_u0_first():
    from ctrlblocks.tuning.relay import NOISE_BAND, RelayExperiment

    noisy, u0 = _three_tank(seed=3)
    noisy.reset(u0)
    exp = RelayExperiment(0.5, u0=u0, setpoint=1.5, ts=0.1, max_samples=2400,
                          hysteresis=None, noise_samples=20)  # fmt: skip
    us = []
    while not exp.done:
        us.append(exp.step(float(noisy.y)))
        noisy.step(us[-1])
    assert us[:20] == [u0] * 20 and us[20] == u0 + 0.5  # held, then the relay
    assert exp.sigma == pytest.approx(0.001, rel=0.35)  # 20 samples of 1 mbar
    assert exp.eps == pytest.approx(NOISE_BAND * exp.sigma)


def test_a_cycle_too_small_for_its_hysteresis_is_refused_with_what_was_seen():
    noisy, u0 = _three_tank(seed=2)
    with pytest.raises(RuntimeError, match=r"less than 4 times the hysteresis .*increase d"):
        relay_autotune(noisy, 0.5, u0=u0, setpoint=1.5, hysteresis=0.02, max_time=240.0)


def test_a_relay_that_gives_up_says_what_it_saw():
    noisy, u0 = _three_tank(seed=1)
    with pytest.raises(RuntimeError) as err:  # d far too small for the noise
        relay_autotune(noisy, 0.002, u0=u0, setpoint=1.5, hysteresis="auto", max_time=60.0)
    msg = str(err.value)
    assert msg.startswith("no steady relay limit cycle within 62 s: ")  # 2 s measuring noise
    for part in ("upward switch(es) in", "noise sigma 0.00", "hysteresis 0.00"):
        assert part in msg
    assert "increase d" in msg
