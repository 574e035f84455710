"""The historian's writer process: the cycles append records, another process writes the database.

Why a process: in the runtime's own process the database writes -- the
row tuples, ``executemany`` and the commits of 10,000 rows/s with 1,000
loops -- ran in a thread next to the cycles, and every stretch of it that
held the GIL delayed the cycles; whole cycles stalled by 100-300 ms next
to the flushes (docs/performance.md).  Now the runtime only packs each
sample into a fixed-size binary record (:data:`RECORD`, 72 bytes) and hands
the cycle's records to a pipe without ever blocking; a writer process
(:func:`serve_writer`) reads them, builds the rows and commits them in
batches (every ``flush_interval`` seconds or ``batch`` rows), with its own
CPU and its own GIL.

:class:`ProcessHistorian` is the runtime's side.  It is a
:class:`~ctrlblocks.runtime.historian.Historian` (the same reading API:
``samples``, ``audit_rows``, ``query`` read the database through a
connection of their own), and:

* :meth:`~ProcessHistorian.record` and :meth:`~ProcessHistorian.audit`
  append to a queue in memory, :meth:`~ProcessHistorian.send` (the
  runtime calls it every 50 ms) writes what the pipe takes (non-blocking);
  the queue is bounded (``max_pending_bytes``, 64 MiB: about 90 s of 1,000
  loops at 100 ms): past it the oldest samples are dropped, counted in
  ``rows_lost`` and logged;
* a writer that dies (killed, out of memory, a defect) is detected at the
  next :meth:`~ProcessHistorian.send` (its exit code, or the broken pipe),
  logged as an error with the exit code, and started again at most every
  ``restart_interval`` seconds on the same run; the queue waits for it.
  What the dead writer had received but not committed (at most about
  ``flush_interval`` seconds) is lost, as in a crash of the runtime;
* :meth:`~ProcessHistorian.flush` waits until the writer has committed
  everything recorded before the call (the faceplate's trends call it);
* the runtime's process killed (SIGKILL, out of memory): the samples it had
  recorded but not yet handed over are lost.  Both processes keep a tally in a
  small shared file (samples recorded, samples handed over, updated as they
  happen); the writer, finding the end of its pipe without a close, commits
  what it received and writes how many were lost to the audit table
  (``who = "historian"``, ``action = "lost"``) and to its standard error;
* :meth:`~ProcessHistorian.close` (a clean stop) hands over everything,
  waits for the writer to commit it and to mark the run stopped, then
  collects the writer's statistics (:attr:`ProcessHistorian.writer_stats`:
  rows, commits, its CPU seconds); a writer that had died is started once
  more for that, so a clean stop loses no row.

The writer runs at a lower priority (nice + 5: when the two compete for a
core, the cycles go first and the queue waits) and ignores SIGINT and
SIGTERM (a Ctrl-C or a service stop reaches the whole process group): it
ends when the runtime closes it, or when the pipe reaches its end because
the runtime's process is gone -- then it commits what it has and exits
(the run stays without a stop time, as after any crash).

Protocol (private to the two processes; the pipe runtime -> writer carries
frames ``kind (1 byte) | payload length (uint32) | payload``):

* ``I``: the first frame: the settings (JSON: the ``[historian]`` table,
  and the run to go on with after a restart);
* ``S``: samples, ``n`` :data:`RECORD` s;
* ``N``: a name: code (uint32) and UTF-8 text (loop names and modes share
  one table; a record carries codes);
* ``A``: one audit row (JSON list);
* ``F``: flush: a token (uint64); the writer commits, then answers;
* ``C``: close: commit, mark the run stopped, answer with the statistics.

The answers (writer -> runtime, its stdout) are frames too, with a JSON
payload: ``O`` opened (``run_id`` or ``error``), ``F`` token,
``E`` an error to log (a failed commit; the rows are kept and retried),
``C`` statistics.
"""

from __future__ import annotations

import collections
import contextlib
import json
import logging
import mmap
import os
import select
import signal
import site
import struct
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .historian import (
    Historian,
    HistoryError,
    PostgresHistorian,
    SQLiteHistorian,
    hide_dsn_secrets,
)

