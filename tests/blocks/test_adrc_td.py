"""The ADRC's tracking differentiator (``td_time``; issue 34, the reference-tracking option).

A linear, critically damped tracking differentiator of order n (the TD of Han
2009 in a linear form): the working setpoint through n lags ``w/(s + w)``,
``w = 1/td_time``, whose derivatives are fed forward in the law (4b) of Nowak
et al. 2018 by the reference ``r_eff = r_f + (kd1 r_f' + kd2 r_f'' + r_f^(n))/kp``
(:func:`ctrlblocks.blocks.adrc.tracking_differentiator`).  Checked against
oracles that do not use the block's function:

* its discretisation against ``scipy.signal.cont2discrete`` (ZOH) of the chain's
  state space, to 1e-12, and its outputs against ``scipy.signal.dlsim`` of that
  discrete system with the output matrices of the derivatives read off the
  continuous system (``C A^k``, ``C A^(k-1) B``: r held over the sample), to 1e-9;
* the block with the TD is a plain ADRC fed the oracle's ``r_eff``, to 1e-9;
* in closed loop on ``b0/s^n`` (python-control, ZOH) the set-point response is
  the analytic ``w^n/(s + w)^n`` step response, faster than the plain ADRC's
  ``omega_c`` allows and without overshoot, and the response to a load is bit
  for bit the plain ADRC's;
* MAN -> AUTO and retunes without a bump, bad configurations refused.

The float32 cycle and the exported FB are the block over the PLC traces
(``tests/plc/traces.py``: the TD among ADRC_OPTIONS, retuned mid-run).
"""

from __future__ import annotations

import math

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal

from ctrlblocks import ADRC
from ctrlblocks.blocks.adrc import td_restart, td_state, tracking_differentiator
from ctrlblocks.blocks.base import ErrorCode, ParameterError
from ctrlblocks.tuning.margins import controller_ss


def td_ss(n: int, td_time: float) -> tuple[np.ndarray, ...]:
    """The chain of n lags ``w/(s+w)`` and, as outputs, r_f and its derivatives 1..n.

    The k-th derivative of ``r_f = c z`` for an input held constant is ``c A^k z +
    c A^(k-1) B r`` (the Markov parameters; rows beyond n are zero in the block).
    """
    w = 1.0 / td_time
    a = w * (np.eye(n, k=-1) - np.eye(n))
    b = np.zeros((n, 1))
    b[0, 0] = w
    c = np.zeros((1, n))
    c[0, n - 1] = 1.0
    rows_c, rows_d = [c], [np.zeros((1, 1))]
    for k in range(1, n + 1):
        rows_c.append(c @ np.linalg.matrix_power(a, k))
        rows_d.append(c @ np.linalg.matrix_power(a, k - 1) @ b)
    return a, b, np.vstack(rows_c), np.vstack(rows_d)


def td_discrete(n: int, td_time: float, h: float) -> tuple[np.ndarray, ...]:
    """The ZOH image ``(Phi, Gamma)`` of :func:`td_ss` (scipy) and the output matrices of
    the block's outputs: r_f and the derivatives below n at the sample's instant, the
    n-th as its mean over the sample, ``(C_(n-1) (x(t+h) - x(t)))/h``."""
    ac, bc, cc, dc = td_ss(n, td_time)
    phi, gam, cd, dd, _h = signal.cont2discrete((ac, bc, cc, dc), h, method="zoh")
    cd, dd = cd.copy(), dd.copy()
    cd[n] = cc[n - 1] @ (phi - np.eye(n)) / h
    dd[n] = cc[n - 1] @ gam / h
    return phi, gam, cd, dd


def td(r, n, td_time, h, z, gains=(1.0, 0.0, 0.0)):
    """One step of the block's TD from the states ``z`` (no mode, no preset)."""
    zz = list(z) + [0.0] * (3 - len(z))
    out = tracking_differentiator(r, 0.0, True, True, False, False, n, td_time, h, *gains, *zz)
    return out, np.array(out[5 : 5 + n])


