"""The historian: every cycle of every loop, and an audit trail, in SQLite or PostgreSQL.

Schema (the same in both databases; ``docs/runtime.md`` explains each column)::

    runs    (run_id, started, stopped, name)
    samples (run_id, loop, cycle, t_wall, t, dt, sp, pv, mv, mode,
             error_id, pv_ok, write_ok, overrun)      key (run_id, cycle, loop)
    audit   (id, t_wall, who, loop, action, old, new, ok, message)

* SQLite (default, embedded): WAL journal, ``synchronous=NORMAL``; rows are
  buffered and written in batches (every ``flush_interval`` seconds or
  ``batch`` rows) in one transaction.  SQLite stores NaN as NULL; the export
  gives NaN back.
* PostgreSQL (psycopg 3): the same tables (``DOUBLE PRECISION``/``BIGINT``).

Every start of the runtime opens a new run (``run_id`` + 1) and appends; a
graceful stop flushes the buffer, so no sample is lost across a restart.
``retention_days > 0`` deletes samples (and audit rows) older than that at
open and once an hour.
"""

from __future__ import annotations

import contextlib
import csv
import importlib.util
import json
import logging
import math
import re
import sqlite3
import threading
import time
import urllib.parse
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .loop import Sample

__all__ = [
    "EXPORT_FORMATS",
    "SAMPLE_COLUMNS",
    "Historian",
    "HistoryError",
    "PostgresHistorian",
    "SQLiteHistorian",
    "audit_row",
    "export_history",
]

log = logging.getLogger(__name__)

SAMPLE_COLUMNS = (
    "run_id",
    "loop",
    "cycle",
    "t_wall",
    "t",
    "dt",
    "sp",
    "pv",
    "mv",
    "mode",
    "error_id",
    "pv_ok",
    "write_ok",
    "overrun",
)
"""Columns of the ``samples`` table, in order."""

AUDIT_COLUMNS = ("id", "t_wall", "who", "loop", "action", "old", "new", "ok", "message")

_AUDIT_INSERT = (
    "INSERT INTO audit (t_wall, who, loop, action, old, new, ok, message) "
    "VALUES (?, ?, ?, ?, ?, ?, ?, ?)"
)

_SQLITE_SCHEMA = """
CREATE TABLE IF NOT EXISTS runs (
    run_id INTEGER PRIMARY KEY, started REAL NOT NULL, stopped REAL, name TEXT);
CREATE TABLE IF NOT EXISTS samples (
    run_id INTEGER NOT NULL, loop TEXT NOT NULL, cycle INTEGER NOT NULL,
    t_wall REAL NOT NULL, t REAL, dt REAL, sp REAL, pv REAL, mv REAL, mode TEXT,
    error_id INTEGER, pv_ok INTEGER, write_ok INTEGER, overrun INTEGER,
    PRIMARY KEY (run_id, cycle, loop));
CREATE INDEX IF NOT EXISTS samples_loop_time ON samples (loop, t_wall);
CREATE TABLE IF NOT EXISTS audit (
    id INTEGER PRIMARY KEY AUTOINCREMENT, t_wall REAL NOT NULL, who TEXT, loop TEXT,
    action TEXT, old TEXT, new TEXT, ok INTEGER, message TEXT);
"""

_PG_SCHEMA = """
CREATE TABLE IF NOT EXISTS runs (
    run_id BIGINT PRIMARY KEY, started DOUBLE PRECISION NOT NULL,
    stopped DOUBLE PRECISION, name TEXT);
CREATE TABLE IF NOT EXISTS samples (
    run_id BIGINT NOT NULL, loop TEXT NOT NULL, cycle BIGINT NOT NULL,
    t_wall DOUBLE PRECISION NOT NULL, t DOUBLE PRECISION, dt DOUBLE PRECISION,
    sp DOUBLE PRECISION, pv DOUBLE PRECISION, mv DOUBLE PRECISION, mode TEXT,
    error_id BIGINT, pv_ok SMALLINT, write_ok SMALLINT, overrun SMALLINT,
    PRIMARY KEY (run_id, cycle, loop));
CREATE INDEX IF NOT EXISTS samples_loop_time ON samples (loop, t_wall);
CREATE TABLE IF NOT EXISTS audit (
    id BIGSERIAL PRIMARY KEY, t_wall DOUBLE PRECISION NOT NULL, who TEXT, loop TEXT,
    action TEXT, old TEXT, new TEXT, ok SMALLINT, message TEXT);
"""


