"""The ADRC option ``input_delay``: the ESO fed the delayed input (Zhao & Gao 2014)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ctrlblocks import ADRC, ErrorCode, ParameterError
from ctrlblocks.blocks.adrc import adrc_gains, adrc_switches, control_law, eso_euler
from ctrlblocks.plants import FOPDT

TS = 0.05
L = 3.0  # dead time of the test process [s], three times its lag T = 1 s


def load_iae(delay: float, wc: float, ratio: float, seconds: float = 200.0) -> float:
    """IAE of a unit load step at the process input, FOPDT 1 e^(-3 s)/(s + 1), loop at rest."""
    plant = FOPDT(1.0, 1.0, L, TS)
    adrc = ADRC(order=1, b0=1.0, omega_c=wc, omega_o=ratio * wc, ts=TS, u_min=-10.0,
                u_max=10.0, input_delay=delay)  # fmt: skip
    total = 0.0
    for k in range(int(seconds / TS)):
        y = plant.y
        u = adrc(0.0, y)
        plant.step(u + (1.0 if k * TS >= 10.0 else 0.0))
        total += abs(y) * TS
    return total


def test_delayed_observer_holds_a_tuning_the_plain_one_cannot_on_a_dead_time_process() -> None:
    # same tuning: omega_c = 0.6/T, omega_o = 3 omega_c; the plain ESO attributes the
    # dead time's lag to the disturbance and the loop oscillates into the limits
    plain, delayed = load_iae(0.0, 0.6, 3.0), load_iae(L, 0.6, 3.0)
    assert plain > 100.0
    assert delayed == pytest.approx(7.24, abs=0.05)
    # no controller does better than about L * d (the load is unseen for L seconds)
    assert delayed > L


def test_delayed_observer_beats_the_best_plain_tuning_on_a_dead_time_dominant_fopdt() -> None:
    best_plain = min(
        load_iae(0.0, wc, ratio) for wc in (0.2, 0.3, 0.35, 0.4, 0.45) for ratio in (3.0, 5.0)
    )
    assert best_plain == pytest.approx(6.51, abs=0.05)
    assert load_iae(L, 1.0, 5.0) == pytest.approx(3.59, abs=0.05)


def test_the_eso_is_fed_the_applied_u_of_d_samples_ago() -> None:
    # an independent wiring of (4a)/(4b) from the law functions with u_{i-1-d} in the ESO
    d, ts, b0, wc, wo = 4, 0.1, 0.5, 1.0, 4.0
    adrc = ADRC(order=2, b0=b0, omega_c=wc, omega_o=wo, ts=ts, input_delay=d * ts)
    l1, l2, l3, l4, kp, kd1, kd2 = adrc_gains(2, wc, wo)
    sw = adrc_switches(2)
    rng = np.random.default_rng(3)
    ys = np.cumsum(rng.normal(0.0, 0.1, 60))
    us = [0.0] * (d + 1)  # u applied before the start: u0 = 0
    x = (ys[0], 0.0, 0.0, 0.0)
    for y in ys:
        x = eso_euler(*x, us[-1 - d], y, 1.0, ts, b0, l1, l2, l3, l4, *sw)
        u = control_law(1.0, *x, b0, kp, kd1, kd2)
        assert adrc(1.0, y) == u
        us.append(u)
    assert adrc.x == x


def test_a_delay_below_half_a_sample_is_the_plain_block_bit_for_bit() -> None:
    a, b = ADRC(ts=0.1, input_delay=0.049), ADRC(ts=0.1)
    c, d = ADRC(ts=0.1, input_delay=0.26), ADRC(ts=0.1, input_delay=0.3)
    for k in range(300):
        y = math.sin(0.05 * k)
        assert a(1.0, y) == b(1.0, y)
        assert c(1.0, y) == d(1.0, y)  # rounded to 3 samples both


@pytest.mark.parametrize("bad", [-0.1, math.nan, math.inf, 1e9, "x", None])
def test_a_bad_input_delay_is_refused_and_the_old_configuration_stays(bad: object) -> None:
    adrc = ADRC(ts=0.1, input_delay=0.3)
    with pytest.raises((ParameterError, TypeError)) as exc:
        adrc.configure(input_delay=bad)
    if isinstance(exc.value, ParameterError):
        assert exc.value.code == ErrorCode.BAD_TIME_CONSTANT
    assert adrc.config.input_delay == 0.3
    with pytest.raises(ParameterError):
        ADRC(ts=0.1, input_delay=bad)


@settings(max_examples=30, deadline=None)
@given(d=st.integers(0, 12), split=st.integers(1, 80))
def test_snapshot_and_restore_carry_the_history_of_u(d: int, split: int) -> None:
    adrc = ADRC(order=1, b0=1.0, omega_c=0.5, omega_o=2.0, ts=0.1, input_delay=0.1 * d,
                u_min=-5.0, u_max=5.0)  # fmt: skip
    ys = [math.sin(0.1 * k) for k in range(split + 40)]
    for y in ys[:split]:
        adrc(1.0, y)
    snap = adrc.snapshot()
    first = [adrc(1.0, y) for y in ys[split:]]
    adrc.restore(snap)
    assert [adrc(1.0, y) for y in ys[split:]] == first


def test_a_snapshot_of_before_the_option_restores_with_the_history_at_rest() -> None:
    adrc = ADRC(ts=0.1, input_delay=0.3)
    for k in range(20):
        adrc(1.0, 0.1 * k)
    snap = adrc.snapshot()
    del snap["_u_hist"]
    adrc.restore(snap)
    assert adrc._u_hist == (adrc.out,) * 3


def test_a_longer_delay_pads_the_history_with_its_oldest_value_and_stays_bumpless() -> None:
    adrc = ADRC(ts=0.1, input_delay=0.2, omega_c=0.5, omega_o=2.0)
    for k in range(30):
        adrc(1.0, 0.02 * k)
    old = adrc._u_hist
    adrc.configure(input_delay=0.5)
    assert adrc._u_hist == (old[0],) * 3 + old
    adrc.configure(input_delay=0.1)
    assert adrc._u_hist == old[-1:]


def test_manual_to_auto_with_a_delay_continues_from_the_manual_value() -> None:
    plant = FOPDT(1.0, 1.0, 1.0, 0.1)
    adrc = ADRC(order=1, b0=1.0, omega_c=0.5, omega_o=2.0, ts=0.1, input_delay=1.0)
    adrc.manual, adrc.u_man = True, 0.4
    for _ in range(100):
        plant.step(adrc(0.4, plant.y))
    adrc.manual = False
    assert adrc(0.4, plant.y) == pytest.approx(0.4, abs=1e-12)


def test_the_compiled_paths_and_the_plc_cycle_name_the_option_they_lack() -> None:
    assert "input_delay" in ADRC(input_delay=0.2).fast_path_blockers()
    assert ADRC(input_delay=0.0).fast_path_blockers() == []
    with pytest.raises(ParameterError, match="input_delay"):
        ADRC(input_delay=0.2, precision="float32")
