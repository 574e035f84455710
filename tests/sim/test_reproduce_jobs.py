"""``ctrlblocks reproduce --jobs N``: the same report and files on any number of processes."""

from __future__ import annotations

import re

from click.testing import CliRunner

from ctrlblocks.cli import main

NAMES = ["nowak_fig6", "astrom_fig52", "nowak_fig1"]  # small ones, not in shipped order


def _reproduce(out, *options: str) -> str:
    res = CliRunner().invoke(main, ["reproduce", *NAMES, "--quick", "--out", str(out), *options])
    assert res.exit_code == 0, res.output
    return res.output


def _without_time(report: str) -> str:
    return re.sub(r"in [0-9.]+ s\.", "in - s.", report)


def test_reproduce_on_two_processes_writes_the_same_report_and_files_as_on_one(tmp_path):
    _reproduce(tmp_path / "one", "--jobs", "1")
    _reproduce(tmp_path / "two", "--jobs", "2")
    one = (tmp_path / "one" / "report.md").read_text(encoding="utf-8")
    two = (tmp_path / "two" / "report.md").read_text(encoding="utf-8")
    assert _without_time(one) == _without_time(two)
    # the report follows the shipped (alphabetical) order, whatever finished first
    assert one.index("`astrom_fig52`") < one.index("`nowak_fig1`") < one.index("`nowak_fig6`")
    for name in NAMES:
        for f in ("metrics.json", "claims.json"):
            assert (tmp_path / "one" / name / f).read_bytes() == (
                tmp_path / "two" / name / f
            ).read_bytes()
        assert list((tmp_path / "two" / name).glob("*.png"))


def test_reproduce_no_plots_writes_traces_and_metrics_but_no_png(tmp_path):
    _reproduce(tmp_path, "--no-plots", "--jobs", "2")
    for name in NAMES:
        assert (tmp_path / name / "metrics.json").is_file()
        assert list((tmp_path / name).glob("trace_*"))
        assert not list((tmp_path / name).glob("*.png"))


def test_reproduce_refuses_zero_jobs(tmp_path):
    res = CliRunner().invoke(main, ["reproduce", "astrom_fig52", "--jobs", "0"])
    assert res.exit_code == 2
    assert "--jobs" in res.output