def audit_row(
    who: str, loop: str, action: str, old: Any, new: Any, ok: bool, message: str = ""
) -> tuple[Any, ...]:
    """The ``audit`` table's row (without ``id``): now, ``old``/``new`` as JSON."""
    old_j, new_j = json.dumps(old, default=str), json.dumps(new, default=str)
    return (time.time(), who, loop, action, old_j, new_j, int(ok), message)


def _row(run_id: int, s: Sample) -> tuple[Any, ...]:
    return (
        run_id,
        s.loop,
        s.cycle,
        s.t_wall,
        s.t,
        s.dt,
        s.sp,
        s.pv,
        s.mv,
        s.mode,
        s.error_id,
        int(s.pv_ok),
        int(s.write_ok),
        int(s.overrun),
    )


class Historian:
    """Buffered writer of samples and audit rows (base of the two databases).

    ``record`` only appends to a buffer (cheap, in the cycle); ``flush``
    writes the buffer in one transaction (the runtime calls it from a worker
    thread every ``flush_interval``).
    """

    placeholder = "?"
    schema = _SQLITE_SCHEMA
    skip_duplicates = ("INSERT OR IGNORE INTO", "")  # the insert that skips stored keys

    def __init__(self, *, name: str = "ctrlblocks", retention_days: float = 0.0) -> None:
        self.name = name
        self.retention_days = float(retention_days)
        self.run_id = 0
        self.rows_written = 0
        self._buf: list[tuple[Any, ...]] = []
        self._buf_lock = threading.Lock()
        self._db_lock = threading.Lock()
        self._conn: Any = None
        self._last_retention = 0.0

    # -- database specifics (overridden) ------------------------------------------

    def _connect(self) -> Any:  # pragma: no cover - abstract
        raise NotImplementedError

    def _executescript(self, sql: str) -> None:
        cur = self._conn.cursor()
        for stmt in sql.split(";"):
            if stmt.strip():
                cur.execute(stmt)
        self._conn.commit()

    def _sql(self, sql: str) -> str:
        return sql.replace("?", self.placeholder)

    # -- life cycle -----------------------------------------------------------------

    def open(self, run_id: int | None = None) -> None:
        """Create the tables if needed, start a new run, apply the retention.

        ``run_id``: go on with that run instead (a restarted writer process,
        :mod:`ctrlblocks.runtime.writer`).
        """
        with self._db_lock:
            self._conn = self._connect()
            self._executescript(self.schema)
            cur = self._conn.cursor()
            if run_id is not None:
                self.run_id = int(run_id)
            else:
                cur.execute("SELECT COALESCE(MAX(run_id), 0) FROM runs")
                self.run_id = int(cur.fetchone()[0]) + 1
                cur.execute(
                    self._sql("INSERT INTO runs (run_id, started, name) VALUES (?, ?, ?)"),
                    (self.run_id, time.time(), self.name),
                )
            self._conn.commit()
        self.apply_retention()

    def close(self) -> None:
        """Flush, mark the run stopped, close."""
        if self._conn is None:
            return
        self.flush()
        with self._db_lock:
            cur = self._conn.cursor()
            cur.execute(
                self._sql("UPDATE runs SET stopped = ? WHERE run_id = ?"),
                (time.time(), self.run_id),
            )
            self._conn.commit()
            self._conn.close()
            self._conn = None

    @contextlib.contextmanager
    def reading(self) -> Iterator[Historian]:
        """Open the database to read it only (no tables made, no run started); close on exit.

        For the history another process writes, or a finished one::

            with SQLiteHistorian("history.sqlite").reading() as h:
                rows = h.samples("level")
        """
        self.open_reading()
        try:
            yield self
        finally:
            self.close_connection()

    def open_reading(self) -> None:
        """Open the database to read it only (:meth:`reading` without the ``with``)."""
        with self._db_lock:
            self._conn = self._connect_for_reading()

    def close_connection(self) -> None:
        """Close the connection as it is: no flush, the run keeps no stop time (a crash's end)."""
        with self._db_lock:
            if self._conn is not None:
                self._conn.close()
                self._conn = None

    def _connect_for_reading(self) -> Any:
        """The connection of :meth:`reading` (override: never create a database)."""
        return self._connect()

    # -- writing ----------------------------------------------------------------------

    def record(self, sample: Sample) -> None:
        """Buffer one sample (written by the next :meth:`flush`)."""
        with self._buf_lock:
            self._buf.append(_row(self.run_id, sample))

    @property
    def pending(self) -> int:
        """Samples buffered and not yet written."""
        return len(self._buf)

    def flush(self) -> int:
        """Write the buffered samples in one transaction; return how many."""
        with self._buf_lock:
            rows, self._buf = self._buf, []
        if not rows:
            return 0
        try:
            self.insert(rows)
        except Exception:
            with self._buf_lock:  # keep them for the next try
                self._buf[:0] = rows
            raise
        return len(rows)

    def insert(
        self,
        rows: Sequence[tuple[Any, ...]],
        audits: Sequence[tuple[Any, ...]] = (),
        *,
        skip_duplicates: bool = False,
    ) -> None:
        """Insert sample rows (:data:`SAMPLE_COLUMNS`) and audit rows (:func:`audit_row`).

        One transaction (rolled back on an error); applies the retention once
        an hour.  ``skip_duplicates``: a sample whose key is already stored
        is left out instead of failing the transaction.
        """
        cols = ", ".join(SAMPLE_COLUMNS)
        marks = ", ".join([self.placeholder] * len(SAMPLE_COLUMNS))
        head, tail = self.skip_duplicates if skip_duplicates else ("INSERT INTO", "")
        with self._db_lock:
            cur = self._conn.cursor()
            try:
                if rows:
                    cur.executemany(f"{head} samples ({cols}) VALUES ({marks}){tail}", rows)
                if audits:
                    cur.executemany(self._sql(_AUDIT_INSERT), audits)
                self._conn.commit()
            except Exception:
                with contextlib.suppress(Exception):
                    self._conn.rollback()
                raise
        self.rows_written += len(rows)
        if self.retention_days > 0 and time.time() - self._last_retention > 3600.0:
            self.apply_retention()

    def audit(
        self,
        who: str,
        loop: str,
        action: str,
        old: Any,
        new: Any,
        ok: bool,
        message: str = "",
    ) -> None:
        """Write one audit row (who changed what, when, and whether it was accepted)."""
        self._write_audit(audit_row(who, loop, action, old, new, ok, message))

    def _write_audit(self, row: tuple[Any, ...]) -> None:
        """Insert one :func:`audit_row` at once (the writer process queues it instead)."""
        with self._db_lock:
            cur = self._conn.cursor()
            cur.execute(self._sql(_AUDIT_INSERT), row)
            self._conn.commit()

    def apply_retention(self) -> None:
        """Delete samples and audit rows older than ``retention_days`` (0: keep all)."""
        self._last_retention = time.time()
        if self.retention_days <= 0:
            return
        cutoff = time.time() - self.retention_days * 86400.0
        with self._db_lock:
            cur = self._conn.cursor()
            cur.execute(self._sql("DELETE FROM samples WHERE t_wall < ?"), (cutoff,))
            cur.execute(self._sql("DELETE FROM audit WHERE t_wall < ?"), (cutoff,))
            self._conn.commit()

    # -- reading ------------------------------------------------------------------------

    def query(self, sql: str, params: Sequence[Any] = ()) -> list[tuple[Any, ...]]:
        """Run a read query (``?`` placeholders) and return all rows."""
        with self._db_lock:
            cur = self._conn.cursor()
            cur.execute(self._sql(sql), tuple(params))
            rows = cur.fetchall()
            self._conn.commit()
        return rows

    def samples(
        self, loop: str | None = None, start: float | None = None, end: float | None = None
    ) -> list[dict[str, Any]]:
        """The samples (of one loop), one dict per row; NULL floats as NaN.

        Parameters
        ----------
        loop : str, optional
            Only this loop (default all).
        start, end : float, optional
            Only the samples with ``start <= t_wall <= end`` (Unix time [s]).
            Without a window the rows are ordered by run, loop and cycle; with
            one (either bound given), by ``t_wall``, run and cycle.

        Buffered samples are not included: :meth:`flush` first for the latest.
        """
        conds, params = [], []
        if loop:
            conds.append("loop = ?")
            params.append(loop)
        if start is not None:
            conds.append("t_wall >= ?")
            params.append(start)
        if end is not None:
            conds.append("t_wall <= ?")
            params.append(end)
        where = f"WHERE {' AND '.join(conds)} " if conds else ""
        window = start is not None or end is not None
        order = "t_wall, run_id, cycle" if window else "run_id, loop, cycle"
        rows = self.query(
            f"SELECT {', '.join(SAMPLE_COLUMNS)} FROM samples {where}ORDER BY {order}", params
        )
        return [_as_dict(r) for r in rows]

    def audit_rows(self, loop: str | None = None, limit: int | None = None) -> list[dict[str, Any]]:
        """The audit trail (of one loop), oldest first; ``limit``: only the newest ``limit``."""
        where, params = ("WHERE loop = ? ", [loop]) if loop else ("", [])
        if limit is None:
            sql = f"SELECT {', '.join(AUDIT_COLUMNS)} FROM audit {where}ORDER BY id"
            rows = self.query(sql, params)
        else:
            sql = f"SELECT {', '.join(AUDIT_COLUMNS)} FROM audit {where}ORDER BY id DESC LIMIT ?"
            rows = self.query(sql, (*params, int(limit)))[::-1]
        return [dict(zip(AUDIT_COLUMNS, r, strict=True)) for r in rows]


