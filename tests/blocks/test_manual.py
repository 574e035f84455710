"""ManualStation (Åström 1987, section 4, Fig. 4.5): rate, acceleration, tracking, bumpless."""

from __future__ import annotations

import math

import pytest

from ctrlblocks import ErrorCode, ManualStation, ParameterError
from ctrlblocks.blocks.manual import manual_travel


def _hold(ms: ManualStation, n: int, **buttons: bool) -> list[float]:
    return [ms(**buttons) for _ in range(n)]


def test_rate_while_held_without_acceleration_is_span_over_tm() -> None:
    ms = ManualStation(tm=20.0, span=100.0, accel_max=1.0, ts=0.1, y0=10.0)
    ys = _hold(ms, 30, inc=True)
    # 100 % in 20 s = 5 %/s = 0.5 % per sample
    assert ys[0] == pytest.approx(10.5, abs=1e-12)
    assert ys[-1] == pytest.approx(25.0, abs=1e-12)
    ys = _hold(ms, 10, dec=True)
    assert ys[-1] == pytest.approx(20.0, abs=1e-12)


def test_no_button_or_both_buttons_hold_the_output() -> None:
    ms = ManualStation(y0=40.0)
    assert _hold(ms, 5) == [40.0] * 5
    assert _hold(ms, 5, inc=True, dec=True) == [40.0] * 5


@pytest.mark.parametrize(
    ("seconds", "travel"),
    [
        # A(T) = T + T^2/(2 t_accel) with t_accel = 2 until the cap at T_c = 2 (3 - 1) = 4 s
        (1.0, 1.25),
        (2.0, 3.0),
        (4.0, 8.0),
        # after the cap: A = A(4) + 3 (T - 4)
        (6.0, 14.0),
    ],
)
def test_acceleration_law_travel_after_holding(seconds: float, travel: float) -> None:
    assert manual_travel(seconds, 2.0, 3.0) == pytest.approx(travel, abs=1e-12)
    ms = ManualStation(
        tm=10.0, span=10.0, t_accel=2.0, accel_max=3.0, out_min=-1e3, out_max=1e3, ts=0.05
    )
    ys = _hold(ms, round(seconds / 0.05), inc=True)
    # base rate 1 unit/s: the travel is A(T) units
    assert ys[-1] == pytest.approx(travel, abs=1e-9)


def test_rate_grows_while_held_and_restarts_after_release() -> None:
    ms = ManualStation(tm=10.0, span=10.0, t_accel=1.0, accel_max=4.0, out_max=1e3, ts=0.1)
    ys = [0.0, *_hold(ms, 40, inc=True)]
    rates = [(ys[k + 1] - ys[k]) / 0.1 for k in range(40)]
    # sample k covers held time [0.1 k, 0.1 (k+1)]: mean factor 1 + 0.1 (k + 0.5), capped at 4
    assert rates[0] == pytest.approx(1.05, abs=1e-9)
    assert rates[10] == pytest.approx(2.05, abs=1e-9)
    assert rates[35] == pytest.approx(4.0, abs=1e-9)
    ms(inc=False)
    assert (ms(inc=True) - ys[-1]) / 0.1 == pytest.approx(1.05, abs=1e-9)


def test_changing_direction_restarts_the_acceleration() -> None:
    ms = ManualStation(tm=10.0, span=10.0, t_accel=1.0, accel_max=4.0, ts=0.1, y0=50.0)
    _hold(ms, 20, inc=True)
    before = ms.out
    assert before - ms(dec=True) == pytest.approx(0.105, abs=1e-12)


def test_output_stays_in_its_range() -> None:
    ms = ManualStation(tm=1.0, span=100.0, ts=0.1, y0=95.0)
    assert _hold(ms, 5, inc=True)[-1] == 100.0
    assert _hold(ms, 30, dec=True)[-1] == 0.0


