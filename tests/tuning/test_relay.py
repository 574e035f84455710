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
    assert abs(h.ku / ku - 1) < 0.02 and abs(h.pu / pu - 1) < 0.015  # measured -1.1 %, +1.0 %
    assert df.ku / ku - 1 == pytest.approx(-0.061, abs=0.005)  # the classic 4d/(pi a) is 6 % low
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