def _as_dict(r: Sequence[Any]) -> dict[str, Any]:
    d = dict(zip(SAMPLE_COLUMNS, r, strict=True))
    for k in ("t", "dt", "sp", "pv", "mv"):
        if d[k] is None:
            d[k] = math.nan
    return d


class SQLiteHistorian(Historian):
    """The embedded historian (SQLite, WAL)."""

    def __init__(self, path: str | Path, **kw: Any) -> None:
        super().__init__(**kw)
        self.path = str(path)

    def _connect(self) -> Any:
        conn = sqlite3.connect(self.path, check_same_thread=False, timeout=10.0)
        conn.execute("PRAGMA journal_mode=WAL")
        conn.execute("PRAGMA synchronous=NORMAL")
        # 32 MiB of page cache: the index (loop, t_wall) gets one insert point per loop,
        # and with the default 2 MiB 1,000 loops missed the cache on every row
        conn.execute("PRAGMA cache_size=-32768")
        return conn

    def _connect_for_reading(self) -> Any:
        """An existing database only (``mode=rw``: a missing file is an error, not created)."""
        p = Path(self.path)
        if not p.is_file():
            raise HistoryError(f"{self.path}: no such historian database")
        uri = f"{p.resolve().as_uri()}?mode=rw"
        try:
            conn = sqlite3.connect(uri, uri=True, check_same_thread=False, timeout=10.0)
            tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master")}
        except sqlite3.DatabaseError as exc:
            raise HistoryError(f"{self.path}: not a historian database ({exc})") from None
        if "samples" not in tables:
            conn.close()
            raise HistoryError(
                f"{self.path}: not a ctrlblocks historian database (no samples table)"
            )
        return conn


