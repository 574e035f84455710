"""Sweeps give the same rows as sequential runs of the simulator, on any executor."""

from __future__ import annotations

import concurrent.futures as cf
import csv
import importlib
import math
import sys

import pytest
from click.testing import CliRunner

from ctrlblocks.cli import main
from ctrlblocks.sim import parse_scenario, run_scenario
from ctrlblocks.sim.sweep import (
    SweepError,
    apply_key,
    parameter_sets,
    read_scenario_text,
    sweep,
    write_rows,
)

VARY = {"controllers[2].kp": [5.0, 6.31], "sensor.noise": [0.0, 0.002]}
DURATION = 4.0


def _rows_equal(a, b):
    assert len(a) == len(b)
    for ra, rb in zip(a, b, strict=True):
        assert ra.keys() == rb.keys()
        for k in ra:
            va, vb = ra[k], rb[k]
            if isinstance(va, float) and isinstance(vb, float) and math.isnan(va):
                assert math.isnan(vb)
            else:
                assert va == vb, k


def test_apply_key_sets_nested_tables_and_list_items():
    doc = {"controllers": [{"kp": 1.0}, {"kp": 2.0}], "sensor": {"noise": 0.0}}
    apply_key(doc, "controllers[1].kp", 7.5)
    apply_key(doc, "sensor.noise", 0.01)
    assert doc == {"controllers": [{"kp": 1.0}, {"kp": 7.5}], "sensor": {"noise": 0.01}}
    with pytest.raises(SweepError, match="out of range"):
        apply_key(doc, "controllers[5].kp", 1.0)
    with pytest.raises(SweepError, match=r"unknown key 'plant'; valid keys: controllers, sensor"):
        apply_key(doc, "plant.k", 1.0)


def test_parameter_sets_are_the_cartesian_product():
    sets = parameter_sets({"a": [1, 2], "b": ["x", "y", "z"]})
    assert len(sets) == 6
    assert sets[0] == {"a": 1, "b": "x"} and sets[-1] == {"a": 2, "b": "z"}


def test_serial_sweep_equals_runs_of_the_edited_scenario_file():
    rows = sweep("nowak_fig7", {"controllers[2].kp": [5.0, 6.31]}, executor="serial",
                 duration=DURATION)  # fmt: skip
    text, _ = read_scenario_text("nowak_fig7")
    assert "kp = 6.31" in text
    edited = parse_scenario(text.replace("kp = 6.31", "kp = 5.0"))
    ref = run_scenario(edited, duration=DURATION)
    mine = [r for r in rows if r["controllers[2].kp"] == 5.0]
    assert len(mine) == len(ref.metrics) == 6  # 3 controllers x 2 cases
    for r, m in zip(mine, ref.metrics, strict=True):
        assert (r["controller"], r["case"]) == (m["controller"], m["case"])
        assert r["iae"] == m["iae"] and r["tv_u"] == m["tv_u"]
    # the varied gain changes the PID_FT rows only
    other = [r for r in rows if r["controllers[2].kp"] == 6.31]
    assert [r["iae"] for r in other if r["controller"] == "ADRC n=2"] == [
        r["iae"] for r in mine if r["controller"] == "ADRC n=2"
    ]
    assert [r["iae"] for r in other if r["controller"] == "PID_FT"] != [
        r["iae"] for r in mine if r["controller"] == "PID_FT"
    ]


def test_process_pool_sweep_equals_the_serial_sweep():
    serial = sweep("nowak_fig7", VARY, executor="serial", duration=DURATION)
    with cf.ProcessPoolExecutor(max_workers=2) as ex:
        pooled = sweep("nowak_fig7", VARY, executor=ex, duration=DURATION)
    assert len(serial) == 4 * 6
    _rows_equal(serial, pooled)


def test_dask_local_cluster_sweep_equals_the_serial_sweep():
    pytest.importorskip("distributed")
    from ctrlblocks.sim import dask_executor

    vary = {"controllers[2].kp": [5.0, 6.31]}
    serial = sweep("nowak_fig7", vary, executor="serial", duration=DURATION)
    ex = dask_executor(n_workers=1, processes=False, dashboard_address=None)
    try:
        on_dask = sweep("nowak_fig7", vary, executor=ex, duration=DURATION)
    finally:
        ex.shutdown()
    _rows_equal(serial, on_dask)


def test_the_scenario_text_is_read_once_and_never_changed_by_a_set():
    sweep_mod = importlib.import_module("ctrlblocks.sim.sweep")  # the name is the function
    text, file = read_scenario_text("nowak_fig7")
    sweep_mod._document.cache_clear()
    a = sweep_mod._scenario(text, file, {"controllers[2].kp": 5.0})
    b = sweep_mod._scenario(text, file, {})  # a later set without that key
    assert sweep_mod._document.cache_info().misses == 1  # one TOML read for both
    assert a.controllers[2].blocks["main"].params["kp"] == 5.0
    assert b.controllers[2].blocks["main"].params["kp"] == 6.31  # the file's, not 5.0
    assert parse_scenario(text).controllers[2].blocks["main"].params["kp"] == 6.31


def test_bad_value_is_refused_before_any_run():
    with pytest.raises(SweepError, match="kp"):
        sweep("nowak_fig7", {"controllers[2].kp": [-1.0]}, executor="serial", duration=DURATION)


