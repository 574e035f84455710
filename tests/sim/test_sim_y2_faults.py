"""Sensor faults of the inner measurement ``y2`` in scenarios (``sensor`` events, ``target``).

The scenario language reads ``target = "y2"`` on a ``sensor`` event (default
``"y"``), refuses it with the key path and the line where no controller
measures ``y2``, and the process side gives the controllers a flagged or a
NaN ``y2`` while the plants keep running on the true one.  The cascade's
rule for a bad ``y2`` (the primary holds its last output,
``Cascade.follow_value``) is checked end to end in
tests/sim/test_dispatch_structures.py on both engines.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import tomllib

from ctrlblocks.sim import PlantProcess, ProcessSide, parse_scenario, run_scenario, simulate
from ctrlblocks.sim.report import load_shipped
from ctrlblocks.sim.scenario import ScenarioError, parse_scenario_doc

CASCADE = """\
[scenario]
name = "y2"
title = "y2 faults"
structure = "cascade"
ts = 0.1
duration = 40.0

[inner_plant]
type = "PT1"
k = 1.0
t = 1.5

[plant]
type = "FOPDT"
k = 1.5
t = 8.0
dead_time = 1.0

[initial]
y = 0.5

[[controllers]]
name = "c"
[controllers.primary]
type = "PID"
kp = 1.5
ti = 8.0
[controllers.secondary]
type = "PID"
kp = 2.0
ti = 1.0

[[events]]
t = 10.0
do = "sensor"
target = "y2"
nan = true

[[events]]
t = 20.0
do = "sensor"
target = "y2"
nan = false
ok = false

[[events]]
t = 30.0
do = "sensor"
target = "y2"
ok = true

