"""Operators and their logins: scrypt password hashes in a users file, session tokens.

Who may do what (:data:`PERMISSIONS`, enforced by the server):

* anyone who reaches the page sees the live state only when the
  configuration says so (``[web] public_view = true``; the demo does);
* a *viewer* (logged in) watches: loop list, trends, history, CSV, audit trail;
* an *operator* may also change mode, manual value and setpoint;
* an *engineer* may also change the output limits and the tunings, and run,
  abort, accept or reject a live auto-tuning.

The users file is JSON, written with mode 0600::

    {"version": 1,
     "users": {"alice": {"role": "operator", "scrypt": {"n": 16384, "r": 8, "p": 1},
                         "salt": "<32 hex digits>", "hash": "<64 hex digits>",
                         "disabled": false}}}

A running server sees a change of the file within seconds
(:meth:`UserStore.reload_if_changed`, by its modification time, size and
inode): a session of a user who was removed, disabled, given another role or
a new password ends (:meth:`SessionStore.revoke_stale`).

A password is never stored or logged: only ``hashlib.scrypt(password,
salt=<16 random bytes per user>, n=2**14, r=8, p=1, dklen=32)`` and its salt
(scrypt, RFC 7914; the parameters are the interactive-login values of
RFC 7914, section 2), compared in constant time (:func:`hmac.compare_digest`).
Create operators with ``ctrlblocks operator add NAME``.

A login gives a random session token (``secrets.token_urlsafe(32)``) in an
``HttpOnly``, ``SameSite=Strict`` cookie; sessions live in the server's
memory (a restart logs everybody out) and expire after ``SESSION_HOURS``.
"""

from __future__ import annotations

import dataclasses
import hashlib
import hmac
import json
import logging
import os
import re
import secrets
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = [
    "NAME_RE",
    "PERMISSIONS",
    "ROLES",
    "SESSION_HOURS",
    "SessionStore",
    "UserError",
    "UserStore",
    "hash_password",
    "verify_password",
]

log = logging.getLogger(__name__)

ROLES = ("viewer", "operator", "engineer")
"""Roles a user in the users file can have."""

PERMISSIONS: dict[str, frozenset[str]] = {
    "viewer": frozenset(),
    "operator": frozenset({"mode", "manual_value", "sp"}),
    "engineer": frozenset({"mode", "manual_value", "sp", "u_min", "u_max", "tunings", "tune"}),
}
"""Command keys each role may send (``POST /api/loops/NAME/command``); ``tune``: live
auto-tuning (``/api/loops/NAME/tune``)."""

SESSION_HOURS = 8.0
"""Lifetime of a login session [h] (one shift)."""

SCRYPT = {"n": 2**14, "r": 8, "p": 1}
"""scrypt cost parameters for new hashes (RFC 7914, section 2: interactive logins)."""

NAME_RE = re.compile(r"^[A-Za-z0-9_.@\-]{1,64}$")
"""User names: 1-64 letters, digits and ``_ . @ -``."""
MIN_PASSWORD = 8
"""Shortest password accepted when an operator is created [characters]."""


class UserError(ValueError):
    """A bad user name or password, or an unknown user, in the users file tools."""


def hash_password(password: str, salt: bytes | None = None, **cost: int) -> dict[str, Any]:
    """Hash ``password`` with scrypt and a fresh 16-byte salt; return the stored record.

    Parameters
    ----------
    password : str
        The password (UTF-8 encoded before hashing).
    salt : bytes, optional
        Only for tests; default 16 bytes from :func:`secrets.token_bytes`.
    **cost : int
        ``n``, ``r``, ``p`` overriding :data:`SCRYPT`.

    Returns
    -------
    dict
        ``{"scrypt": {"n", "r", "p"}, "salt": hex, "hash": hex}``.
    """
    params = {**SCRYPT, **cost}
    salt = secrets.token_bytes(16) if salt is None else salt
    digest = _scrypt(password, salt, params)
    return {"scrypt": params, "salt": salt.hex(), "hash": digest.hex()}