if TYPE_CHECKING:
    from .loop import Sample

__all__ = ["RECORD", "ProcessHistorian", "open_historian", "serve_writer"]

log = logging.getLogger(__name__)

RECORD = struct.Struct("<IIqddddddiBBBx")
"""One sample: loop code, mode code, cycle, t_wall, t, dt, sp, pv, mv, error id, pv_ok,
write_ok, overrun (72 bytes, little-endian)."""

_HEAD = struct.Struct("<cI")  # frame kind, payload length
_WRITER_MAIN = (  # nice + 5 before the imports: the cycles first, also while it starts
    "import os\ntry:\n    os.nice(5)\nexcept OSError:\n    pass\n"
    "from ctrlblocks.runtime.writer import serve_writer\nserve_writer()\n"
)
_CODE = struct.Struct("<I")
_TOKEN = struct.Struct("<Q")
_TALLY = struct.Struct("<QQ")  # samples recorded, samples handed over to the writer


class _Tally:
    """The shared tally file (module docstring): mapped by the runtime and by the writer."""

    def __init__(self, path: str, create: bool = False) -> None:
        self.path = path
        if create:
            with open(path, "wb") as f:
                f.write(bytes(_TALLY.size))
        with open(path, "r+b") as f:
            self.map = mmap.mmap(f.fileno(), _TALLY.size)
        self.recorded = self.handed = 0

    def write(self) -> None:
        _TALLY.pack_into(self.map, 0, self.recorded, self.handed)

    def read(self) -> tuple[int, int]:
        return _TALLY.unpack_from(self.map, 0)

    def remove(self) -> None:
        with contextlib.suppress(OSError, ValueError):
            self.map.close()
        with contextlib.suppress(OSError):
            os.unlink(self.path)


def _frame(kind: bytes, payload: bytes) -> bytes:
    return _HEAD.pack(kind, len(payload)) + payload


def _settings(config: Any, name: str) -> dict[str, Any]:
    """The part of a ``[historian]`` configuration the writer process needs (picklable)."""
    return {
        "backend": config.backend,
        "path": config.path,
        "dsn": config.dsn,
        "flush_interval": float(config.flush_interval),
        "batch": int(config.batch),
        "retention_days": float(config.retention_days),
        "name": name,
    }


def _database(settings: dict[str, Any]) -> Historian:
    kw = {"name": settings["name"], "retention_days": settings["retention_days"]}
    if settings["backend"] == "postgresql":
        return PostgresHistorian(settings["dsn"], **kw)
    return SQLiteHistorian(settings["path"], **kw)


