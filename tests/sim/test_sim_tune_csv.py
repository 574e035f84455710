"""[controllers.tune] with a recorded bump test (file = "bump.csv"), read as identify does."""

from __future__ import annotations

from pathlib import Path

import pytest

from ctrlblocks.plants import FOPDT
from ctrlblocks.sim.scenario import ScenarioError, load_scenario
from ctrlblocks.tuning import amigo
from ctrlblocks.tuning.identify import fit_fopdt, read_step_csv

SCENARIO = """
[scenario]
name = "from_csv"
title = "PID tuned on a recorded bump test"
ts = 0.1
duration = 10.0

[plant]
type = "FOPDT"
k = 2.0
t = 10.0
dead_time = 2.0

[[controllers]]
name = "pid"
type = "PID"
u_min = -100.0
u_max = 100.0
[controllers.tune]
rule = "amigo"
file = "{file}"
{extra}
"""


def _bump(path: Path, *, european: bool = False) -> None:
    """A recorded bump test of K = 2, T = 10 s, L = 2 s: MV 1 -> 1.5 at t = 5 s."""
    plant = FOPDT(k=2.0, t=10.0, dead_time=2.0, ts=0.1)
    plant.reset(1.0)
    sep, rows = (";", ["time_s;mv [%];pv [degC]"]) if european else (",", ["t,u,y"])
    for k in range(800):
        u = 1.0 if k < 50 else 1.5
        row = f"{k * 0.1:.1f}{sep}{u}{sep}{plant.y:.6f}"
        rows.append(row.replace(".", ",") if european else row)
        plant.step(u)
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")


def test_a_recorded_bump_test_tunes_the_block_as_identify_and_the_rule_would(tmp_path) -> None:
    _bump(tmp_path / "bump.csv")
    scn = tmp_path / "scenario.toml"
    scn.write_text(SCENARIO.format(file="bump.csv", extra=""))  # relative to the scenario
    spec = load_scenario(scn).controllers[0].blocks["main"]
    data = read_step_csv(tmp_path / "bump.csv")
    model = fit_fopdt(data.t, data.u, data.y)
    by_hand = amigo(model.gain, model.time_constant, model.dead_time)
    assert spec.params["kp"] == pytest.approx(by_hand.kp, rel=1e-9)
    assert spec.params["ti"] == pytest.approx(by_hand.ti, rel=1e-9)
    assert spec.params["td"] == pytest.approx(by_hand.td, rel=1e-9)
    info = spec.extra["tuned"]
    assert info["gain"] == pytest.approx(2.0, rel=1e-3) and info["du"] == pytest.approx(0.5)


def test_a_european_export_is_read_with_the_identify_options(tmp_path) -> None:
    _bump(tmp_path / "bump_eu.csv", european=True)
    scn = tmp_path / "scenario.toml"
    extra = 'time = "time_s"\nu = "mv"\ny = "pv"\n'
    scn.write_text(SCENARIO.format(file="bump_eu.csv", extra=extra))
    info = load_scenario(scn).controllers[0].blocks["main"].extra["tuned"]
    assert info["gain"] == pytest.approx(2.0, rel=1e-3)
    assert info["dead_time"] == pytest.approx(2.0, abs=0.1)


def test_a_missing_or_bad_record_is_named_at_the_file_key(tmp_path) -> None:
    scn = tmp_path / "scenario.toml"
    scn.write_text(SCENARIO.format(file="nope.csv", extra=""))
    with pytest.raises(ScenarioError) as info:
        load_scenario(scn)
    assert info.value.key == "controllers[0].tune.file"
    assert "nope.csv" in str(info.value)
    (tmp_path / "bad.csv").write_text("t,u,y\n0,1,x\n")
    scn.write_text(SCENARIO.format(file="bad.csv", extra=""))
    with pytest.raises(ScenarioError) as info:
        load_scenario(scn)
    assert info.value.key == "controllers[0].tune.file"


def test_the_tune_table_takes_every_reading_option_of_identify() -> None:
    from ctrlblocks.sim.scenario import _CSV_KEYS
    from ctrlblocks.tuning.records import CSV_OPTIONS

    assert set(CSV_OPTIONS) <= set(_CSV_KEYS)


def test_a_historian_export_with_bad_cells_and_a_window_is_read_with_the_options(tmp_path):
    _bump(tmp_path / "bump.csv")
    lines = (tmp_path / "bump.csv").read_text().splitlines()
    lines[100] = lines[100].rsplit(",", 1)[0] + ",I/O Timeout"
    (tmp_path / "bump.csv").write_text("\n".join(lines) + "\n")
    scn = tmp_path / "scenario.toml"
    scn.write_text(SCENARIO.format(file="bump.csv", extra=""))
    with pytest.raises(ScenarioError, match=r"line 101, column 'y': 'I/O Timeout' is not a num"):
        load_scenario(scn)
    scn.write_text(SCENARIO.format(file="bump.csv", extra='bad_rows = "skip"\nstart = 2.0'))
    info = load_scenario(scn).controllers[0].blocks["main"].extra["tuned"]
    assert info["gain"] == pytest.approx(2.0, rel=1e-3)
    assert info["dead_time"] == pytest.approx(2.0, abs=0.1)
    scn.write_text(SCENARIO.format(file="bump.csv", extra='bad_rows = "drop"'))
    with pytest.raises(ScenarioError, match=r"controllers\[0\]\.tune: bad_rows must be one of"):
        load_scenario(scn)
