"""The historian: N cycles in, N rows out, across restarts; SQLite and PostgreSQL; export."""

from __future__ import annotations

import asyncio
import csv
import json
import math
import os
import sqlite3
import time

import pytest

from ctrlblocks.runtime import (
    MemoryBus,
    PostgresHistorian,
    SQLiteHistorian,
    export_history,
)
from ctrlblocks.runtime.config import HistorianConfig
from ctrlblocks.runtime.historian import SAMPLE_COLUMNS
from ctrlblocks.runtime.loop import Sample
from ctrlblocks.runtime.writer import ProcessHistorian

from .conftest import loop_toml, make, run

PG_DSN = os.environ.get("CTRLBLOCKS_TEST_PG_DSN", "")


def run_runtime(historian, t_end: float, bus: MemoryBus) -> int:
    """Run two loops for ``t_end`` s of virtual time; return the number of cycles per loop."""
    loops = loop_toml(name="a", ts=0.1) + loop_toml(name="b", ts=0.1, pv="pv2", mv="mv2")
    rt, clock, _ = make(loops, {"io": bus}, historian=historian)

    async def main():
        await run(rt, clock, t_end)
        await rt.stop()

    asyncio.run(main())
    return rt.loops["a"].cycle_count


def bus() -> MemoryBus:
    return MemoryBus({"pv": 0.5, "mv": 0.0, "pv2": math.nan, "mv2": 0.0})


def check_two_runs(make_historian):
    h1 = make_historian()
    h1.open()
    n1 = run_runtime(h1, 2.0, bus())
    h2 = make_historian()  # a restart: a new run appended to the same database
    h2.open()
    n2 = run_runtime(h2, 1.0, bus())
    with h2.reading():
        rows = h2.samples()
        runs = h2.query("SELECT run_id, stopped IS NOT NULL FROM runs ORDER BY run_id")
    assert (n1, n2) == (21, 11)
    assert len(rows) == 2 * (n1 + n2)  # N cycles in, N rows out, both loops
    assert runs == [(1, 1), (2, 1)]
    for run_id, n in ((1, n1), (2, n2)):
        for loop in ("a", "b"):
            cycles = [r["cycle"] for r in rows if r["run_id"] == run_id and r["loop"] == loop]
            assert cycles == list(range(n))
    a = [r for r in rows if r["loop"] == "a"]
    b = [r for r in rows if r["loop"] == "b"]
    assert all(r["pv"] == 0.5 and r["pv_ok"] == 1 for r in a)
    assert all(math.isnan(r["pv"]) and r["pv_ok"] == 0 for r in b)  # NaN survives
    assert all(r["mode"] == "auto" and r["sp"] == 1.0 for r in rows)
    return rows


@pytest.fixture(params=["in-process", "writer-process"])
def sqlite_historian(request):
    """A factory of SQLite historians: written in this process, or by the writer process."""

    def make(path, retention_days: float = 0.0):
        if request.param == "in-process":
            return SQLiteHistorian(path, retention_days=retention_days)
        return ProcessHistorian(HistorianConfig(path=str(path), retention_days=retention_days))

    return make


def test_sqlite_keeps_every_sample_across_a_restart(tmp_path, sqlite_historian):
    path = tmp_path / "h.sqlite"
    check_two_runs(lambda: sqlite_historian(path))
    with sqlite3.connect(path) as c:
        assert c.execute("PRAGMA journal_mode").fetchone()[0] == "wal"


def test_flush_writes_the_buffer_in_one_batch(tmp_path):
    h = SQLiteHistorian(tmp_path / "h.sqlite")
    h.open()
    s = Sample("x", 0, time.time(), 0.0, 0.1, 1.0, 0.5, 0.2, "auto", 0, True, True, False)
    for k in range(250):
        h.record(Sample(**{**s.__dict__, "cycle": k}))
    assert h.pending == 250
    assert len(h.samples()) == 0  # nothing written before the flush
    assert h.flush() == 250
    assert h.pending == 0 and len(h.samples()) == 250
    h.close()


def test_retention_deletes_old_samples_at_open(tmp_path, sqlite_historian):
    path = tmp_path / "h.sqlite"
    h = sqlite_historian(path, retention_days=1.0)
    h.open()
    now = time.time()
    for k, age_days in enumerate((3.0, 1.5, 0.5, 0.0)):
        h.record(Sample("x", k, now - age_days * 86400.0, 0, 0.1, 1, 1, 1, "auto", 0, 1, 1, 0))
    h.close()
    h2 = sqlite_historian(path, retention_days=1.0)
    h2.open()
    assert [r["cycle"] for r in h2.samples()] == [2, 3]
    h2.close()


