"""The process side of a scenario (ProcessSide): plant wiring, initial state, time line."""

from __future__ import annotations

import math

import pytest

from ctrlblocks.sim import ProcessSide, SetpointProfile, parse_scenario, simulate

SCENARIO = """
[scenario]
name = "proc"
title = "process side"
ts = 0.5
duration = 10.0

[plant]
type = "PT1"
k = 2.0
t = 4.0

[actuator]
u_min = 0.0
u_max = 10.0

[initial]
y = 3.0
load = 0.5

[[controllers]]
name = "PI"
type = "PID"
kp = 1.0
ti = 5.0
u_min = 0.0
u_max = 10.0

[[events]]
t = 1.0
do = "setpoint"
value = 4.0
ramp = 0.4

[[events]]
t = 1.0
do = "mode"
mode = "manual"

[[events]]
t = 2.0
do = "load"
value = 1.5

[[events]]
t = 3.0
do = "sensor"
ok = false
"""


def _side() -> ProcessSide:
    sc = parse_scenario(SCENARIO)
    return ProcessSide(sc, sc.cases[0].events)


def test_initial_y_gives_the_steady_state_mv_minus_the_load() -> None:
    side = _side()
    # y = k (u + load): u0 = 3 / 2 - 0.5
    assert side.u0 == pytest.approx(1.0, abs=1e-12)
    assert side.plant.y_true == pytest.approx(3.0, abs=1e-12)
    assert side.setpoint.value == pytest.approx(3.0, abs=1e-12)  # default: the initial output


def test_due_pops_the_events_within_half_a_sample() -> None:
    side = _side()
    assert side.due(0.0) == []
    due = side.due(0.5)  # t = 1.0 is more than half a sample (0.25 s) after 0.5
    assert due == []
    due = side.due(1.0)
    assert [e.kind for e in due] == ["setpoint", "mode"]
    assert [e.kind for e in side.pending] == ["load", "sensor"]


def test_apply_handles_process_events_and_leaves_controller_events() -> None:
    side = _side()
    setpoint, mode = side.due(1.0)
    assert side.apply(setpoint) is True
    assert side.apply(mode) is False
    # a ramp of 0.4/s from 3.0 towards 4.0: 0.2 per sample of 0.5 s
    assert side.setpoint.advance(0.5) == pytest.approx(3.2, abs=1e-12)
    (load,) = side.due(2.0)
    assert side.apply(load)
    assert side.actuator.load == 1.5
    (sensor,) = side.due(3.0)
    assert side.apply(sensor) and side.sensor_ok is False


def test_plant_steps_as_a_zero_order_hold_pt1() -> None:
    side = _side()
    side.plant.step(2.0)  # u + load = 2.5, k = 2: steady state 5.0
    a = math.exp(-0.5 / 4.0)
    assert side.plant.y_true == pytest.approx(3.0 * a + 5.0 * (1 - a), abs=1e-12)


def test_setpoint_profile_steps_without_a_ramp() -> None:
    sp = SetpointProfile(1.0)
    sp.step_to(2.0, 1.0)
    assert sp.advance(0.25) == pytest.approx(1.25)
    sp.step_to(-1.0, None)
    assert sp.value == -1.0 and sp.advance(0.25) == -1.0


def test_simulator_trace_follows_the_process_side_setpoint() -> None:
    run = simulate(parse_scenario(SCENARIO), "PI")
    sp = run.signals["sp"]
    # samples 0, 1: 3.0; t = 1.0: the event takes effect, ramp starts the next sample
    assert list(sp[:5]) == pytest.approx([3.0, 3.0, 3.0, 3.2, 3.4], abs=1e-12)
