"""What every route of the faceplate shares: the runtime, the users, the defences, helpers.

:class:`Faceplate` is made once per application (:func:`~ctrlblocks.web.app.create_app`)
and found by every route as ``request.app.state.faceplate``.  It holds the
runtime, the users and sessions, the rate limits and the lockout
(:mod:`.defences`), the live hub (:mod:`.live`), the loops' engineering bounds,
and the small steps the routes are made of: who is logged in, which client
sent a request (``X-Forwarded-For`` believed only from a configured proxy), a
bounded JSON body, a bounded audit row of a refusal, a call on the runtime's
event loop.
"""

from __future__ import annotations

import asyncio
import contextlib
import ipaddress
import json
import logging
import math
import os
import threading
import time
from collections.abc import Callable, Iterable
from typing import Any

from fastapi import Request, WebSocket
from fastapi.responses import JSONResponse

from ..blocks.base import ErrorCode
from ..runtime.audit import RefusalBudget
from ..runtime.bounds import LoopBounds
from ..runtime.historian import SAMPLE_COLUMNS
from .auth import SessionStore, UserStore
from .defences import LoginGuard, SlidingWindow, json_problem, read_body
from .live import LiveHub

__all__ = [
    "AUDIT_REFUSALS",
    "CLIENT_LOGINS",
    "COMMAND_REQUESTS",
    "COOKIE",
    "HASH_NICE",
    "HISTORY_COLUMNS",
    "LOCKOUT_FAILURES",
    "LOCKOUT_SECONDS",
    "LOGIN_REQUESTS",
    "MAX_PENDING_HASHES",
    "Faceplate",
    "article",
    "error",
]

log = logging.getLogger("ctrlblocks.web.app")

COOKIE = "ctrlblocks_session"
"""Name of the session cookie."""

LOCKOUT_FAILURES = 5
LOCKOUT_SECONDS = 60.0
"""At most LOCKOUT_FAILURES password checks of one user name within LOCKOUT_SECONDS (a good
login gives its check back); further logins of that name are refused (429) until the oldest
check is LOCKOUT_SECONDS old."""

CLIENT_LOGINS = 20
"""Password checks admitted per client address within LOCKOUT_SECONDS."""

LOGIN_REQUESTS = (40, 60.0)
COMMAND_REQUESTS = (40, 10.0)
"""Requests per client address and window [s] on ``/api/login`` and on the command endpoint
(what is above is refused with 429 before the body is read)."""

AUDIT_REFUSALS = (10, 60.0)
"""Audit rows of refused requests per client address and window [s] (the rest is counted,
and the count is written with the next row that is let through); the runtime bounds the
refusals of each user the same way (:data:`ctrlblocks.runtime.runtime.AUDIT_REFUSALS`)."""

HASH_NICE = 10
"""Nice value of the password-hashing thread (Linux): the cycle wins the CPU over a login."""

MAX_PENDING_HASHES = 8
"""Password checks waiting for the hashing thread at most (then 503, try again)."""

HISTORY_COLUMNS = ("t_wall", *(c for c in SAMPLE_COLUMNS if c not in ("loop", "t_wall")))
"""Columns of a history answer and of the CSV download (``t_wall``: s since the epoch, then
the historian's other sample columns but the loop)."""


def error(status: int, message: str, field: str = "", code: int | None = None) -> JSONResponse:
    """The JSON answer of a refusal: ``{"ok": false, "error": {field, message, code, ...}}``."""
    err: dict[str, Any] = {"field": field, "message": message, "code": None}
    if code is not None:
        err["code"] = int(code)
        err["code_hex"] = f"16#{int(code):04X}"
        try:
            err["name"] = ErrorCode(code).name
        except ValueError:
            err["name"] = ""
    return JSONResponse({"ok": False, "error": err}, status_code=status)


def article(word: str) -> str:
    """``"an engineer"``, ``"an operator"``, ``"a viewer"``."""
    return f"{'an' if word[:1].lower() in 'aeiou' else 'a'} {word}"


def _lower_priority() -> None:
    """Run this thread (password hashing) at a lower CPU priority than the control cycle.

    Linux: a thread's nice value is set through its thread id; elsewhere nothing happens.
    """
    with contextlib.suppress(AttributeError, OSError):
        os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), HASH_NICE)


def _networks(proxies: Iterable[str]) -> list[Any]:
    return [ipaddress.ip_network(p, strict=False) for p in proxies]


