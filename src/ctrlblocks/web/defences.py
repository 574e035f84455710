"""The faceplate's defences against a client on the plant network that is not a friend.

* :func:`read_body` -- a request body of at most :data:`MAX_BODY` bytes: a
  larger ``Content-Length`` is refused before one byte is read, a chunked body
  is dropped as soon as it passes the limit (answer 413);
* :func:`json_problem` -- JSON nesting depth and item count limits;
* :class:`SlidingWindow` -- at most ``limit`` events per ``window`` seconds per
  key (client address, user name), with a bounded number of keys, so a flood
  of new keys cannot grow the memory (:mod:`ctrlblocks.runtime.audit`, where
  the runtime bounds each user's refusals with it);
* :class:`LoginGuard` -- the lockout: a password check is *admitted* (counted)
  before the hash is computed, atomically (no ``await`` between the check and
  the count), at most ``per_user`` per user name and ``per_client`` per client
  address per window; a successful login gives its count back;
* :func:`summary` -- what the audit trail keeps of a refused anonymous request:
  the client address, the endpoint and at most :data:`MAX_FIELDS` field names
  of at most :data:`MAX_NAME` characters -- never values, never the body.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from typing import Any

from ..runtime.audit import SlidingWindow

__all__ = [
    "MAX_BODY",
    "MAX_DEPTH",
    "MAX_FIELDS",
    "MAX_ITEMS",
    "MAX_NAME",
    "LoginGuard",
    "SlidingWindow",
    "json_problem",
    "read_body",
    "summary",
]

MAX_BODY = 4096
"""Largest body of a command or login request [bytes]."""

MAX_DEPTH = 4
"""Deepest JSON nesting of a body (object -> ``tunings`` -> value -> list item)."""

MAX_ITEMS = 64
"""Most keys and list items in a body, counted over all levels."""

MAX_FIELDS = 8
"""Most field names an audit summary keeps."""

MAX_NAME = 32
"""Longest field name an audit summary keeps [characters] (longer ones are cut)."""


async def read_body(request: Any, limit: int = MAX_BODY) -> bytes | None:
    """The body of ``request``, or None when it is longer than ``limit`` bytes.

    A ``Content-Length`` above the limit (or not a number) is refused without
    reading; a body without one is read chunk by chunk and dropped as soon as
    it passes the limit.
    """
    declared = request.headers.get("content-length")
    if declared is not None and (not declared.isdigit() or int(declared) > limit):
        return None
    chunks, size = [], 0
    async for chunk in request.stream():
        size += len(chunk)
        if size > limit:
            return None
        chunks.append(chunk)
    return b"".join(chunks)


def json_problem(doc: Any, max_depth: int = MAX_DEPTH, max_items: int = MAX_ITEMS) -> str | None:
    """Why ``doc`` (parsed JSON) is too deep or too big (None: it is fine)."""
    items = 0
    stack = [(doc, 1)]
    while stack:
        x, depth = stack.pop()
        if isinstance(x, (dict, list)):
            if depth > max_depth:
                return f"nested deeper than {max_depth} levels"
            items += len(x)
            if items > max_items:
                return f"more than {max_items} fields and items"
            stack.extend((v, depth + 1) for v in (x.values() if isinstance(x, dict) else x))
    return None


def summary(client: str, endpoint: str, body: Any) -> dict[str, Any]:
    """The bounded audit record of a refused anonymous request (see the module docstring)."""
    names: list[str] = []
    if isinstance(body, Mapping):
        for k, v in body.items():
            names.append(str(k))
            if isinstance(v, Mapping):
                names.extend(f"{k}.{kk}" for kk in v)
    out: dict[str, Any] = {
        "client": client[:64],
        "endpoint": endpoint[:128],
        "fields": [n[:MAX_NAME] for n in names[:MAX_FIELDS]],
    }
    if len(names) > MAX_FIELDS:
        out["more_fields"] = len(names) - MAX_FIELDS
    return out


class LoginGuard:
    """Password checks admitted per user name and per client address (the lockout).

    Parameters
    ----------
    per_user, per_client : int
        Checks admitted per window for one user name / one client address.
    window : float
        The window [s]; a locked name or address is free again when its
        oldest check is ``window`` old.
    clock : callable
        Time source [s].
    """

    def __init__(
        self,
        per_user: int = 5,
        per_client: int = 20,
        window: float = 60.0,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.window = window
        self.users = SlidingWindow(per_user, window, clock)
        self.clients = SlidingWindow(per_client, window, clock)

    def admit(self, user: str, client: str) -> str | None:
        """Count one password check of ``user`` from ``client``; why it is refused (or None).

        Synchronous on purpose: called on the event loop, the check and the
        count cannot be interleaved by a concurrent login.
        """
        if self.clients.full(client):
            return "too many logins from this address"
        if not self.users.hit(user):
            return "too many failed logins"
        self.clients.hit(client)
        return None

    def succeeded(self, user: str, client: str) -> None:
        """A good password: the user's failures are forgotten, the client's check given back."""
        self.users.clear(user)
        self.clients.give_back(client)

    def withdraw(self, user: str, client: str) -> None:
        """An admitted check that was never made (the hashing queue was full)."""
        self.users.give_back(user)
        self.clients.give_back(client)