def test_tracking_follows_the_input_with_time_constant_tr() -> None:
    ms = ManualStation(tr=0.5, ts=0.1)
    ys = [ms(track=42.0) for _ in range(5)]
    # first-order approach, exact: 42 (1 - exp(-t/Tr)); t = 0.5 s = Tr
    assert ys[-1] == pytest.approx(42.0 * (1.0 - math.exp(-1.0)), abs=1e-12)
    assert ys[-1] == pytest.approx(26.549, abs=1e-3)
    assert ys[0] == pytest.approx(42.0 * (1.0 - math.exp(-0.2)), abs=1e-12)


def test_zero_tr_tracks_ideally() -> None:
    ms = ManualStation(tr=0.0)
    assert [ms(track=w) for w in (10.0, 55.5, 3.0)] == [10.0, 55.5, 3.0]


def test_manual_to_auto_to_manual_switch_is_bumpless() -> None:
    ms = ManualStation(tm=20.0, tr=0.2, ts=0.1, y0=20.0)
    # automatic: the PID output (a slow ramp) is applied and fed back as tracking input
    u = 0.0
    for k in range(100):
        u = 30.0 + 0.05 * k
        ms(track=u)
    # exact steady lag of a first-order tracker on a ramp of slope r per sample:
    # r * a / (1 - a), a = exp(-h/Tr)
    a = math.exp(-0.5)
    assert u - ms.out == pytest.approx(0.05 * a / (1.0 - a), abs=1e-9)
    # switch to manual: no button, no tracking -> the output stays where it was
    first_manual = ms()
    assert first_manual == ms.out
    assert abs(first_manual - u) < 0.08
    # the operator then moves it at the base rate 5 %/s
    assert ms(inc=True) - first_manual == pytest.approx(0.5 * (1 + 0.1 / 4), abs=1e-12)


def test_tracking_with_button_settles_at_offset_m_tr() -> None:
    # external saturation at 60 while the operator holds "increase": v settles at
    # w + m Tr (m the manual rate), not winding up further
    ms = ManualStation(tm=20.0, tr=0.4, accel_max=1.0, ts=0.1, y0=60.0)
    for _ in range(200):
        ms.update_state(60.0, inc=True)
    assert ms.out == pytest.approx(60.0 + 5.0 * 0.4, abs=1e-9)
    assert ms.compute_output() == ms.out


def test_nan_tracking_input_holds_and_recovers() -> None:
    ms = ManualStation(tr=0.0, y0=12.0)
    assert ms(track=math.nan) == 12.0
    assert ms.error_id == ErrorCode.BAD_INPUT
    assert ms(track=13.0) == 13.0 and ms.error_id == ErrorCode.NO_ERROR


@pytest.mark.parametrize("dt", [0.0, -0.1, math.nan, math.inf])
def test_bad_dt_gives_no_cycle_and_the_previous_output(dt: float) -> None:
    ms = ManualStation(y0=30.0)
    assert ms(inc=True, dt=dt) == 30.0 and ms.error_id == ErrorCode.NO_CYCLE


def test_per_call_dt() -> None:
    ms = ManualStation(tm=20.0, accel_max=1.0, ts=0.1)
    assert ms(inc=True, dt=0.4) == pytest.approx(2.0, abs=1e-12)


def test_narrowing_the_range_limits_the_output_at_once() -> None:
    ms = ManualStation(y0=80.0)
    ms.configure(out_max=50.0)
    assert ms.out == 50.0


@pytest.mark.parametrize(
    ("params", "code"),
    [
        ({"tm": 0.0}, ErrorCode.BAD_TIME_CONSTANT),
        ({"tr": -1.0}, ErrorCode.BACK_CALC_T),
        ({"t_accel": 0.0}, ErrorCode.BAD_TIME_CONSTANT),
        ({"accel_max": 0.5}, ErrorCode.BAD_PARAMETER),
        ({"span": -100.0}, ErrorCode.BAD_PARAMETER),
        ({"out_min": 100.0, "out_max": 0.0}, ErrorCode.BAD_LIMITS),
        ({"ts": -0.1}, ErrorCode.NO_CYCLE),
    ],
)
def test_bad_configuration_has_its_code(params: dict, code: ErrorCode) -> None:
    with pytest.raises(ParameterError) as info:
        ManualStation(**params)
    assert info.value.code == code
