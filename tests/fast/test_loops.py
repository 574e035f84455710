"""Compiled and interpreted closed loops equal the block objects sample by sample (1e-12).

The reference is :func:`ctrlblocks.fast.reference_loop`, which calls the
``PID``/``ADRC`` block objects and the plant objects themselves.  The
scenarios drive the loops through output limits (loads that saturate the
controller), manual mode and the bumpless return to auto, both anti-windup
methods of the PID and all three x4 rules of the ADRC.
"""

from __future__ import annotations

import numpy as np
import pytest

from ctrlblocks import ADRC, PID
from ctrlblocks.fast import HAVE_NUMBA, UnsupportedConfig, closed_loop, reference_loop
from ctrlblocks.fast.kernels import pid_params
from ctrlblocks.plants import PT1, PTn, ThreeTank

N = 700
TOL = 1e-12

ENGINES = ["python", *(["auto"] if HAVE_NUMBA else [])]


def _signals(y0: float = 0.0, hi_load: float = 3.0) -> dict[str, np.ndarray]:
    sp = np.full(N, y0 + 1.0)
    sp[350:] = y0 + 0.5
    manual = np.zeros(N, dtype=bool)
    manual[120:200] = True
    u_man = np.full(N, 0.8)
    u_man[160:] = 1.9
    load = np.zeros(N)
    load[450:560] = hi_load  # drives the output into its low limit (anti-windup)
    load[560:620] = -hi_load  # and into its high limit
    noise = np.random.default_rng(7).normal(0.0, 0.002, N)
    return {"sp": sp, "manual": manual, "u_man": u_man, "load": load, "noise": noise}


def _compare(make_ctrl, make_plant, engine, sig=None, prepare=None):
    sig = _signals() if sig is None else sig
    ref_c, ref_p = make_ctrl(), make_plant()
    fast_c, fast_p = make_ctrl(), make_plant()
    if prepare is not None:
        prepare(ref_c, ref_p)
        prepare(fast_c, fast_p)
    res = closed_loop(fast_c, fast_p, engine=engine, **sig)
    ref = reference_loop(ref_c, ref_p, **sig)
    assert res.path == ("compiled" if engine == "auto" else "python")
    np.testing.assert_allclose(res.u, ref.u, rtol=0, atol=TOL)
    np.testing.assert_allclose(res.y, ref.y, rtol=0, atol=TOL)
    return res, ref


PIDS = {
    "clamping": dict(kp=4.0, ti=6.0, td=1.0, ts=0.1, u_min=0.0, u_max=2.5),
    "back_calc": dict(kp=4.0, ti=6.0, td=1.0, ts=0.1, u_min=0.0, u_max=2.5,
                      anti_windup="back_calc_model", tt=2.0),
    "weights_tustin": dict(kp=2.5, ti=4.0, td=0.8, n=8.0, b=0.6, c=0.3, ts=0.1, u_min=-1.0,
                           u_max=2.5, derivative_method="tustin", integral_method="backward"),
    "forward_pi": dict(kp=3.0, ti=5.0, ts=0.1, u_min=0.0, u_max=2.5, integral_method="forward"),
    "p_only": dict(kp=2.0, ts=0.1, u_min=0.0, u_max=2.5, reset_value=0.3),
    "parallel": dict(form="parallel", kp=3.0, ti=2.0, td=1.5, ts=0.1, u_min=0.0, u_max=2.5),
}  # fmt: skip


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("name", list(PIDS))
def test_pid_loop_equals_blocks_through_limits_manual_and_antiwindup(engine, name):
    res, _ = _compare(
        lambda: PID(**PIDS[name]), lambda: PTn(k=0.73, t=(7.3, 2.2, 1.4), ts=0.1), engine
    )
    assert np.any(res.u == 2.5 if name != "p_only" else res.u == 0.0)  # the limits were hit
    assert np.all(res.u[125:160] == 0.8) and np.all(res.u[165:200] == 1.9)  # manual values


@pytest.mark.parametrize("engine", ENGINES)
def test_reverse_pid_with_fractional_dead_time_equals_blocks(engine):
    sig = _signals()
    sig["sp"] = -sig["sp"]
    _compare(
        lambda: PID(kp=1.5, ti=3.0, td=0.4, ts=0.1, u_min=0.0, u_max=3.0, reverse=True),
        lambda: PT1(k=-1.2, t=2.0, ts=0.1, dead_time=0.35),
        engine,
        sig,
    )