def verify_password(password: str, record: dict[str, Any]) -> bool:
    """True when ``password`` matches a record made by :func:`hash_password` (constant time)."""
    try:
        salt = bytes.fromhex(record["salt"])
        expected = bytes.fromhex(record["hash"])
        params = {k: int(record["scrypt"][k]) for k in ("n", "r", "p")}
    except (KeyError, TypeError, ValueError):
        return False
    return hmac.compare_digest(_scrypt(password, salt, params), expected)


def _scrypt(password: str, salt: bytes, params: dict[str, int]) -> bytes:
    n, r, p = params["n"], params["r"], params["p"]
    return hashlib.scrypt(
        password.encode("utf-8"), salt=salt, n=n, r=r, p=p, dklen=32, maxmem=256 * r * n + 2**20
    )


class UserStore:
    """The users file (see the module docstring); ``path=None`` keeps it in memory only.

    Parameters
    ----------
    path : str or Path, optional
        JSON file; read if it exists, written by :meth:`add` and :meth:`remove`.
    """

    def __init__(self, path: str | Path | None = None) -> None:
        self.path = Path(path) if path is not None else None
        self._users: dict[str, dict[str, Any]] = {}
        self._stamp: tuple[int, int, int] | None = None
        if self.path is not None and self.path.exists():
            self._users, self._stamp = self._read()

    def _read(self) -> tuple[dict[str, dict[str, Any]], tuple[int, int, int] | None]:
        assert self.path is not None
        stamp = _stamp(self.path)
        doc = json.loads(self.path.read_text(encoding="utf-8"))
        users = doc.get("users", {}) if isinstance(doc, dict) else {}
        if not isinstance(users, dict) or not all(isinstance(u, dict) for u in users.values()):
            raise UserError(f"{self.path}: 'users' must be a table of user tables")
        return users, stamp

    def reload_if_changed(self) -> bool:
        """Read the users file again if it changed on disk (another process, the CLI).

        Returns True when it was read again.  A file that cannot be read or
        parsed leaves no user (nobody can log in, every session ends) and is
        logged; a removed file, too.
        """
        if self.path is None:
            return False
        stamp = _stamp(self.path)
        if stamp == self._stamp:
            return False
        try:
            self._users, self._stamp = self._read() if stamp is not None else ({}, None)
        except (OSError, ValueError) as exc:
            log.error("users file %s unreadable, every login refused: %s", self.path, exc)
            self._users, self._stamp = {}, stamp
        return True

    def names(self) -> list[str]:
        """User names, sorted."""
        return sorted(self._users)

    def exists(self, name: str) -> bool:
        """True when ``name`` is a user of the file (enabled or not)."""
        return name in self._users

    def role(self, name: str) -> str | None:
        """The role of ``name`` (None: no such user)."""
        u = self._users.get(name)
        return None if u is None else str(u.get("role", "operator"))

    def disabled(self, name: str) -> bool:
        """True when ``name`` is disabled (cannot log in; its sessions end)."""
        return bool(self._users.get(name, {}).get("disabled", False))

    def fingerprint(self, name: str) -> tuple[str, str] | None:
        """What a session of ``name`` depends on: ``(role, hash)``; None: no such or disabled."""
        u = self._users.get(name)
        if u is None or u.get("disabled", False):
            return None
        return str(u.get("role", "operator")), str(u.get("hash", ""))

    def set_disabled(self, name: str, disabled: bool = True) -> None:
        """Disable (or enable again) user ``name``."""
        if name not in self._users:
            raise UserError(f"no user {name!r}")
        self._users[name]["disabled"] = bool(disabled)
        self._save()

    def add(self, name: str, password: str, role: str = "operator", **cost: int) -> None:
        """Create or replace user ``name`` (password at least :data:`MIN_PASSWORD` characters)."""
        if not NAME_RE.match(name):
            raise UserError("user names are 1-64 letters, digits and _ . @ - only")
        if len(password) < MIN_PASSWORD:
            raise UserError(f"the password must have at least {MIN_PASSWORD} characters")
        if role not in ROLES:
            raise UserError(f"role must be one of {ROLES}, got {role!r}")
        self._users[name] = {"role": role, **hash_password(password, **cost)}
        self._save()

    def remove(self, name: str) -> None:
        """Delete user ``name``."""
        if name not in self._users:
            raise UserError(f"no user {name!r}")
        del self._users[name]
        self._save()

    def verify(self, name: str, password: str) -> bool:
        """True when ``name`` exists, is not disabled and ``password`` is its password."""
        u = self._users.get(name)
        if u is None or u.get("disabled", False):
            # same work as for a real user, so the time does not tell which names exist
            verify_password(password, self._dummy())
            return False
        return verify_password(password, u)

    def _dummy(self) -> dict[str, Any]:
        """A record with the scrypt cost of the users in the file (default :data:`SCRYPT`)."""
        cost = next((u.get("scrypt") for u in self._users.values() if "scrypt" in u), None)
        try:
            params = {k: int(cost[k]) for k in ("n", "r", "p")} if cost else SCRYPT
        except (KeyError, TypeError, ValueError):
            params = SCRYPT
        key = tuple(sorted(params.items()))
        if key not in _DUMMIES:
            _DUMMIES[key] = hash_password("not a password", salt=b"\0" * 16, **params)
        return _DUMMIES[key]

    def _save(self) -> None:
        if self.path is None:
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        tmp = self.path.with_name(self.path.name + ".tmp")
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump({"version": 1, "users": self._users}, f, indent=2, sort_keys=True)
        os.replace(tmp, self.path)
        self._stamp = _stamp(self.path)


