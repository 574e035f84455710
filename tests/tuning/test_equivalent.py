"""The ADRC read as a PID (ctrlblocks.tuning.equivalent) against python-control and by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ctrlblocks import ADRC, PID
from ctrlblocks.blocks.adrc import adrc_gains
from ctrlblocks.tuning.equivalent import equivalent_pid
from ctrlblocks.tuning.identify import FOPDT
from ctrlblocks.tuning.margins import Loop, controller_ss

control = pytest.importorskip("control")


def _continuous_ladrc(n: int, b0: float, wc: float, wo: float):
    """The continuous linear ADRC (ESO (s + wo)^(n+1), law (s + wc)^n) as a python-control
    state space with inputs [r, y] and output u (Gao's bandwidth gains)."""
    l1, l2, l3, l4, kp, kd1, kd2 = adrc_gains(n, wc, wo)
    m = n + 1
    a = np.diag(np.ones(n), 1)
    k = np.zeros(m)
    k[: min(n, 3)] = [kp, kd1, kd2][:n]
    k[n] = 1.0  # u = (kp r - k x)/b0: the disturbance estimate x_{n+1} cancelled
    bu = np.zeros(m)
    bu[n - 1] = b0
    lv = np.array([*[l1, l2, l3][:n], l4])
    c1 = np.zeros(m)
    c1[0] = 1.0
    acl = a - np.outer(bu, k) / b0 - np.outer(lv, c1)
    b = np.column_stack([bu * kp / b0, lv])
    return control.ss(acl, b, -k[None, :] / b0, np.array([[kp / b0, 0.0]]))


CASES = [(1, 0.5, 0.4, 2.0), (2, 0.05, 0.35, 1.75), (3, 0.01, 0.3, 1.5)]


@pytest.mark.parametrize("n, b0, wc, wo", CASES)
def test_the_block_law_is_python_controls_linear_adrc_at_a_short_sample_time(n, b0, wc, wo):
    h = 1e-3
    ss = controller_ss(ADRC(order=n, b0=b0, omega_c=wc, omega_o=wo, ts=h, u_min=-1e9))
    sysc = _continuous_ladrc(n, b0, wc, wo)
    w = np.array([0.01, 0.1, 0.5, 1.0]) * wc
    g = ss.response(w)[:, 0, :]
    gc = np.array([np.asarray(sysc(1j * x)).reshape(2) for x in w])
    assert np.max(np.abs(g - gc) / np.abs(gc)) < 2e-3  # O(wo h)


@pytest.mark.parametrize("n, b0, wc, wo", CASES)
def test_the_expansion_equals_that_of_python_controls_transfer_function(n, b0, wc, wo):
    eq = equivalent_pid(controller_ss(ADRC(order=n, b0=b0, omega_c=wc, omega_o=wo, ts=1e-3,
                                            u_min=-1e9)))  # fmt: skip
    tf_y = control.ss2tf(_continuous_ladrc(n, b0, wc, wo)[0, 1])
    num, den = (np.asarray(tf_y.num[0][0], float), np.asarray(tf_y.den[0][0], float))
    # s C_y(s) = -num/(den/s) around s = 0 (den has the integrator's root s = 0): its
    # Taylor coefficients by polynomial division, in ascending powers
    assert abs(den[-1]) < 1e-9 * np.max(np.abs(den))
    f_num = -num[::-1]
    f_den = den[::-1][1:]
    c = np.zeros(3)
    rem = np.pad(f_num, (0, 6))
    for j in range(3):  # c_j = (rem_j - sum c_i den_{j-i}) / den_0
        known = sum(c[i] * f_den[j - i] for i in range(j) if j - i < len(f_den))
        c[j] = (rem[j] - known) / f_den[0]
    assert eq.ki == pytest.approx(c[0], rel=5e-3)
    assert eq.kp == pytest.approx(c[1], rel=5e-3)
    assert eq.kd == pytest.approx(c[2], rel=2e-2)


def test_first_order_adrc_is_a_pi_with_a_lag_by_hand():
    b0, wc, wo = 0.5, 0.4, 2.0
    l1, l2 = 2 * wo, wo * wo
    eq = equivalent_pid(controller_ss(ADRC(order=1, b0=b0, omega_c=wc, omega_o=wo, ts=1e-3,
                                            u_min=-1e9)))  # fmt: skip
    # s C_y(s) = (l2 wc + (wc l1 + l2) s) / (b0 (s + wc + l1))
    assert eq.ki == pytest.approx(l2 * wc / (b0 * (wc + l1)), rel=1e-3)
    assert eq.kp == pytest.approx(((wc * l1 + l2) - l2 * wc / (wc + l1)) / (b0 * (wc + l1)),
                                  rel=1e-3)  # fmt: skip
    assert eq.kd < 0.0 and eq.td < 0.0  # the lag


def test_the_integral_gain_is_the_loops_and_a_pid_reads_as_itself():
    adrc = ADRC(order=2, b0=0.05, omega_c=0.35, omega_o=1.75, ts=0.1, u_min=-1e9)
    lp = Loop(FOPDT(1.0, 10.0, 1.0), adrc)
    assert equivalent_pid(lp.ctrl).ki == pytest.approx(lp.integral_gain(), rel=1e-6)
    # a PI reads as itself
    pid = PID(kp=2.0, ti=5.0, td=0.0, b=0.6, ts=0.1, u_min=-1e9)
    eq = equivalent_pid(controller_ss(pid))
    # Tustin's integral ki h/2 (z + 1)/(z - 1) = ki/s + O(s) at z = e^{s h}: kp exactly
    assert eq.kp == pytest.approx(2.0, rel=1e-6)
    assert eq.ki == pytest.approx(2.0 / 5.0, rel=1e-9)
    assert math.isfinite(eq.b)
