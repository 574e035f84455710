"""Margins of the exact discrete loop, checked against python-control and the real blocks.

The process models are sampled independently here (python-control's c2d and
the modified z-transform of a FOPDT written out by hand), the controllers are
the state spaces read off the blocks; python-control interconnects them.
"""

from __future__ import annotations

import itertools
import math

import control
import numpy as np
import pytest

from ctrlblocks import ADRC, PID
from ctrlblocks.plants.linear import FOPDT as PlantFOPDT
from ctrlblocks.plants.linear import PT2, LinearPlant
from ctrlblocks.tuning import FOPDT, SOPDT, Integrating
from ctrlblocks.tuning.margins import Loop, controller_ss, margins

TS = 0.2

# (id, model, L/T): FOPDT and SOPDT with L/T from 0.05 to 1, one integrating; the dead
# time of "fopdt-0.3" is not a multiple of ts (fractional: the modified z-transform)
PROCESSES = [
    ("fopdt-0.05", FOPDT(1.5, 20.0, 1.0)),
    ("fopdt-0.3", FOPDT(2.0, 10.0, 3.07)),
    ("fopdt-0.5", FOPDT(0.8, 12.0, 6.0)),
    ("fopdt-1", FOPDT(1.0, 8.0, 8.0)),
    ("sopdt", SOPDT(0.56, 9.5, 2.2, 4.2)),
    ("integrating", Integrating(0.05, 2.0)),
]


def _z_delay(n: int) -> control.TransferFunction:
    return control.tf([1.0], [1.0] + [0.0] * n, TS) if n else control.tf([1.0], [1.0], TS)


def _independent_plant(model) -> control.TransferFunction:
    """The sampled process, built without ctrlblocks.plants."""
    d, eps = divmod(model.dead_time, TS)
    d = round(d)
    if abs(eps - TS) < 1e-9:
        d, eps = d + 1, 0.0
    if isinstance(model, FOPDT):
        # modified z-transform of k e^{-Ls}/(Ts + 1) behind a ZOH (Astrom & Wittenmark 1997, 2.3)
        a = 1.0 / model.time_constant
        p = math.exp(-a * TS)
        q = math.exp(-a * (TS - eps))
        num = model.gain * np.array([1.0 - q, q - p])
        return control.tf(num, [1.0, -p, 0.0], TS) * _z_delay(d)
    if isinstance(model, SOPDT):
        cont = control.tf(
            [model.gain], np.polymul([model.time_constant, 1.0], [model.time_constant_2, 1.0])
        )
    else:
        cont = control.tf([model.gain], [1.0, 0.0])
    assert eps < 1e-9 or isinstance(model, FOPDT)
    return control.c2d(cont, TS, "zoh") * _z_delay(d)


def _controllers(model):
    k = model.gain
    if isinstance(model, Integrating):
        pid = PID(kp=0.35 / (k * 2.0), ti=26.8, td=0.0, ts=TS, u_min=-1e9, u_max=1e9)
        b0 = k
        wc = 0.1
    else:
        T = model.time_constant + getattr(model, "time_constant_2", 0.0) / 2
        L = model.dead_time
        pid = PID(kp=(0.2 + 0.45 * T / L) / k, ti=(0.4 * L + 0.8 * T) / (L + 0.1 * T) * L,
                  td=0.5 * L * T / (0.3 * L + T), n=8.0, b=0.5, c=0.2, ts=TS,
                  integral_method="tustin", derivative_method="backward",
                  u_min=-1e9, u_max=1e9)  # fmt: skip
        b0 = k / T
        wc = 0.6 / (T + L)
    out = [("pid", pid)]
    for n in (1, 2, 3):
        for disc in ("euler", "exact"):
            out.append(
                (f"adrc{n}-{disc}", ADRC(order=n, b0=b0 / (2.0 ** (n - 1)), omega_c=wc,
                                         omega_o=4.0 * wc, ts=TS, discretisation=disc))
            )  # fmt: skip
    return out


CASES = [
    pytest.param(m, c, id=f"{pid}-{cid}") for pid, m in PROCESSES for cid, c in _controllers(m)
]


def _control_loop(model, block):
    """python-control's ``L = C_y P`` (state space: the transfer functions are of high degree)."""
    ss = controller_ss(block)
    ctrl = control.ss(ss.a, ss.b, ss.c, ss.d, TS)
    c_y = -ctrl[0, 1]
    return c_y * control.ss(_independent_plant(model)), ctrl