[[events]]
t = 5.0
do = "setpoint"
value = 1.0
"""


def error_of(text: str) -> ScenarioError:
    with pytest.raises(ScenarioError) as e:
        parse_scenario(text, file="bad.toml")
    return e.value


def line_of(text: str, written: str, nth: int = 0) -> int:
    return [i + 1 for i, s in enumerate(text.splitlines()) if s == written][nth]


# -- the language ----------------------------------------------------------------------


def test_a_y2_sensor_event_parses_with_its_target_and_label() -> None:
    sc = parse_scenario(CASCADE)
    evs = [e for e in sc.cases[0].events if e.kind == "sensor"]
    assert [e.fields.get("target") for e in evs] == ["y2"] * 3
    assert [e.label for e in evs] == ["y2 sensor NaN", "y2 sensor fault", "y2 sensor ok"]
    # without a target: y, as before (labels unchanged)
    sc = parse_scenario(CASCADE.replace('target = "y2"\nnan = true', "nan = true"))
    assert "target" not in sc.cases[0].events[1].fields
    assert sc.cases[0].events[1].label == "sensor NaN"


def test_an_unknown_target_lists_the_valid_ones_with_key_path_and_line() -> None:
    text = CASCADE.replace('target = "y2"\nnan = true', 'target = "y3"\nnan = true')
    e = error_of(text)
    assert (e.key, e.line) == ("events[0].target", line_of(text, 'target = "y3"'))
    assert e.problem == "unknown target 'y3'; expected one of: y, y2"
    assert str(e).startswith(f"bad.toml, line {e.line}: events[0].target: unknown target")
    e = error_of(CASCADE.replace('target = "y2"\nnan = true', "target = 2\nnan = true"))
    assert e.key == "events[0].target" and "must be a str, got" in e.problem


def test_y2_is_refused_where_no_controller_measures_it() -> None:
    single = (
        CASCADE.replace('structure = "cascade"', 'structure = "single"')
        .replace('[inner_plant]\ntype = "PT1"\nk = 1.0\nt = 1.5\n', "")
        .replace("[controllers.primary]\n", "")
        .replace('[controllers.secondary]\ntype = "PID"\nkp = 2.0\nti = 1.0\n', "")
    )
    parse_scenario(single.replace('target = "y2"\n', ""))  # the same file on y is fine
    e = error_of(single)
    assert (e.key, e.line) == ("events[0].target", line_of(single, 'target = "y2"'))
    assert "'y2' needs a controller that measures y2" in e.problem
    assert e.problem.endswith("the controllers here measure y")
    # an override whose blocks all measure y: refused; one block on y2: accepted
    override = CASCADE.replace('structure = "cascade"', 'structure = "override"').replace(
        "[controllers.primary]\n", "[[controllers.blocks]]\n"
    ).replace("[controllers.secondary]\n", "[[controllers.blocks]]\n")
    e = error_of(override)
    assert e.key == "events[0].target" and "needs a controller that measures y2" in e.problem
    on_y2 = override.replace("kp = 2.0\n", 'kp = 2.0\nmeasure = "y2"\n')
    assert parse_scenario(on_y2).cases[0].events[1].fields["target"] == "y2"
    # in a case's own time line: the key path names the case
    case = single.replace("[[events]]", "[[cases.events]]").replace(
        "[[cases.events]]", '[[cases]]\nname = "a"\n[[cases.events]]', 1
    )
    e = error_of(case)
    assert e.key == "cases[0].events[0].target" and e.line == line_of(case, 'target = "y2"')


# -- the process side ---------------------------------------------------------------------


def test_the_process_side_gives_a_bad_y2_and_keeps_the_plants_on_the_true_one() -> None:
    sc = parse_scenario(CASCADE)
    proc = ProcessSide(sc, sc.cases[0].events)
    seen = []
    for k in range(400):
        for ev in proc.due(k * sc.ts):
            assert proc.apply(ev)  # process events
        seen.append((proc.inner.y, proc.y2_measured, proc.sensor2_ok, proc.sensor_ok))
        proc.step(0.7)
    y2, y2m, ok2, ok = (np.array(c, dtype=float) for c in zip(*seen, strict=True))
    t = np.arange(400) * sc.ts
    nan = (t >= 10.0 - 1e-9) & (t < 20.0 - 1e-9)
    flag = (t >= 20.0 - 1e-9) & (t < 30.0 - 1e-9)
    assert np.all(np.isnan(y2m[nan])) and np.all(np.isfinite(y2m[~nan]))
    assert np.array_equal(y2m[~nan], y2[~nan]) and np.all(ok2[flag] == 0.0)
    assert np.all(ok2[~flag] == 1.0) and np.all(ok == 1.0)  # y is not touched
    # the inner plant ran on the MV throughout: 0.7 (1 - e^(-t/1.5)) from 0.5 / 1.5
    assert y2[-1] == pytest.approx(0.7, abs=1e-6) and np.all(np.isfinite(y2))


def test_the_plant_server_serves_a_bad_y2_as_nan() -> None:
    sc = parse_scenario(CASCADE)
    plant = PlantProcess(sc)
    pv2 = []
    for _ in range(400):
        pv2.append(plant.values()["pv2"])
        plant.step(0.7)
    pv2 = np.array(pv2)
    t = np.arange(400) * sc.ts
    bad = (t >= 10.0 - 1e-9) & (t < 30.0 - 1e-9)  # NaN, then flagged
    assert np.all(np.isnan(pv2[bad])) and np.all(np.isfinite(pv2[~bad]))
    assert plant.sensor_ok  # pv (y) stays good


def test_the_opcua_plant_server_gives_pv2_a_bad_status_during_a_y2_fault() -> None:
    pytest.importorskip("asyncua")
    from asyncua import ua

    from ctrlblocks.runtime.plant_server import PlantServer

    plant = PlantProcess(parse_scenario(CASCADE))
    server = PlantServer(plant, opcua_port=None, modbus_port=None)
    read_pv, read_pv2 = (server._opcua_reader(n, ua.VariantType.Double) for n in ("pv", "pv2"))
    statuses = []
    for _ in range(400):
        statuses.append((read_pv(None, None).StatusCode.is_good(),
                         read_pv2(None, None).StatusCode.is_good(), plant.sensor2_ok))  # fmt: skip
        plant.step(0.7)
    t = np.arange(400) * 0.1
    flagged = (t >= 20.0 - 1e-9) & (t < 30.0 - 1e-9)  # (10..20 s: a NaN value, good status)
    assert [s[1] for s in statuses] == list(~flagged)  # pv2: BadSensorFailure while flagged
    assert all(s[0] for s in statuses)  # pv stays good
    assert [s[2] for s in statuses] == list(~flagged)


def test_the_python_path_records_the_true_y2_and_the_secondary_sees_the_fault() -> None:
    sc = parse_scenario(CASCADE)
    run = simulate(sc, "c")
    t, y2, u = run.signals["t"], run.signals["y2"], run.signals["u"]
    assert np.all(np.isfinite(y2)) and np.all(np.isfinite(u))
    bad = (t >= 10.0 - 1e-9) & (t < 30.0 - 1e-9)
    assert np.ptp(u[bad]) == 0.0  # the secondary holds its output (no safe_value)
    # without the events the MV moves in that stretch: the fault is what holds it
    parts = CASCADE.split("[[events]]")  # the setpoint step only
    calm = parse_scenario(parts[0] + "[[events]]" + parts[-1])
    u_calm = simulate(calm, "c").signals["u"]
    assert np.ptp(u_calm[bad]) > 0.05


def test_three_step_feedback_loses_the_position_during_a_y2_fault() -> None:
    """The three-step structure measures y2 (the valve position) too: the Python path."""
    (sc,) = load_shipped(["three_step_valve"])
    doc = tomllib.loads(Path(sc.file).read_text(encoding="utf-8"))
    doc["events"] += [
        {"t": 100.0, "do": "sensor", "target": "y2", "nan": True},
        {"t": 120.0, "do": "sensor", "target": "y2", "nan": False},
    ]
    sc2 = parse_scenario_doc(doc, file=sc.file)
    res = run_scenario(sc2, duration=130.0)
    sig = next(r for r in res.runs if r.controller == "position feedback").signals
    t, err = sig["t"], sig["est_error"]
    bad = (t >= 100.0 - 1e-9) & (t < 120.0 - 1e-9)
    assert np.all(np.isnan(err[bad])) and np.all(np.isfinite(err[~bad]))
    assert math.isfinite(sig["y2"][bad][0])  # the valve's true position is recorded
