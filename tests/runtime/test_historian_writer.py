"""The historian's writer process: rows never lost on a clean stop, a crash detected, never blocks.

The runtime's side (:class:`~ctrlblocks.runtime.writer.ProcessHistorian`)
only queues fixed-size records; these tests kill, stop and starve the
writer process and count the rows that reach the database.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
import time

import pytest

from ctrlblocks.runtime import SQLiteHistorian
from ctrlblocks.runtime.config import HistorianConfig
from ctrlblocks.runtime.historian import HistoryError
from ctrlblocks.runtime.loop import Sample
from ctrlblocks.runtime.writer import RECORD, ProcessHistorian

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="POSIX pipes and signals")


def sample(k: int, loop: str = "x", pv: float = 0.5) -> Sample:
    return Sample(
        loop, k, 1000.0 + 0.1 * k, 0.1 * k, 0.1, 1.0, pv, 0.2, "auto", 0, True, True, False
    )


def writer(path, **kw) -> ProcessHistorian:
    h = ProcessHistorian(HistorianConfig(path=str(path)), timeout=60.0, **kw)
    h.open()
    return h


def stored(path) -> tuple[list[int], list[tuple]]:
    """(cycles of loop x, runs rows (run_id, stopped is set)) of a database."""
    with SQLiteHistorian(path).reading() as h:
        cycles = [r["cycle"] for r in h.samples("x")]
        runs = h.query("SELECT run_id, stopped IS NOT NULL FROM runs ORDER BY run_id")
    return cycles, runs


def test_a_record_is_72_bytes_and_every_sample_reaches_the_database(tmp_path):
    assert RECORD.size == 72
    h = writer(tmp_path / "h.sqlite")
    for k in range(500):
        h.record(sample(k, pv=float("nan") if k == 7 else 0.5))
    h.audit("alice", "x", "sp", {"sp": 1.0}, {"sp": 2.0}, True)
    h.close()
    assert h.writer_stats["rows"] == 500 and h.writer_stats["ok"]
    with SQLiteHistorian(tmp_path / "h.sqlite").reading() as r:
        rows = r.samples("x")
        audit = r.audit_rows()
    assert [s["cycle"] for s in rows] == list(range(500))
    assert rows[7]["pv"] != rows[7]["pv"] and rows[8]["pv"] == 0.5  # NaN back as NaN
    assert rows[3]["t_wall"] == pytest.approx(1000.3) and rows[3]["mode"] == "auto"
    assert [(a["who"], a["action"], a["new"]) for a in audit] == [("alice", "sp", '{"sp": 2.0}')]


def test_reads_see_everything_recorded_before_them(tmp_path):
    h = writer(tmp_path / "h.sqlite")
    for k in range(30):
        h.record(sample(k))
    h.audit("bob", "x", "mode", None, {"mode": "manual"}, False, "refused")
    assert len(h.samples("x")) == 30  # no explicit flush: the read waits for the commit
    assert [a["message"] for a in h.audit_rows("x", limit=5)] == ["refused"]
    h.close()
    with h.reading():
        assert len(h.samples()) == 30  # reading after the stop


def test_a_killed_writer_is_reported_started_again_and_a_clean_stop_loses_no_row(tmp_path, caplog):
    h = writer(tmp_path / "h.sqlite", restart_interval=3600.0)  # no restart before the stop
    for k in range(100):
        h.record(sample(k))
    h.flush()  # 0..99 committed
    pid = h.process.pid
    os.kill(pid, signal.SIGKILL)
    h.process.wait(30)
    with caplog.at_level(logging.ERROR, logger="ctrlblocks.runtime.writer"):
        for k in range(100, 200):
            h.record(sample(k))
            h.send()  # never raises, never blocks: detects the death
    assert h.process is None and h.pending >= 100  # they wait in memory
    assert any(
        "historian writer process died (exit code -9)" in r.getMessage() for r in caplog.records
    )
    h.close()  # starts a writer for the queue, on the same run
    assert h.restarts == 1
    cycles, runs = stored(tmp_path / "h.sqlite")
    assert cycles == list(range(200))
    assert runs == [(1, 1)]


def test_a_writer_that_hangs_never_blocks_the_cycles_and_the_queue_is_bounded(tmp_path, caplog):
    h = writer(tmp_path / "h.sqlite", max_pending_bytes=200_000)
    os.kill(h.process.pid, signal.SIGSTOP)  # a writer that does not read any more
    try:
        with caplog.at_level(logging.ERROR, logger="ctrlblocks.runtime.writer"):
            for k in range(40_000):  # 2.9 MB: more than the pipe and the queue hold
                h.record(sample(k))
                if k % 1000 == 999:
                    h.send()
        assert h.rows_lost > 0 and h.pending * RECORD.size <= 200_000 + 100 * RECORD.size
        assert any("does not keep up" in r.getMessage() for r in caplog.records)
    finally:
        os.kill(h.process.pid, signal.SIGCONT)
    h.close()
    cycles, _ = stored(tmp_path / "h.sqlite")
    assert len(cycles) + h.rows_lost == 40_000  # every sample stored or counted as lost
    assert cycles == sorted(cycles) and cycles[0] == 0  # the oldest in the queue went first


def test_the_writer_commits_what_it_got_and_ends_when_the_runtime_process_dies(tmp_path):
    db = tmp_path / "h.sqlite"
    script = textwrap.dedent(
        f"""
        import os
        from ctrlblocks.runtime.config import HistorianConfig
        from ctrlblocks.runtime.loop import Sample
        from ctrlblocks.runtime.writer import ProcessHistorian
        h = ProcessHistorian(HistorianConfig(path={str(db)!r}))
        h.open()
        for k in range(50):
            h.record(Sample("x", k, 1.0, 0.0, 0.1, 1.0, 0.5, 0.2, "auto", 0, True, True, False))
        h.send()
        assert h.pending == 0
        os._exit(0)  # no close: as a crash of the runtime
        """
    )
    subprocess.run([sys.executable, "-c", script], check=True, timeout=120)
    t_end = time.monotonic() + 60.0
    cycles: list[int] = []
    while time.monotonic() < t_end and len(cycles) < 50:
        time.sleep(0.1)
        cycles, runs = stored(db)
    assert cycles == list(range(50))
    assert runs == [(1, 0)]  # no stop time: the run ended in a crash


def test_a_runtime_killed_with_samples_in_memory_leaves_the_count_it_lost_in_the_audit(
    tmp_path,
):
    """SIGKILL with 30 samples recorded after the last hand-over: the writer commits the 50
    it received and writes ``lost`` = 30 (of 80 recorded) to the audit table."""
    db = tmp_path / "h.sqlite"
    script = textwrap.dedent(
        f"""
        import os, signal
        from ctrlblocks.runtime.config import HistorianConfig
        from ctrlblocks.runtime.loop import Sample
        from ctrlblocks.runtime.writer import ProcessHistorian
        h = ProcessHistorian(HistorianConfig(path={str(db)!r}))
        h.open()
        def s(k):
            return Sample("x", k, 1.0, 0.0, 0.1, 1.0, 0.5, 0.2, "auto", 0, True, True, False)
        for k in range(50):
            h.record(s(k))
        h.send()
        assert h.pending == 0
        for k in range(50, 80):
            h.record(s(k))  # recorded, never handed over
        os.kill(os.getpid(), signal.SIGKILL)
        """
    )
    subprocess.run([sys.executable, "-c", script], timeout=120)
    t_end = time.monotonic() + 60.0
    lost: list[dict] = []
    while time.monotonic() < t_end and not lost:
        time.sleep(0.1)
        with (
            contextlib.suppress(sqlite3.OperationalError, HistoryError),
            SQLiteHistorian(db).reading() as h,
        ):
            lost = [r for r in h.audit_rows() if r["action"] == "lost"]
    cycles, _ = stored(db)
    assert cycles == list(range(50))
    (row,) = lost
    assert row["who"] == "historian" and json.loads(row["new"]) == {"lost": 30, "recorded": 80}
    assert "30 of its 80 recorded sample(s)" in row["message"]


def test_a_database_that_cannot_be_opened_says_which_and_why(tmp_path):
    path = tmp_path / "no such folder" / "h.sqlite"
    h = ProcessHistorian(HistorianConfig(path=str(path)))
    with pytest.raises(HistoryError, match=r"no such folder/h\.sqlite: OperationalError: unable"):
        h.open()
    assert h.process is None
    h.close()  # nothing to do


def test_a_sample_stored_twice_is_skipped_with_an_error_and_the_others_are_kept(tmp_path, caplog):
    h = writer(tmp_path / "h.sqlite")
    for k in range(10):
        h.record(sample(k))
    h.flush()
    with caplog.at_level(logging.ERROR, logger="ctrlblocks.runtime.writer"):
        for k in (5, 10, 11):  # cycle 5 again (a defect)
            h.record(sample(k))
        h.close()
    cycles, runs = stored(tmp_path / "h.sqlite")
    assert cycles == list(range(12)) and runs == [(1, 1)]
    assert h.writer_stats["ok"]
    assert any("already stored are left out" in r.getMessage() for r in caplog.records)