@pytest.mark.parametrize(("model", "block"), CASES)
def test_loop_and_sensitivities_equal_python_control_to_1e_9(model, block):
    lp = Loop(model, block)
    w = np.pi / TS * np.logspace(-4, 0, 60)[:-1]
    L_ref, _ = _control_loop(model, block)
    ref = L_ref(np.exp(1j * w * TS))
    ours = lp.loop_gain(w)
    np.testing.assert_allclose(ours, ref, rtol=1e-9, atol=1e-12)
    S, T = lp.sensitivity(w)
    s_ref = control.feedback(1, L_ref)(np.exp(1j * w * TS))
    np.testing.assert_allclose(S, s_ref, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(S + T, 1.0, atol=1e-12)


MARGIN_CASES = [
    pytest.param(m, c, id=f"{pid}-{cid}")
    for pid, m in PROCESSES
    for cid, c in _controllers(m)
    if cid in ("pid", "adrc1-euler", "adrc2-exact", "adrc3-euler")
]


@pytest.mark.parametrize(("model", "block"), MARGIN_CASES)
def test_ms_stability_and_margins_agree_with_python_control(model, block):
    mg = margins(model, block)
    L_ref, _ = _control_loop(model, block)
    cl = control.feedback(L_ref, 1)
    stable_ref = bool(np.max(np.abs(cl.poles())) < 1.0)
    assert mg.stable == stable_ref
    if not mg.stable:
        assert math.isinf(mg.ms)
        return
    w = np.pi / TS * np.logspace(-6, 0, 1500)
    w_peak = mg.w_ms * np.linspace(0.99, 1.01, 201)
    peak = np.abs(1.0 / (1.0 + L_ref(np.exp(1j * np.concatenate([w, w_peak]) * TS))))
    # ours is refined between grid points: never below python-control's peak, barely above
    assert float(np.max(peak)) - 1e-9 <= mg.ms <= float(np.max(peak)) * (1 + 1e-6)
    # gain and phase margins: at our refined frequencies python-control's response is on
    # the negative real axis / the unit circle, and a dense grid finds no worse crossing
    lw = L_ref(np.exp(1j * w * TS))
    re, im, mag = lw.real, lw.imag, np.abs(lw)
    cross = np.nonzero((np.sign(im[:-1]) != np.sign(im[1:])) & (re[:-1] < 0))[0]
    if math.isfinite(mg.gm):
        at = L_ref(np.exp(1j * mg.w_gm * TS))
        assert abs(at.imag) <= 1e-9 * abs(at) and mg.gm == pytest.approx(-1 / at.real, rel=1e-9)
        assert np.min(-1.0 / re[cross]) >= mg.gm * (1 - 0.02)
    else:
        assert len(cross) == 0
    gain = np.nonzero(np.sign(mag[:-1] - 1) != np.sign(mag[1:] - 1))[0]
    if math.isfinite(mg.pm):
        at = L_ref(np.exp(1j * mg.wc_crossover * TS))
        assert abs(at) == pytest.approx(1.0, abs=1e-9)
        assert mg.pm == pytest.approx(math.degrees(np.angle(-at)), abs=1e-7)
        assert np.min(np.degrees(np.angle(-lw[gain]))) >= mg.pm - 1.0
    else:
        assert len(gain) == 0


@pytest.mark.parametrize(("model", "block"), CASES)
def test_linear_loop_equals_a_closed_loop_simulation_with_the_real_block(model, block):
    """The controller matrices are the block: same y and u as the block on the plant."""
    lp = Loop(model, block)
    t, y_lin, u_lin = lp.simulate(60.0, r=1.0, load=0.3, t_load=30.0)
    plant = {
        FOPDT: lambda m: PlantFOPDT(m.gain, m.time_constant, m.dead_time, TS),
        SOPDT: lambda m: PT2(m.gain, m.time_constant, m.time_constant_2, TS, m.dead_time),
        Integrating: lambda m: LinearPlant([m.gain], [1.0, 0.0], ts=TS, dead_time=m.dead_time),
    }[type(model)](model)
    real = type(block)(block.config)
    real(0.0, 0.0)  # start-up cycle at rest: the block's state is then zero
    plant.reset(0.0)
    ys, us = [], []
    for tk in t:
        y = plant.y
        u = real(1.0, y)
        ys.append(y)
        us.append(u)
        plant.step(u + (0.3 if tk >= 30.0 else 0.0))
    scale = max(1.0, float(np.max(np.abs(u_lin))))
    np.testing.assert_allclose(ys, y_lin, atol=1e-9 * scale)
    np.testing.assert_allclose(us, u_lin, atol=1e-9 * scale)


def test_the_issues_adrc_on_k2_t30_l5_is_unstable_and_amigo_is_robust():
    """Issue example: the old default ADRC (omega_c 0.095, omega_o 0.476) swings for ever."""
    model = FOPDT(2.0, 30.0, 5.0)
    old = margins(model, ADRC(order=2, b0=0.008, omega_c=0.0952, omega_o=0.476, ts=0.2))
    assert not old.stable and old.radius > 1.0 and math.isinf(old.ms)
    pid = PID(kp=(0.2 + 0.45 * 6) / 2, ti=(2 + 24) / 8 * 5, td=0.5 * 5 * 30 / 31.5, ts=0.2,
              b=0.0, u_min=-1e9, u_max=1e9)  # fmt: skip
    mg = margins(model, pid)
    assert mg.stable and 1.3 < mg.ms < 1.6 and mg.gm > 2.5 and 45.0 < mg.pm < 75.0


def test_a_pid_without_integral_action_has_no_spurious_pole_at_one():
    mg = margins(FOPDT(1.0, 10.0, 1.0), PID(kp=2.0, ti=0.0, td=0.0, ts=0.1, u_min=-1e9))
    assert mg.stable and mg.radius < 0.999


@pytest.mark.parametrize("extra", [{"sp_rate": 1.0}, {"out_rate": 2.0}, {"deadband": 0.5}])
def test_a_pid_with_a_ramp_or_a_dead_band_is_refused_with_a_clear_message(extra):
    from ctrlblocks.blocks.base import ParameterError

    with pytest.raises(ParameterError, match="margins need a linear law"):
        margins(FOPDT(1.0, 10.0, 1.0), PID(kp=1.0, ti=5.0, ts=0.1, **extra))


def test_dead_time_between_samples_moves_the_margins_continuously():
    """Fractional dead time is exact: margins move smoothly between whole samples."""
    blk = PID(kp=2.0, ti=8.0, ts=0.5, u_min=-1e9, u_max=1e9)
    ms = [margins(FOPDT(1.0, 10.0, L), blk).ms for L in (2.0, 2.1, 2.25, 2.4, 2.5)]
    assert all(a < b for a, b in itertools.pairwise(ms))
    assert ms[-1] - ms[0] < 0.25
