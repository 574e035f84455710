"""PID modes (controltheplant 2024, 2.3.5), bumpless (2.3.6), dead band (2.3.10), ramps, FF, AW."""

from __future__ import annotations

import math

import pytest

from ctrlblocks import PID, Bumpless, ErrorCode, LeadLag, Mode

RANGE = 100.0  # output range of these tests [%]
BUMP = 1e-9 * RANGE


class Plant:
    """PT1 process y' = (K u - y)/T, exact ZOH step, for closed-loop tests."""

    def __init__(self, k: float = 0.8, t: float = 3.0, h: float = 0.1, y0: float = 0.0) -> None:
        self.a = math.exp(-h / t)
        self.k = k
        self.y = y0

    def __call__(self, u: float) -> float:
        self.y = self.a * self.y + (1 - self.a) * self.k * u
        return self.y


def _pid(**kw: object) -> PID:
    base = dict(kp=1.5, ti=4.0, td=0.5, b=0.7, ts=0.1, u_min=0.0, u_max=100.0)
    base.update(kw)
    return PID(**base)


def test_priority_of_the_mode_inputs_is_reset_track_hold_manual_auto() -> None:
    pid = _pid()
    assert pid.mode == Mode.AUTO
    pid.manual = True
    assert pid.mode == Mode.MANUAL
    pid.hold = True
    assert pid.mode == Mode.HOLD
    pid.track = True
    assert pid.mode == Mode.TRACK
    pid.reset_active = True
    assert pid.mode == Mode.RESET


def test_manual_output_is_the_manual_value_and_ignores_sp_and_pv() -> None:
    pid = _pid()
    pid.manual, pid.manual_value = True, 37.0
    assert [pid(sp, pv) for sp, pv in ((10, 0), (50, 80), (0, 3))] == [37.0, 37.0, 37.0]


def test_manual_value_follows_the_output_in_auto() -> None:
    pid = _pid()
    for k in range(20):
        u = pid(50.0, 40.0 + 0.1 * k)
        assert pid.manual_value == u


def test_auto_to_manual_is_bumpless() -> None:
    pid, plant = _pid(), Plant()
    for _ in range(30):
        u = pid(50.0, plant.y)
        plant(u)
    pid.manual = True
    assert abs(pid(50.0, plant.y) - u) < BUMP


def _manual_then_auto(pid: PID, plant: Plant, *, steady: bool) -> tuple[float, float, PID]:
    """Run in manual at 30 %; return (u before switch, u at switch)."""
    pid.manual, pid.manual_value = True, 30.0
    for k in range(600 if steady else 20):
        u = pid(50.0, plant.y)
        plant(u if steady else u + 10 * math.sin(0.5 * k))  # transient: PV moves
    pid.manual = False
    return u, pid(50.0, plant.y), pid


@pytest.mark.parametrize("algorithm", ["positional", "velocity"])
@pytest.mark.parametrize("method", Bumpless.ALL)
def test_manual_to_auto_is_bumpless_in_steady_state(method: str, algorithm: str) -> None:
    pid = _pid(bumpless=method, sp_rate=5.0, algorithm=algorithm)
    before, at, _ = _manual_then_auto(pid, Plant(), steady=True)
    assert before == 30.0
    assert abs(at - before) < BUMP


@pytest.mark.parametrize("algorithm", ["positional", "velocity"])
def test_manual_to_auto_by_integrator_tracking_is_bumpless_in_a_transient(algorithm: str) -> None:
    pid = _pid(bumpless=Bumpless.INTEGRATOR, algorithm=algorithm)
    before, at, pid = _manual_then_auto(pid, Plant(), steady=False)
    assert abs(at - before) < BUMP
    # and control then acts on the full error: the next sample moves
    assert abs(pid(50.0, 20.0) - at) > 0.1


def test_track_setpoint_ramps_the_working_setpoint_from_pv_back_to_sp() -> None:
    pid = _pid(bumpless=Bumpless.TRACK_SETPOINT, sp_rate=2.0)  # 2 %/s = 0.2 per sample
    pid.manual, pid.manual_value = True, 30.0
    for _ in range(5):
        pid(60.0, 24.0)
        assert pid.sp_w == 24.0  # SP follows PV in manual (controltheplant 2024)
    pid.manual = False
    pid(60.0, 24.0)
    assert pid.sp_w == pytest.approx(24.2, abs=1e-12)
    for _ in range(9):
        pid(60.0, 24.0)
    assert pid.sp_w == pytest.approx(26.0, abs=1e-9)


