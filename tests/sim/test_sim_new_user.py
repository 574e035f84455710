"""What a new user hits with ``run``, ``reproduce`` and ``sweep``.

One trace file per run, typos answered with the key they meant, no traceback
for an output directory that cannot be written, progress lines in a log and
labelled event lines in the plots.
"""

from __future__ import annotations

import re

import pytest
from click.testing import CliRunner

from ctrlblocks.cli import main
from ctrlblocks.sim.results import trace_names, unique_slugs
from ctrlblocks.sim.scenario import ScenarioError, parse_scenario, unknown_key_problem

SCENARIO = """
[scenario]
name = "typo"
title = "a PT1 under ADRC"
ts = 0.1
duration = 4.0

[plant]
type = "PT1"
k = 1.0
t = 2.0

[[controllers]]
name = "Tt = 0.05"
type = "ADRC"
order = 1
b0 = 0.5
omega_c = 1.0
omega_o = 5.0

[[controllers]]
name = "Tt = 0.5"
type = "ADRC"
order = 1
b0 = 0.5
omega_c = 2.0
omega_o = 10.0

[[events]]
t = 1.0
do = "setpoint"
value = 1.0
label = "step up"

[[events]]
t = 2.5
do = "load"
value = 0.2
"""


def _err(text: str) -> ScenarioError:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, file="typo.toml")
    return info.value


# -- unknown keys ------------------------------------------------------------


def test_a_block_key_typo_says_what_was_meant_and_lists_the_valid_keys() -> None:
    e = _err(SCENARIO.replace("omega_c = 1.0", "omegac = 1.0", 1))
    assert e.key == "controllers[0].omegac"
    assert e.problem.startswith("unknown key 'omegac' (did you mean 'omega_c'?); valid keys: ")
    valid = e.problem.split("valid keys: ")[1].split(", ")
    assert {"omega_c", "omega_o", "b0", "order", "type", "name", "u_min"} <= set(valid)
    assert valid == sorted(valid)
    assert "ADRC: ADRC" not in str(e) and "__init__" not in str(e)


def test_a_plant_key_typo_says_what_was_meant() -> None:
    e = _err(SCENARIO.replace("t = 2.0", "tt = 2.0"))
    assert str(e) == (
        "typo.toml, line 11: plant.tt: unknown key 'tt' (did you mean 't'?); "
        "valid keys: dead_time, k, t, ts, type"
    )


def test_a_section_key_typo_gets_the_same_hint() -> None:
    e = _err(SCENARIO.replace("duration = 4.0", "duraton = 4.0"))
    assert e.key == "scenario.duraton"
    assert "unknown key 'duraton' (did you mean 'duration'?)" in e.problem


def test_no_hint_when_nothing_is_close() -> None:
    problem = unknown_key_problem("xyz", ["beta", "alpha"])
    assert problem == "unknown key 'xyz'; valid keys: alpha, beta"


def test_the_runtime_loop_file_reports_block_typos_the_same_way() -> None:
    from ctrlblocks.runtime import RuntimeConfigError, parse_config
    from tests.runtime.test_config import CONN, LOOP

    with pytest.raises(RuntimeConfigError) as e:
        parse_config(CONN + LOOP.replace("ti = 8.0", "tii = 8.0"))
    assert e.value.key == "loops[0].block.tii"
    assert e.value.problem.startswith("unknown key 'tii' (did you mean 'ti'?); valid keys: ")


def test_sweep_vary_typos_are_errors_with_the_meant_key(tmp_path) -> None:
    f = tmp_path / "typo.toml"
    f.write_text(SCENARIO)
    runner = CliRunner()
    res = runner.invoke(main, ["sweep", str(f), "--vary", "controllers[0].omegac=1,2", "--serial"])
    assert res.exit_code == 1 and "Traceback" not in res.output
    assert "controllers[0].omegac: unknown key 'omegac' (did you mean 'omega_c'?)" in res.output
    assert res.exception is None or isinstance(res.exception, SystemExit)
    res = runner.invoke(main, ["sweep", str(f), "--vary", "plnt.k=1,2", "--serial"])
    assert res.exit_code == 1
    assert "unknown key 'plnt' (did you mean 'plant'?)" in res.output
    assert not (tmp_path / "results").exists()


# -- trace files ---------------------------------------------------------------


def test_unique_slugs_keep_dots_and_number_collisions() -> None:
    assert unique_slugs(["Tt = 0.05", "Tt = 0.5", "a b", "a_b", "A B"]) == [
        "Tt_0.05",
        "Tt_0.5",
        "a_b",
        "a_b-2",
        "A_B-3",
    ]


def test_every_run_gets_its_own_trace_file_named_after_controller_and_case(tmp_path) -> None:
    f = tmp_path / "typo.toml"
    f.write_text(SCENARIO)
    res = CliRunner().invoke(main, ["run", str(f), "--out", str(tmp_path), "--format", "csv"])
    assert res.exit_code == 0, res.output
    names = sorted(p.name for p in (tmp_path / "typo").glob("trace_*"))
    assert names == ["trace_Tt_0.05__main.csv", "trace_Tt_0.5__main.csv"]
    assert "(5 files)" in res.output  # 2 traces, metrics.json, claims.json, main.png


