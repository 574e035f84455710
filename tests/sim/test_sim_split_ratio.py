"""The split-range and ratio structures in the simulator (the shipped scenarios and errors)."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from ctrlblocks.sim import ScenarioError, parse_scenario, simulate
from ctrlblocks.sim.report import load_shipped


@functools.cache
def _run(scenario: str, controller: str):
    (sc,) = load_shipped([scenario])
    return sc, simulate(sc, controller).signals


@pytest.mark.parametrize("controller", ["no gap", "gap 10 %", "overlap 10 %"])
def test_split_actuators_are_the_split_of_the_controller_output_every_sample(controller):
    sc, s = _run("split_range_heat_cool", controller)
    split = next(c for c in sc.controllers if c.name == controller).options["split"]
    ab = np.array([split(v) for v in s["u"]])
    np.testing.assert_array_equal(s["u_a"], ab[:, 0])
    np.testing.assert_array_equal(s["u_b"], ab[:, 1])
    # the steepest slope of the split bounds every actuator step by the controller's step
    slope = max(100.0 / (split.a_end - split.v_min), 100.0 / (split.v_max - split.b_start))
    du = np.abs(np.diff(s["u"]))
    assert np.all(np.abs(np.diff(s["u_a"])) <= slope * du + 1e-9)
    assert np.all(np.abs(np.diff(s["u_b"])) <= slope * du + 1e-9)


def test_handover_from_heater_to_cooler_has_no_bump_in_the_actuators_or_the_pv():
    """No gap: around the sample where the output crosses the split point (50 %)."""
    _, s = _run("split_range_heat_cool", "no gap")
    t, u = s["t"], s["u"]
    k = int(np.flatnonzero((t > 300.0) & (u < 50.0))[0])  # the heater hands over
    assert u[k - 1] >= 50.0 > u[k]
    assert s["u_b"][k - 1] > 0.0 == s["u_b"][k] and s["u_a"][k - 1] == 0.0 < s["u_a"][k]
    assert abs(s["u_a"][k] - s["u_a"][k - 1]) + abs(s["u_b"][k] - s["u_b"][k - 1]) < 0.2
    assert s["b_status"][k - 1] == 0.0 and s["b_status"][k] == 1.0  # heater active -> idle
    # the PV keeps the ramp's rate (-0.1 K/s): its curvature near the handover is as small as
    # in the rest of the ramp (the ramp's start, behind the dead time, gives 0.008 K)
    d2 = np.abs(np.diff(s["y"], 2))
    assert d2[k - 10 : k + 10].max() < 1e-3
    assert np.all(np.abs(np.diff(s["y"][k - 10 : k + 10]) + 0.1) < 0.01)


def test_ratio_setpoint_is_the_ratio_times_the_wild_flow_and_holds_on_a_fault():
    _, s = _run("ratio_blend", "ratio rate 0.05/s")
    t = s["t"]
    np.testing.assert_allclose(s["sp"], s["ratio"] * s["wild"], rtol=1e-12)
    k = int(np.argmin(np.abs(t - 30.0)))
    assert s["sp"][k] == pytest.approx(2.0 * 14.0) and s["sp_in"][k] == 2.0
    fault = (t >= 100.0) & (t < 120.0)
    assert np.all(s["wild_hold"][fault] == 1.0) and np.all(s["sp"][fault] == 35.0)
    assert np.all(s["wild"][fault] == 14.0)  # the last good wild flow
    k = int(np.argmin(np.abs(t - 120.0)))  # back: ratio 35 / 12, then down at 0.05/s
    assert s["ratio"][k] == pytest.approx(35.0 / 12.0 - 0.025)
    assert s["ratio_limited"][-1] == 1.0 and s["ratio"][-1] == 3.0 and s["sp"][-1] == 36.0


def test_ratio_at_once_jumps_where_the_rate_limited_station_does_not():
    _, a = _run("ratio_blend", "ratio at once")
    _, b = _run("ratio_blend", "ratio rate 0.05/s")
    assert np.abs(np.diff(a["sp"])).max() == pytest.approx(7.0)  # 14 * (2.5 - 2)
    assert np.abs(np.diff(b["sp"][(b["t"] > 50.0)])).max() <= 0.05 * 0.5 * 14.0 + 1e-12


HEAD = """
[scenario]
name = "x"
title = "x"
structure = "{structure}"
ts = 1.0
duration = 10.0
[plant]
type = "{plant}"
{plant_params}
[[controllers]]
name = "c"
[controllers.main]
type = "PID"
kp = 1.0
u_min = 0.0
u_max = 100.0
"""

HC = "k_heat = 0.6\nk_cool = 0.4\nt = 60.0"


def _scenario(structure="split_range", plant="HeatCool", params=HC, extra=""):
    return HEAD.format(structure=structure, plant=plant, plant_params=params) + extra


def test_split_range_needs_a_two_input_plant():
    sc = parse_scenario(_scenario(plant="PT1", params="k = 1.0\nt = 5.0"))
    with pytest.raises(ScenarioError, match=r"plant\.type: .*two MVs; PT1 has one input"):
        simulate(sc, "c")


def test_split_range_refuses_initial_y_and_a_wild_flow():
    with pytest.raises(ScenarioError, match=r"initial\.y: the split_range structure starts from"):
        parse_scenario(_scenario(extra="[initial]\ny = 30.0\n"))
    with pytest.raises(ScenarioError, match=r"initial\.wild: only for the ratio structure"):
        parse_scenario(_scenario(extra="[initial]\nwild = 3.0\n"))
    ev = '[[events]]\nt = 1.0\ndo = "wild"\nvalue = 2.0\n'
    with pytest.raises(ScenarioError, match=r"a 'wild' event \(t=1\) needs the ratio structure"):
        parse_scenario(_scenario(extra=ev))


def test_ratio_scenario_errors_name_the_key():
    text = _scenario("ratio", "PT1", "k = 1.0\nt = 5.0", "[controllers.ratio]\nrate = -1.0\n")
    with pytest.raises(ScenarioError, match=r"controllers\[0\]\.ratio\.rate: must be > 0"):
        parse_scenario(text)
    ev = '[[events]]\nt = 1.0\ndo = "wild"\nok = "no"\n'
    with pytest.raises(ScenarioError, match=r"events\[0\]\.ok: must be a bool"):
        parse_scenario(_scenario("ratio", "PT1", "k = 1.0\nt = 5.0", ev))