ADRCS = {
    "n1": dict(order=1, b0=0.3, omega_o=0.9, omega_c=0.3),
    "n2": dict(order=2, b0=0.05, omega_o=1.75, omega_c=0.35),
    "n3": dict(order=3, b0=0.025, omega_o=1.75, omega_c=0.35),
    "n2_freeze": dict(order=2, b0=0.05, omega_o=1.75, omega_c=0.35, anti_windup="freeze"),
    "n2_off": dict(order=2, b0=0.05, omega_o=1.75, omega_c=0.35, anti_windup="off"),
    "n2_tref": dict(order=2, b0=0.05, omega_o=1.75, omega_c=0.35, t_ref=2.0),
}


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("name", list(ADRCS))
def test_adrc_loop_equals_blocks_on_the_three_tank_process(engine, name):
    def plant():
        p = ThreeTank(ts=0.1)
        p.reset(p.u_for_y(1.5))
        return p

    def ctrl():
        return ADRC(**ADRCS[name], ts=0.1, u_min=0.0, u_max=5.0, u0=2.19)

    res, _ = _compare(ctrl, plant, engine, _signals(y0=1.5, hi_load=4.0))
    assert np.any(res.u == 5.0) or np.any(res.u == 0.0)  # a limit was hit


@pytest.mark.parametrize("engine", ENGINES)
def test_adrc_loop_equals_blocks_on_a_linear_plant(engine):
    _compare(
        lambda: ADRC(order=2, b0=0.05, omega_o=1.75, omega_c=0.35, ts=0.1, u_min=0.0, u_max=3.0),
        lambda: PTn(k=0.73, t=(7.3, 2.2, 1.4), ts=0.1),
        engine,
    )


@pytest.mark.parametrize("engine", ENGINES)
def test_loop_continues_from_the_current_block_state(engine):
    def prepare(c, p):
        for _ in range(30):
            u = c(1.0, p.y)
            p.step(u)

    _compare(
        lambda: PID(kp=2.0, ti=8.0, td=1.0, ts=0.1, u_min=0.0, u_max=2.5),
        lambda: PTn(k=0.73, t=(7.3, 2.2, 1.4), ts=0.1),
        engine,
        prepare=prepare,
    )


def test_closed_loop_does_not_advance_the_blocks():
    pid, plant = PID(kp=2.0, ti=8.0, ts=0.1), PTn(k=1.0, t=(2.0,), ts=0.1)
    closed_loop(pid, plant, sp=1.0, n=50)
    assert pid.out == 0.0 and plant.y == 0.0


def test_pid_loop_reaches_the_setpoint_of_a_hand_checked_case():
    # P-only on k/(t s + 1): steady state y = K k r / (1 + K k) = 2*1/(1+2) = 2/3
    pid = PID(kp=2.0, ts=0.1, u_min=-10.0, u_max=10.0)
    res = closed_loop(pid, PTn(k=1.0, t=(1.0,), ts=0.1), sp=1.0, n=400)
    assert res.y[-1] == pytest.approx(2.0 / 3.0, abs=1e-9)


def test_unsupported_configuration_runs_the_blocks():
    pid = PID(kp=2.0, ti=8.0, ts=0.1, sp_filter=1.0)
    with pytest.raises(UnsupportedConfig, match="sp_filter"):
        pid_params(pid)
    res = closed_loop(pid, PTn(k=1.0, t=(2.0,), ts=0.1), sp=1.0, n=20)
    assert res.path == "blocks"


def test_track_or_awin_input_runs_the_blocks():
    pid = PID(kp=2.0, ti=8.0, ts=0.1)
    pid.awin = True
    assert closed_loop(pid, PTn(k=1.0, t=(2.0,), ts=0.1), sp=1.0, n=5).path == "blocks"
    adrc = ADRC(order=1, b0=1.0, omega_c=1.0, omega_o=3.0, ts=0.1)
    adrc.awin = True
    assert closed_loop(adrc, PTn(k=1.0, t=(2.0,), ts=0.1), sp=1.0, n=5).path == "blocks"


def test_bad_engine_is_refused():
    with pytest.raises(ValueError, match="engine"):
        closed_loop(PID(kp=1.0, ts=0.1), PTn(k=1.0, t=(1.0,), ts=0.1), 1.0, n=3, engine="gpu")


@pytest.mark.parametrize("engine", ENGINES)
def test_outlet_valve_switch_of_the_three_tank_equals_blocks(engine):
    outlet = ["a"] * 200 + ["b"] * 300 + ["a"] * 200
    sig = {"sp": np.full(N, 1.5), "outlet": outlet}

    def plant():
        p = ThreeTank(ts=0.1)
        p.reset(p.u_for_y(1.5))
        return p

    res, _ = _compare(
        lambda: PID(
            kp=6.31, ti=5.4, td=1.36, n=5.0, ts=0.1, u_min=0.0, u_max=5.0, reset_value=2.19
        ),
        plant,
        engine,
        sig,
    )
    # valve "b" halves R_out: p3 drops below the setpoint until the PID recovers
    assert res.y[205] < 1.5 - 0.01
