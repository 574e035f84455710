"""Half rule (Skogestad 2003) and the inverse half-rule of Nowak et al. 2018 (Table 1)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ctrlblocks.blocks.base import ErrorCode, ParameterError
from ctrlblocks.tuning import FOPDT, SOPDT, half_rule, inverse_half_rule


def test_table1_k1_second_order_b0_is_0_011():
    r = inverse_half_rule(0.56, 11.0, 3.3, 2)
    assert round(r.b0, 3) == 0.011
    assert r.time_constants == pytest.approx((7.7, 6.6))  # T1 = T - T0, T2 = 2 T0
    assert r.b0_min == r.b0_max == r.b0
    assert r.warnings == []


def test_table1_k2_third_order_range_is_0_0236_to_0_1022():
    r = inverse_half_rule(0.73, 8.3, 3.0, 3)
    assert (round(r.b0_min, 4), round(r.b0_max, 4)) == (0.0236, 0.1022)
    assert r.b0 == r.b0_min  # Nowak et al. 2018 advises the lower limit


def test_printed_0_33_and_exact_one_third_give_the_same_b0_max_for_k2():
    k, T, T0 = 0.73, 8.3, 3.0
    t2p = min(T / 1.5, 2 * T0)
    first = k / ((T - 0.5 * t2p) * t2p * (T0 - 0.5 * t2p))
    for c in (0.33, 1.0 / 3.0):
        second = k / ((T - c * T0) * (T0 / 1.5) ** 2)
        assert round(max(first, second), 4) == 0.1022
        assert second < 0.026  # the other corner never wins here
    # only 1/3 satisfies the half-rule equality (7): T1 + T2/2 = T
    assert pytest.approx(T) == (T - T0 / 3) + (T0 / 1.5) / 2
    assert pytest.approx(T, abs=1e-3) != (T - 0.33 * T0) + (T0 / 1.5) / 2


@pytest.mark.parametrize(("T", "T0"), [(8.3, 3.0), (11.0, 3.3), (5.0, 4.0), (20.0, 7.5)])
def test_third_order_range_equals_brute_force_over_the_feasible_set(T, T0):
    # (5)-(7): with T2 free, T1 = T - T2/2, T3 = T0 - T2/2, feasible when
    # T1 >= T2 >= T3 > 0.  Scan T2 densely and take the extreme products.
    k = 1.0
    t2 = np.linspace(2 * T0 / 3, min(2 * T / 3, 2 * T0), 2_000_001)[:-1]
    prod = (T - t2 / 2) * t2 * (T0 - t2 / 2)
    r = inverse_half_rule(k, T, T0, 3)
    assert r.b0_min == pytest.approx(k / prod.max(), rel=1e-9)
    if T < 3 * T0:
        assert r.b0_max == pytest.approx(k / prod.min(), rel=1e-5)
    else:
        assert math.isinf(r.b0_max) and r.warnings


def test_first_order_b0_is_k_over_t():
    assert inverse_half_rule(0.73, 8.3, 3.0, 1).b0 == pytest.approx(0.73 / 8.3)


@pytest.mark.parametrize(("k", "T", "T0"), [(0.56, 11.0, 3.3), (0.73, 8.3, 3.0), (-2.0, 30.0, 4.0)])
def test_inverse_half_rule_maps_back_to_the_same_fopdt_through_the_half_rule(k, T, T0):
    r2 = inverse_half_rule(k, T, T0, 2)
    m2 = half_rule(k, r2.time_constants)
    if T >= 3 * T0:
        assert (m2.gain, m2.time_constant, m2.dead_time) == pytest.approx((k, T, T0))
    else:  # T1 = T - T0 < T2 = 2 T0: the half rule pairs them the other way (warned)
        assert r2.warnings
        assert (m2.time_constant, m2.dead_time) == pytest.approx(
            (2 * T0 + (T - T0) / 2, (T - T0) / 2)
        )
    r3 = inverse_half_rule(k, T, T0, 3)
    m3 = half_rule(k, r3.time_constants)
    assert (m3.time_constant, m3.dead_time) == pytest.approx((T, T0))
    assert math.prod(r3.time_constants) == pytest.approx(k / r3.b0_min)


def test_half_rule_fopdt_and_sopdt_hand_evaluated():
    # 0.73/((7.3s+1)(2.2s+1)(1.4s+1)) e^{-0.5 s}: FOPDT tau = 7.3 + 1.1, theta = 0.5 + 1.1 + 1.4
    m = half_rule(0.73, (2.2, 7.3, 1.4), 0.5)
    assert isinstance(m, FOPDT)
    assert (m.time_constant, m.dead_time) == pytest.approx((8.4, 3.0))
    s = half_rule(0.73, (7.3, 2.2, 1.4), 0.5, order=2)
    assert isinstance(s, SOPDT)
    assert (s.time_constant, s.time_constant_2, s.dead_time) == pytest.approx((7.3, 2.9, 1.2))
    # an inverse-response zero (-0.4 s + 1) and a 0.2 s sample time add 0.4 + 0.1
    m = half_rule(1.0, (9.5, 4.2), inverse_response=(0.4,), ts=0.2)
    assert (m.time_constant, m.dead_time) == pytest.approx((11.6, 2.1 + 0.5))


def test_second_order_warns_when_t_below_three_t0():
    r = inverse_half_rule(0.73, 8.3, 3.0, 2)
    assert r.b0 == pytest.approx(0.73 / (5.3 * 6.0))
    assert any("T < 3 T0" in w for w in r.warnings)


@pytest.mark.parametrize(
    ("args", "code"),
    [
        ((0.5, 10.0, 2.0, 4), ErrorCode.BAD_ORDER),
        ((0.5, -1.0, 2.0, 2), ErrorCode.BAD_TIME_CONSTANT),
        ((0.5, 10.0, 0.0, 2), ErrorCode.BAD_TIME_CONSTANT),
        ((0.5, 2.0, 3.0, 2), ErrorCode.BAD_TIME_CONSTANT),
        ((0.5, 2.0, 3.0, 3), ErrorCode.BAD_TIME_CONSTANT),
        ((0.0, 10.0, 2.0, 2), ErrorCode.BAD_PARAMETER),
        ((math.nan, 10.0, 2.0, 2), ErrorCode.BAD_PARAMETER),
    ],
)
def test_impossible_inputs_are_refused_with_a_code(args, code):
    with pytest.raises(ParameterError) as info:
        inverse_half_rule(*args)
    assert info.value.code == code


def test_table2_estimates_come_from_one_fopdt_of_the_real_setup():
    # Nowak et al. 2018, Table 2 prints the b0 estimates for the pneumatic setup but not
    # its FOPDT.  The four numbers (n = 1: 0.099, n = 2: 0.025, n = 3:
    # [0.025, 0.13]) are all reproduced by one FOPDT, found by least squares:
    # k = 0.859, T = 8.665 s, T0 = 3.086 s.
    k, T, T0 = 0.859, 8.665, 3.086
    assert round(inverse_half_rule(k, T, T0, 1).b0, 3) == 0.099
    assert round(inverse_half_rule(k, T, T0, 2).b0, 3) == 0.025
    r3 = inverse_half_rule(k, T, T0, 3)
    assert (round(r3.b0_min, 3), round(r3.b0_max, 2)) == (0.025, 0.13)
