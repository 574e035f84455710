"""The split-range function and the ratio station, against hand-evaluated numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ctrlblocks.blocks.base import ErrorCode, ParameterError
from ctrlblocks.loops import ControllerSide, parse_controller
from ctrlblocks.loops.ratio import RatioConfig, RatioStation
from ctrlblocks.loops.split import ACTIVE, IDLE, LIMIT, SplitRange

# -- split range -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("v", "a", "b"),
    [
        (0.0, 100.0, 0.0),  # full cooling at v_min
        (22.5, 50.0, 0.0),  # A halfway through [0, 45]
        (45.0, 0.0, 0.0),  # end of A's range
        (50.0, 0.0, 0.0),  # the split point, inside the gap
        (55.0, 0.0, 0.0),  # start of B's range
        (77.5, 0.0, 50.0),  # B halfway through [55, 100]
        (100.0, 0.0, 100.0),  # full heating at v_max
        (-5.0, 100.0, 0.0),  # outside the range: the end values
        (120.0, 0.0, 100.0),
    ],
)
def test_heat_cool_split_with_a_gap_of_10_at_chosen_points(v, a, b):
    s = SplitRange(gap=10.0)
    assert s.a_end == 45.0 and s.b_start == 55.0
    assert s(v) == pytest.approx((a, b), abs=1e-12)


def test_overlap_makes_both_actuators_act_around_the_split_point():
    s = SplitRange(split=40.0, gap=-20.0, a=(0.0, 100.0), b=(0.0, 100.0))  # two valves
    assert (s.a_end, s.b_start) == (50.0, 30.0)
    assert s(30.0) == pytest.approx((60.0, 0.0))
    assert s(40.0) == pytest.approx((80.0, 100.0 * 10.0 / 70.0))
    assert s(50.0) == pytest.approx((100.0, 200.0 / 7.0))
    assert s.status(40.0) == (ACTIVE, ACTIVE)


def test_split_values_are_continuous_across_every_breakpoint():
    """Both sides of the split point, the gap's and the overlap's ends agree to 1e-9."""
    for s in (SplitRange(), SplitRange(gap=10.0), SplitRange(gap=-10.0, split=30.0)):
        for p in (s.v_min, s.a_end, s.split, s.b_start, s.v_max):
            lo, hi = np.array(s(p - 1e-9)), np.array(s(p + 1e-9))
            assert np.max(np.abs(hi - lo)) < 1e-6
        # Lipschitz: no step larger than the steepest slope times the input step
        v = np.linspace(-10.0, 110.0, 24001)
        ab = np.array([s(x) for x in v])
        slope = max(100.0 / (s.a_end - s.v_min), 100.0 / (s.v_max - s.b_start))
        assert np.max(np.abs(np.diff(ab, axis=0))) <= slope * (v[1] - v[0]) * (1 + 1e-9)


def test_limit_status_of_each_actuator():
    s = SplitRange(gap=10.0)
    assert s.status(0.0) == (LIMIT, IDLE)  # the controller at its low limit: AW acts
    assert s.status(20.0) == (ACTIVE, IDLE)
    assert s.status(50.0) == (IDLE, IDLE)  # in the gap
    assert s.status(70.0) == (IDLE, ACTIVE)
    assert s.status(100.0) == (IDLE, LIMIT)
    assert s.status(math.nan) == (IDLE, IDLE)
    assert s(math.nan) == (0.0, 0.0)  # the split-side ends: heater and cooler off


@pytest.mark.parametrize(
    ("kw", "field"),
    [
        ({"v_min": 10.0, "v_max": 0.0}, "v_min"),
        ({"gap": 100.0}, "split"),
        ({"split": 0.0}, "split"),
        ({"split": 100.0}, "split"),
        ({"a": (5.0, 5.0)}, "a"),
        ({"b": (0.0,)}, "b"),
        ({"gap": math.nan}, "gap"),
    ],
)
def test_bad_split_is_refused_with_the_field(kw, field):
    with pytest.raises(ParameterError) as e:
        SplitRange(**kw)
    assert e.value.field == field


def _split_entry(**split):
    main = {"type": "PID", "kp": 2.0, "ti": 10.0, "u_min": 0.0, "u_max": 100.0}
    return {"name": "s", "main": main, "split": split}


def test_split_structure_takes_the_controllers_limits_as_the_combined_range():
    spec = parse_controller(_split_entry(gap=4.0), "split_range", 1.0, key="c")
    split = spec.options["split"]
    assert (split.v_min, split.v_max, split.split, split.gap) == (0.0, 100.0, 50.0, 4.0)
    side = ControllerSide("split_range", spec, 1.0)
    side.set_manual(True, 75.0)
    u = side.compute(20.0, 20.0)
    assert u == 75.0
    assert side.actuator_values() == pytest.approx((0.0, 100.0 * 23.0 / 48.0))
    assert side.values["a_status"] == IDLE and side.values["b_status"] == ACTIVE


def test_saturated_controller_reports_the_limit_and_does_not_wind_up():
    """Both actuators at their far ends only at the combined limits; the PI's AW acts there."""
    entry = _split_entry()
    entry["main"].update(kp=1.0, ti=1.0)
    side = ControllerSide("split_range", parse_controller(entry, "split_range", 1.0, key="c"), 1.0)
    for _ in range(50):  # a large error for 50 s: the output sits at 100 %
        side.step(100.0, 0.0)
    assert side.u == 100.0 and side.actuator_values() == (0.0, 100.0)
    assert (side.values["a_status"], side.values["b_status"]) == (IDLE, LIMIT)
    u = side.step(100.0, 110.0)  # the error reverses: the output leaves the limit at once
    assert 0.0 < u < 100.0 and side.values["b_status"] != LIMIT


