"""PID tuning rules against hand-evaluated formulas (model k = 2, T = 10 s, L = 2 s)."""

from __future__ import annotations

import pytest

from ctrlblocks.blocks.base import ErrorCode, ParameterError
from ctrlblocks.tuning import (
    FOPDT,
    SOPDT,
    amigo,
    lambda_tuning,
    pid_from_model,
    simc,
    tyreus_luyben,
    ziegler_nichols_closed,
    ziegler_nichols_open,
)

K, T, L = 2.0, 10.0, 2.0

# (function call, expected (kp, ti, td)) evaluated by hand from the formulas
# in ctrlblocks.tuning.pid_rules (sources cited there).
CASES = {
    # SIMC, tau_c = L = 2: kc = 10/(2*4) = 1.25, tau_I = min(10, 16) = 10
    "simc": (lambda: simc(K, T, L), (1.25, 10.0, 0.0)),
    # SIMC tau_c = 6: kc = 10/(2*8) = 0.625, tau_I = min(10, 32) = 10
    "simc tau_c": (lambda: simc(K, T, L, tau_c=6.0), (0.625, 10.0, 0.0)),
    # SIMC lag-dominant T = 40: kc = 40/8 = 5, tau_I = min(40, 16) = 16
    "simc lag": (lambda: simc(K, 40.0, L), (5.0, 16.0, 0.0)),
    # SIMC SOPDT T2 = 3, series (1.25, 10, 3) -> ISA (1.25*13/10, 13, 30/13)
    "simc sopdt": (lambda: simc(K, T, L, time_constant_2=3.0), (1.625, 13.0, 30.0 / 13.0)),
    # SIMC integrating k' = 0.1: kc = 1/(0.1*4) = 2.5, tau_I = 16
    "simc int": (lambda: simc(0.1, 0.0, L, integrating=True), (2.5, 16.0, 0.0)),
    # AMIGO PI: 0.15/2 + (0.35 - 20/144) * 10/4 ; 0.35*2 + 13*2*100/(100 + 240 + 28)
    "amigo pi": (
        lambda: amigo(K, T, L, controller="pi"),
        (0.075 + (0.35 - 20.0 / 144.0) * 2.5, 0.7 + 2600.0 / 368.0, 0.0),
    ),
    # AMIGO PID: (0.2 + 0.45*5)/2 ; (0.8 + 8)/(2 + 1) * 2 ; 0.5*2*10/(0.6 + 10)
    "amigo pid": (lambda: amigo(K, T, L), (1.225, 8.8 / 3.0 * 2.0, 10.0 / 10.6)),
    "amigo int pi": (
        lambda: amigo(0.1, 0.0, L, controller="pi", integrating=True),
        (1.75, 26.8, 0.0),
    ),
    "amigo int pid": (lambda: amigo(0.1, 0.0, L, integrating=True), (2.25, 16.0, 1.0)),
    # ZN step response, a = K L/T = 0.4
    "zn open p": (lambda: ziegler_nichols_open(K, T, L, controller="p"), (2.5, 0.0, 0.0)),
    "zn open pi": (lambda: ziegler_nichols_open(K, T, L, controller="pi"), (2.25, 6.0, 0.0)),
    "zn open pid": (lambda: ziegler_nichols_open(K, T, L), (3.0, 4.0, 1.0)),
    # ZN ultimate gain ku = 5, pu = 8 s
    "zn closed p": (lambda: ziegler_nichols_closed(5.0, 8.0, controller="p"), (2.5, 0.0, 0.0)),
    "zn closed pi": (
        lambda: ziegler_nichols_closed(5.0, 8.0, controller="pi"),
        (2.25, 8.0 / 1.2, 0.0),
    ),
    "zn closed pid": (lambda: ziegler_nichols_closed(5.0, 8.0), (3.0, 4.0, 1.0)),
    # Tyreus-Luyben ku = 5, pu = 8 s
    "tl pi": (lambda: tyreus_luyben(5.0, 8.0, controller="pi"), (5.0 / 3.2, 17.6, 0.0)),
    "tl pid": (lambda: tyreus_luyben(5.0, 8.0), (5.0 / 2.2, 17.6, 8.0 / 6.3)),
    # lambda PI, default lambda = max(T, L) = 10: 10/(2*12) ; lambda = 4: 10/(2*6)
    "lambda pi": (lambda: lambda_tuning(K, T, L), (10.0 / 24.0, 10.0, 0.0)),
    "lambda pi 4": (lambda: lambda_tuning(K, T, L, lam=4.0), (10.0 / 12.0, 10.0, 0.0)),
    # IMC PID, lambda = 10: (20 + 2)/(2*(20 + 2)) ; 10 + 1 ; 10*2/(20 + 2)
    "lambda pid": (lambda: lambda_tuning(K, T, L, controller="pid"), (0.5, 11.0, 20.0 / 22.0)),
}


