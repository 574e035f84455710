"""``ctrlblocks run`` and ``ctrlblocks reproduce`` end to end (click's CliRunner)."""

from __future__ import annotations

import csv
import importlib.util
import json
import math

import pytest
from click.testing import CliRunner

from ctrlblocks.cli import main
from ctrlblocks.sim.report import shipped_scenarios

KEYS = {
    "scenario",
    "controller",
    "case",
    "iae",
    "ise",
    "itae",
    "overshoot",
    "settling_time",
    "tv_u",
}


def test_reproduce_quick_writes_the_full_report(tmp_path):
    out = tmp_path / "report"
    res = CliRunner().invoke(main, ["reproduce", "--quick", "--out", str(out)])
    assert res.exit_code == 0, res.output
    report = (out / "report.md").read_text(encoding="utf-8")
    names = [p.stem for p in shipped_scenarios()]
    for name in names:
        assert f"`{name}`" in report
        metrics = json.loads((out / name / "metrics.json").read_text())
        assert isinstance(metrics, list) and metrics
        assert all(set(m) >= KEYS for m in metrics)
        assert list((out / name).glob("*.png")), name
        assert list((out / name).glob("trace_*"))
    assert "Quick mode" in report
    assert "claims of the sources hold in simulation" in report
    assert "claims hold; report:" in res.output


def test_reproduce_list_and_unknown_name():
    runner = CliRunner()
    res = runner.invoke(main, ["reproduce", "--list"])
    assert res.exit_code == 0
    assert "nowak_fig7" in res.output and "astrom_fig34" in res.output
    res = runner.invoke(main, ["reproduce", "no_such_scenario"])
    assert res.exit_code != 0
    assert "unknown scenario(s): no_such_scenario" in res.output


def test_reproduce_selected_scenario_only(tmp_path):
    res = CliRunner().invoke(main, ["reproduce", "astrom_fig52", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    assert "2/2 claims hold" in res.output
    assert [p.name for p in tmp_path.iterdir() if p.is_dir()] == ["astrom_fig52"]


def test_run_writes_trace_metrics_and_plot(tmp_path):
    scenario = next(p for p in shipped_scenarios() if p.stem == "astrom_fig52")
    res = CliRunner().invoke(
        main, ["run", str(scenario), "--out", str(tmp_path), "--format", "csv"]
    )
    assert res.exit_code == 0, res.output
    d = tmp_path / "astrom_fig52"
    with (d / "trace_jump_and_rate__main.csv").open() as fh:
        rows = list(csv.reader(fh))
    assert rows[0][:5] == ["t", "sp", "y", "ym", "u"]
    assert len(rows) == 1 + 2000
    # y at t = 7: the state x = 4 - exp(-4) minus the jump |jlow| = 0.5
    assert float(rows[1 + 700][2]) == pytest.approx(3.5 - math.exp(-4.0), abs=1e-12)
    assert (d / "main.png").stat().st_size > 10_000
    assert "| jump and rate | main |" in res.output


def test_run_reports_a_malformed_file_with_its_key(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('[scenario]\nname = "x"\ntitle = "t"\nts = 0.1\nduration = "ten"\n')
    res = CliRunner().invoke(main, ["run", str(bad)])
    assert res.exit_code != 0
    assert "bad.toml, line 5: scenario.duration: must be a number, got a string 'ten'" in res.output


def test_trace_format_auto_is_parquet_with_pyarrow_else_csv(tmp_path):
    scenario = next(p for p in shipped_scenarios() if p.stem == "astrom_fig52")
    res = CliRunner().invoke(main, ["run", str(scenario), "--out", str(tmp_path)])
    assert res.exit_code == 0
    d = tmp_path / "astrom_fig52"
    if importlib.util.find_spec("pyarrow") is None:
        assert (d / "trace_jump_and_rate__main.csv").exists()
        assert not (d / "trace_jump_and_rate__main.parquet").exists()
    else:
        import pyarrow.parquet as pq

        table = pq.read_table(d / "trace_jump_and_rate__main.parquet")
        assert table.column_names[:3] == ["t", "sp", "y"]
        y = table.column("y").to_pylist()
        assert y[700] == pytest.approx(3.5 - math.exp(-4.0), abs=1e-12)


def test_docs_simulator_example_runs():
    from pathlib import Path

    text = (Path(__file__).parents[2] / "docs" / "simulator.md").read_text(encoding="utf-8")
    code = text.split("## For the README tour")[1].split("```python")[1].split("```")[0]
    ns: dict = {}
    exec(compile(code, "docs/simulator.md", "exec"), ns)
    metrics = ns["result"].metrics
    assert [m["controller"] for m in metrics] == ["PI", "ADRC"]
    assert all(0.0 < m["iae"] < 20.0 for m in metrics)