def test_the_parent_checks_each_value_once_not_every_set():
    sweep_mod = importlib.import_module("ctrlblocks.sim.sweep")
    vary = {"controllers[2].kp": [5.0, 6.0, 7.0], "controllers[2].ti": [5.4, 6.0]}
    sets = sweep_mod.parameter_sets(vary)
    assert sweep_mod._probes(sets, vary) == [
        {"controllers[2].kp": 5.0, "controllers[2].ti": 5.4},
        {"controllers[2].kp": 6.0, "controllers[2].ti": 5.4},
        {"controllers[2].kp": 7.0, "controllers[2].ti": 5.4},
        {"controllers[2].kp": 5.0, "controllers[2].ti": 6.0},
    ]  # 4 parses in the parent for 6 sets (48 x 5 x 2 = 480 sets: 53)


@pytest.mark.parametrize("executor", ["serial", "pool"])
def test_a_value_refused_only_in_combination_stops_the_sweep_with_its_set(executor):
    # u_min = 3 and u_max = 2 are each fine with the file's other limit, not together
    vary = {"controllers[2].u_min": [0.0, 3.0], "controllers[2].u_max": [5.0, 2.0]}
    ex = cf.ProcessPoolExecutor(max_workers=2) if executor == "pool" else "serial"
    try:
        with pytest.raises(SweepError) as info:
            sweep("nowak_fig7", vary, executor=ex, duration=DURATION)
    finally:
        if executor == "pool":
            ex.shutdown()
    msg = str(info.value)
    assert msg.startswith("with controllers[2].u_min = 3.0, controllers[2].u_max = 2.0: ")
    assert "low limit 3.0 is above high limit 2.0" in msg


def test_rows_fall_back_to_csv_without_pyarrow(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    path = write_rows([{"a": 1.0, "b": None}, {"a": 2.0, "c": "x"}], tmp_path / "r.parquet")
    assert path.suffix == ".csv"
    with path.open() as f:
        got = list(csv.DictReader(f))
    assert got == [{"a": "1.0", "b": "", "c": ""}, {"a": "2.0", "b": "", "c": "x"}]


def test_cli_sweep_writes_one_row_per_set_controller_and_case(tmp_path):
    out = tmp_path / "sweep.csv"
    res = CliRunner().invoke(
        main,
        ["sweep", "nowak_fig7", "--vary", "controllers[2].kp=5,6.31", "--serial",
         "--duration", str(DURATION), "--out", str(out)],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "2 parameter sets, 12 rows" in res.output
    with out.open() as f:
        rows = list(csv.DictReader(f))
    assert [r["controllers[2].kp"] for r in rows] == ["5"] * 6 + ["6.31"] * 6


def test_cli_sweep_rejects_a_malformed_vary():
    res = CliRunner().invoke(main, ["sweep", "nowak_fig7", "--vary", "kp"])
    assert res.exit_code != 0 and "KEY=v1,v2" in res.output


def test_cli_sweep_of_a_file_that_is_not_utf8_is_one_line(tmp_path):
    bad = tmp_path / "bin.toml"
    bad.write_bytes(b"x = 1\n\xff\xfe\n")
    res = CliRunner().invoke(main, ["sweep", str(bad), "--vary", "ts=0.1", "--serial"])
    assert res.exit_code == 1 and res.exc_info[0] is SystemExit, res.output  # no traceback
    assert f"Error: {bad}, line 2: not a UTF-8 text file (byte 0xff)" in res.output


class _RecordingPool(cf.ThreadPoolExecutor):
    """A thread pool that records how many parameter sets each task carries."""

    def __init__(self, max_workers: int) -> None:
        super().__init__(max_workers=max_workers)
        self.sizes: list[int] = []

    def submit(self, fn, /, *args, **kwargs):
        self.sizes.append(len(args[2]))
        return super().submit(fn, *args, **kwargs)


def test_batch_size_aims_at_a_tenth_of_a_second_and_a_task_per_worker():
    from ctrlblocks.sim.sweep import TASK_SECONDS, batch_size

    assert TASK_SECONDS == 0.1
    assert batch_size(0.01, 100, 2) == 10  # 10 sets of 10 ms = 100 ms per task
    assert batch_size(0.003, 100, 2) == 34
    assert batch_size(0.5, 100, 2) == 1  # one set is already more than 100 ms
    assert batch_size(0.001, 10, 2) == 5  # every worker gets a task
    assert batch_size(0.001, 0, 2) == 1


def test_first_tasks_carry_one_set_and_the_rest_go_in_batches(monkeypatch):
    sw = sys.modules["ctrlblocks.sim.sweep"]  # the module (the package's `sweep` is the function)
    monkeypatch.setattr(sw, "TASK_SECONDS", 1e6)  # any set is "fast": batches as large as allowed
    vary = {"controllers[2].kp": [4.0, 4.5, 5.0, 5.5, 6.0, 6.31, 7.0, 7.5, 8.0]}
    serial = sweep("nowak_fig7", vary, executor="serial", duration=1.0)
    pool = _RecordingPool(2)
    seen: list[int] = []
    try:
        rows = sweep("nowak_fig7", vary, executor=pool, duration=1.0,
                     progress=lambda done, total: seen.append(done))  # fmt: skip
    finally:
        pool.shutdown()
    _rows_equal(serial, rows)  # the order of the parameter sets, whatever finished first
    # after the first: batches of up to ceil(7 / 2) = 4, but never more than a quarter
    # (2 workers, 2 tasks each) of the sets left: 7 -> 2, 5 -> 2, 3 -> 1, 2 -> 1, 1 -> 1
    assert pool.sizes == [1, 1, 2, 2, 1, 1, 1]
    assert seen == sorted(seen) and seen[-1] == 9


def test_given_batch_size_on_a_process_pool_equals_the_serial_sweep():
    serial = sweep("nowak_fig7", VARY, executor="serial", duration=DURATION)
    pooled = sweep("nowak_fig7", VARY, duration=DURATION, batch=3)
    _rows_equal(serial, pooled)