@pytest.mark.parametrize("name", list(CASES))
def test_rule_equals_hand_evaluated_formula(name):
    call, expected = CASES[name]
    r = call()
    assert (r.kp, r.ti, r.td) == pytest.approx(expected, rel=1e-12)
    assert r.form == "isa"  # the value PID(form=...) takes


def test_zn_open_and_closed_agree_for_the_pure_integrator_with_delay_limit():
    # ZN's step rule PID has ti = 4 td, like the ultimate-gain rule (pu/2 vs pu/8)
    r = ziegler_nichols_open(K, T, L)
    assert r.ti == pytest.approx(4 * r.td)


def test_negative_process_gain_gives_reverse_action_for_the_pid_block():
    r = simc(-K, T, L)
    assert r.kp == pytest.approx(-1.25)
    assert r.as_kwargs() == {"kp": 1.25, "ti": 10.0, "td": 0.0, "reverse": True}
    assert simc(K, T, L).as_kwargs()["reverse"] is False


def test_as_kwargs_is_accepted_by_the_pid_block():
    from ctrlblocks import PID

    pid = PID(**amigo(K, T, L).as_kwargs(), ts=0.1)
    assert (pid.config.kp, pid.config.ti, pid.config.td) == pytest.approx(
        (1.225, 8.8 / 1.5, 10 / 10.6)
    )


def test_pid_from_model_uses_half_rule_for_sopdt_except_in_simc():
    s = SOPDT(K, T, L, 3.0)
    assert pid_from_model(s, "simc").ti == pytest.approx(13.0)
    a = pid_from_model(s, "amigo")
    b = amigo(K, T + 1.5, L + 1.5)
    assert (a.kp, a.ti, a.td) == (b.kp, b.ti, b.td)
    f = pid_from_model(FOPDT(K, T, L), "zn")
    assert (f.kp, f.ti, f.td) == pytest.approx((3.0, 4.0, 1.0))


@pytest.mark.parametrize(
    "call",
    [
        lambda: simc(0.0, T, L),
        lambda: amigo(K, T, 0.0),
        lambda: ziegler_nichols_open(K, -1.0, L),
        lambda: ziegler_nichols_closed(5.0, 0.0),
        lambda: lambda_tuning(K, T, L, controller="pd"),
    ],
)
def test_bad_model_or_option_is_refused(call):
    with pytest.raises(ParameterError) as info:
        call()
    assert info.value.code in (ErrorCode.BAD_PARAMETER, ErrorCode.BAD_TIME_CONSTANT)


def test_amigo_pid_sets_the_setpoint_weight_by_normalised_dead_time():
    assert amigo(K, T, L).b == 0.0  # L/(L+T) = 0.17 <= 0.5
    assert amigo(K, 1.0, 3.0).b == 1.0  # 0.75 > 0.5
    assert amigo(K, T, L).as_kwargs()["b"] == 0.0
    assert amigo(K, T, L, controller="pi").b is None
    assert "b" not in simc(K, T, L).as_kwargs()