def test_suppress_p_action_keeps_p_off_until_the_deviation_is_within_tolerance() -> None:
    pid = _pid(bumpless=Bumpless.SUPPRESS_P_ACTION, dev_tol=1.0, td=0.0)
    plant = Plant()
    before, at, pid = _manual_then_auto(pid, plant, steady=True)
    assert abs(at - before) < BUMP
    assert pid.p_suppressed and pid.p == 0.0
    u_prev, back = at, None
    for k in range(3000):
        plant(u_prev)
        u = pid(50.0, plant.y)
        if back is None and not pid.p_suppressed:
            back = k
            assert abs(pid.e) <= 1.0
            assert pid.p != 0.0
            assert abs(u - u_prev) < BUMP  # P returns without a bump
        if back is None:
            assert pid.p == 0.0
        u_prev = u
    assert back is not None and back > 10
    assert plant.y == pytest.approx(50.0, abs=1e-3)


def test_hold_freezes_the_output_and_returns_without_a_bump() -> None:
    pid, plant = _pid(), Plant()
    for _ in range(30):
        u = pid(50.0, plant.y)
        plant(u)
    pid.hold = True
    for k in range(20):
        assert pid(80.0 - k, plant(u)) == u
    pid.hold = False
    assert abs(pid(80.0, plant.y) - u) < BUMP


def test_track_mode_outputs_the_tracking_value_and_returns_without_a_bump() -> None:
    pid = _pid()
    pid.track, pid.track_value = True, 42.0
    assert pid(50.0, 10.0) == 42.0
    pid.track_value = 150.0
    assert pid(50.0, 10.0) == 100.0 and pid.limits_active  # limits apply in every mode
    pid.track_value = 42.0
    pid(50.0, 10.0)
    pid.track = False
    assert abs(pid(50.0, 12.0) - 42.0) < BUMP


def test_reset_sets_the_output_immediately_and_clears_errors() -> None:
    pid = _pid(reset_value=12.0, out_rate=1.0)  # even with a slow output ramp
    for _ in range(10):
        pid(50.0, 10.0)
    pid.set_limits(10.0, 0.0)
    assert pid.error_id == ErrorCode.BAD_LIMITS
    pid.reset_active = True
    assert pid(50.0, 10.0) == 12.0
    assert pid.error_id == 0 and not pid.error
    pid.reset_active = False
    assert abs(pid(50.0, 10.0) - 12.0) < BUMP


def test_output_ramp_is_active_in_manual_too() -> None:
    pid = _pid(out_rate=10.0)  # 10 %/s = 1 % per sample
    pid.manual, pid.manual_value = True, 0.0
    pid(0.0, 0.0)
    pid.manual_value = 5.0
    outs = [pid(0.0, 0.0) for _ in range(7)]
    assert outs == pytest.approx([1.0, 2.0, 3.0, 4.0, 5.0, 5.0, 5.0], abs=1e-12)
    assert not pid.limits_active
    pid.manual_value = 50.0
    pid(0.0, 0.0)
    assert pid.limits_active  # the ramp limits (controltheplant 2024, section 2.3.8)


# --- scaling, reverse, feed-forward --------------------------------------------


def test_scaling_maps_sp_and_pv_to_percent_of_the_range() -> None:
    pid = PID(kp=2.0, ts=0.1, pv_range=(2.0, 12.0), u_min=-100, u_max=100)
    u = pid(7.0, 4.0)  # 50 % and 20 %
    assert (pid.sp_w, pid.pv_f) == pytest.approx((50.0, 20.0), abs=1e-12)
    assert u == pytest.approx(60.0, abs=1e-12)


def test_reverse_action_mirrors_the_law() -> None:
    kw = dict(kp=1.2, ti=2.0, td=0.3, ts=0.1, u_min=-1e3, u_max=1e3)
    direct, reverse = PID(**kw), PID(**kw, reverse=True)
    for k in range(50):
        pv = math.sin(0.2 * k)
        assert reverse(1.0, pv) == pytest.approx(-direct(1.0, pv), abs=1e-12)


def test_feed_forward_is_added_before_the_limits() -> None:
    pid = PID(kp=1.0, ts=0.1, u_min=0.0, u_max=10.0)
    assert pid(3.0, 1.0, ff=4.0) == pytest.approx(6.0, abs=1e-12)
    assert pid.ff == 4.0
    assert pid(3.0, 1.0, ff=20.0) == 10.0 and pid.limits_active


def test_lead_lag_feed_forward_path_is_seed_003_version_4() -> None:
    h, k, t_lead, t_lag = 0.1, 2.0, 1.0, 0.5
    pid = PID(kp=1.0, ts=h, u_min=-100, u_max=100, ff_k=k, ff_t_lead=t_lead, ff_t_lag=t_lag)
    ref = LeadLag(k=k, t_lead=t_lead, t_lag=t_lag, ts=h)
    # first sample of a unit step from rest: K (h + 2 Tt)/(h + 2 Tn) (Bonde et al. 2021 Tustin)
    u = pid(0.0, 0.0, dv=1.0)
    assert u == pytest.approx(k * (h + 2 * t_lead) / (h + 2 * t_lag), abs=1e-12)
    assert ref(1.0) == pytest.approx(u, abs=1e-12)
    for j in range(40):
        dv = 1.0 if j < 20 else -0.5
        assert pid(0.0, 0.0, dv=dv) == pytest.approx(ref(dv), abs=1e-12)


