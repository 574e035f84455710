"""ADRC b0 searched with the bandwidths (largest ki under Ms), and ``Loop.integral_gain``."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ctrlblocks.blocks.adrc import ADRC
from ctrlblocks.blocks.base import ParameterError
from ctrlblocks.blocks.pid import PID
from ctrlblocks.tuning import SOPDT, adrc_tuning
from ctrlblocks.tuning.adrc import _Search
from ctrlblocks.tuning.identify import FOPDT
from ctrlblocks.tuning.margins import Loop

# the SOPDT fit of the shipped bump test docs/examples/bump_k2.csv
SO = SOPDT(gain=0.7299415127443426, time_constant=7.134311968273849,
           time_constant_2=2.859576245091417, dead_time=0.9168136029596695)  # fmt: skip
HALF = (SO.gain, SO.time_constant + SO.time_constant_2 / 2, SO.dead_time + SO.time_constant_2 / 2)


def test_integral_gain_of_a_pid_is_kp_over_ti_and_zero_without_integral_action():
    model = FOPDT(1.0, 10.0, 2.0)
    pi = Loop(model, PID(kp=2.0, ti=8.0, td=0.5, n=10.0, ts=0.1))
    assert pi.integral_gain() == pytest.approx(2.0 / 8.0, rel=1e-6)
    p = Loop(model, PID(kp=2.0, ti=0.0, ts=0.1))
    assert abs(p.integral_gain()) < 1e-6


@pytest.mark.parametrize("block", [PID(kp=1.5, ti=6.0, ts=0.1),
                                   ADRC(order=2, b0=0.1, omega_c=0.5, omega_o=2.0, ts=0.1)])
def test_integrated_error_of_a_unit_load_step_is_one_over_ki(block):
    """Final-value theorem: the PV's integrated deviation is 1/ki (IE = -1/ki)."""
    lp = Loop(SO, block)
    assert lp.stable()
    _t, y, _u = lp.simulate(lp.response_time() * 2, r=0.0, load=1.0)
    ie = -float(np.sum(y)) * lp.ts  # e = r - y = -y
    assert ie == pytest.approx(-1.0 / lp.integral_gain(), rel=1e-4)


def test_searched_b0_on_the_three_tank_sopdt_has_the_numbers_of_the_docstring():
    rule = adrc_tuning(*HALF, 2, ts=0.1, model=SO)
    found = adrc_tuning(*HALF, 2, ts=0.1, model=SO, b0_search=True)
    assert found.b0_rule == pytest.approx(rule.b0, rel=1e-12) == pytest.approx(0.02502, abs=5e-5)
    assert found.b0 == pytest.approx(0.125, rel=0.03)
    assert found.b0 / rule.b0 == pytest.approx(5, rel=0.03)
    assert found.omega_c == pytest.approx(0.62, rel=0.03)
    assert 1.0 / found.integral_gain == pytest.approx(0.83, rel=0.03)
    assert 1.0 / rule.integral_gain == pytest.approx(18.5, rel=0.03)
    assert found.margins.stable and found.margins.ms <= 1.6 * (1 + 1e-6)
    assert found.omega_o == pytest.approx(min(5 * found.omega_c, 0.2 / 0.1))
    assert any("largest integral gain" in w for w in found.warnings)


@pytest.mark.parametrize("order", [1, 2, 3])
def test_no_nearby_b0_gives_a_larger_integral_gain_under_the_same_ms(order):
    found = adrc_tuning(*HALF, order, ts=0.1, model=SO, b0_search=True)
    assert 0.2 <= found.b0 / found.b0_rule <= 25.0
    for f in (1 / 1.3, 1.3):
        s = _Search(SO, order, found.b0 * f, 5.0, HALF[1] + HALF[2], "euler")
        wc = s.fastest(1.6, 0.1)
        ki = s.loop(wc, s.omega_o(wc, 0.1), 0.1).integral_gain()
        assert ki <= found.integral_gain * 1.03, (f, ki, found.integral_gain)  # resolution


def test_b0_search_is_for_the_safe_default_only():
    with pytest.raises(ParameterError, match="no settling_time"):
        adrc_tuning(*HALF, 2, ts=0.1, model=SO, settling_time=20.0, b0_search=True)


def test_the_rule_b0_tuning_reports_its_integral_gain_too():
    r = adrc_tuning(0.73, 8.3, 3.0, 2, ts=0.1)
    block = ADRC(order=2, b0=r.b0, omega_c=r.omega_c, omega_o=r.omega_o, ts=0.1)
    assert r.integral_gain == pytest.approx(Loop(FOPDT(0.73, 8.3, 3.0), block).integral_gain())
    assert r.b0_rule == r.b0 and math.isfinite(r.integral_gain)


@pytest.mark.parametrize(("order", "b0_ratio", "ki_ratio", "settle"),
                         [(1, 4.1, 3.2, 74.0), (2, 7.6, 20.0, 96.0), (3, 7.6, 15.0, 203.0)])
def test_docs_worked_dead_time_example_with_b0_searched(order, b0_ratio, ki_ratio, settle):
    """docs/tuning.md, the table of rules: k = 2, T = 30 s, L = 5 s, ts = 0.5 s."""
    rule = adrc_tuning(2.0, 30.0, 5.0, order, ts=0.5)
    found = adrc_tuning(2.0, 30.0, 5.0, order, ts=0.5, b0_search=True)
    assert found.b0 / rule.b0 == pytest.approx(b0_ratio, abs=0.05)
    assert found.integral_gain / rule.integral_gain == pytest.approx(ki_ratio, rel=0.03)
    assert found.settling_time_loop == pytest.approx(settle, abs=1.0)
    assert 1.59 <= found.margins.ms <= 1.6