class PostgresHistorian(Historian):
    """The server historian (PostgreSQL via psycopg 3), same schema as SQLite."""

    placeholder = "%s"
    schema = _PG_SCHEMA
    skip_duplicates = ("INSERT INTO", " ON CONFLICT DO NOTHING")

    def __init__(self, dsn: str, **kw: Any) -> None:
        super().__init__(**kw)
        self.dsn = dsn

    def _connect(self) -> Any:
        try:
            import psycopg
        except ImportError as exc:  # pragma: no cover - depends on the install
            raise ImportError(
                "the PostgreSQL historian needs psycopg: pip install 'ctrlblocks[runtime]'"
            ) from exc
        try:
            return psycopg.connect(self.dsn, connect_timeout=10)
        except psycopg.Error as exc:  # a DSN that does not parse, a server that does not answer
            raise HistoryError(
                f"PostgreSQL: {type(exc).__name__}: {hide_dsn_secrets(str(exc), self.dsn)}"
            ) from None

    def _connect_for_reading(self) -> Any:
        """A database with the historian's tables only (none are created)."""
        conn = self._connect()
        if conn.execute("SELECT to_regclass('samples')").fetchone()[0] is None:
            conn.close()
            raise HistoryError("PostgreSQL: not a ctrlblocks historian database (no samples table)")
        return conn