# --- anti-windup inputs -----------------------------------------------------------


@pytest.mark.parametrize("algorithm", ["positional", "velocity"])
def test_back_calc_real_tracks_the_measured_actuator_position(algorithm: str) -> None:
    # dI = K/Ti e + (pos - v)/Tt  ->  fixed point v - pos = (K/Ti) e (Tt + h) (implicit Euler)
    pid = PID(
        kp=1.0,
        ti=1.0,
        ts=0.1,
        u_min=-1e3,
        u_max=1e3,
        anti_windup="back_calc_real",
        tt=0.5,
        algorithm=algorithm,
    )
    pid.actuator_pos = 30.0  # actuator stuck at 30 %
    for _ in range(300):
        pid(1.0, 0.0)
    assert pid.out == pytest.approx(30.0 + 1.0 * 1.0 * (0.5 + 0.1), abs=1e-9)


def test_awin_freezes_the_integrator() -> None:
    pid = PID(kp=1.0, ti=1.0, ts=0.1, u_min=-100, u_max=100)
    for _ in range(10):
        pid(1.0, 0.0)
    i = pid.i
    pid.awin = True
    for _ in range(10):
        pid(1.0, 0.0)
        assert pid.i == i
    pid.awin = False
    pid(1.0, 0.0)
    assert pid.i == pytest.approx(i + 0.1, abs=1e-12)


def test_awout_tells_the_primary_that_this_block_is_limited() -> None:
    pid = PID(kp=1.0, ti=1.0, ts=0.1, u_min=0.0, u_max=5.0)
    pid(1.0, 0.0)
    assert not pid.awout
    pid(10.0, 0.0)
    assert pid.awout and pid.limits_active


# --- adaptive dead band (controltheplant 2024, section 2.3.10) ------------------------------


def test_adaptive_deadband_holds_the_moving_average_and_releases_without_a_bump() -> None:
    ts, t_stab, width = 0.1, 1.0, 2.0
    pid = PID(kp=2.0, ti=2.0, ts=ts, u_min=-100, u_max=100, deadband=width, t_stab=t_stab)
    outs = []
    noise = [0.5 * math.sin(1.7 * k) for k in range(200)]
    k = 0
    while not pid.deadband_active:
        outs.append(pid(50.0, 50.0 + noise[k]))
        k += 1
        assert k < 50
    # active after |e| <= width for t_stab = 10 samples (first sample starts the time)
    assert k == 11
    held = sum(outs[-10:]) / 10  # moving average over t_stab/ts samples
    for j in range(20):
        assert pid(50.0, 50.0 + noise[k + j]) == pytest.approx(held, abs=1e-12)
    before = pid.out
    u = pid(50.0, 53.0)  # |e| = 3 > width: released
    assert not pid.deadband_active
    assert abs(u - before) < BUMP
    assert pid(50.0, 53.0) < u - 0.05  # and the controller acts again


def test_pv_and_sp_filters_are_first_order_lags_preset_to_the_first_value() -> None:
    ts, t_pv, t_sp = 0.1, 2.0, 0.5
    pid = PID(kp=1.0, ts=ts, pv_filter=t_pv, sp_filter=t_sp, u_min=-100, u_max=100)
    pid(10.0, 5.0)
    assert (pid.sp_w, pid.pv_f) == (10.0, 5.0)
    a_pv, a_sp = math.exp(-ts / t_pv), math.exp(-ts / t_sp)
    for k in range(1, 30):
        u = pid(20.0, 6.0)
        assert pid.pv_f == pytest.approx(6.0 - a_pv**k, abs=1e-12)
        assert pid.sp_w == pytest.approx(20.0 - 10.0 * a_sp**k, abs=1e-12)
        assert u == pytest.approx(pid.sp_w - pid.pv_f, abs=1e-12)


def test_setpoint_ramp_limits_the_rate_of_the_working_setpoint() -> None:
    pid = PID(kp=1.0, ts=0.1, sp_rate=4.0, u_min=-100, u_max=100)  # 0.4 per sample
    pid(10.0, 0.0)
    sps = []
    for _ in range(6):
        pid(11.0, 0.0)
        sps.append(pid.sp_w)
    assert sps == pytest.approx([10.4, 10.8, 11.0, 11.0, 11.0, 11.0], abs=1e-12)
