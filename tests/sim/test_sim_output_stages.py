"""The pulse-width, three-step and gain-scheduled structures in the simulator."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from ctrlblocks.blocks.schedule import interpolate
from ctrlblocks.sim import ScenarioError, parse_scenario, simulate
from ctrlblocks.sim.report import load_shipped


@functools.cache
def _run(scenario: str, controller: str):
    (sc,) = load_shipped([scenario])
    return sc, simulate(sc, controller).signals


def test_pwm_mv_is_on_or_off_and_averages_the_controller_output():
    _, s = _run("pulse_width_heater", "PWM P = 4 s")
    assert set(np.unique(s["u"])) == {0.0, 100.0}
    t = s["t"]
    steady = (t >= 300.0) & (t < 396.0)  # 24 whole periods of 4 s at duty about 0.5
    assert s["u"][steady].mean() == pytest.approx(s["v_ctrl"][steady].mean(), abs=1.0)
    assert s["duty"][steady].mean() == pytest.approx(0.5, abs=0.02)
    _, c = _run("pulse_width_heater", "continuous heater")
    np.testing.assert_array_equal(c["u"], c["v_ctrl"])  # no pwm table: the output is the MV


def test_three_step_mv_is_open_close_or_stop_and_the_valve_follows_the_demand():
    _, s = _run("three_step_valve", "no position feedback")
    assert set(np.unique(s["u"])) <= {-1.0, 0.0, 1.0}
    assert s["pulses"][-1] == np.count_nonzero(np.diff(np.abs(s["u"])) > 0)
    assert abs(s["y2"][-1] - s["demand"][-1]) < 1.0  # within about the dead band
    assert np.all(s["position_est"] >= 0.0) and np.all(s["position_est"] <= 100.0)
    _, f = _run("three_step_valve", "position feedback")
    # with feedback the estimate is the position read at the sample's start, moved by this
    # sample's travel (0.1 s x 100 % / 30 s) when the motor runs
    assert np.max(f["est_error"]) <= 0.1 * 100.0 / 30.0 + 1e-9


def test_gain_schedule_retunes_for_the_setpoint_by_linear_interpolation():
    sc, s = _run("gain_schedule_three_tank", "scheduled on the setpoint")
    t = s["t"]
    k = int(np.argmin(np.abs(t - 200.0)))  # setpoint 2.2 bar
    assert s["w"][k] == 2.2
    assert s["kp"][k] == pytest.approx(2.35 + (2.3 - 2.35) * 0.4)  # 2.33
    assert s["ti"][k] == pytest.approx(7.0 + (6.0 - 7.0) * 0.4)  # 6.6
    sched = sc.controllers[2].options["schedule"]
    assert s["ti"][k] == interpolate(tuple(sched["breakpoints"]), tuple(sched["ti"]), 2.2)


HEAD = """
[scenario]
name = "x"
title = "x"
structure = "{structure}"
ts = 0.5
duration = 10.0
[plant]
type = "PT1"
k = 1.0
t = 5.0
{extra}
[[controllers]]
name = "c"
[controllers.main]
type = "PID"
kp = 1.0
ti = 5.0
u_min = 0.0
u_max = 100.0
"""


@pytest.mark.parametrize(
    ("structure", "table", "key", "problem"),
    [
        ("pulse_width", "[controllers.pwm]\nperiod = 0.1\n", "pwm.period", "must be >= ts"),
        ("pulse_width", "[controllers.pwm]\nperiodd = 4.0\n", "pwm.periodd", "unknown key"),
        ("scheduled", '[controllers.schedule]\non = "u"\nbreakpoints = [0.0]\nkp = [1.0]\n',
         "schedule.on", "must be 'sp' or 'y'"),
        ("scheduled", "[controllers.schedule]\nbreakpoints = [0.0, 1.0]\nkp = [1.0, -1.0]\n",
         "schedule.table at breakpoint 1.0: kp", "> 0"),
        ("scheduled", "[controllers.schedule]\nkp = [1.0]\n", "schedule", "needs breakpoints"),
        # not a parameter of the block: was a TypeError's text under schedule.table
        ("scheduled", "[controllers.schedule]\nbreakpoints = [0.0]\nkq = [1.0]\n", "schedule.kq",
         "unknown key 'kq'"),
    ],
)  # fmt: skip
def test_output_stage_and_schedule_errors_name_the_key(structure, table, key, problem):
    with pytest.raises(ScenarioError) as e:
        parse_scenario(HEAD.format(structure=structure, extra="") + table)
    assert e.value.key == f"controllers[0].{key}" and problem in e.value.problem, str(e.value)


def test_an_adrc_scheduled_on_the_measurement_keeps_acting():
    # refused before the ADRC's retune kept acting (it held its output for the sample of
    # every retune, so a schedule on y, which retunes every sample, froze it)
    adrc = HEAD.format(structure="scheduled", extra="").replace(
        'type = "PID"\nkp = 1.0\nti = 5.0',
        'type = "ADRC"\norder = 1\nb0 = 0.2\nomega_c = 0.5\nomega_o = 1.2',
    )
    sc = parse_scenario(
        adrc + '[controllers.schedule]\non = "y"\nbreakpoints = [0.0, 2.0]\n'
        'omega_c = [0.3, 0.6]\n[[events]]\nt = 1.0\ndo = "setpoint"\nvalue = 1.0\n'
    )
    s = simulate(sc, "c").signals
    moving = slice(3, None)  # from the sample after the setpoint step on, y moves
    assert np.all(np.diff(s["omega_c"][moving]) != 0.0)  # so it retunes every sample
    assert np.all(np.diff(s["u"][moving]) != 0.0)  # and the MV moves on in every one
    assert s["y"][-1] > 0.5  # towards the setpoint 1 (PT1 of 5 s, 9 s after the step)


def test_a_schedule_on_the_measurement_retunes_every_sample_and_keeps_acting():
    sc, s = _run("gain_schedule_three_tank", "scheduled on the measurement")
    sched = sc.controllers[3].options["schedule"]
    assert sched["on"] == "y"
    np.testing.assert_array_equal(s["w"], s["y"])  # w is the measurement of the sample
    u = s["u"]
    inside = (u[1:] > 0.0) & (u[1:] < 5.0) & (u[:-1] > 0.0) & (u[:-1] < 5.0)
    k = np.flatnonzero((np.diff(s["kp"]) != 0.0) & inside)  # retuned, MV off the limits
    assert k.size > 100  # retuned in most samples of the transients
    assert np.all(np.diff(u)[k] != 0.0)  # and the MV moves on in every one (no freeze)
    t = s["t"]
    j = int(np.argmin(np.abs(t - 240.0)))
    assert s["kp"][j] == interpolate(tuple(sched["breakpoints"]), tuple(sched["kp"]), s["y"][j])


def test_three_step_needs_the_valve_as_inner_plant_and_a_bool_feedback():
    valve = '[inner_plant]\ntype = "MotorValve"\ntravel_time = 10.0\n'
    text = HEAD.format(structure="three_step", extra=valve)
    with pytest.raises(ScenarioError, match="feedback: must be true or false"):
        parse_scenario(text + "[controllers.stepper]\nfeedback = 1\n")
    with pytest.raises(ScenarioError, match="inner_plant"):
        parse_scenario(HEAD.format(structure="three_step", extra=""))
    sc = parse_scenario(text + "[controllers.stepper]\ntravel_time = 10.0\nts = 0.5\n")
    assert simulate(sc, "c").signals["u"].shape == (20,)