def test_export_to_csv_and_parquet(tmp_path):
    path = tmp_path / "h.sqlite"
    h = SQLiteHistorian(path)
    h.open()
    run_runtime(h, 0.5, bus())
    out = export_history(path, tmp_path / "a.csv", loop="a")
    with out.open() as f:
        rows = list(csv.reader(f))
    assert tuple(rows[0]) == SAMPLE_COLUMNS
    assert len(rows) == 1 + 6
    assert [int(r[2]) for r in rows[1:]] == list(range(6))
    import pyarrow.parquet as pq  # in the runtime extra

    out = export_history(path, tmp_path / "all.parquet")
    table = pq.read_table(out)
    assert table.num_rows == 12 and tuple(table.column_names) == SAMPLE_COLUMNS


@pytest.mark.skipif(
    not PG_DSN,
    reason="no PostgreSQL server: set CTRLBLOCKS_TEST_PG_DSN "
    "(.ci/run starts one with tests/runtime/ci_postgres.sh)",
)
@pytest.mark.parametrize("writer", ["in-process", "writer-process"])
def test_postgresql_keeps_every_sample_across_a_restart(writer):
    import psycopg

    with psycopg.connect(PG_DSN) as c:
        for t in ("samples", "runs", "audit"):
            c.execute(f"DROP TABLE IF EXISTS {t}")
    pg = HistorianConfig(backend="postgresql", dsn=PG_DSN)
    rows = check_two_runs(
        lambda: PostgresHistorian(PG_DSN) if writer == "in-process" else ProcessHistorian(pg)
    )
    assert rows[0]["run_id"] == 1
    h = PostgresHistorian(PG_DSN)
    h.open()
    h.audit("alice", "a", "sp", {"sp": 1.0}, {"sp": 2.0}, True)
    rows = h.audit_rows()
    audit = [(r["who"], r["action"], r["ok"]) for r in rows if r["action"] != "alarm"]
    assert audit == [("runtime", "stop", 1)] * 4 + [("alice", "sp", 1)]  # 2 runs x 2 loops
    # loop b's NaN PV raises its condition alarms once per run: bad PV, then the safe value
    alarms = [(r["loop"], json.loads(r["new"])["code"]) for r in rows if r["action"] == "alarm"]
    assert alarms == [("b", "bad_pv"), ("b", "safe_value")] * 2
    h.close()


def test_samples_of_a_loop_in_a_time_window_ordered_by_wall_time(tmp_path, sqlite_historian):
    h = sqlite_historian(tmp_path / "h.sqlite")
    h.open()
    # loop x at t_wall 100, 101, ..., 109; loop y at the same times; one row written out of order
    for k in (3, 0, 1, 2, 4, 5, 6, 7, 8, 9):
        h.record(Sample("x", k, 100.0 + k, 0.1 * k, 0.1, 1.0, 0.5, float(k), "auto", 0, 1, 1, 0))
        h.record(Sample("y", k, 100.0 + k, 0.1 * k, 0.1, 2.0, math.nan, 0.0, "auto", 0, 0, 1, 0))
    h.flush()
    rows = h.samples("x", 102.0, 105.0)  # both bounds included
    assert [r["cycle"] for r in rows] == [2, 3, 4, 5]
    assert [r["mv"] for r in rows] == [2.0, 3.0, 4.0, 5.0] and {r["loop"] for r in rows} == {"x"}
    assert [r["cycle"] for r in h.samples("x", start=108.0)] == [8, 9]
    assert [r["cycle"] for r in h.samples("x", end=100.5)] == [0]
    y = h.samples("y", 101.0, 101.0)
    assert len(y) == 1 and math.isnan(y[0]["pv"])  # NULL back as NaN
    assert len(h.samples(None, 100.0, 109.0)) == 20
    assert h.samples("x", 200.0, 300.0) == []
    h.close()


def test_audit_rows_of_a_loop_and_the_newest_few(tmp_path, sqlite_historian):
    h = sqlite_historian(tmp_path / "h.sqlite")
    h.open()
    for i in range(5):
        h.audit("alice", "a" if i % 2 == 0 else "b", f"sp{i}", None, {"sp": i}, True)
    assert [r["action"] for r in h.audit_rows()] == ["sp0", "sp1", "sp2", "sp3", "sp4"]
    assert [r["action"] for r in h.audit_rows("a")] == ["sp0", "sp2", "sp4"]
    assert [r["action"] for r in h.audit_rows(limit=2)] == ["sp3", "sp4"]  # oldest first
    assert [r["action"] for r in h.audit_rows("b", limit=1)] == ["sp3"]
    h.close()