def _stamp(path: Path) -> tuple[int, int, int] | None:
    """Modification time [ns], size and inode of ``path`` (None: it does not exist)."""
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_mtime_ns, st.st_size, st.st_ino


_DUMMIES: dict[tuple[tuple[str, int], ...], dict[str, Any]] = {}
"""Records of unknown users' checks, per scrypt cost (computed once)."""


@dataclasses.dataclass
class Session:
    """One login."""

    user: str
    role: str
    expires: float
    fingerprint: Any = None


class SessionStore:
    """Session tokens in memory (token -> :class:`Session`)."""

    def __init__(self, hours: float = SESSION_HOURS) -> None:
        self.hours = hours
        self._sessions: dict[str, Session] = {}

    def create(self, user: str, role: str, fingerprint: Any = None) -> str:
        """Start a session for ``user``; return its token (``fingerprint``: ``revoke_stale``)."""
        self._purge()
        token = secrets.token_urlsafe(32)
        self._sessions[token] = Session(user, role, time.time() + 3600.0 * self.hours, fingerprint)
        return token

    def revoke_stale(self, fingerprint: Callable[[str], Any]) -> list[str]:
        """End every session whose user's ``fingerprint(user)`` is no longer the one of its login.

        Returns the users whose sessions ended (removed, disabled, new role or password).
        """
        gone = [t for t, s in self._sessions.items() if fingerprint(s.user) != s.fingerprint]
        users = sorted({self._sessions[t].user for t in gone})
        for t in gone:
            del self._sessions[t]
        return users

    def get(self, token: str | None) -> Session | None:
        """The live session of ``token`` (None: no token, unknown or expired)."""
        if not token:
            return None
        s = self._sessions.get(token)
        if s is None or s.expires < time.time():
            self._sessions.pop(token, None)
            return None
        return s

    def end(self, token: str | None) -> None:
        """Log out."""
        if token:
            self._sessions.pop(token, None)

    def _purge(self) -> None:
        now = time.time()
        for t in [t for t, s in self._sessions.items() if s.expires < now]:
            del self._sessions[t]
