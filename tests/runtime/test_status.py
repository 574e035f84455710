"""The conditions an operator sees at a glance, and the runtime's check for a swinging MV."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from ctrlblocks.runtime import MemoryBus
from ctrlblocks.runtime.status import OFF_DELAY, Conditions, SwingDetector

from .conftest import ClockedPlant, bounded, loop_toml, make


def test_the_bang_bang_of_the_issue_is_oscillating_within_six_cycles():
    """The ADRC's MV of the issue banged 0 <-> 5 bar every cycle and the faceplate said 'ok'."""
    det = SwingDetector()
    flags = [det.update(5.0 * (k % 2), 5.0) for k in range(10)]
    assert flags.index(True) == 5 and all(flags[5:])


@settings(max_examples=200, deadline=None)
@given(
    noise=st.floats(0.0, 0.0999, allow_nan=False),
    seed=st.integers(0, 2**32 - 1),
    level=st.floats(-100.0, 100.0, allow_nan=False),
)
def test_noise_inside_the_band_never_counts_as_a_swing(noise, seed, level):
    """An MV whose peak-to-peak noise is below 10 % of the range never swings."""
    rng = np.random.default_rng(seed)
    det = SwingDetector()
    u = level + noise * 10.0 * (rng.random(500) - 0.5)  # range 10: band 1, p-p < 1
    assert not any(det.update(float(x), 10.0) for x in u)


@settings(max_examples=100, deadline=None)
@given(period=st.integers(2, 40), amplitude=st.floats(0.06, 0.5))
def test_a_swing_above_the_band_is_found_after_two_periods_within_the_window(period, amplitude):
    """A square wave of half-period ``period`` cycles, swinging more than 10 % of the range."""
    det = SwingDetector()
    flags = [det.update(amplitude * (1 if (k // period) % 2 else -1), 1.0) for k in range(400)]
    if 3 * period <= det.window - 1:  # four reversals fit in the window
        assert any(flags) and flags.index(True) <= 5 * period + 1
    else:  # slower: not reported
        assert not any(flags)


def test_a_flickering_condition_is_one_episode_with_one_raise_and_one_clear():
    c = Conditions()
    for k in range(40):
        c.set("late_io", k % 3 == 0 and k < 20, "late", float(k), off_delay=OFF_DELAY)
    raised = [(up, cond.code) for up, cond in c.events]
    assert raised == [(True, "late_io"), (False, "late_io")]


def test_conditions_are_listed_highest_severity_first_and_info_is_not_audited():
    c = Conditions()
    c.set("mv_limit", True, "at the limit", 1.0)
    c.set("late_io", True, "late", 2.0)
    c.set("bad_pv", True, "PV bad", 3.0)
    assert c.codes() == ["bad_pv", "late_io", "mv_limit"]
    assert [cond.code for _, cond in c.events] == ["late_io", "bad_pv"]


def test_an_over_tuned_loop_is_shown_oscillating_and_audited():
    """A PI far too hot for its plant: the MV swings between its limits."""
    bus = MemoryBus()
    block = '{ type = "PID", kp = 30.0, ti = 0.2, u_min = 0.0, u_max = 5.0 }'
    rt, clock, samples = make(loop_toml(block=block, sp="1.0"), {"io": bus})
    plant = ClockedPlant(bus, clock, 0.1, a=0.5, u0=1.5)

    async def main():
        plant.start()
        await rt.start()
        await clock.run_until(10.0)
        st_ = rt.state("loop")
        await rt.stop()
        return st_

    st_ = bounded(main())
    mv = np.array([s.mv for s in samples])
    assert np.ptp(mv[-30:]) > 2.0 and not math.isnan(mv[-1])  # it does swing
    assert "oscillating" in st_["status"]
    (cond,) = [c for c in st_["conditions"] if c["code"] == "oscillating"]
    assert cond["severity"] == "warning" and "reversed" in cond["text"]