@pytest.mark.parametrize("n", [1, 2, 3])
@pytest.mark.parametrize("a", [1e-4, 0.01, 0.3, 1.0, 5.0])
def test_discretisation_is_the_zoh_image_of_the_chain(n, a):
    td_time = 2.0
    h = a * td_time
    ac, bc, cc, dc = td_ss(n, td_time)
    phi, gam, _c, _d, _h = signal.cont2discrete((ac, bc, cc, dc), h, method="zoh")
    for j in range(n):  # the columns of Phi: the step from a unit state, r = 0
        z = np.zeros(n)
        z[j] = 1.0
        _out, zn = td(0.0, n, td_time, h, z)
        np.testing.assert_allclose(zn, phi[:, j], rtol=0, atol=1e-12)
    _out, zn = td(1.0, n, td_time, h, np.zeros(n))  # Gamma: the step from rest at 0, r = 1
    np.testing.assert_allclose(zn, gam[:, 0], rtol=0, atol=1e-12)
    # the closed form of the brief: Phi_kj = e^-a a^(k-j)/(k-j)!, Gamma_k = 1 - e^-a sum_i<k
    for k in range(n):
        g = 1.0 - math.exp(-a) * sum(a**i / math.factorial(i) for i in range(k + 1))
        assert gam[k, 0] == pytest.approx(g, abs=1e-12)
        for j in range(k + 1):
            assert phi[k, j] == pytest.approx(
                math.exp(-a) * a ** (k - j) / math.factorial(k - j), abs=1e-12
            )