class ProcessHistorian(Historian):
    """The runtime's side of the historian's writer process (see the module docstring).

    Parameters
    ----------
    config : HistorianConfig
        The ``[historian]`` table (backend ``sqlite`` or ``postgresql``).
    name : str
        The runtime's name (the runs table).
    max_pending_bytes : int
        Bound of the queue in the runtime's memory (default 64 MiB).
    restart_interval : float
        Seconds between two starts of a writer that died (default 5).
    timeout : float
        Seconds to wait for the writer's answers: opened, flushed, closed
        (default 60).
    """

    def __init__(
        self,
        config: Any,
        *,
        name: str = "ctrlblocks",
        max_pending_bytes: int = 64 << 20,
        restart_interval: float = 5.0,
        timeout: float = 60.0,
    ) -> None:
        super().__init__(name=name, retention_days=config.retention_days)
        self.settings = _settings(config, name)
        self.max_pending_bytes = int(max_pending_bytes)
        self.restart_interval = float(restart_interval)
        self.timeout = float(timeout)
        self.rows_lost = 0  # samples dropped because the queue was full
        self.restarts = 0  # writers started again after one died
        self.writer_stats: dict[str, Any] = {}  # the writer's statistics at close
        self.process: Any = None
        self._codes: dict[str, int] = {}
        self._recs = bytearray()  # records of the frame being built
        self._frames: collections.deque[bytes] = collections.deque()
        self._sent = 0  # bytes of _frames[0] already in the pipe
        self._queued = 0  # bytes in _frames
        self._fd = -1  # the pipe to the writer (its stdin), non-blocking
        self._answers = -1  # the pipe from the writer (its stdout), non-blocking
        self._inbuf = bytearray()
        self._opened = False
        self._dead_since: float | None = None
        self._lock = threading.Lock()
        self._token = 0
        self._flushed = 0
        self._closed_stats: dict[str, Any] | None = None
        self._closed = False
        self._open_error = ""
        self._reader: Historian | None = None
        fd, tally = tempfile.mkstemp(prefix="ctrlblocks-historian-", suffix=".tally")
        os.close(fd)
        self._tally = _Tally(tally, create=True)
        self.settings["tally"] = tally

    # -- the writer process ------------------------------------------------------------

    def open(self) -> None:
        """Start the writer and wait until it has opened the database (a new run)."""
        with self._lock:
            self._start_writer()
        self._wait(lambda: self._opened or bool(self._open_error), "open the database")
        if self._open_error:
            with self._lock:
                self._closed = True
                if self.process is not None:
                    with contextlib.suppress(subprocess.TimeoutExpired):
                        self.process.wait(10.0)  # it ends by itself after the answer
                    self._writer_gone("")
                self._tally.remove()
            raise HistoryError(f"historian: {self._open_error}")

    def _start_writer(self) -> None:
        """Start a writer process (lock held); the queue starts with its settings and names."""
        env = dict(os.environ)
        src = str(Path(__file__).resolve().parents[2])  # the folder that holds ctrlblocks
        if src not in {str(Path(p).resolve()) for p in site.getsitepackages()}:
            # a source tree (tests, a checkout on sys.path): the writer imports the same code
            env["PYTHONPATH"] = os.pathsep.join(p for p in (src, env.get("PYTHONPATH")) if p)
        proc = subprocess.Popen(
            [sys.executable, "-c", _WRITER_MAIN],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            env=env,
            start_new_session=True,  # a Ctrl-C in the terminal reaches the runtime only
        )
        assert proc.stdin is not None and proc.stdout is not None
        self.process, self._opened, self._inbuf = proc, False, bytearray()
        self._fd, self._answers = proc.stdin.fileno(), proc.stdout.fileno()
        os.set_blocking(self._fd, False)
        os.set_blocking(self._answers, False)
        with contextlib.suppress(AttributeError, OSError):  # Linux: a 1 MiB pipe
            import fcntl

            fcntl.fcntl(self._fd, fcntl.F_SETPIPE_SZ, 1 << 20)
        self._sent = 0  # a frame the dead writer got in part goes again whole
        init = {"settings": self.settings, "run_id": self.run_id or None}  # a restart goes on
        first = [_frame(b"I", json.dumps(init).encode())]
        first += [_frame(b"N", _CODE.pack(c) + n.encode()) for n, c in self._codes.items()]
        self._frames.extendleft(reversed(first))
        self._queued += sum(map(len, first))

    def _answer(self) -> None:
        """Handle the writer's answers that have arrived (lock held)."""
        while self._answers >= 0:
            try:
                chunk = os.read(self._answers, 1 << 16)
            except BlockingIOError:
                break
            except OSError:
                chunk = b""
            if not chunk:  # the writer is gone (_alive tells why)
                break
            self._inbuf += chunk
        pos, buf = 0, self._inbuf
        while len(buf) - pos >= _HEAD.size:
            kind, n = _HEAD.unpack_from(buf, pos)
            if len(buf) - pos - _HEAD.size < n:
                break
            body = json.loads(bytes(buf[pos + _HEAD.size : pos + _HEAD.size + n]))
            pos += _HEAD.size + n
            if kind == b"O":
                if "error" in body:
                    self._open_error = str(body["error"])
                else:
                    self.run_id, self._opened = int(body["run_id"]), True
            elif kind == b"F":
                self._flushed = max(self._flushed, int(body))
            elif kind == b"E":
                log.error("historian writer: %s", body)
            elif kind == b"C":
                self._closed_stats = body
        del buf[:pos]

    def _alive(self) -> bool:
        """Whether the writer runs; a writer found dead is reported once (lock held)."""
        if self.process is None:
            return False
        code = self.process.poll()
        if code is None:
            return True
        if self._open_error:
            self._writer_gone("")
        else:
            self._writer_gone(f"exit code {code}")
        return False

    def _writer_gone(self, why: str) -> None:
        """Forget a writer that ended (lock held); ``why`` non-empty: log an error."""
        if why:
            log.error(
                "historian writer process died (%s): %d byte(s) of samples wait in memory "
                "(at most %d); it is started again within %g s",
                why, self._queued + len(self._recs), self.max_pending_bytes,
                self.restart_interval,
            )  # fmt: skip
        proc, self.process = self.process, None
        if proc is not None:
            if proc.poll() is None:
                proc.kill()
            for f in (proc.stdin, proc.stdout):
                with contextlib.suppress(OSError):
                    f.close()  # type: ignore[union-attr]
            with contextlib.suppress(subprocess.TimeoutExpired):
                proc.wait(1.0)
        self._fd = self._answers = -1
        self._opened = False
        self._dead_since = time.monotonic()

    # -- the queue -----------------------------------------------------------------------

    def _push(self, kind: bytes, payload: bytes) -> None:
        """Close the frame of records being built, then queue one frame (lock held)."""
        if self._recs:
            self._queue(_frame(b"S", bytes(self._recs)))
            self._recs.clear()
        if kind:
            self._queue(_frame(kind, payload))

    def _queue(self, frame: bytes) -> None:
        self._frames.append(frame)
        self._queued += len(frame)
        if self._queued > self.max_pending_bytes:
            self._drop()

    def _drop(self) -> None:
        """Drop the oldest sample frames (never a name, never one in the pipe) to the bound."""
        keep: collections.deque[bytes] = collections.deque()
        lost = 0
        first = True
        while self._frames and self._queued > self.max_pending_bytes // 2:
            f = self._frames.popleft()
            if f[:1] == b"S" and not (first and self._sent):
                self._queued -= len(f)
                lost += (len(f) - _HEAD.size) // RECORD.size
            else:
                keep.append(f)
            first = False
        self._frames.extendleft(reversed(keep))
        self._tally.handed += lost  # counted in rows_lost (logged), not lost again at a kill
        if lost:
            if not self.rows_lost:
                log.error(
                    "historian: the writer does not keep up; %d sample(s) dropped "
                    "(the queue holds at most %d bytes)", lost, self.max_pending_bytes,
                )  # fmt: skip
            self.rows_lost += lost

    def _code(self, name: str) -> int:
        c = self._codes.get(name)
        if c is None:
            c = self._codes[name] = len(self._codes)
            self._push(b"N", _CODE.pack(c) + name.encode())
        return c

    def record(self, sample: Sample) -> None:
        """Queue one sample (cheap: a 72-byte record; :meth:`send` hands it over)."""
        s = sample
        with self._lock:
            codes = self._codes
            lc = codes.get(s.loop)
            if lc is None:
                lc = self._code(s.loop)
            mc = codes.get(s.mode)
            if mc is None:
                mc = self._code(s.mode)
            self._recs += RECORD.pack(
                lc, mc, s.cycle, s.t_wall, s.t, s.dt, s.sp, s.pv, s.mv,
                s.error_id, s.pv_ok, s.write_ok, s.overrun,
            )  # fmt: skip
            tally = self._tally
            tally.recorded += 1
            tally.write()

    @property
    def pending(self) -> int:
        """Samples queued and not yet handed to the writer (bytes / record size, about)."""
        return (self._queued + len(self._recs)) // RECORD.size

    def _write_audit(self, row: tuple[Any, ...]) -> None:
        """Queue one audit row (written with the next commit, in order with the samples)."""
        with self._lock:
            self._push(b"A", json.dumps(row).encode())
        self.send()

    def send(self) -> None:
        """Hand to the writer what the pipe takes now (never blocks); restart a dead writer."""
        with self._lock:
            self._push(b"", b"")
            self._pump()

    def _pump(self) -> None:
        """Read answers, then write to the writer or start a new one when it is due (lock held)."""
        self._answer()
        if self._alive():
            self._write()
        elif not self._closed and time.monotonic() - (self._dead_since or 0.0) >= (
            self.restart_interval
        ):
            self.restarts += 1
            log.warning("historian writer started again (%d restart(s))", self.restarts)
            self._start_writer()

    def _write(self) -> None:
        """Write queued frames to the pipe until it is full (lock held)."""
        while self._frames:
            f = self._frames[0]
            try:
                n = os.write(self._fd, memoryview(f)[self._sent :])
            except BlockingIOError:
                return
            except OSError as exc:  # the writer is gone
                if self._alive():
                    self._writer_gone(f"its pipe failed: {exc}")
                return
            self._sent += n
            if self._sent < len(f):
                return
            self._frames.popleft()
            self._queued -= len(f)
            self._sent = 0
            if f[:1] == b"S":
                self._tally.handed += (len(f) - _HEAD.size) // RECORD.size
                self._tally.write()

    def _wait(self, done: Any, what: str) -> None:
        """Send and read answers until ``done()`` (blocking: never on the event loop)."""
        deadline = time.monotonic() + self.timeout
        while True:
            with self._lock:
                self._pump()
                if done():
                    return
                answers = self._answers
            if time.monotonic() > deadline:
                raise HistoryError(f"historian writer: could not {what} in {self.timeout:g} s")
            try:
                select.select([answers] if answers >= 0 else [], [], [], 0.005)
            except (OSError, ValueError):  # closed meanwhile
                time.sleep(0.005)

    def flush(self) -> int:
        """Wait until the writer has committed everything recorded so far; 0 (rows go async)."""
        with self._lock:
            self._token += 1
            token = self._token
            self._push(b"F", _TOKEN.pack(token))
        self._wait(lambda: self._flushed >= token, "commit the samples")
        return 0

    def close(self) -> None:
        """Hand over everything, wait until it is committed and the run is marked stopped.

        A writer that had died is started at once for it (no row is lost on a
        clean stop); raises HistoryError when the writer does not finish in
        ``timeout`` seconds (then it is killed).
        """
        if self._closed:
            return
        with self._lock:
            self._push(b"C", b"")
            if self.process is None:
                self._dead_since = -self.restart_interval  # start it now
        try:
            self._wait(lambda: self._closed_stats is not None, "close")
            self.writer_stats = dict(self._closed_stats or {})
            self.rows_written = int(self.writer_stats.get("rows", 0))
            if not self.writer_stats.get("ok", False):
                log.error("historian: the last rows could not be committed: %s",
                          self.writer_stats.get("error"))  # fmt: skip
        finally:
            with self._lock:
                self._closed = True
                proc = self.process
                if proc is not None:
                    with contextlib.suppress(subprocess.TimeoutExpired):
                        proc.wait(10.0)
                    if proc.poll() is None:
                        log.error("historian writer did not end: killed")
                    self._writer_gone("")
                self._frames.clear()
                self._queued = 0
                self._tally.remove()
            self._close_reader()

    # -- reading (a connection of its own) -------------------------------------------------

    @contextlib.contextmanager
    def reading(self) -> Iterator[ProcessHistorian]:
        """Read (also after :meth:`close`); the reading connection closes on exit."""
        try:
            yield self
        finally:
            self._close_reader()

    def _close_reader(self) -> None:
        if self._reader is not None:
            self._reader.close_connection()
            self._reader = None

    def query(self, sql: str, params: Any = ()) -> list[tuple[Any, ...]]:
        """Run a read query on the database, after everything recorded so far is committed.

        Waits for the writer (a :meth:`flush`, when it runs): call it from a
        thread, not on the runtime's event loop.
        """
        if self.process is not None and not self._closed:
            self.flush()
        if self._reader is None:
            r = _database(self.settings)
            r.open_reading()
            self._reader = r
        return self._reader.query(sql, params)


