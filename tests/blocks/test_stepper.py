"""StepController: three-point OPEN/CLOSE pulses for a motorised valve (Åström 1987, Fig. 2.2)."""

from __future__ import annotations

import math

import pytest

from ctrlblocks import PID, ErrorCode, ParameterError, StepController
from ctrlblocks.plants import FOPDT, MotorValve


def _sc(position: float = 50.0, **kw: float) -> StepController:
    params = {"travel_time": 10.0, "min_pulse": 0.2, "min_pause": 0.3, "deadband": 1.0, "ts": 0.1}
    params.update(kw)
    sc = StepController(**params)
    sc.preset_position(position)
    return sc


def test_a_demand_at_the_estimated_position_gives_no_pulse() -> None:
    sc = _sc(position=73.0)
    assert sc(73.0) == 0.0
    assert sc.pending == 0.0 and sc.pulses == 0


def test_the_estimate_starts_at_mid_travel() -> None:
    assert StepController(ts=0.1).position == 50.0


def test_a_demand_step_gives_one_pulse_of_the_owed_travel() -> None:
    sc = _sc(position=20.0)  # 1 % per sample
    sc(20.0)
    out = [sc(27.0) for _ in range(12)]
    assert out == [1.0] * 7 + [0.0] * 5
    assert sc.pulses == 1
    assert sc.position == pytest.approx(27.0, abs=1e-12)
    assert sc.open_cmd is False and sc.close_cmd is False


def test_the_pending_travel_sums_the_demand_increments() -> None:
    """Åström 1987 Fig. 2.2: the motor integrates; the block sends the increments."""
    sc = _sc(position=50.0, deadband=100.0)  # a dead band so wide that nothing moves
    for u in (50.0, 51.0, 50.5, 53.0, 52.0):
        sc(u)
    assert sc.pending == pytest.approx((51 - 50) + (50.5 - 51) + (53 - 50.5) + (52 - 53))


def test_travel_below_the_dead_band_starts_no_pulse() -> None:
    sc = _sc(deadband=2.0)
    sc(50.0)
    assert [sc(51.9) for _ in range(5)] == [0.0] * 5
    assert sc.pending == pytest.approx(1.9)
    assert sc(52.1) == 1.0  # 2.1 % owed: above the dead band


def test_a_short_demand_gets_the_minimum_pulse() -> None:
    sc = _sc(min_pulse=0.5, deadband=0.0)  # minimum pulse: 5 samples = 5 %
    sc(50.0)
    out = [sc(53.0) for _ in range(8)]
    assert out[:5] == [1.0] * 5 and out[5:] == [0.0] * 3
    assert sc.pending == pytest.approx(-2.0)  # over-travel, less than half a min pulse
    assert [sc(53.0) for _ in range(20)] == [0.0] * 20  # ... so no hunting back


def test_the_pause_separates_pulses_and_a_reversal() -> None:
    sc = _sc(min_pause=0.5, deadband=0.0, min_pulse=0.1)
    sc(50.0)
    out = [sc(52.0) for _ in range(2)]  # 2 % owed: 2 samples open
    out += [sc(40.0) for _ in range(20)]  # now 12 % the other way
    assert out[:2] == [1.0, 1.0]
    first_close = out.index(-1.0)
    assert first_close - 2 >= 5  # 0.5 s pause = 5 samples after the pulse
    assert out.count(-1.0) == 12


def test_end_switch_stops_the_motor_and_drops_the_owed_travel() -> None:
    sc = _sc()
    sc(50.0)
    assert sc(60.0) == 1.0
    assert sc(100.0, open_limit=True) == 0.0  # the switch: the valve is fully open
    assert sc.pending == 0.0 and sc.position == 100.0
    assert [sc(100.0, open_limit=True) for _ in range(5)] == [0.0] * 5  # nothing winds up
    assert sc.pending == 0.0 and sc.pulses == 1
    out = [sc(70.0) for _ in range(5)]
    assert out == [-1.0] * 5  # a closing demand is served at once (the pause is over)


def test_a_demand_at_the_range_end_runs_on_to_the_stop() -> None:
    sc = _sc(position=99.5)  # the estimate believes the valve is nearly open
    out = [sc(100.0) for _ in range(10)]
    assert out == [1.0] * 10  # it keeps opening: the estimate may have drifted
    assert sc(100.0, open_limit=True) == 0.0
    sc = _sc(position=0.2)
    assert [sc(0.0) for _ in range(5)] == [-1.0] * 5
    assert sc(0.0, close_limit=True) == 0.0