class Faceplate:
    """The state and the shared steps of one faceplate application (module docstring).

    Parameters are those of :func:`~ctrlblocks.web.app.create_app`.
    """

    def __init__(
        self,
        runtime: Any,
        *,
        users: UserStore,
        push_period: float,
        trend_seconds: float,
        public_view: bool,
        users_check_interval: float,
        clock: Callable[[], float],
        trusted_proxies: Iterable[str] = (),
    ) -> None:
        self.runtime = runtime
        self.users = users
        self.push_period = push_period
        self.trend_seconds = trend_seconds
        self.public_view = public_view
        self.users_check_interval = users_check_interval
        self.clock = clock
        self.sessions = SessionStore()
        self.guard = LoginGuard(LOCKOUT_FAILURES, CLIENT_LOGINS, LOCKOUT_SECONDS, clock)
        self.login_rate = SlidingWindow(*LOGIN_REQUESTS, clock)
        self.command_rate = SlidingWindow(*COMMAND_REQUESTS, clock)
        self.refusals = RefusalBudget(*AUDIT_REFUSALS, clock)  # audit rows per client
        self.hub = LiveHub(runtime, seconds=trend_seconds, period=push_period)
        web_cfg = getattr(runtime.config, "web", None)
        confirm_step = float(getattr(web_cfg, "confirm_step", 0.1))
        # the loops' own engineering ranges (they check every command), with the page's step
        self.bounds: dict[str, LoopBounds] = {}
        for n in runtime.loop_names():
            b = self.bounds[n] = runtime.loops[n].bounds
            b.confirm_step = confirm_step
        self.proxies = _networks(trusted_proxies)
        self.hashing: dict[str, Any] = {"pool": None, "pending": 0}
        self._last_users_check = -math.inf

    # -- who is asking --------------------------------------------------------------

    def check_users(self) -> None:
        """Read a changed users file; end the sessions it invalidated (throttled)."""
        now = self.clock()
        if now - self._last_users_check >= self.users_check_interval:
            self._last_users_check = now
            self.users.reload_if_changed()
        for name in self.sessions.revoke_stale(self.users.fingerprint):
            log.warning("sessions of %r ended: the user was removed, disabled or changed", name)

    def session_of(self, conn: Request | WebSocket) -> Any:
        self.check_users()
        return self.sessions.get(conn.cookies.get(COOKIE))

    def may_view(self, conn: Request | WebSocket) -> bool:
        return self.public_view or self.session_of(conn) is not None

    def client_of(self, conn: Request | WebSocket) -> str:
        """The client's address: the peer, or what a trusted proxy says it forwarded.

        ``X-Forwarded-For`` counts only when the peer is one of ``[web]
        trusted_proxies``; then the right-most address that is not a trusted
        proxy is the client (a client can prepend anything, not append).
        """
        peer = (conn.client.host if conn.client else "unknown")[:64]
        if not self.proxies or not self._trusted(peer):
            return peer
        hops = [h.strip() for h in conn.headers.get("x-forwarded-for", "").split(",")]
        for hop in reversed([h for h in hops if h]):
            if not self._trusted(hop):
                return hop[:64]
        return peer

    def _trusted(self, address: str) -> bool:
        try:
            ip = ipaddress.ip_address(address)
        except ValueError:
            return False
        return any(ip in net for net in self.proxies)

    # -- bounded requests -------------------------------------------------------------

    def audit_refusal(self, client: str, **row: Any) -> None:
        """An audit row of a refused request, at most AUDIT_REFUSALS per client and window."""
        suffix = self.refusals.admit(client)
        if suffix is None:
            return
        row["message"] = f"{row.get('message', '')}{suffix}"
        self.runtime.audit(**row)

    async def json_body(self, request: Request) -> dict[str, Any] | JSONResponse:
        """The request's JSON object, or the refusal (type, size, syntax, depth, items)."""
        ctype = request.headers.get("content-type", "")
        if not ctype.startswith("application/json"):
            # a cross-site form cannot send JSON without a CORS preflight (CSRF guard)
            return error(415, "send the body as application/json")
        raw = await read_body(request)
        if raw is None:
            return error(413, "the body is too large", "body")
        try:
            body = json.loads(raw)
        except (ValueError, RecursionError):
            return error(400, "the body is not valid JSON")
        if not isinstance(body, dict):
            return error(400, "the body must be a JSON object")
        problem = json_problem(body)
        if problem is not None:
            return error(400, f"the body is {problem}", "body")
        return body

    # -- the runtime --------------------------------------------------------------------

    async def on_runtime(self, fn: Callable[..., Any], *args: Any, **kw: Any) -> Any:
        """``fn(*args, **kw)`` on the runtime's event loop (it may be another thread's).

        A coroutine function is awaited there.
        """
        rt_loop = self.runtime.event_loop

        async def call() -> Any:
            out = fn(*args, **kw)
            return await out if asyncio.iscoroutine(out) else out

        if rt_loop is None or rt_loop is asyncio.get_running_loop():
            return await call()
        return await asyncio.wrap_future(asyncio.run_coroutine_threadsafe(call(), rt_loop))

    def loop_state(self, name: str) -> dict[str, Any]:
        if name not in self.runtime.loop_names():
            raise KeyError(name)
        return self.hub.state(name)

    def hashing_pool(self) -> Any:
        """The password-hashing thread (its own: a burst of logins never takes others')."""
        import concurrent.futures

        if self.hashing["pool"] is None:
            self.hashing["pool"] = concurrent.futures.ThreadPoolExecutor(
                1, "ctrlblocks-password", initializer=_lower_priority
            )
        return self.hashing["pool"]

    def close(self) -> None:
        self.hub.detach()
        if self.hashing["pool"] is not None:
            self.hashing["pool"].shutdown(wait=False, cancel_futures=True)
            self.hashing["pool"] = None

    # -- the historian ---------------------------------------------------------------------

    def historian_or_error(self) -> Any:
        h = self.runtime.historian
        if h is None:
            return error(404, "this runtime has no historian ([historian] backend = 'none')")
        return h

    async def history_rows(self, name: str, start: float | None, end: float | None) -> Any:
        """The loop's historian rows in ``start .. end`` (default the last 10 min)."""
        h = self.historian_or_error()
        if isinstance(h, JSONResponse):
            return h
        end = time.time() if end is None else end
        start = end - 600.0 if start is None else start
        if not (math.isfinite(start) and math.isfinite(end)) or start > end:
            return error(400, "need finite start <= end (s since the epoch)", "start")
        await asyncio.to_thread(h.flush)  # include the samples still in the buffer
        samples = await asyncio.to_thread(h.samples, name, start, end)
        return [tuple(s[c] for c in HISTORY_COLUMNS) for s in samples]

    # -- answers --------------------------------------------------------------------------

    @staticmethod
    def not_logged_in() -> JSONResponse:
        return error(401, "log in to see this", "login")

    @staticmethod
    def unknown_loop(name: str) -> JSONResponse:
        return error(404, f"unknown loop {name[:64]!r}", "loop")