def _signals(kind: str, m: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.arange(m)
    if kind == "step":
        return np.where(t >= 5, 3.0, -1.0)
    if kind == "ramp":
        return 0.05 * t - 2.0
    return np.repeat(rng.normal(0.0, 2.0, m // 10 + 1), 10)[:m] + rng.normal(0.0, 0.1, m)


@pytest.mark.parametrize("n", [1, 2, 3])
@pytest.mark.parametrize("kind", ["step", "ramp", "random"])
@pytest.mark.parametrize("td_time", [0.3, 2.0])
def test_outputs_are_dlsim_of_the_discrete_chain(n, kind, td_time):
    h, m = 0.1, 300
    r = _signals(kind, m, seed=n)
    z0 = np.full(n, 0.7)  # a chain at rest on 0.7
    _t, want, xs = signal.dlsim((*td_discrete(n, td_time, h), h), r, x0=z0)
    z = z0
    for k in range(m):
        out, z = td(r[k], n, td_time, h, z)
        got = [out[1], *out[2 : 2 + n]]  # r_f, r_f', ..., r_f^(n)
        scale = 1.0 + np.abs(want[k]).max()
        np.testing.assert_allclose(got, want[k], rtol=0, atol=1e-9 * scale)
        if k + 1 < m:
            np.testing.assert_allclose(z, xs[k + 1], rtol=0, atol=1e-9)
        for d in out[2 + n : 5]:
            assert d == 0.0  # derivatives beyond n


def r_eff_oracle(sp, n, td_time, h, y0, block):
    """``r_eff`` of the reference feed-forward law from dlsim and the block's gains."""
    _t, out, _x = signal.dlsim((*td_discrete(n, td_time, h), h), sp, x0=np.full(n, y0))
    g = block.gains
    kd = [g["kd1"], g["kd2"]]
    r_eff = out[:, 0].copy()
    for k in range(1, n):  # kd1 r_f', kd2 r_f'' (the derivatives below the n-th)
        r_eff += kd[k - 1] * out[:, k] / g["kp"]
    return r_eff + out[:, n] / g["kp"]  # r_f^(n) with unit weight


PLANT_A = 0.3


def _loop(block, sp, m, load=None, y0=0.0):
    """A first-order lag plant ``y' = -a y + 2 u + load`` (ZOH); the u the block gave."""
    e = math.exp(-PLANT_A * 0.1)
    y, us, ys = y0, [], []
    for k in range(m):
        u = block(sp[k], y)
        us.append(u)
        ys.append(y)
        d = 0.0 if load is None else load[k]
        y = e * y + (1.0 - e) * (2.0 * u + d) / PLANT_A
    return np.array(us), np.array(ys)


class Chain:
    """The plant ``b0/s^n`` with a small leak, ZOH via python-control."""

    def __init__(self, n: int, b0: float, h: float, y0: float = 0.0) -> None:
        den = np.poly([-0.05] + [0.0] * (n - 1))
        sysd = control.c2d(control.ss(control.tf([b0], den)), h, "zoh")
        self.a, self.b, self.c = np.asarray(sysd.A), np.asarray(sysd.B), np.asarray(sysd.C)
        self.x = np.linalg.lstsq(self.c, np.array([[y0]]), rcond=None)[0]

    @property
    def y(self) -> float:
        return float((self.c @ self.x)[0, 0])

    def step(self, u: float) -> None:
        self.x = self.a @ self.x + self.b * u


def _chain(block, sp, y0=0.0, plant=None):
    """The block's loop on :class:`Chain`; its u."""
    p = plant or Chain(block.config.order, block.config.b0, block.config.ts, y0)
    us = []
    for r in sp:
        u = block(r, p.y)
        us.append(u)
        p.step(u)
    return np.array(us)


@pytest.mark.parametrize("n", [1, 2, 3])
@pytest.mark.parametrize("disc", ["euler", "exact"])
def test_block_is_a_plain_adrc_on_r_eff(n, disc):
    cfg = {"order": n, "b0": 2.0, "omega_c": 1.5, "omega_o": 6.0, "ts": 0.1,
           "discretisation": disc}  # fmt: skip
    m = 400
    sp = _signals("random", m, seed=7) + 1.0
    with_td = ADRC(**cfg, td_time=0.8)
    plain = ADRC(**cfg)
    r_eff = r_eff_oracle(sp, n, 0.8, 0.1, 0.25, plain)
    u1 = _chain(with_td, sp, y0=0.25)
    u2 = _chain(plain, r_eff, y0=0.25)
    scale = 1.0 + np.abs(u2).max()
    np.testing.assert_allclose(u1, u2, rtol=0, atol=1e-9 * scale)
    assert np.abs(r_eff - sp).max() > 0.1  # the TD did something


def _chain_loop(n, td_time, sp, m, load=None, wc=2.0):
    """The loop on the pure chain ``b0/s^n`` (python-control's ZOH image); y sampled."""
    b0, h = 3.0, 0.01
    sysd = control.c2d(control.ss(control.tf([b0], [1.0] + [0.0] * n)), h, "zoh")
    a, b, c = np.asarray(sysd.A), np.asarray(sysd.B), np.asarray(sysd.C)
    # the load enters as an input disturbance (in units of u)
    blk = ADRC(order=n, b0=b0, omega_c=wc, omega_o=10.0 * wc, ts=h, td_time=td_time,
               discretisation="exact")  # fmt: skip
    x = np.zeros((n, 1))
    ys, us = [], []
    for k in range(m):
        y = float((c @ x)[0, 0])
        u = blk(sp[k], y)
        ys.append(y)
        us.append(u)
        d = 0.0 if load is None else load[k]
        x = a @ x + b * (u + d)
    return np.array(ys), np.array(us)


@pytest.mark.parametrize("n", [1, 2, 3])
@pytest.mark.parametrize(("ratio", "tol"), [(0.5, 2e-5), (2.0, 5e-4)])
def test_closed_loop_set_point_response_is_the_td(n, ratio, tol):
    """``w^n/(s+w)^n``, ``w = ratio omega_c``, in closed loop; the plain ADRC: omega_c's.

    Measured on ``b0/s^n`` with the exact observer at ``omega_o = 10 omega_c``: the
    error to the analytic response is 2e-15, 6e-6, 4e-6 of the step for n = 1, 2, 3
    at ``w ts = 0.01`` and 5e-15, 1.3e-4, 2.5e-4 at ``w ts = 0.04`` (n = 1 is exact:
    the mean slope over the sample is what a held u applies); with the n-th
    derivative fed forward at the sample's instant instead of as its mean over the
    sample it was 0.13, 0.08, 0.04 % and 1.0, 1.7, 2.4 % (an overshoot of 0.4 % for
    n = 3).  The plain loop follows ``omega_c``'s response to 3e-5.
    """
    h, m, wc = 0.01, 1500, 2.0
    w = ratio * wc
    sp = np.where(np.arange(m) >= 1, 1.0, 0.0)
    y_td, _u = _chain_loop(n, 1.0 / w, sp, m, wc=wc)
    y_plain, _u = _chain_loop(n, 0.0, sp, m, wc=wc)
    t = np.arange(m - 1) * h
    _t, ideal = control.step_response(control.tf([w**n], np.poly([-w] * n)), t)
    _t, loop = control.step_response(control.tf([wc**n], np.poly([-wc] * n)), t)
    err_td = np.abs(y_td[1:] - ideal).max()
    err_plain = np.abs(y_plain[1:] - loop).max()
    assert err_td < tol, err_td  # the designed response
    assert err_plain < 1e-4, err_plain  # the plain ADRC: omega_c's response
    assert y_td.max() <= 1.0 + 1e-12  # no overshoot
    # the 50 % time is the TD's, not the loop's
    t50 = lambda y: np.argmax(y >= 0.5) * h  # noqa: E731
    assert t50(y_td) == pytest.approx(t50(ideal), abs=2 * h)
    assert abs(t50(y_td) - t50(y_plain)) > 0.3 * t50(y_plain)


@pytest.mark.parametrize("n", [1, 2, 3])
def test_disturbance_response_is_unchanged_by_the_td(n):
    m = 1200
    sp = np.full(m, 0.0)
    load = np.where(np.arange(m) >= 100, -0.5, 0.0)
    y_td, u_td = _chain_loop(n, 0.4, sp, m, load=load)
    y_pl, u_pl = _chain_loop(n, 0.0, sp, m, load=load)
    assert np.array_equal(u_td, u_pl) and np.array_equal(y_td, y_pl)  # bit for bit
    assert np.abs(y_pl).max() > 1e-3  # the load did move the loop


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(1, 3),
    td_time=st.floats(0.05, 10.0),
    sp=st.floats(-50.0, 50.0),
    y0=st.floats(-50.0, 50.0),
    u_man=st.floats(-20.0, 20.0),
    k_man=st.integers(1, 30),
    disc=st.sampled_from(["euler", "exact"]),
)
def test_man_to_auto_is_bumpless(n, td_time, sp, y0, u_man, k_man, disc):
    blk = ADRC(order=n, b0=2.0, omega_c=1.0, omega_o=5.0, ts=0.1, td_time=td_time,
               discretisation=disc)  # fmt: skip
    blk.manual = True
    blk.u_man = u_man
    y = y0
    e = math.exp(-PLANT_A * 0.1)
    for _ in range(k_man):
        u = blk(sp, y)
        y = e * y + (1.0 - e) * 2.0 * u / PLANT_A
    assert blk.sp_td == pytest.approx(blk.y)  # in MAN the TD rests on the PV
    blk.manual = False
    u_auto = blk(sp, y)
    assert u_auto == pytest.approx(u_man, abs=1e-9 * (1.0 + abs(u_man)))


@pytest.mark.parametrize("n", [1, 2, 3])
@pytest.mark.parametrize("change", [{"td_time": 0.3}, {"td_time": 3.0}, {"td_time": 0.0},
                                    {"omega_c": 2.0}, {"order": 2}])  # fmt: skip
def test_retune_in_a_transient_is_bumpless(n, change):
    """The output continues from the last u; a new time constant continues r_f and its slope."""
    if change == {"order": n}:
        pytest.skip("not a change")
    blk = ADRC(order=n, b0=2.0, omega_c=1.0, omega_o=5.0, ts=0.1, td_time=1.0)
    sp = np.where(np.arange(40) >= 5, 2.0, 0.0)
    plant = Chain(n, 2.0, 0.1)
    us = _chain(blk, sp, plant=plant)
    z = (blk._td1, blk._td2, blk._td3)
    rest = z[n - 1]  # r_f after the last step
    slope = z[n - 2] - z[n - 1] if n >= 2 else 0.0  # its derivative (w = 1)
    assert abs(2.0 - rest) > 0.05  # in the TD's transient
    blk.configure(**change)
    u_next = blk(2.0, plant.y)
    plant.step(u_next)
    assert u_next == pytest.approx(us[-1], abs=1e-12)  # continues from the last u
    new = change.get("td_time", 1.0)
    if new > 0.0 and "td_time" in change:
        assert blk.sp_td == pytest.approx(rest, abs=1e-12)  # r_f continues
        assert blk.sp_td_d1 == pytest.approx(slope, abs=1e-12) or n == 1  # and its slope
        # the next move: the new n-th derivative (a set-point step's kick on the distance
        # left) and the handover offset's decay -- no larger than the set-point step's
        kick = (1.0 / new) ** n * abs(2.0 - rest) / 2.0
        assert abs(blk(2.0, plant.y) - u_next) <= 1.05 * max(np.abs(np.diff(us)).max(), kick)
    if new == 0.0:
        assert blk.sp_td == 2.0  # off: the working setpoint
        assert abs(blk(2.0, plant.y) - u_next) < 0.1  # the handover offset fades with omega_c


def test_turned_on_in_operation_starts_on_the_working_setpoint():
    blk = ADRC(order=2, b0=2.0, omega_c=1.0, omega_o=5.0, ts=0.1)
    _loop(blk, np.full(30, 1.5), 30)
    blk.configure(td_time=0.5)
    blk(3.0, blk.y)
    assert blk.sp_td == 1.5  # at rest on the last working setpoint, then on to 3.0
    # the second derivative's mean over the first sample: w^2 (r - z) exp(-w h) from rest
    assert blk.sp_td_d2 == pytest.approx(4.0 * (3.0 - 1.5) * math.exp(-0.2))


@pytest.mark.parametrize("bad", [-1.0, math.nan, math.inf, -math.inf])
def test_bad_td_time_is_refused_and_the_old_config_stays(bad):
    blk = ADRC(order=2, td_time=0.5)
    with pytest.raises(ParameterError) as ex:
        blk.configure(td_time=bad)
    assert ex.value.code == ErrorCode.BAD_TIME_CONSTANT
    assert blk.config.td_time == 0.5
    with pytest.raises(ParameterError) as ex:
        ADRC(td_time=bad)
    assert ex.value.code == ErrorCode.BAD_TIME_CONSTANT


def test_td_with_t_ref_is_refused():
    blk = ADRC(order=2, td_time=0.5)
    with pytest.raises(ParameterError) as ex:
        blk.configure(t_ref=1.0)
    assert ex.value.code == ErrorCode.BAD_PARAMETER
    assert blk.config.t_ref == 0.0 and blk.config.td_time == 0.5
    with pytest.raises(ParameterError):
        ADRC(t_ref=1.0, td_time=0.5)


def test_bad_setpoint_holds_the_td():
    blk = ADRC(order=3, b0=2.0, omega_c=1.0, omega_o=5.0, ts=0.1, td_time=1.0)
    us, ys = _loop(blk, np.where(np.arange(30) >= 5, 2.0, 0.0), 30)
    state = (blk._td1, blk._td2, blk._td3, blk.sp_td)
    u = blk(math.nan, ys[-1])
    assert u == us[-1] and blk.error_id == ErrorCode.BAD_INPUT
    assert (blk._td1, blk._td2, blk._td3) == state[:3]


def test_compiled_kernels_refuse_the_td():
    blk = ADRC(order=2, td_time=0.5)
    assert "td_time" in blk.fast_path_blockers()
    assert not ADRC(order=2).fast_path_blockers()


def test_two_phase_cycle_and_snapshot():
    blk = ADRC(order=2, b0=2.0, omega_c=1.0, omega_o=5.0, ts=0.1, td_time=1.0)
    _loop(blk, np.where(np.arange(20) >= 5, 2.0, 0.0), 20)
    snap = blk.snapshot()
    v1 = blk.compute_output(2.0, 0.5)
    v2 = blk.compute_output(2.0, 0.5)  # idempotent: from the committed state
    assert v1 == v2
    blk.update_state(v1)
    u_a = blk(2.0, 0.6)
    blk.restore(snap)
    blk(2.0, 0.5)
    assert blk(2.0, 0.6) == u_a
    old = {k: v for k, v in snap.items() if "td" not in k}  # a snapshot of before the TD
    blk.restore(old)
    assert blk._td1 == blk._td2 == blk._sp_w


@pytest.mark.parametrize("n", [1, 2, 3])
@pytest.mark.parametrize("disc", ["euler", "exact"])
def test_two_degree_of_freedom_view_has_the_td_in_the_reference_path(n, disc):
    """``C_r`` (the reference path of the controller ``tune adrc`` reads) is the plain
    one times the TD's ``r -> r_eff`` (python-control); ``C_y`` (the loop) is unchanged."""
    h, td_time = 0.1, 0.7
    cfg = {"order": n, "b0": 2.0, "omega_c": 0.8, "omega_o": 4.0, "ts": h,
           "discretisation": disc}  # fmt: skip
    plain = ADRC(**cfg)
    w = np.logspace(-2, math.log10(math.pi / h) - 0.01, 50)
    c_plain = controller_ss(plain).response(w)[:, 0, :]
    c_td = controller_ss(ADRC(**cfg, td_time=td_time)).response(w)[:, 0, :]
    phi, gam, cd, dd = td_discrete(n, td_time, h)
    g = plain.gains
    weights = np.zeros(n + 1)
    weights[0] = 1.0
    weights[n] += 1.0 / g["kp"]  # r_f^(n)
    if n >= 2:
        weights[1] += g["kd1"] / g["kp"]
    if n >= 3:
        weights[2] += g["kd2"] / g["kp"]
    tdsys = control.ss(phi, gam, weights @ cd, weights @ dd, h)
    g_eff = np.array([complex(tdsys(np.exp(1j * wk * h))) for wk in w])
    np.testing.assert_allclose(c_td[:, 0], c_plain[:, 0] * g_eff, rtol=1e-8)
    np.testing.assert_allclose(c_td[:, 1], c_plain[:, 1], rtol=1e-10)
    assert abs(abs(g_eff[0]) - 1.0) < 1e-3 and abs(g_eff[-1] - 1.0) > 0.1  # a 2-DOF filter


@pytest.mark.parametrize("td_time", [5e-324, 1e-300])
def test_a_denormal_td_time_keeps_every_output_finite(td_time):
    """1/td_time overflows: no derivative is fed forward (found by the fuzz campaign)."""
    blk = ADRC(order=3, b0=2.0, omega_c=1.0, omega_o=5.0, ts=0.1, td_time=td_time)
    for k in range(20):
        u = blk(2.0 if k > 3 else 0.0, 0.1 * k)
        outs = (u, blk.sp_td, blk.sp_td_d1, blk.sp_td_d2, blk.sp_td_d3, blk.y_ref)
        assert all(math.isfinite(v) for v in outs), outs
    assert blk.sp_td == 2.0  # the chain is at the setpoint within a sample


@settings(max_examples=200, deadline=None)
@given(
    n=st.sampled_from([1, 2, 3]),
    td_time=st.floats(1e-3, 1e3),
    z=st.lists(st.floats(-1e3, 1e3), min_size=3, max_size=3),
)
def test_td_state_is_the_binomial_sum_of_the_chain(n, td_time, z):
    """``td_state``, the one place the law and the retune read the chain's value and the
    derivatives its states determine, against the sum ``r_f^(k) = w^k sum_j C(k, j)
    (-1)^(k-j) z_{n-j}`` evaluated here with exact fractions (k < n; 0 at and beyond n);
    and ``td_restart`` of an unchanged chain gives its states back (it inverts that sum)."""
    from fractions import Fraction

    w = 1.0 / td_time
    chain = [None, *z]  # chain[k] = z_k
    want = [Fraction(chain[n])]
    for k in (1, 2):
        if k >= n:
            want.append(Fraction(0))
            continue
        total = sum(Fraction(math.comb(k, j)) * (-1) ** (k - j) * Fraction(chain[n - j])
                    for j in range(k + 1))  # fmt: skip
        want.append(Fraction(w) ** k * total)
    got = td_state(n, w, *z)
    scale = max(abs(v) for v in z) + 1.0
    for k, (g, x) in enumerate(zip(got, want, strict=True)):
        assert abs(Fraction(g) - x) <= Fraction(1e-12) * Fraction(scale) * Fraction(w) ** k, k
    back = td_restart(n, td_time, n, td_time, 0.0, *z)
    expect = {1: (z[0],) * 3, 2: (z[0], z[1], z[1]), 3: (z[0], z[1], z[2])}[n]
    assert back == pytest.approx(expect, rel=1e-9, abs=1e-9 * scale)