class HistoryError(ValueError):
    """A historian database or an export request that cannot be served (the CLI's message)."""


_DSN_PASSWORDS = (
    re.compile(r"^[A-Za-z][A-Za-z0-9+.\-]*://[^:/@?#]*:([^@/?#]*)@"),  # postgresql://u:PASS@h
    re.compile(r"password\s*=\s*('(?:[^'\\]|\\.)*'|[^\s&]+)"),  # password=PASS, ?password=
)


_DSN_SECRET_KEYS = ("password", "sslpassword")
"""The connection parameters that hold a secret (libpq: the password, the SSL key's password)."""


def hide_dsn_secrets(message: str, dsn: str) -> str:
    """``message`` on one line, every password written in ``dsn`` replaced by ``***``.

    The secrets are what the database driver itself reads from ``dsn``
    (``psycopg.conninfo.conninfo_to_dict``: every form libpq accepts, quoting,
    escapes and percent-encoding undone), plus, for a DSN the driver refuses
    and may quote back, the text after ``user:`` in a URI and after
    ``password=`` / ``sslpassword=`` (quoted or not, also percent-decoded).
    """
    secrets = set()
    for pattern in _DSN_PASSWORDS:
        for m in pattern.finditer(dsn):
            pw = m.group(1)
            secrets |= {pw, pw.strip("'"), urllib.parse.unquote(pw)}
    try:
        from psycopg.conninfo import conninfo_to_dict

        parsed = conninfo_to_dict(dsn)
    except Exception:  # no driver, or a DSN it refuses: the patterns above
        parsed = {}
    secrets |= {str(parsed[k]) for k in _DSN_SECRET_KEYS if parsed.get(k)}
    text = "; ".join(" ".join(line.split()) for line in message.splitlines() if line.strip())
    for pw in sorted((s for s in secrets if s), key=len, reverse=True):
        text = text.replace(pw, "***")
    return text


EXPORT_FORMATS = {".csv": "csv", ".parquet": "parquet"}
"""Export file suffixes and their formats."""


def export_history(
    source: str | Path,
    out: str | Path,
    *,
    fmt: str = "auto",
    loop: str | None = None,
    postgres: bool = False,
) -> Path:
    """Export the samples of a historian database to CSV or Parquet.

    ``source`` is a SQLite file (or a PostgreSQL DSN with ``postgres=True``);
    ``fmt`` is ``"csv"``, ``"parquet"`` (needs pyarrow) or ``"auto"`` (from
    the suffix of ``out``: ``.csv`` or ``.parquet``).  Returns the written
    path.  Raises :class:`HistoryError` -- before anything is created -- for
    a missing database, an unknown suffix, or a ``loop`` the database does
    not hold; ImportError (with the install command) for Parquet without
    pyarrow.
    """
    out = Path(out)
    if fmt == "auto":
        fmt = EXPORT_FORMATS.get(out.suffix.lower(), "")
        if not fmt:
            raise HistoryError(
                f"{out}: unknown export format {out.suffix or '(no suffix)'!r}; "
                f"use {' or '.join(EXPORT_FORMATS)}"
            )
    if fmt not in EXPORT_FORMATS.values():
        raise HistoryError(f"unknown export format {fmt!r}; use csv or parquet")
    if fmt == "parquet" and importlib.util.find_spec("pyarrow") is None:
        raise ImportError("Parquet export needs pyarrow: pip install pyarrow (or export to .csv)")
    h: Historian = PostgresHistorian(str(source)) if postgres else SQLiteHistorian(source)
    where = "PostgreSQL" if postgres else source  # a DSN may hold a password: never shown
    with h.reading():
        rows = h.samples(loop)
        if loop and not rows:
            names = [r[0] for r in h.query("SELECT DISTINCT loop FROM samples ORDER BY loop")]
            raise HistoryError(
                f"{where}: no samples of loop {loop!r}; loops: {', '.join(names) or 'none'}"
            )
    if fmt == "parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.table({c: [r[c] for r in rows] for c in SAMPLE_COLUMNS})
        pq.write_table(table, out)
        return out
    with out.open("w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(SAMPLE_COLUMNS)
        for r in rows:
            w.writerow([r[c] for c in SAMPLE_COLUMNS])
    return out