def open_historian(config: Any, *, name: str = "ctrlblocks", process: bool = True) -> Any:
    """The opened historian of a ``[historian]`` configuration (None: ``backend = "none"``).

    ``process`` (default): a :class:`ProcessHistorian`
    (the database is written by a process of its own, so the writes never
    hold up the cycles); False: a :class:`Historian` in this process (its
    flushes run in a thread of the runtime's process).
    """
    if config.backend == "none":
        return None
    h: Historian
    if process:
        h = ProcessHistorian(config, name=name)
    elif config.backend == "postgresql":
        h = PostgresHistorian(config.dsn, name=name, retention_days=config.retention_days)
    else:
        h = SQLiteHistorian(config.path, name=name, retention_days=config.retention_days)
    h.open()
    return h


# -- the writer process ---------------------------------------------------------------------


def serve_writer() -> None:
    """The writer process's main (the runtime starts it in a Python process of its own).

    Reads frames from stdin (the first one: settings and run), answers on
    stdout; open the database, then write what comes until a close or the
    end of stdin.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    out = os.dup(1)
    os.dup2(2, 1)  # a stray print cannot corrupt the answers

    def answer(kind: bytes, body: Any) -> None:
        frame = _frame(kind, json.dumps(body).encode())
        with contextlib.suppress(OSError):
            while frame:
                frame = frame[os.write(out, frame) :]

    fd = 0
    buf = bytearray()
    w: _Writer | None = None
    while True:
        wait = w.due() if w is not None and w.pending else None
        ready, _, _ = select.select([fd], [], [], wait)
        if ready:
            chunk = os.read(fd, 1 << 20)
            if not chunk:  # the runtime's process is gone: keep what came, say what was lost
                if w is not None:
                    w.lost_at_the_end()
                    w.commit()
                    w.db.close_connection()
                return
            buf += chunk
            if w is None:
                if len(buf) < _HEAD.size or len(buf) < _HEAD.size + _HEAD.unpack_from(buf)[1]:
                    continue
                n = _HEAD.unpack_from(buf)[1]
                init = json.loads(bytes(buf[_HEAD.size : _HEAD.size + n]))
                del buf[: _HEAD.size + n]
                db = _database(init["settings"])
                try:
                    db.open(run_id=init["run_id"])
                except Exception as exc:
                    where = "PostgreSQL" if isinstance(db, PostgresHistorian) else db.path
                    why = hide_dsn_secrets(str(exc), getattr(db, "dsn", ""))  # on one line
                    if not isinstance(exc, HistoryError):  # (a HistoryError says where)
                        why = f"{where}: {type(exc).__name__}: {why}"
                    answer(b"O", {"error": why})
                    return
                answer(b"O", {"run_id": db.run_id})
                w = _Writer(db, init["settings"], answer)
            if w.frames(buf):
                return
        if w is not None and w.pending and w.due() <= 0.0:
            w.commit()


class _Writer:
    """The writer's state: names, rows to commit, statistics."""

    def __init__(self, db: Historian, settings: dict[str, Any], answer: Any) -> None:
        self.db, self.answer, self.settings = db, answer, settings
        self.interval = settings["flush_interval"]
        self.batch = settings["batch"]
        self.max_bytes = int(settings.get("max_pending_bytes", 256 << 20))
        self.names: dict[int, str] = {}
        self.chunks: list[bytes] = []
        self.audits: list[tuple[Any, ...]] = []
        self.pending = 0
        self.last = time.monotonic()
        self.rows = self.commits = 0
        self.commit_max = 0.0
        self.error = ""

    def lost_at_the_end(self) -> None:
        """The runtime died without a close: count what it recorded and never handed over.

        Written as an audit row (committed with the rest) and to standard error.
        """
        path = self.settings.get("tally")
        if not path:
            return
        try:
            tally = _Tally(path)
            recorded, handed = tally.read()
        except (OSError, ValueError) as exc:
            log.error("historian writer: the runtime ended without a stop; the tally of lost "
                      "samples cannot be read (%s)", exc)  # fmt: skip
            return
        lost = max(0, recorded - handed)
        msg = (f"the runtime ended without a stop: {lost} of its {recorded} recorded "
               "sample(s) were not handed over to the historian and are lost")  # fmt: skip
        log.error("historian writer: %s", msg)
        from .historian import audit_row

        new = {"lost": lost, "recorded": recorded}
        self.audits.append(audit_row("historian", "", "lost", None, new, lost == 0, msg))
        self.pending += 1
        tally.remove()

    def due(self) -> float:
        """Seconds until the next commit is due."""
        if self.pending >= self.batch:
            return 0.0
        return max(0.0, self.last + self.interval - time.monotonic())

    def frames(self, buf: bytearray) -> bool:
        """Handle the whole frames in ``buf`` (consumed); True after a close."""
        pos = 0
        while len(buf) - pos >= _HEAD.size:
            kind, n = _HEAD.unpack_from(buf, pos)
            if len(buf) - pos - _HEAD.size < n:
                break
            body = bytes(buf[pos + _HEAD.size : pos + _HEAD.size + n])
            pos += _HEAD.size + n
            if kind == b"S":
                self.chunks.append(body)
                self.pending += n // RECORD.size
            elif kind == b"N":
                self.names[_CODE.unpack_from(body)[0]] = body[_CODE.size :].decode()
            elif kind == b"A":
                self.audits.append(tuple(json.loads(body)))
                self.pending += 1
            elif kind == b"F":
                self.commit()
                self.answer(b"F", _TOKEN.unpack(body)[0])
            elif kind == b"C":
                del buf[:pos]
                self.commit()
                ok = not self.pending
                if ok:
                    self.db.close()
                self.answer(b"C", self.stats(ok))
                return True
        del buf[:pos]
        return False

    def stats(self, ok: bool) -> dict[str, Any]:
        return {
            "rows": self.rows,
            "commits": self.commits,
            "commit_max_ms": round(1e3 * self.commit_max, 2),
            "cpu_s": round(time.process_time(), 3),
            "ok": ok,
            "error": self.error,
        }

    def commit(self) -> None:
        """Insert the pending rows and audit rows in one transaction; kept on failure.

        A sample whose key is already stored (a defect; it would fail every
        retry) is left out with an error line.  Rows kept for a retry are
        bounded by ``max_bytes``: past it the oldest samples are dropped.
        """
        if not self.pending:
            self.last = time.monotonic()
            return
        t = time.monotonic()
        run, names = self.db.run_id, self.names
        rows = [
            (run, names.get(r[0], f"#{r[0]}"), *r[2:9], names.get(r[1], "?"), *r[9:])
            for chunk in self.chunks for r in RECORD.iter_unpack(chunk)
        ]  # fmt: skip
        try:
            try:
                self.db.insert(rows, self.audits)
            except Exception as exc:
                if not any(c.__name__ == "IntegrityError" for c in type(exc).__mro__):
                    raise
                self.answer(b"E", f"{exc}: the samples already stored are left out")
                self.db.insert(rows, self.audits, skip_duplicates=True)
        except Exception as exc:  # kept for the next commit
            self.error = f"{type(exc).__name__}: {exc}"
            self.answer(b"E", f"commit of {len(rows)} row(s) failed, kept for the next: "
                              f"{self.error}")  # fmt: skip
            self.last = time.monotonic()
            self._bound()
            return
        self.rows += len(rows)
        self.commits += 1
        self.chunks, self.audits, self.pending = [], [], 0
        self.last = time.monotonic()
        self.commit_max = max(self.commit_max, self.last - t)

    def _bound(self) -> None:
        """Drop the oldest kept samples beyond ``max_bytes`` (the database is down long)."""
        size = sum(map(len, self.chunks))
        lost = 0
        while self.chunks and size > self.max_bytes:
            c = self.chunks.pop(0)
            size -= len(c)
            lost += len(c) // RECORD.size
        if lost:
            self.pending -= lost
            self.answer(b"E", f"{lost} sample(s) dropped: the database is not written "
                              f"({self.max_bytes} bytes kept at most)")  # fmt: skip


if __name__ == "__main__":
    serve_writer()