def test_position_feedback_makes_the_pending_travel_the_position_error() -> None:
    sc = _sc()
    assert sc(40.0, feedback=30.0) == 1.0
    assert sc.pending == pytest.approx(9.0)  # 10 owed, one sample travelled
    assert sc(40.0, feedback=39.8) == 1.0  # still inside the minimum pulse (0.2 s)
    assert sc(40.0, feedback=40.6) == 0.0  # 0.6 % too far: below the start threshold
    assert sc.pending == pytest.approx(-0.6) and sc.pulses == 1


def test_manual_drives_the_motor_and_the_return_is_bumpless_at_the_tracked_position() -> None:
    sc = _sc()
    sc(50.0)
    sc.manual, sc.manual_command = True, -1
    assert [sc(80.0) for _ in range(3)] == [-1.0] * 3  # the operator closes; demand ignored
    assert sc.position == pytest.approx(47.0)
    sc.manual_command = 0
    sc(80.0)
    sc.manual = False
    assert sc(sc.position) == 0.0  # a controller that tracked the position: no pulse
    assert sc.pulses == 0
    assert sc(60.0) == 1.0  # the demand is a position: a different one is served


def test_bad_demand_and_bad_feedback_stop_the_motor_and_recover() -> None:
    sc = _sc()
    sc(50.0)
    assert sc(60.0) == 1.0
    assert sc(math.nan) == 0.0 and sc.error_id == ErrorCode.BAD_INPUT
    assert sc(60.0, feedback=math.inf) == 0.0 and sc.error_id == ErrorCode.BAD_MEASUREMENT
    assert sc(60.0, dt=-1.0) == 0.0 and sc.error_id == ErrorCode.NO_CYCLE
    assert sc(60.0) == 1.0 and sc.error_id == ErrorCode.NO_ERROR


def test_bad_configuration_is_refused_with_its_code() -> None:
    sc = _sc()
    with pytest.raises(ParameterError) as info:
        sc.configure(travel_time=0.0)
    assert info.value.code == ErrorCode.BAD_TIME_CONSTANT
    assert sc.config.travel_time == 10.0


def _valve_loop(
    n: int, noise: float = 0.0, deadband: float = 0.5
) -> tuple[list[float], StepController, PID]:
    """PID -> step controller -> motorised valve (30 s travel) -> FOPDT process."""
    ts = 0.1
    pid = PID(kp=1.5, ti=40.0, ts=ts, u_min=0.0, u_max=100.0)
    sc = StepController(travel_time=30.0, min_pulse=0.3, min_pause=0.5, deadband=deadband, ts=ts)
    valve = MotorValve(travel_time=30.0, ts=ts, x0=20.0)
    proc = FOPDT(k=1.0, t=60.0, dead_time=5.0, ts=ts)
    proc.reset(20.0)
    sc.preset_position(20.0)
    ys = []
    import random

    rnd = random.Random(1)
    for k in range(n):
        sp = 20.0 if k < 100 else 50.0
        y = proc.y + noise * rnd.gauss(0.0, 1.0)
        u = pid(sp, y)
        cmd = sc(u, open_limit=valve.open_limit, close_limit=valve.close_limit)
        proc.step(valve.step(cmd))
        ys.append(proc.y)
    return ys, sc, pid


def test_the_valve_loop_tracks_the_setpoint_with_few_pulses() -> None:
    ys, sc, _ = _valve_loop(6000)  # 600 s
    assert abs(ys[-1] - 50.0) < 1.0  # within twice the dead band's effect on the process
    assert max(ys) < 50.0 * 1.25
    # the pulse count is bounded by the dead band: a few dozen, not one per sample
    assert sc.pulses < 100


def test_pulse_count_is_bounded_and_a_dead_band_sized_to_the_noise_keeps_it_small() -> None:
    bound = 600.0 / (0.3 + 0.5)  # at most T / (min_pulse + min_pause) pulses in 600 s
    # PV noise sigma 0.2 % through kp = 1.5: the demand jitters by 0.3 % (1 sigma)
    _, narrow, _ = _valve_loop(6000, noise=0.2, deadband=0.5)
    ys, wide, _ = _valve_loop(6000, noise=0.2, deadband=1.0)  # > 3 sigma of the demand
    assert narrow.pulses <= bound
    assert narrow.pulses > 400  # a dead band inside the noise: the motor works constantly
    assert wide.pulses < 100
    assert abs(sum(ys[3000:]) / 3000 - 50.0) < 0.1  # and the loop still holds its setpoint
