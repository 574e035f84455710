"""Every contract breach found by the issue-12 probes, one test each (they failed before the fix).

The block contract (README, "The block contract"; docs/reliability.md): process
data never raises, ``out`` is finite and inside the limits in force, a refused
configuration leaves configuration and state unchanged and carries a code.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import ctrlblocks
from ctrlblocks import (
    ADRC,
    PID,
    PT1,
    DeadBand,
    ErrorCode,
    LeadLag,
    ManualStation,
    MaxSelector,
    MinSelector,
    MovingAverage,
    ParameterError,
    RateLimiter,
    Saturation,
    Scale,
)
from ctrlblocks.blocks.adrc import exact_coefficients

NAN, INF = math.nan, math.inf


def _finite_inside(block, lo=-INF, hi=INF) -> None:
    assert math.isfinite(block.out), block
    assert lo <= block.out <= hi, block


# --- MovingAverage reconfiguration ------------------------------------------------


def test_moving_average_growing_window_keeps_the_values_and_never_raises() -> None:
    ma = MovingAverage(n=3)
    for x in (1.0, 2.0, 3.0, 4.0):
        ma(x)
    ma.configure(n=5)
    assert ma.out == pytest.approx(3.0)  # the newest three: 2, 3, 4
    assert ma(6.0) == pytest.approx((2 + 3 + 4 + 6) / 4)
    assert ma(7.0) == pytest.approx((2 + 3 + 4 + 6 + 7) / 5)
    assert ma(8.0) == pytest.approx((3 + 4 + 6 + 7 + 8) / 5)


def test_moving_average_shrinking_window_gives_the_mean_of_the_newest_values() -> None:
    ma = MovingAverage(n=5)
    for x in (1.0, 2.0, 3.0, 4.0, 5.0, 6.0):
        ma(x)
    ma.configure(n=2)
    assert ma.out == pytest.approx(5.5)
    assert ma(10.0) == pytest.approx(8.0)
    assert ma(20.0) == pytest.approx(15.0)


def test_pid_dead_band_window_change_then_step_does_not_raise() -> None:
    p = PID(kp=1, ti=10, deadband=1, t_stab=1)
    for _ in range(20):
        p(50, 45)
    p.configure(t_stab=5)
    assert math.isfinite(p(50, 45))
    p.configure(ts=0.05)
    assert math.isfinite(p(50, 45))


def test_moving_average_sum_overflow_gives_the_finite_mean() -> None:
    ma = MovingAverage(n=4)
    big = 1.5e308
    for _ in range(8):
        y = ma(big)
    assert y == pytest.approx(big)
    assert ma.error_id == ErrorCode.NO_ERROR


def test_pid_with_dead_band_and_infinite_limits_never_raises_on_huge_outputs() -> None:
    p = PID(kp=1e300, ti=1.0, deadband=1.0, t_stab=0.5, u_min=-INF, u_max=INF)
    for k in range(30):
        p(1.7 if k % 2 else -1.7, 0.0)
        _finite_inside(p)


# --- huge Python ints, numpy scalars, strings --------------------------------------


def test_huge_int_process_value_is_bad_input_not_overflow_error() -> None:
    p = PID(kp=1, ti=10)
    u = p(10**400, 0)
    assert p.error_id == ErrorCode.BAD_INPUT
    assert math.isfinite(u)


@pytest.mark.parametrize("name", [n for n in ctrlblocks.__all__ if n in (
    "PT1", "RateLimiter", "DeadBand", "Scale", "MovingAverage", "SteadyStateDetector",
    "Saturation", "LeadLag", "JumpAndRate")])  # fmt: skip
def test_every_one_input_block_takes_a_huge_int_as_bad_input(name: str) -> None:
    block = getattr(ctrlblocks, name)()
    block(10**400)
    assert block.error_id == ErrorCode.BAD_INPUT
    _finite_inside(block)


def test_huge_int_dt_is_no_cycle_and_huge_int_track_is_bad_input() -> None:
    f = PT1(t=1.0)
    f(1.0, dt=10**400)
    assert f.error_id == ErrorCode.NO_CYCLE
    ms = ManualStation()
    ms(track=10**400)
    assert ms.error_id == ErrorCode.BAD_INPUT
    sel = MaxSelector()
    assert sel(1.0, 10**400) == 1.0 and sel.error_id == ErrorCode.BAD_INPUT


@pytest.mark.parametrize(
    ("make", "field", "value"),
    [
        (DeadBand, "width", "0.5"),
        (Scale, "in_lo", "0"),
        (RateLimiter, "rate_up", "2"),
        (PID, "sp_rate", "1"),
        (PID, "kp", "2"),
        (ADRC, "y_sat", "1"),
        (ADRC, "tau_wait", "1"),
        (ADRC, "b0", "1"),
    ],
)
def test_numeric_strings_are_refused_with_a_code_and_never_stored(make, field, value) -> None:
    with pytest.raises(ParameterError) as err:
        make(**{field: value})
    assert err.value.code != ErrorCode.NO_ERROR
    block = make()
    before = getattr(block.config, field)
    with pytest.raises(ParameterError):
        block.configure(**{field: value})
    assert getattr(block.config, field) == before
    assert not isinstance(getattr(block.config, field), str)


def test_numbers_are_stored_as_floats_once() -> None:
    p = PID(kp=np.float32(2.0), ti=4, pv_range=[0, np.int64(100)])
    assert type(p.config.kp) is float and type(p.config.ti) is float
    assert p.config.pv_range == (0.0, 100.0) and type(p.config.pv_range[1]) is float
    assert type(MovingAverage(n=np.int64(4)).config.n) is int
    with pytest.raises(ParameterError):
        PID(kp=10**400)
    with pytest.raises(ParameterError):
        PID(kp=True)


def test_adrc_refused_configure_keeps_the_limits_set_at_run_time() -> None:
    a = ADRC(u_min=0.0, u_max=10.0)
    a.set_limits(1.0, 2.0)
    with pytest.raises(ParameterError):
        a.configure(y_sat="3")
    with pytest.raises(ParameterError):
        a.configure(omega_o=-1.0)
    assert (a.u_min, a.u_max) == (1.0, 2.0)


def test_pt1_takes_numpy_float16_as_its_value() -> None:
    f = PT1(t=1, gain=688506)
    y = f(np.float16(0))
    assert y == 0.0 and f.error_id == ErrorCode.NO_ERROR
    assert f(np.float16(1)) == pytest.approx(688506 * (1 - math.exp(-0.1)))


def test_rate_limiter_fed_float16_keeps_its_rate() -> None:
    r = RateLimiter(rate_up=2.0, rate_down=2.0, ts=0.1)
    y = r(np.float16(513))
    assert y == pytest.approx(0.2)
    assert type(y) is float


def test_selectors_pick_by_value_across_numpy_types() -> None:
    assert MaxSelector()(np.float16(513), 512.5, np.int64(3)) == 513.0
    assert MinSelector()(np.float32(0.1), 0.2, np.bool_(True)) == pytest.approx(0.1)


@pytest.mark.parametrize("bad", ["1", None, np.array([1.0, 2.0]), object(), 1 + 2j])
def test_anything_else_is_bad_input_never_an_exception(bad) -> None:
    for block in (PID(ti=1.0), ADRC(), PT1(), Saturation(lo=0, hi=1), LeadLag(), MovingAverage()):
        y = block(bad, 0.0) if isinstance(block, (PID, ADRC)) else block(bad)
        assert math.isfinite(y)
        assert block.error_id in (ErrorCode.BAD_INPUT, ErrorCode.BAD_MEASUREMENT)


def test_bools_are_numbers_at_the_edge() -> None:
    assert Saturation()(True) == 1.0
    assert PT1()(np.bool_(True)) == 1.0


# --- extreme finite configurations ---------------------------------------------------


def test_pid_with_a_subnormal_derivative_filter_is_refused() -> None:
    with pytest.raises(ParameterError) as err:
        PID(kp=1, ti=10, td=1, n=5e-324)
    assert err.value.code == ErrorCode.BAD_PID_COEFFS
    PID(kp=1, ti=10, td=0, n=5e-324)  # no derivative: n does not matter


def test_refused_configure_leaves_config_and_state_unchanged() -> None:
    p = PID(kp=1, ti=10, td=1)
    for _ in range(5):
        p(50, 45)
    before_cfg, before = p.config, p.snapshot()
    with pytest.raises(ParameterError):
        p.configure(n=5e-324)
    assert p.config == before_cfg
    assert p.snapshot() == before


def test_pid_huge_gain_holds_a_finite_output_and_recovers_when_the_gain_is_set_back() -> None:
    p = PID(kp=1, ti=10, u_min=-INF, u_max=INF)
    for _ in range(5):
        u0 = p(50, 45)
    p.configure(kp=1e308)
    u = p(50, 45)
    assert u == u0 and p.error_id == ErrorCode.BAD_RESULT
    p.configure(kp=1.0)
    u1 = p(50, 45)
    assert math.isfinite(u1) and p.error_id == ErrorCode.NO_ERROR
    assert abs(u1 - u0) < 1e-9  # bumpless from the held output
    assert p(50, 45) > u1  # integrating again


# --- ADRC exact discretisation --------------------------------------------------------


@pytest.mark.parametrize("order", [1, 2, 3])
def test_adrc_exact_at_a_tiny_dt_is_finite_and_raises_nothing(order: int) -> None:
    a = ADRC(order=order, discretisation="exact", b0=1.0, omega_c=1.0, omega_o=5.0)
    for _ in range(3):
        a(1.0, 0.0)
    u = a(1.0, 0.0, dt=1e-300)
    assert math.isfinite(u)
    assert all(math.isfinite(x) for x in a.x)
    assert math.isfinite(a(1.0, 0.0))


@pytest.mark.parametrize("order", [1, 2, 3])
@pytest.mark.parametrize("ts", [0.1, 1e-300])
def test_adrc_exact_disturbance_gain_at_tiny_bandwidth_is_the_closed_form(order, ts) -> None:
    # current observer of the chain of m = n + 1 integrators, all poles at z = exp(-wo ts):
    # the disturbance gain is (1 - z)^m / ts^(m - 1) (n = 1 by hand: Lc = (1 - z^2, (1 - z)^2/ts))
    m = order + 1
    wo = 5e-6 / ts if ts > 1e-200 else 5.0
    *coef, kp, _kd1, _kd2 = exact_coefficients(order, 1.0, wo, wo, ts)
    gains = (kp,)
    d = -math.expm1(-wo * ts)
    assert coef[-1] == pytest.approx(d**m / ts ** (m - 1) if ts > 1e-200 else wo**m * ts, rel=1e-9)
    assert coef[-1] > 0.0
    # the controller gains tend to Gao's table (s + wc)^n as wc ts -> 0
    assert gains[0] == pytest.approx(wo**order, rel=1e-5)  # kp = wc^n


@pytest.mark.parametrize("order", [1, 2, 3])
def test_adrc_exact_gains_equal_a_scipy_ackermann_reference(order: int) -> None:
    from scipy.linalg import expm

    ts, b0, wc, wo = 0.1, 0.7, 0.35, 1.75
    m = order + 1
    a = np.diag(np.ones(m - 1), 1)  # chain (Y, ..., h)
    phi = expm(a * ts)
    c = np.eye(m)[0]
    obs = np.array([c @ np.linalg.matrix_power(phi, k) for k in range(m)])
    poly = np.poly([math.exp(-wo * ts)] * m)
    p_phi = sum(cf * np.linalg.matrix_power(phi, m - j) for j, cf in enumerate(poly))
    lc = np.linalg.solve(phi, p_phi @ np.linalg.solve(obs, np.eye(m)[-1]))
    coef = exact_coefficients(order, b0, wc, wo, ts)[:13]
    idx = {1: [0, 3], 2: [0, 1, 3], 3: [0, 1, 2, 3]}[order]
    got = np.zeros(4)
    got[:] = coef[9:]
    assert got[idx] == pytest.approx(lc, rel=1e-9)
    # the error dynamics (I - Lc C) Phi have all poles at exp(-wo ts)
    err = (np.eye(m) - np.outer(lc, c)) @ phi
    assert np.poly(err) == pytest.approx(poly, abs=1e-12)


# --- NaN through the clamp, held outputs re-limited ----------------------------------------


def test_adrc_unstable_euler_observer_never_outputs_nan() -> None:
    a = ADRC(order=2, b0=1.0, omega_c=1.0, omega_o=10.0, ts=0.1, u_min=0.0, u_max=5.0)
    assert a.warning
    y = 0.0
    for k in range(3000):
        u = a(1.0, y)
        _finite_inside(a, 0.0, 5.0)
        y = 0.9 * y + 0.1 * u + (1e3 if k % 500 == 7 else 0.0)


@pytest.mark.parametrize(
    ("block", "call"),
    [
        (ADRC(u_min=0.0, u_max=5.0), lambda b: b(1.0, 0.5, dt=1e300)),
        (ManualStation(), lambda b: b(inc=True, dt=3.6e307)),
        (ManualStation(), lambda b: b(inc=True, dt=1.7e308)),
        (PT1(t=1.0, gain=10.0), lambda b: b(1.7e308)),
        (LeadLag(k=10.0, t_lead=5.0, t_lag=1.0), lambda b: b(1.7e308)),
        (Scale(in_lo=0.0, in_hi=1e-300, out_lo=0.0, out_hi=1e300), lambda b: b(1e300)),
    ],
)
def test_extreme_finite_data_never_leaves_as_nan_or_inf(block, call) -> None:
    for _ in range(3):
        call(block)
        _finite_inside(block, *block.output_limits())


def test_held_outputs_are_limited_to_the_limits_in_force() -> None:
    s = Saturation(lo=0.0, hi=10.0)
    s(8.0)
    s.configure(hi=5.0)
    assert s(NAN) == 5.0 and s.error_id == ErrorCode.BAD_INPUT
    sc = Scale(in_lo=0, in_hi=10, out_lo=0, out_hi=100, clamp=True)
    sc(9.0)
    sc.configure(out_hi=50.0)
    assert sc(NAN) == 50.0
    ll = LeadLag(out_min=0.0, out_max=10.0)
    for _ in range(100):
        ll(9.0)
    ll.configure(out_max=3.0)
    assert ll(NAN) == 3.0
    a = ADRC(u_min=0.0, u_max=10.0, u0=8.0)
    a.set_limits(0.0, 2.0)
    assert a(1.0, 0.0, dt=-1.0) == 2.0 and a.error_id == ErrorCode.NO_CYCLE


# --- PID status and bumps ----------------------------------------------------------------


def test_pid_valid_limits_configure_clears_bad_limits() -> None:
    p = PID(kp=1, ti=10)
    p.set_limits(5.0, 1.0)
    assert p.error_id == ErrorCode.BAD_LIMITS
    p.configure(u_min=0.0, u_max=50.0)
    assert p.error_id == ErrorCode.NO_ERROR
    p(50, 45)
    assert p.error_id == ErrorCode.NO_ERROR


def test_pid_recovery_from_bad_data_with_the_dead_band_active_is_bumpless() -> None:
    p = PID(kp=1, ti=10, deadband=1, t_stab=1, safe_value=0.0, u_min=-100, u_max=100)
    for _ in range(50):
        p(50, 49.7)
    assert p.deadband_active
    assert p(NAN, 49.7) == 0.0
    assert abs(p(50, 49.7) - 0.0) < 1e-9


def test_pid_clamping_anti_windup_settles_at_the_limit_and_says_so() -> None:
    p = PID(kp=2, ti=4, ts=0.1, u_min=0, u_max=3)
    a = math.exp(-0.1 / 7.3)
    y = 0.0
    for _ in range(3000):
        u = p(2.5, y)
        y = a * y + (1 - a) * 0.73 * u
    assert u == 3.0 and p.u_max == 3.0
    assert p.awout is True and p.limits_active is True
    # no windup: after a setpoint below the reachable range the output leaves the limit at once
    u2 = p(1.0, y)
    assert u2 < 3.0


# --- velocity form with derivative action: the law of Åström 1987, Figs. 2.2/2.5 ---------


def _incremental_reference(k, ti, td, n, h, lo, hi, sp, pv):
    """Fig. 2.5 with switch A closed and the output integrator limited, written out.

    P = K (r - y), D by (2.11) on -y, I increments by the trapezoid; the output
    integrator x sums the increments and is limited: x = sat(x + dP + dI + dD).
    """
    tf = td / n
    a, bd = tf / (tf + h), k * td / (tf + h)
    x, p_prev, d, d_prev, w_prev, e_prev = 0.0, 0.0, 0.0, 0.0, None, None
    out = []
    for r, y in zip(sp, pv, strict=True):
        e, p, w = r - y, k * (r - y), -y
        d = 0.0 if w_prev is None else a * d + bd * (w - w_prev)
        di = 0.0 if e_prev is None else k * h / (2 * ti) * (e + e_prev)
        x = min(hi, max(lo, x + (p - p_prev) + (d - d_prev) + di))
        out.append(x)
        p_prev, d_prev, w_prev, e_prev = p, d, w, e
    return out


def test_velocity_form_with_derivative_is_the_incremental_law_and_loses_the_clamped_kick() -> None:
    h, steps = 0.1, 300
    sp = [50.0] * steps
    pv = [50.0] * 20 + [55.0] * (steps - 20)
    p = PID(kp=1, ti=10, td=2, n=10, ts=h, algorithm="velocity", u_min=0, u_max=100)
    got = [p(r, y) for r, y in zip(sp, pv, strict=True)]
    ref = _incremental_reference(1.0, 10.0, 2.0, 10.0, h, 0.0, 100.0, sp, pv)
    assert got == pytest.approx(ref, abs=1e-9)
    # the PV step drives the output into u_min (the D kick is cut there), then the decay
    # of D is integrated: the output climbs to ~32.5 % although e = -5 throughout ...
    assert max(got[25:]) == pytest.approx(32.52, abs=0.01)
    # ... where the positional form stays at u_min (its D decays back to zero)
    q = PID(kp=1, ti=10, td=2, n=10, ts=h, u_min=0, u_max=100)
    pos = [q(r, y) for r, y in zip(sp, pv, strict=True)]
    assert max(pos[20:]) == 0.0


@pytest.mark.parametrize(("td", "bound"), [(0.0, 500), (1.0, 2000)])
def test_one_huge_pv_sample_does_not_pin_a_clamping_pid(td: float, bound: int) -> None:
    # before: with derivative action the D kick hid the limit and the integrator
    # took -5e297 at once, holding the output at u_min for ever
    a = math.exp(-0.1 / 7.3)
    p = PID(kp=1, ti=10, td=td, ts=0.1, u_min=0, u_max=100)
    y = 0.0
    for _ in range(3000):
        u0 = p(50, y)
        y = a * y + (1 - a) * 1.5 * u0
    p(50, 1e300)
    assert abs(p.i) < 1e3
    for n in range(1, 10**5):
        u = p(50, y)
        y = a * y + (1 - a) * 1.5 * u
        if n > 20 and abs(u - u0) < 0.5:
            break
    assert n < bound


def test_adrc_anti_backoff_with_gains_that_underflow_never_raises() -> None:
    # found by the long campaign: omega_c = omega_o = 5e-324 gives kp + Gamma = 0 in (12b)
    a = ADRC(order=2, omega_c=5e-324, omega_o=5e-324, anti_backoff=True, y_sat=2.0, y_sat_lo=-1.0)
    for y in (0.0, 1.0, 2.5, 3.0, 0.5):
        a(1.0, y)
        _finite_inside(a)


@pytest.mark.parametrize(
    ("make", "attr"),
    [
        (
            lambda: ADRC(order=1, b0=1.0, omega_c=1.0, omega_o=5.0, ts=0.1, precision="float32"),
            "u_man",
        ),
        (lambda: PID(kp=1.0, ti=10.0, ts=0.1, precision="float32"), "manual_value"),
    ],
)
def test_float32_cycle_converts_a_huge_int_manual_value_at_the_edge(make, attr) -> None:
    # Found by the long fuzz run (ADRC, seed 7001): the float32 cycle passed the
    # manual value through unconverted, and float(10**400) raised OverflowError.
    b = make()
    b(1.0, 0.5)
    b.manual = True
    setattr(b, attr, 10**400)
    out = b(1.0, 0.5)
    assert math.isfinite(out)
    assert b.error_id == ErrorCode.BAD_INPUT
    setattr(b, attr, 2.0)
    assert b(1.0, 0.5) == pytest.approx(2.0)


def test_pid_fast_lane_and_two_phase_agree_when_the_integral_gain_underflows() -> None:
    # Found by the long fuzz run (PID, seed 7201): K/Ti = 3e-323 is not 0 but K h/Ti
    # is; the fast lane (pid_step) then skipped the back-calculation and the two-phase
    # path did not, so the per-call block stayed wound up beyond u_max for ever.
    def make() -> PID:
        return PID(kp=5e-324, ti=0.15, td=0.07, ts=0.0012, u_min=0.0, u_max=1.0,
                   anti_windup="back_calc_model", reset_value=5.0)  # fmt: skip

    a, b = make(), make()
    for k in range(50):
        sp = 1.0 if k < 25 else -1.0
        ua = a(sp, 0.5)
        ub = b.compute_output(sp, 0.5)
        b.update_state(ub)
        assert ua == ub
        assert a.i == b.i
        assert a.snapshot() == b.snapshot()
    assert a.i == 5.0  # no integral action at all: the integrator keeps its reset value


def test_pid_configure_refuses_a_series_tuning_whose_gain_overflows() -> None:
    # Found by the long fuzz run (PID, seed 7501): series form, Td' = 0, and
    # Ti' = 1e308 make K = K'(Ti'+Td')/Ti' overflow; the forward derivative's
    # coefficients then divided by Tf = 0 and configure raised ZeroDivisionError.
    p = PID(kp=55.5, ti=517.0, td=0.0, n=11.0, ts=0.17, form="series", derivative_method="forward")
    p(1.0, 0.0)
    before = (p.config, p.snapshot())
    with pytest.raises(ctrlblocks.ParameterError) as exc:
        p.configure(ti=1e308)
    assert exc.value.code == ErrorCode.BAD_PID_COEFFS
    assert (p.config, p.snapshot()) == before
    with pytest.raises(ctrlblocks.ParameterError):
        PID(kp=55.5, ti=1e308, td=0.0, n=11.0, ts=0.17, form="series", derivative_method="forward")


# --- per-call and two-phase STATES (the campaign's state check) -------------------------


def _two_phase(block, sp: float, y: float, **kw) -> float:
    v = block.compute_output(sp, y, **kw)
    block.update_state(v)
    return v


@pytest.mark.parametrize("dt", [None, 0.1])  # None: the fast lane (adrc_step); 0.1: no lane
def test_adrc_failed_cycle_commits_the_same_reference_on_both_paths(dt) -> None:
    # Found by the campaign's state check (ADRC, seed 99, action 527): a cycle whose law
    # overflows (BAD_RESULT, the guard restarts the ESO) committed this cycle's reference
    # filter state on the fast lane, but the two-phase path's restart dropped it and kept
    # the previous one while y_ref reported the new one.
    def make() -> ADRC:
        return ADRC(order=1, b0=1.0, omega_c=1.0, omega_o=5.0, ts=0.1, t_ref=1.0,
                    u_min=-10.0, u_max=10.0)  # fmt: skip

    a, b = make(), make()
    for _ in range(5):
        a(1.0, 0.0, dt=dt)
        _two_phase(b, 1.0, 0.0, dt=dt)
    a(5.0, 1e308, dt=dt)  # the ESO overflows: BAD_RESULT
    _two_phase(b, 5.0, 1e308, dt=dt)
    assert a.error_id == b.error_id == ErrorCode.BAD_RESULT
    # the exact PT1 of Nowak et al. 2018, section 5, one more step from 1 - exp(-0.5)
    a_ref = math.exp(-0.1 / 1.0)
    expected = a_ref * (1.0 - math.exp(-0.5)) + (1.0 - a_ref) * 5.0
    assert a.y_ref == pytest.approx(expected, rel=1e-12)
    assert a._ref == b._ref == b.y_ref == pytest.approx(expected, rel=1e-12)
    assert a.snapshot() == b.snapshot()


def test_gain_schedule_reset_puts_the_controller_at_the_initial_schedule() -> None:
    # Found by the campaign's state check (GainSchedule, seed 99, action 16,789): reset()
    # set the scheduling variable back to the first breakpoint but left the PID tuned
    # for the old one, so a later restore(snapshot()) -- which retunes for the restored
    # variable -- changed kp under the restored state, and P and I differed from a block
    # that was not restored while the output sat at the limit.
    gs = ctrlblocks.GainSchedule(
        PID(kp=1.0, ti=10.0, ts=0.1, u_min=0.0, u_max=100.0), breakpoints=(0.0, 100.0),
        kp=(1.0, 3.0),
    )  # fmt: skip
    gs(50.0, 45.0, w=100.0)
    assert gs.controller.config.kp == 3.0
    gs.reset()
    assert gs.w == 0.0
    assert gs.controller.config.kp == gs.parameters["kp"] == 1.0
    twin = ctrlblocks.GainSchedule(
        PID(kp=1.0, ti=10.0, ts=0.1, u_min=0.0, u_max=100.0), breakpoints=(0.0, 100.0),
        kp=(1.0, 3.0),
    )  # fmt: skip
    assert twin.controller.config.kp == 1.0  # construction: the same initial schedule
    gs.restore(gs.snapshot())
    for k in range(5):
        w = math.nan if k == 0 else 0.0  # a bad scheduling variable keeps the tuning
        assert gs(60.0, 45.0, w=w) == twin(60.0, 45.0, w=w)
        assert gs.snapshot() == twin.snapshot()


@pytest.mark.parametrize("td", [0.0, 0.5])
@pytest.mark.parametrize("sp", [-1.7976931348623157e308, 1.7976931348623157e308])
def test_pid_failed_cycle_commits_the_same_memory_on_both_paths(td, sp) -> None:
    # Found by the campaign's state check (PID, seeds 8101 and 8104): a cycle whose law
    # overflows (BAD_RESULT) committed this cycle's derivative memory and deviation
    # (w, e, D) on the fast lane (pid_step commits before the guard runs), but the
    # two-phase path's restart dropped them and kept the previous cycle's.
    def make() -> PID:
        return PID(kp=30.0, ti=560.0, td=td, n=10.0, ts=0.2, u_min=-INF, u_max=INF)

    a, b = make(), make()
    for k in range(5):
        a(30.0, 10.0 * k)
        _two_phase(b, 30.0, 10.0 * k)
    assert a.snapshot() == b.snapshot()
    held = a.out
    a(sp, 45.0)  # K (sp - pv) overflows
    _two_phase(b, sp, 45.0)
    assert a.error_id == b.error_id == ErrorCode.BAD_RESULT
    assert a.out == b.out == held  # the fallback: the last valid output
    assert a.snapshot() == b.snapshot()
    for _ in range(3):  # the recovery is the same on both paths too
        assert a(30.0, 40.0) == _two_phase(b, 30.0, 40.0)
        assert a.snapshot() == b.snapshot()


# --- PID output ramp and limits written at run time (sixth session) -----------------


def test_pid_recovers_bumplessly_after_limits_narrowed_during_bad_data() -> None:
    """Found by the two-path property test: out_rate, a bad PV, the limits narrowed to
    [-30, -30] (out limited to -30) and widened to [-30, -29]; the first good cycle jumped
    from -30 to -29.25 -- the output ramp had kept the old output -28.67 as its state."""
    pid = PID(kp=3.2, ti=27.0, ts=0.0018, u_min=-28.68, u_max=-28.67, out_rate=317.0,
              form="parallel", algorithm="velocity", reset_value=-14.2)  # fmt: skip
    pid(30.0, 0.0, pv_ok=False)
    pid.set_limits(-30.0, -30.0)
    pid.set_limits(-30.0, -29.0)
    assert pid.out == -30.0
    assert pid(30.0, 0.0) == pytest.approx(-30.0, abs=1e-9 * 30.0)


@pytest.mark.parametrize("two_phase", [False, True])
def test_pid_output_ramp_continues_from_the_limited_output(two_phase: bool) -> None:
    """Limits narrowed below the output: the output is limited at once, and the next cycle
    ramps from there towards the law's value (before, it stayed at the limit while the ramp
    came down from the old output)."""
    pid = PID(kp=1.0, ti=0.0, ts=0.1, u_min=0.0, u_max=100.0, out_rate=10.0)
    pid.configure(reset_value=50.0)
    pid.reset()
    assert pid.out == 50.0
    if two_phase:  # a pending cycle: its ramp state is limited with the output
        pid.compute_output(10.0, 50.0)  # the law: -40 + the bias 50 = 10; ramped to 49
        pid.set_limits(0.0, 20.0)
        pid.update_state(pid.out)
    else:
        pid.set_limits(0.0, 20.0)
    assert pid.out == 20.0
    assert pid(10.0, 50.0) == pytest.approx(19.0)  # towards the law's 10 at 10 %/s