def test_nowak_table2_b0_writes_four_trace_files_for_its_four_runs(tmp_path) -> None:
    res = CliRunner().invoke(
        main, ["reproduce", "nowak_table2_b0", "--quick", "--out", str(tmp_path)]
    )
    assert res.exit_code == 0, res.output
    traces = list((tmp_path / "nowak_table2_b0").glob("trace_*"))
    assert len(traces) == 4
    assert {p.name.split("__")[0] for p in traces} == {
        "trace_n_1_b0_0.099_estimated",
        "trace_n_1_b0_0.3_final",
        "trace_n_2_b0_0.025_estimated",
        "trace_n_2_b0_0.05_final",
    }


def test_trace_names_are_distinct_for_runs_whose_names_slug_alike() -> None:
    class R:
        def __init__(self, controller: str, case: str) -> None:
            self.controller, self.case = controller, case

    runs = [R("a b", "main"), R("a_b", "main"), R("a b", "load")]
    assert trace_names(runs) == ["trace_a_b__main", "trace_a_b__main-2", "trace_a_b__load"]


# -- output directories that cannot be written -----------------------------------


@pytest.mark.parametrize("command", ["run", "reproduce"])
def test_an_unwritable_output_directory_is_an_error_before_any_run(tmp_path, command) -> None:
    f = tmp_path / "typo.toml"
    f.write_text(SCENARIO)
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    target = blocker / "sub"  # a directory cannot be made inside a file
    args = [str(f)] if command == "run" else ["astrom_fig52"]
    res = CliRunner().invoke(main, [command, *args, "--out", str(target)])
    assert res.exit_code == 1, res.output
    assert isinstance(res.exception, SystemExit)
    assert f"--out {target}: cannot make the directory" in res.output
    assert "Traceback" not in res.output
    assert "reproducing" not in res.output  # refused before the runs


# -- progress in a log -------------------------------------------------------------


def test_reproduce_prints_one_line_per_scenario_when_not_on_a_terminal(tmp_path) -> None:
    res = CliRunner().invoke(
        main, ["reproduce", "astrom_fig52", "codesys_deadband", "--quick", "--out", str(tmp_path)]
    )
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    assert lines[0] == f"reproducing 2 scenarios (3 runs) into {tmp_path}/"
    # scenarios may finish in any order (they run in parallel): one line each, counted up
    assert [ln[:6] for ln in lines[1:3]] == ["[1/2] ", "[2/2] "]
    done = sorted(ln[6:] for ln in lines[1:3])
    assert re.fullmatch(r"astrom_fig52: 1 run\(s\), \d+\.\d s", done[0])
    assert re.fullmatch(r"codesys_deadband: 2 run\(s\), \d+\.\d s", done[1])
    assert lines[3].startswith("5/5 claims hold")


def test_sweep_prints_a_line_per_chunk_when_not_on_a_terminal(tmp_path) -> None:
    f = tmp_path / "typo.toml"
    f.write_text(SCENARIO)
    values = ",".join(str(0.4 + 0.1 * i) for i in range(12))
    res = CliRunner().invoke(
        main,
        ["sweep", str(f), "--vary", f"controllers[0].b0={values}", "--serial",
         "--out", str(tmp_path / "s.csv")],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    progress = [ln for ln in res.output.splitlines() if ln.startswith("sweep: ")]
    # 12 runs in chunks of ceil(12/10) = 2: a line after runs 2, 4, ..., 12
    assert [ln.split(" ")[1] for ln in progress] == [f"{k}/12" for k in range(2, 13, 2)]
    assert res.output.splitlines()[-1] == f"12 parameter sets, 24 rows -> {tmp_path / 's.csv'}"


# -- plots ---------------------------------------------------------------------------


def test_event_lines_carry_their_labels_in_the_plot(tmp_path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ctrlblocks.sim.plot import _label_events

    sc = parse_scenario(SCENARIO)
    fig, ax = plt.subplots()
    ax.plot([0, 4], [0, 1])
    _label_events(ax, sc.cases[0].events)
    texts = sorted((t.xy[0], t.get_text()) for t in ax.texts)
    plt.close(fig)
    assert texts == [(1.0, "step up"), (2.5, "load input = 0.2")]


# -- one overshoot unit in every table ---------------------------------------------------


def test_every_report_table_shows_the_overshoot_in_percent(tmp_path) -> None:
    import json

    res = CliRunner().invoke(
        main, ["reproduce", "astrom_fig34", "nowak_fig6", "--quick", "--out", str(tmp_path)]
    )
    assert res.exit_code == 0, res.output
    report = (tmp_path / "report.md").read_text(encoding="utf-8")
    heads = [ln for ln in report.splitlines() if "vershoot" in ln and ln.startswith(("|", "O"))]
    assert heads, "the report has an overshoot table"
    assert all("[%]" in h for h in heads), heads
    assert "| overshoot |" not in report
    # astrom_fig34 has one window: the whole-run table, in percent of metrics.json's fraction
    metrics = json.loads((tmp_path / "astrom_fig34" / "metrics.json").read_text())
    table = report.split('<a id="astrom_fig34"></a>')[1].split("<a id=")[0]
    col = table.splitlines()
    at = next(i for i, ln in enumerate(col) if "| overshoot [%] |" in ln)
    head = col[at].split(" | ")
    rows = [ln.split(" | ") for ln in col[at + 2 : at + 2 + len(metrics)]]
    k = head.index("overshoot [%]")
    for m, row in zip(metrics, rows, strict=True):
        assert float(row[k]) == pytest.approx(100.0 * m["overshoot"], rel=1e-3)
