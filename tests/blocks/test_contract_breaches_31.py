"""The contract breaches left after issue 12 (issue 31), one test each; each failed before its fix.

The class behind them: extreme-magnitude arithmetic in a running sum or an
accumulator (a time held, a sum of squares, a window's sum, a run time) and a
state updated where the output did not need it (an observer in MAN, the
anti-backoff wait, a PID's derivative in a mode's hold). The fuzz campaign now
checks a finite state after every action and each block's own oracle
(``ctrlblocks.testing``, promises 7 and 8).
"""

from __future__ import annotations

import math
import statistics

import pytest

from ctrlblocks import (
    ADRC,
    PID,
    CycleMonitor,
    ErrorCode,
    ManualStation,
    Mode,
    MovingAverage,
    SteadyStateDetector,
    StepController,
)
from ctrlblocks.blocks.manual import manual_increment, manual_travel

MAX = 1.7976931348623157e308


def _finite_state(block) -> bool:
    def fin(x) -> bool:
        if isinstance(x, float):
            return math.isfinite(x)
        if isinstance(x, dict):
            return all(fin(v) for v in x.values())
        if isinstance(x, list | tuple):
            return all(fin(v) for v in x)
        return True

    return fin(block.snapshot())


# --- ManualStation: a button held through one absurd dt -----------------------------


def test_manual_station_held_through_an_absurd_dt_keeps_running_and_tracking() -> None:
    ms = ManualStation(tm=20.0, span=100.0, t_accel=2.0, accel_max=5.0, tr=0.0)
    ms(inc=True)
    assert ms(inc=True, dt=1.7e308) == 100.0  # travels to the top of the range
    assert math.isfinite(ms.held) and ms.error_id == ErrorCode.NO_ERROR
    ms.configure(out_max=200.0)
    assert ms(inc=True) == pytest.approx(100.0 + 5.0 * 0.1 * 5.0)  # still held: top rate
    assert ms.error_id == ErrorCode.NO_ERROR and math.isfinite(ms.held)
    ms.configure(out_max=100.0)
    ms(dec=True)  # a new button: at the base rate again, not NaN
    assert ms.out == pytest.approx(100.0 - 5.0 * manual_travel(0.1, 2.0, 5.0))
    assert ms(track=37.5) == 37.5 and ms.error_id == ErrorCode.NO_ERROR  # tracking works
    for _ in range(3):
        ms(inc=True, dt=MAX)  # held time saturates, never inf
    assert ms.held == MAX and ms.out == 100.0 and _finite_state(ms)


def test_manual_increment_is_the_difference_of_travels_and_exact_for_any_hold_time() -> None:
    for tau, h in [(0.0, 0.1), (3.95, 0.1), (8.0, 0.5), (7.9, 0.2), (0.0, 100.0)]:
        assert manual_increment(tau, h, 2.0, 5.0) == pytest.approx(
            manual_travel(tau + h, 2.0, 5.0) - manual_travel(tau, 2.0, 5.0), rel=1e-12
        )
    # held for 1e300 s: the difference of two travels is 0 (or NaN); the integral is 5 h
    assert manual_travel(1e300 + 0.1, 2.0, 5.0) - manual_travel(1e300, 2.0, 5.0) == 0.0
    assert manual_increment(1e300, 0.1, 2.0, 5.0) == 5.0 * 0.1


# --- CycleMonitor ---------------------------------------------------------------------


def test_cycle_monitor_jitter_std_stays_finite_for_huge_cycle_times() -> None:
    mon = CycleMonitor(ts=0.1)
    times = [0.1, 0.12, 2e154, 0.09, 1.7e308, 0.1]
    for t in times:
        mon(t)
    scaled = [t / 1e300 for t in times]
    assert mon.jitter_std == pytest.approx(statistics.pstdev(scaled) * 1e300, rel=1e-12)
    assert mon.mean == pytest.approx(statistics.fmean(scaled) * 1e300, rel=1e-12)


def test_cycle_monitor_jitter_std_is_welford_on_ordinary_times() -> None:
    mon = CycleMonitor(ts=0.01)
    times = [0.010, 0.011, 0.013, 0.009, 0.025, 0.0101, 0.0099]
    for t in times:
        mon(t)
    assert mon.jitter_std == pytest.approx(statistics.pstdev(times), rel=1e-13)


def test_cycle_monitor_acknowledge_keeps_flags_whose_cause_is_present() -> None:
    mon = CycleMonitor(ts=0.1, warn_limit=0.15, alarm_limit=0.2)
    mon(0.5)  # not latched: the flags are the live condition
    mon.acknowledge()
    assert (mon.warning, mon.alarm) == (True, True)
    mon(0.1)
    assert (mon.warning, mon.alarm) == (False, False)
    latched = CycleMonitor(ts=0.1, warn_limit=0.15, alarm_limit=0.2, latch=True)
    latched(0.5)
    latched(0.17)  # still above the warning limit, no longer above the alarm limit
    latched.acknowledge()
    assert (latched.warning, latched.alarm) == (True, False)
    latched(0.1)
    assert (latched.warning, latched.alarm) == (True, False)  # latched until acknowledged
    latched.acknowledge()
    assert (latched.warning, latched.alarm) == (False, False)


def test_cycle_monitor_new_limits_re_evaluate_the_flags() -> None:
    mon = CycleMonitor(ts=0.1)
    mon(0.18)
    assert (mon.warning, mon.alarm) == (True, False)
    mon.configure(alarm_limit=0.17)
    assert (mon.warning, mon.alarm) == (True, True)


