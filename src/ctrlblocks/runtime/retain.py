"""Retentive state, like a PLC's RETAIN memory: what an operator set survives a restart.

Per loop: setpoint, mode and manual value (where they are not bound to
I/O), the MV limits, the MV block's tunings, the last MV and every block's
snapshot (integrators, filters, observer states).  The runtime writes them
every ``interval`` seconds and on stop, all loops in one SQLite transaction
(atomic: a crash leaves the previous complete set), to a file with a schema
version (``[retain]`` in the configuration; default beside the historian).

**Durable commands.**  An operator's or engineer's change is written at once
(:meth:`RetainStore.save_loop`: that loop's row, in a transaction of its own,
``synchronous = FULL``: on the disk, fsync'd, when the call returns), and
:meth:`Runtime.execute <ctrlblocks.runtime.Runtime.execute>` -- the faceplate's
and :meth:`~ctrlblocks.runtime.Runtime.submit`'s path -- confirms a change only
after that; a ``kill -9`` right after the confirmation keeps it.  The periodic
snapshot stays for the integrator and observer states.  One thread writes the
file (:meth:`Runtime.retain_call <ctrlblocks.runtime.Runtime.retain_call>`), so
a periodic save never overtakes a command's row.

On restart the runtime restores each loop's state and reads the MVs back
from the devices; the first cycle outputs the read-back MV (the retained
one if it cannot be read) and the blocks track it, so the loop continues
without a bump (:mod:`ctrlblocks.runtime.loop`).  A tuning whose value in the
configuration file changed since it was retained comes from the file, with a
log line saying which.
"""

from __future__ import annotations

import json
import logging
import math
import sqlite3
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

__all__ = ["SCHEMA_VERSION", "RetainStore", "encode_state"]

log = logging.getLogger(__name__)

SCHEMA_VERSION = 1
"""Version of the retain file's layout; a file of another version is not restored."""


def _plain(x: Any) -> Any:
    """``x`` with tuples as lists and enums as ints (JSON; NaN/inf as JSON's extensions)."""
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, bool) or x is None or isinstance(x, str):
        return x
    if isinstance(x, int):
        return int(x)
    if isinstance(x, float):
        return float(x)
    try:
        return float(x)
    except (TypeError, ValueError):
        return str(x)


def encode_state(state: Mapping[str, Any]) -> str:
    """One loop's retained state as the retain file stores it (JSON text)."""
    return json.dumps(_plain(dict(state)))


class RetainStore:
    """The retain file (SQLite): :meth:`save` all loops at once, :meth:`load` them back."""

    def __init__(self, path: str | Path) -> None:
        self.path = str(path)

    def _connect(self) -> sqlite3.Connection:
        conn = sqlite3.connect(self.path, timeout=10.0)
        conn.execute("PRAGMA synchronous = FULL")  # a commit is on the disk (fsync)
        conn.execute("CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT)")
        conn.execute(
            "CREATE TABLE IF NOT EXISTS loops (name TEXT PRIMARY KEY, t_wall REAL, state TEXT)"
        )
        return conn

    def check(self) -> None:
        """Make sure the file can be written: create it (empty) when absent, take a write lock.

        Raises ``sqlite3.OperationalError`` (a folder that does not exist, a
        read-only file) or OSError; the runtime refuses to start then.
        """
        if not Path(self.path).is_file():
            self.save({})
            return
        conn = self._connect()
        try:
            conn.execute("BEGIN IMMEDIATE")
            conn.rollback()
        finally:
            conn.close()

    def save(self, states: Mapping[str, Mapping[str, Any] | str]) -> None:
        """Write every loop's state in one transaction (replacing the previous set).

        A state is a mapping, or already text from :func:`encode_state`.
        """
        rows = [
            (n, time.time(), s if isinstance(s, str) else encode_state(s))
            for n, s in states.items()
        ]
        conn = self._connect()
        try:
            with conn:  # one transaction: all or nothing
                conn.execute(
                    "INSERT OR REPLACE INTO meta VALUES ('schema_version', ?)",
                    (str(SCHEMA_VERSION),),
                )
                conn.execute("DELETE FROM loops")
                conn.executemany("INSERT INTO loops VALUES (?, ?, ?)", rows)
        finally:
            conn.close()

    def save_loop(self, name: str, state: Mapping[str, Any] | str) -> None:
        """Write one loop's state now, in a transaction of its own (a command's durability).

        The other loops' rows stay as they are; the call returns when the row
        is on the disk.
        """
        text = state if isinstance(state, str) else encode_state(state)
        conn = self._connect()
        try:
            with conn:
                conn.execute(
                    "INSERT OR REPLACE INTO meta VALUES ('schema_version', ?)",
                    (str(SCHEMA_VERSION),),
                )
                conn.execute(
                    "INSERT OR REPLACE INTO loops VALUES (?, ?, ?)", (name, time.time(), text)
                )
        finally:
            conn.close()

    def load(self) -> dict[str, dict[str, Any]]:
        """The retained states by loop name (empty without a file or for another schema)."""
        if not Path(self.path).is_file():
            return {}
        try:
            conn = self._connect()
        except sqlite3.DatabaseError as exc:
            log.warning("retain file %s unreadable (%s): cold start", self.path, exc)
            return {}
        try:
            row = conn.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
            if row is None or row[0] != str(SCHEMA_VERSION):
                log.warning(
                    "retain file %s has schema version %s, not %d: cold start",
                    self.path,
                    None if row is None else row[0],
                    SCHEMA_VERSION,
                )
                return {}
            return {n: json.loads(s) for n, s in conn.execute("SELECT name, state FROM loops")}
        except (sqlite3.DatabaseError, ValueError) as exc:
            log.warning("retain file %s unreadable (%s): cold start", self.path, exc)
            return {}
        finally:
            conn.close()


def finite_or_none(x: Any) -> float | None:
    """``x`` as a finite float, else None."""
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None
