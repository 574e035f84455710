"""Pneumatic three-tank model: linearisation vs (10b) of Nowak et al. 2018, integration error."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ctrlblocks.blocks.base import ErrorCode, ParameterError
from ctrlblocks.plants import PTn, ThreeTank, process
from ctrlblocks.plants.threetank import OUTLETS, P_ATM, R_BETWEEN

K_10B, T_10B = 0.73, (7.3, 2.2, 1.4)  # Nowak et al. 2018, (10b)


def _fd_linearisation(plant, u0, h=1e-6):
    """A, B of (T2) by central finite differences of the right-hand side.

    Independent of ``ThreeTank.linearise`` (which is analytic).
    """
    x0 = np.array(plant.steady_state(u0))
    a = np.zeros((3, 3))
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        a[:, j] = (plant.derivatives(x0 + e, u0) - plant.derivatives(x0 - e, u0)) / (2 * h)
    b = (plant.derivatives(x0, u0 + h) - plant.derivatives(x0, u0 - h)) / (2 * h)
    return a, b


def test_linearisation_at_the_operating_point_matches_10b_within_1_percent():
    plant = ThreeTank()
    u0 = plant.u_for_y(1.5)
    assert u0 == pytest.approx(2.1904, abs=1e-4)
    a, b = _fd_linearisation(plant, u0)
    gain = -np.linalg.solve(a, b)[2]
    taus = sorted(-1.0 / np.linalg.eigvals(a).real, reverse=True)
    assert gain == pytest.approx(K_10B, rel=0.01)
    for t, t_ref in zip(taus, T_10B, strict=True):
        assert t == pytest.approx(t_ref, rel=0.01)
    # the stored seven-digit resistances in fact give (10b) to about 1e-7
    assert gain == pytest.approx(K_10B, rel=1e-5)
    assert taus == pytest.approx(list(T_10B), rel=1e-5)


def test_analytic_linearisation_equals_finite_differences():
    plant = ThreeTank()
    for u0 in (0.5, 2.19, 4.5):
        a_fd, b_fd = _fd_linearisation(plant, u0)
        a, b, c = plant.linearise(u0)
        assert np.allclose(a, a_fd, rtol=1e-7, atol=1e-9)
        assert np.allclose(b[:, 0], b_fd, rtol=1e-7, atol=1e-9)
        assert c.tolist() == [[0.0, 0.0, 1.0]]


@pytest.mark.parametrize(
    ("y0", "u0", "gain", "taus"),
    [
        (0.5, 0.785, 0.6804, (12.534, 3.860, 2.370)),
        (1.0, 1.499, 0.7146, (9.206, 2.792, 1.758)),
        (1.5, 2.190, 0.7300, (7.300, 2.200, 1.400)),
        (2.0, 2.871, 0.7382, (6.056, 1.819, 1.164)),
        (3.0, 4.217, 0.7464, (4.523, 1.354, 0.871)),
    ],
)
def test_linearisation_depends_on_the_operating_point_as_documented(y0, u0, gain, taus):
    plant = ThreeTank()
    u = plant.u_for_y(y0)
    g, t = plant.linear_model(u)
    assert u == pytest.approx(u0, abs=1e-3)
    assert g == pytest.approx(gain, abs=1e-4)
    assert t == pytest.approx(taus, abs=1e-3)


def test_steady_state_has_equal_mass_flows_and_is_kept_by_the_integrator():
    plant = ThreeTank()
    u0 = 3.0
    p = [u0 + P_ATM] + [v + P_ATM for v in plant.steady_state(u0)] + [P_ATM]
    rs = [*R_BETWEEN, OUTLETS["a"]]
    flows = [(p[i] ** 2 - p[i + 1] ** 2) / rs[i] for i in range(4)]  # (T1) up to 1/(2 p_atm)
    assert np.ptp(flows) <= 1e-12 * max(flows)
    assert np.max(np.abs(plant.derivatives(plant.steady_state(u0), u0))) < 1e-12
    plant.reset(u0)
    y0 = plant.y
    for _ in range(200):
        plant.step(u0)
    assert plant.y == pytest.approx(y0, abs=1e-12)


def _reference_run(plant, us):
    """solve_ivp (DOP853, rtol 1e-12) sample by sample with the input held."""
    x = np.array([plant.p1, plant.p2, plant.p3])
    out = [x[2]]
    for u in us:
        sol = solve_ivp(
            lambda _t, z, u=u: plant.derivatives(z, u),
            (0.0, plant.ts),
            x,
            method="DOP853",
            rtol=1e-12,
            atol=1e-13,
        )
        x = sol.y[:, -1]
        out.append(x[2])
    return np.array(out)


def test_rk4_error_against_solve_ivp_is_below_the_documented_bound():
    # random supply steps over the whole valve range, held 2 s each, 40 s
    us = np.random.default_rng(0).uniform(0.0, 5.0, 20).repeat(20)
    errs = {}
    for n in (1, 2):
        plant = ThreeTank(substeps=n)
        plant.reset(0.0)
        ys = [plant.y] + [plant.step(float(u)) for u in us]
        plant.reset(0.0)
        errs[n] = float(np.max(np.abs(np.array(ys) - _reference_run(plant, us))))
    assert errs[2] < 1e-7  # documented bound for the default substeps = 2
    assert errs[1] < 1e-6
    assert errs[1] / errs[2] > 10.0  # fourth order: halving h divides the error by ~16


def test_small_step_follows_the_linear_model_10b():
    plant = ThreeTank()
    u0 = plant.u_for_y(1.5)
    plant.reset(u0)
    lin = PTn(K_10B, T_10B, 0.1)
    du = 0.01
    dev = []
    for _ in range(400):
        dy = plant.step(u0 + du) - 1.5
        dev.append(dy - lin.step(du))
    # nonlinearity is second order in du: within 1 % of the final change 0.0073 bar
    assert max(abs(d) for d in dev) < 0.01 * K_10B * du


def test_outlet_switch_changes_gain_and_dynamics_by_the_documented_amount():
    plant = ThreeTank()
    u0 = plant.u_for_y(1.5)
    plant.outlet = "b"
    assert plant.r_out == pytest.approx(0.5 * OUTLETS["a"])
    g, t = plant.linear_model(u0)
    assert g == pytest.approx(0.5909, abs=1e-4)
    assert t == pytest.approx((6.380, 2.169, 1.396), abs=1e-3)
    assert plant.steady_state(u0)[2] == pytest.approx(1.1622, abs=1e-4)


def test_outlet_switch_at_run_time_moves_to_the_new_steady_state():
    chain = process(ThreeTank(), u_min=0.0, u_max=5.0)
    plant = chain.find(ThreeTank)
    u0 = plant.u_for_y(1.5)
    chain.reset(u0)
    plant.outlet = "b"
    ys = [chain.step(u0) for _ in range(600)]
    assert ys[0] < 1.5 and ys[-1] == pytest.approx(plant.steady_state(u0)[2], abs=1e-3)
    assert all(b <= a + 1e-12 for a, b in itertools.pairwise(ys))  # falls monotonically


def test_supply_is_clamped_to_the_valve_range_and_nan_holds():
    plant = ThreeTank()
    plant.step(7.0)
    assert plant.u == 5.0
    plant.step(-1.0)
    assert plant.u == 0.0
    plant.step(2.0)
    plant.step(math.nan)
    assert plant.u == 2.0


def test_full_supply_settles_at_the_closed_form_steady_state():
    plant = ThreeTank()
    plant.reset(0.0)
    for _ in range(1500):  # 150 s, > 10 slowest time constants at high pressure
        plant.step(5.0)
    ra, rb, rc = R_BETWEEN
    ro = OUTLETS["a"]
    p3 = math.sqrt(P_ATM**2 + ((5 + P_ATM) ** 2 - P_ATM**2) * ro / (ra + rb + rc + ro)) - P_ATM
    assert plant.y == pytest.approx(p3, abs=1e-6)


def test_snapshot_restores_pressures_and_the_outlet():
    plant = ThreeTank()
    plant.reset(2.0)
    snap = plant.snapshot()
    plant.outlet = "b"
    a = [plant.step(3.0) for _ in range(20)]
    plant.restore(snap)
    assert plant.outlet == "a"
    plant.outlet = "b"
    assert [plant.step(3.0) for _ in range(20)] == a


@pytest.mark.parametrize(
    ("kwargs", "code"),
    [
        ({"ts": 0.0}, ErrorCode.NO_CYCLE),
        ({"outlet": "c"}, ErrorCode.BAD_PARAMETER),
        ({"substeps": 0}, ErrorCode.BAD_PARAMETER),
        ({"u_min": 3.0, "u_max": 1.0}, ErrorCode.BAD_LIMITS),
        ({"resistances": (1e8, -1.0, 1e8)}, ErrorCode.BAD_PARAMETER),
    ],
)
def test_bad_configuration_is_refused(kwargs, code):
    with pytest.raises(ParameterError) as exc:
        ThreeTank(**kwargs)
    assert exc.value.code == code


def test_set_parameter_switches_the_outlet_and_refuses_unknown_names():
    plant = ThreeTank()
    plant.set_parameter("outlet", "b")
    assert plant.outlet == "b" and plant.r_out == OUTLETS["b"]
    with pytest.raises(ParameterError) as exc:
        plant.set_parameter("outlet", "c")
    assert exc.value.code == ErrorCode.BAD_PARAMETER and plant.outlet == "b"
    with pytest.raises(ParameterError):
        plant.set_parameter("volume", 1.0)