def test_split_structure_refuses_infinite_limits_and_a_bad_split():
    entry = _split_entry()
    entry["main"]["u_min"] = -math.inf
    with pytest.raises(Exception, match="finite limits u_min and u_max"):
        parse_controller(entry, "split_range", 1.0, key="c")
    with pytest.raises(Exception, match=r"c\.split\.split") as e:
        parse_controller(_split_entry(split=120.0), "split_range", 1.0, key="c")
    assert "empty" in str(e.value)
    with pytest.raises(Exception, match=r"unknown key 'gapp'"):
        parse_controller(_split_entry(gapp=1.0), "split_range", 1.0, key="c")


# -- ratio station ----------------------------------------------------------------------


def test_ratio_station_setpoint_is_bias_plus_ratio_times_wild_flow():
    st = RatioStation(bias=0.5, ts=1.0)
    assert st(2.0, 10.0) == 20.5
    assert st(1.25, 8.0) == 10.5
    assert st.ratio == 1.25 and not st.limited and st.error_id == ErrorCode.NO_ERROR


def test_ratio_limits_clamp_the_request_and_flag_it():
    st = RatioStation(r_min=0.5, r_max=2.0, ts=1.0)
    assert st(3.0, 10.0) == 20.0 and st.limited
    assert st(0.1, 10.0) == 5.0 and st.limited
    assert st(1.0, 10.0) == 10.0 and not st.limited


def test_ratio_changes_ramp_at_the_rate():
    st = RatioStation(rate=0.1, ts=0.5)  # 0.05 per sample
    assert st(1.0, 10.0) == 10.0  # the first sample takes the request
    sps = [st(1.2, 10.0) for _ in range(5)]
    assert sps == pytest.approx([10.5, 11.0, 11.5, 12.0, 12.0])


def test_bad_wild_flow_holds_the_last_good_setpoint_with_a_status():
    st = RatioStation(ts=1.0)
    assert st(2.0, 10.0) == 20.0
    assert st(2.0, 99.0, wild_ok=False) == 20.0
    assert st.holding and st.error_id == ErrorCode.BAD_MEASUREMENT
    assert st(2.0, math.inf) == 20.0 and st.error_id == ErrorCode.BAD_INPUT
    assert st.wild == 10.0  # the last good wild flow


def test_recovery_back_calculates_the_ratio_so_the_setpoint_does_not_jump():
    st = RatioStation(rate=0.1, ts=1.0)
    st(2.0, 10.0)
    st(2.0, math.nan)
    sp = st(2.0, 16.0)  # wild flow back at 16: ratio 20/16 = 1.25, then +0.1 per sample
    assert sp == pytest.approx(1.35 * 16.0)
    assert not st.holding and st.error_id == ErrorCode.NO_ERROR
    assert st(2.0, 16.0) == pytest.approx(1.45 * 16.0)


def test_no_good_wild_flow_yet_gives_nan_and_a_bad_request_keeps_the_last():
    st = RatioStation(ts=1.0)
    assert math.isnan(st(2.0, math.nan))
    assert st(2.0, 5.0) == 10.0
    assert st(math.nan, 6.0) == 12.0 and st.error_id == ErrorCode.BAD_INPUT


def test_ratio_station_snapshot_restore_reproduces_the_trace():
    st = RatioStation(rate=0.2, r_max=3.0, ts=0.5)
    st(1.0, 4.0)
    snap = st.snapshot()
    a = [st(r, w) for r, w in ((2.0, 4.0), (2.0, math.nan), (5.0, 6.0))]
    st.restore(snap)
    assert [st(r, w) for r, w in ((2.0, 4.0), (2.0, math.nan), (5.0, 6.0))] == a


@pytest.mark.parametrize(
    ("kw", "field", "code"),
    [
        ({"r_min": 2.0, "r_max": 1.0}, "r_min", ErrorCode.BAD_LIMITS),
        ({"r_min": math.nan}, "r_min", ErrorCode.BAD_LIMITS),
        ({"rate": 0.0}, "rate", ErrorCode.BAD_RATE),
        ({"bias": math.inf}, "bias", ErrorCode.BAD_PARAMETER),
        ({"ts": 0.0}, "ts", ErrorCode.NO_CYCLE),
    ],
)
def test_bad_ratio_configuration_is_refused(kw, field, code):
    with pytest.raises(ParameterError) as e:
        RatioConfig(**kw)
    assert (e.value.field, e.value.code) == (field, code)


def test_ratio_structure_feeds_the_station_setpoint_to_the_flow_controller():
    main = {"type": "PID", "kp": 1.0, "ti": 5.0, "u_min": 0.0, "u_max": 100.0}
    entry = {"name": "r", "main": main, "ratio": {"r_min": 1.0, "r_max": 3.0}}
    spec = parse_controller(entry, "ratio", 0.5, key="c")
    side = ControllerSide("ratio", spec, 0.5)
    assert side.measurements == ("y", "w")
    side.compute(2.5, 20.0, w=10.0)
    assert side.values["sp_flow"] == 25.0 and side.blocks["main"].sp_w == 25.0
    side.update()
    side.compute(2.5, 20.0, w=12.0, w_ok=False)
    assert side.values["sp_flow"] == 25.0 and side.values["wild_hold"] == 1.0
    with pytest.raises(Exception, match=r"c\.ratio\.r_min"):
        parse_controller({**entry, "ratio": {"r_min": 4.0, "r_max": 3.0}}, "ratio", 0.5, key="c")