def test_cycle_monitor_restores_a_snapshot_of_before_the_scaled_sum() -> None:
    mon = CycleMonitor(ts=0.1)
    for t in (0.1, 0.2, 0.3):
        mon(t)
    snap = mon.snapshot()
    old = {k: v for k, v in snap.items() if k not in ("_scale", "_q")}
    old["_m2"] = sum((t - 0.2) ** 2 for t in (0.1, 0.2, 0.3))
    twin = CycleMonitor(ts=0.1)
    twin.restore(old)
    assert twin.jitter_std == pytest.approx(mon.jitter_std, rel=1e-12)


# --- MovingAverage: one huge sample -----------------------------------------------


def test_moving_average_keeps_the_small_values_after_a_huge_sample_leaves() -> None:
    ma = MovingAverage(n=1000)
    for _ in range(100):
        ma(0.25)
    ma(1e300)
    for _ in range(999):
        ma(0.5)
    assert ma.out == pytest.approx(1e297)  # the huge sample is still in the window
    assert ma(0.5) == 0.5  # it left: the mean of 1000 samples of 0.5, not 0.0
    for k in range(1, 50):
        assert ma(0.5 + k) == pytest.approx((999 * 0.5 + sum(0.5 + j for j in range(1, k + 1)) -
                                             0.5 * (k - 1)) / 1000, rel=1e-12)  # fmt: skip


def test_moving_average_running_sum_is_unchanged_on_ordinary_data() -> None:
    ma = MovingAverage(n=7)
    xs = [math.sin(0.3 * k) * 50.0 + 20.0 for k in range(200)]
    out = [ma(x) for x in xs]
    s, expect = 0.0, []  # the plain running sum, recomputed with fsum once per window
    buf = [0.0] * 7
    for k, x in enumerate(xs):
        s += x - buf[k % 7]
        buf[k % 7] = x
        if (k + 1) % 7 == 0:
            s = math.fsum(buf)
        expect.append(s / min(k + 1, 7))
    assert out == expect


# --- ADRC: the observer state in MAN and in the anti-backoff wait ----------------------


def test_adrc_in_manual_restarts_an_overflowed_observer_and_says_so() -> None:
    a = ADRC(order=2, b0=1.0, omega_c=1.0, omega_o=4.0, ts=0.1)
    a.manual, a.u_man = True, 1.0
    a(0.0, 0.0)
    assert a(0.0, 1e308) == 1.0  # the manual value stands
    assert a.error_id == ErrorCode.BAD_RESULT  # and the lost observer is reported
    assert all(math.isfinite(v) for v in a.x) and _finite_state(a)
    assert a(0.0, 0.5) == 1.0 and a.error_id == ErrorCode.NO_ERROR
    a.manual = False
    assert a(0.0, 0.5) == pytest.approx(1.0, abs=1e-9)  # bumpless to AUTO


def test_adrc_in_the_anti_backoff_wait_never_keeps_a_nan_observer() -> None:
    a = ADRC(order=1, b0=1.0, omega_c=1.0, omega_o=5.0, ts=0.1, anti_backoff=True, y_sat=10.0,
             u_min=-5.0, u_max=5.0)  # fmt: skip
    for y in (0.0, 10.0, 10.0, 5.0):  # reach the sensor limit and leave it: the wait
        a(0.0, y)
    assert a._ab_wait > 0.0
    for y in (1e308, -1e308, 1e308):
        a(0.0, y)
        assert _finite_state(a) and math.isfinite(a.out)
        assert a.error_id != ErrorCode.NO_ERROR or all(math.isfinite(v) for v in a.x)


def test_float32_adrc_restarts_an_overflowed_observer_too() -> None:
    a = ADRC(order=2, b0=1.0, omega_c=1.0, omega_o=4.0, ts=0.1, precision="float32")
    a.manual, a.u_man = True, 1.0
    a(0.0, 0.0)
    assert a(0.0, 3e38) == 1.0
    assert a.error_id == ErrorCode.BAD_RESULT and _finite_state(a)


def test_float32_blocks_refuse_parameters_a_real_cannot_hold() -> None:
    with pytest.raises(Exception, match="range of REAL"):
        ADRC(b0=1e308, precision="float32")
    with pytest.raises(Exception, match="range of REAL"):
        PID(kp=1e-60, precision="float32")
    a = ADRC(precision="float32")
    a(1.0, 0.0)
    out = a.out
    assert a(1.0, 0.0, dt=1e300) == out and a.error_id == ErrorCode.NO_CYCLE  # TS beyond REAL


# --- the same class in the other accumulating blocks -----------------------------------


def test_pid_in_a_mode_hold_with_an_absurd_dt_keeps_a_finite_memory() -> None:
    pid = PID(kp=1.0, ti=1.0, td=0.5, n=10.0, ts=0.01, derivative_method="forward",
              u_min=0.0, u_max=100.0, reset_value=10.0)  # fmt: skip
    pid(1.0, 0.0)
    pid.reset_active = True
    assert pid.mode == Mode.RESET
    assert pid(1.0, 0.5, dt=MAX) == 10.0
    assert pid.error_id == ErrorCode.BAD_RESULT and _finite_state(pid)
    pid.reset_active = False
    v = pid(1.0, 0.5)
    assert v == pytest.approx(10.0, abs=1e-9) and pid.error_id == ErrorCode.NO_ERROR


def test_step_controller_and_steady_detector_clocks_saturate() -> None:
    sc = StepController(travel_time=60.0, span=100.0, ts=1.0)
    for _ in range(4):
        sc(80.0, dt=MAX)
    assert _finite_state(sc) and 0.0 <= sc.position <= 100.0
    det = SteadyStateDetector(tolerance=1.0, t_stab=2.0, ts=0.1)
    for _ in range(4):
        det(1.0, dt=MAX)
    assert det.steady and _finite_state(det)
