"""Two-point and three-point on/off controllers: switching points, minimum times, bad data."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ctrlblocks import ErrorCode, ParameterError, ThreePoint, TwoPoint


def test_two_point_switches_at_sp_minus_and_plus_half_the_hysteresis() -> None:
    tp = TwoPoint(hysteresis=2.0, ts=1.0)
    # on at PV <= 19, off at PV >= 21, holds in between
    seq = [(20.5, 0.0), (19.01, 0.0), (19.0, 1.0), (20.0, 1.0), (20.99, 1.0), (21.0, 0.0),
           (19.5, 0.0)]  # fmt: skip
    assert [tp(20.0, pv) for pv, _ in seq] == [out for _, out in seq]


def test_two_point_cooling_action_mirrors_the_switching_points() -> None:
    tp = TwoPoint(hysteresis=2.0, reverse=True, ts=1.0)
    assert [tp(20.0, pv) for pv in (21.0, 20.0, 19.01, 19.0, 20.9)] == [1.0, 1.0, 1.0, 0.0, 0.0]


def test_two_point_limit_cycle_on_a_first_order_process_spans_the_hysteresis() -> None:
    # K/(T s + 1) with K = 100, T = 50 s, ts = 0.01 s: the PV moves at most 0.02 K a sample,
    # so it oscillates between the switching points 19.5 and 20.5 K (within one sample's move)
    tp = TwoPoint(hysteresis=1.0, ts=0.01)
    a = math.exp(-0.01 / 50.0)
    y, ys = 0.0, []
    for _ in range(100_000):
        u = tp(20.0, y)
        y = a * y + (1.0 - a) * 100.0 * u
        ys.append(y)
    tail = np.array(ys[50_000:])
    assert tail.min() == pytest.approx(19.5, abs=0.02)
    assert tail.max() == pytest.approx(20.5, abs=0.02)


def test_minimum_on_and_off_times_hold_the_output() -> None:
    tp = TwoPoint(hysteresis=0.0, t_min_on=0.3, t_min_off=0.2, ts=0.1)
    # one sample below the setpoint, then above: on for 3 samples (0.3 s); then below
    # again: off for 2 samples (0.2 s) before it switches on again
    outs = [tp(0.0, pv) for pv in (-1.0, 1.0, 1.0, 1.0, -1.0, -1.0, -1.0)]
    assert outs == [1.0, 1.0, 1.0, 0.0, 0.0, 1.0, 1.0]


@pytest.mark.parametrize("pv, ok, code", [(math.nan, True, ErrorCode.BAD_INPUT),
                                          (math.inf, True, ErrorCode.BAD_INPUT),
                                          (4e38, True, ErrorCode.BAD_INPUT),
                                          (19.0, False, ErrorCode.BAD_MEASUREMENT)])  # fmt: skip
def test_bad_pv_switches_off_at_once_and_recovers(pv: float, ok: bool, code: ErrorCode) -> None:
    tp = TwoPoint(hysteresis=1.0, t_min_on=100.0, ts=1.0)
    assert tp(20.0, 19.0) == 1.0
    assert tp(20.0, pv, pv_ok=ok) == 0.0  # the minimum on time does not hold a bad PV
    assert tp.error_id == code
    assert tp(20.0, 19.0) == 1.0  # the off time of the bad sample was 0 s: back on
    assert tp.error_id == ErrorCode.NO_ERROR


def test_three_point_neutral_zone_and_hysteresis() -> None:
    c = ThreePoint(deadband=1.0, hysteresis=0.4, ts=1.0)
    # e = SP - PV: +1 from e >= 1, held down to e >= 0.6; -1 from e <= -1, held up to -0.6
    seq = [(0.5, 0.0), (1.0, 1.0), (0.7, 1.0), (0.59, 0.0), (-0.9, 0.0), (-1.0, -1.0),
           (-0.61, -1.0), (-0.59, 0.0)]  # fmt: skip
    assert [c(e, 0.0) for e, _ in seq] == [out for _, out in seq]
    assert c.raise_out is False and c.lower_out is False


def test_three_point_reversal_passes_through_stop() -> None:
    c = ThreePoint(deadband=1.0, hysteresis=0.0, t_min_off=0.2, ts=0.1)
    outs = [c(e, 0.0) for e in (5.0, -5.0, -5.0, -5.0)]
    assert outs == [1.0, 0.0, 0.0, -1.0]  # two samples (0.2 s) at stop between the relays


def test_three_point_refuses_a_hysteresis_beyond_twice_the_deadband() -> None:
    c = ThreePoint(deadband=1.0, hysteresis=0.5)
    with pytest.raises(ParameterError) as e:
        c.configure(hysteresis=2.5)
    assert e.value.code == ErrorCode.BAD_LIMITS
    assert c.config.hysteresis == 0.5


@pytest.mark.parametrize("cls", [TwoPoint, ThreePoint])
def test_float32_lane_equals_float64_on_exact_switching_data(cls: type) -> None:
    # values exactly representable in float32: both lanes switch on the same samples
    a, b = cls(ts=0.5), cls(ts=0.5, precision="float32")
    rng = np.random.default_rng(3)
    for pv in rng.integers(-8, 9, 400) / 4.0:
        assert a(0.0, pv) == b(0.0, pv)


def test_huge_dt_saturates_the_time_in_state() -> None:
    tp = TwoPoint(hysteresis=1.0, ts=1.0)
    tp(0.0, -5.0, dt=1e308)
    snap = tp.snapshot()
    assert math.isfinite(snap["_mem"]["t_in"]) and snap["_mem"]["t_in"] <= 1e30
    assert tp.error_id == ErrorCode.NO_CYCLE  # a dt no REAL holds: not run
