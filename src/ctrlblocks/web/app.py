"""The faceplate web application (FastAPI): a page, a WebSocket push and a small REST API.

Routes (all JSON unless said otherwise; ``docs/faceplate.md`` has examples).
"live" means: anyone when ``[web] public_view = true``, else a logged-in user.

======================================  ========  ===============================================
route                                   who       what
======================================  ========  ===============================================
``GET /``                               anyone    the faceplate page (plain HTML/JS, uPlot)
``GET /api/info``                       anyone    runtime name, who is logged in, role and what
                                                  it may change; loops, units and engineering
                                                  ranges when the caller may see live state
``WS /ws``                              live      push every ``push_period`` (0.1 s): the state
                                                  of every loop and the samples not yet sent
``GET /api/loops``, ``/api/loops/NAME``  live      loop states (SP, PV, MV, mode, error, limits,
                                                  tunings, I/O status, alarms)
``GET /api/loops/NAME/history``         login     samples from the historian, ``start``/``end``
                                                  in s since the epoch (default: last 10 min)
``GET /api/loops/NAME/history.csv``     login     the same as a CSV download (every sample)
``GET /api/audit``                      login     the audit trail (who changed what, when)
``POST /api/login``, ``/api/logout``    anyone    ``{"user": .., "password": ..}``; a cookie
``GET /api/alarms``                     live      every loop's alarm state and its annunciated
                                                  alarms (:mod:`ctrlblocks.runtime.health`)
``POST /api/loops/NAME/alarms/ACTION``  operator  ``ack`` (``{"alarm": "H"}``, or all),
                                                  ``shelve`` (``{"alarm": "H", "seconds": 600}``),
                                                  ``unshelve``; audited with the user (engineer too)
``POST /api/loops/NAME/command``        role      ``{"mode": "manual", "manual_value": 40}``,
                                                  ``{"sp": 2.0}`` (operator, engineer);
                                                  ``{"u_min": 0, "u_max": 80}``,
                                                  ``{"tunings": {"kp": 1.5}}`` (engineer)
``GET /api/loops/NAME/tune``            live      the live tuning of the loop (running, or the
                                                  last one with its result), null if none
``POST /api/loops/NAME/tune``           engineer  start one: ``{"method": "step",
                                                  "amplitude": 5, "pv_max": 80}``
``POST /api/loops/NAME/tune/abort``     engineer  ``{"reason": ".."}`` (optional)
``POST /api/loops/NAME/tune/accept``    engineer  ``{"proposal": "PID_AMIGO"}``: applied
                                                  bumplessly, retained (``"force": true``
                                                  for one the margins call fragile)
``POST /api/loops/NAME/tune/reject``    engineer  ``{}``
======================================  ========  ===============================================

A command is checked here first -- body size, JSON shape, login, the role's
permissions (:data:`~ctrlblocks.web.auth.PERMISSIONS`) -- and then goes to
:meth:`Runtime.command <ctrlblocks.runtime.Runtime.command>`, so the loop
checks its engineering ranges (:class:`~ctrlblocks.runtime.bounds.LoopBounds`,
as for every other caller) and the block validates it (its own ``configure``
and bumpless rules), a refused command changes nothing, and the runtime writes it
(accepted or refused, with the user's name) to the historian's audit table.
Answers: 200 ``{"ok": true, "old": {...}, "state": {...}}``; 401 without a
login; 403 for a key the role may not change; 413 for a body above 4 KB; 429
when a client sends too many; 422 with the error ``{"error": {"field",
"code", "code_hex", "name", "message"}}`` (for example ``16#8214 BAD_B0``,
``tunings.b0: must be > 0``) for a value outside its engineering range or
refused by the loop or the block -- also for a value the block accepted but
could not compute with (an ``OverflowError``): never a 500; 404 for an
unknown loop.

The defences (:mod:`~ctrlblocks.web.defences`): bodies of command and login
requests are limited before they are read, JSON depth and item count are
limited, every client address gets a request budget per window on login and
commands, a password check is counted before the hash is computed (at most
:data:`LOCKOUT_FAILURES` per user name and :data:`CLIENT_LOGINS` per client
address per :data:`LOCKOUT_SECONDS`) and the hash runs on its own one-thread
executor (a burst of logins cannot take the threads the runtime's historian
uses, nor more than one core).  What a refused anonymous request leaves in
the audit trail is a bounded summary (:func:`~ctrlblocks.web.defences.summary`),
at most :data:`AUDIT_REFUSALS` rows per client and window; a login with a name
that is not a user is recorded as ``"unknown user"`` (it may be a password
typed into the wrong field).

Text from input fields is accepted for numbers (``"1.5"``, ``"inf"``): a
string is converted to the type of the value in force (int, float, ``None``
for "" when the parameter may be unset); what does not convert goes to the
block unchanged and the block refuses it with its code.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import csv
import importlib
import io
import json
import logging
import math
import os
import threading
import time
from collections.abc import AsyncIterator, Callable, Mapping
from importlib import resources
from typing import Any
from urllib.parse import urlsplit

from fastapi import FastAPI, Request, WebSocket
from fastapi.responses import FileResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles
from starlette.websockets import WebSocketDisconnect

from ..blocks.alarms import ALARM_NAMES
from ..blocks.base import ErrorCode, ParameterError
from ..runtime.bounds import LoopBounds
from ..runtime.historian import SAMPLE_COLUMNS
from ..runtime.loop import CommandError
from .auth import NAME_RE, PERMISSIONS, SessionStore, UserStore
from .defences import LoginGuard, SlidingWindow, json_problem, read_body, summary
from .live import LiveHub, json_safe

ALARM_ROLES = frozenset({"operator", "engineer"})
"""The roles that may acknowledge, shelve and unshelve process alarms (a viewer may not)."""

__all__ = ["COOKIE", "create_app"]

log = logging.getLogger(__name__)

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
"""Audit rows of refused anonymous requests per client address and window [s] (the rest is
counted, and the count is written with the next row that is let through)."""

HASH_NICE = 10
"""Nice value of the password-hashing thread (Linux): the cycle wins the CPU over a login."""

MAX_PENDING_HASHES = 8
"""Password checks waiting for the hashing thread at most (then 503, try again)."""

HISTORY_COLUMNS = ("t_wall", *(c for c in SAMPLE_COLUMNS if c not in ("loop", "t_wall")))
"""Columns of a history answer and of the CSV download (``t_wall``: s since the epoch, then
the historian's other sample columns but the loop)."""

_SECURITY_HEADERS = {
    "Content-Security-Policy": (
        "default-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data:; "
        "connect-src 'self'; frame-ancestors 'none'"
    ),
    "X-Frame-Options": "DENY",
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
}


def _error(status: int, message: str, field: str = "", code: int | None = None) -> JSONResponse:
    err: dict[str, Any] = {"field": field, "message": message, "code": None}
    if code is not None:
        err["code"] = int(code)
        err["code_hex"] = f"16#{int(code):04X}"
        try:
            err["name"] = ErrorCode(code).name
        except ValueError:
            err["name"] = ""
    return JSONResponse({"ok": False, "error": err}, status_code=status)


def _to_number(text: str, current: Any) -> Any:
    """Convert input-field ``text`` to the type of ``current`` (see the module docstring)."""
    s = text.strip()
    if current is None and s.lower() in ("", "none", "null"):
        return None
    if isinstance(current, bool) or not (
        current is None or isinstance(current, (int, float, list, tuple))
    ):
        return text
    if "," in s and (current is None or isinstance(current, (list, tuple))):
        try:
            return [float(p) for p in s.strip("()[]").split(",")]
        except ValueError:
            return text
    if isinstance(current, int):
        try:
            return int(s)
        except ValueError:
            pass
    try:
        return float(s)
    except ValueError:
        return text


def coerce_command(changes: Mapping[str, Any], state: Mapping[str, Any]) -> dict[str, Any]:
    """A command body with input-field text converted to numbers (see the module docstring)."""
    out = dict(changes)
    for k in ("sp", "manual_value", "u_min", "u_max"):
        if isinstance(out.get(k), str):
            out[k] = _to_number(out[k], 0.0)
    tun = out.get("tunings")
    if isinstance(tun, Mapping):
        current = state.get("tunings", {})
        out["tunings"] = {
            k: _to_number(v, current.get(k)) if isinstance(v, str) else v for k, v in tun.items()
        }
    return out


TUNE_OPTIONS = ("method", "amplitude", "mv_min", "mv_max", "pv_min", "pv_max", "max_time",
                "hysteresis", "pre_time")  # fmt: skip
"""Keys of a ``POST /api/loops/NAME/tune`` body (:meth:`LiveTuning.start
<ctrlblocks.runtime.autotune.LiveTuning.start>`)."""


def tune_options(body: Mapping[str, Any], bounds: LoopBounds) -> dict[str, Any]:
    """The start options of a tuning body: text to numbers, empty = default, MV range kept.

    The experiment's MV bounds default to the loop's engineering ``mv_range``
    where it is narrower than the output limits, and may not leave it.
    """
    unknown = sorted(str(k)[:32] for k in body if k not in TUNE_OPTIONS)
    if unknown:
        raise CommandError(unknown[0], f"unknown option; options: {', '.join(TUNE_OPTIONS)}")
    out: dict[str, Any] = {}
    for k, v in body.items():
        if k == "method":
            out[k] = v
        elif v is None or (isinstance(v, str) and not v.strip()):
            continue
        else:
            out[k] = _to_number(v, 0.0) if isinstance(v, str) else v
    rng = bounds.mv
    if rng is not None:
        out.setdefault("mv_min", max(rng.lo, float(bounds.block.u_min)))
        out.setdefault("mv_max", min(rng.hi, float(bounds.block.u_max)))
        for k in ("mv_min", "mv_max"):
            x = out[k]
            if isinstance(x, (int, float)) and not isinstance(x, bool):
                why = rng.refuses(float(x))
                if why is not None:
                    raise CommandError(k, why, ErrorCode.BAD_LIMITS)
    return out


def proposal_outside(
    runtime: Any, loop: str, proposal: str, bounds: LoopBounds
) -> tuple[str, str, int] | None:
    """The engineering-range refusal of accepting ``proposal`` (None: inside, or unknown)."""
    from ..runtime.autotune import block_tunings

    st = runtime.tuning.status(loop) or {}
    prop = (st.get("proposals") or {}).get(proposal)
    if prop is None:
        return None  # the runtime refuses it with the list of proposals
    try:
        tunings = block_tunings(runtime.loops[loop], prop)
    except CommandError:
        return None  # the runtime refuses it with the reason
    return bounds.check({"tunings": tunings})


def _lower_priority() -> None:
    """Run this thread (password hashing) at a lower CPU priority than the control cycle.

    Linux: a thread's nice value is set through its thread id; elsewhere nothing happens.
    """
    with contextlib.suppress(AttributeError, OSError):
        os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), HASH_NICE)


def csv_header(units: Mapping[str, str]) -> list[str]:
    """The CSV download's header: :data:`HISTORY_COLUMNS` with units, ``sp [bar]``, ``t [s]``."""
    with_unit = {
        "t_wall": "s",
        "t": "s",
        "dt": "s",
        **{k: units.get(k, "") for k in ("sp", "pv", "mv")},
    }
    return [f"{c} [{with_unit[c]}]" if with_unit.get(c) else c for c in HISTORY_COLUMNS]


def create_app(
    runtime: Any,
    *,
    users: UserStore | None = None,
    start_runtime: bool = True,
    push_period: float = 0.1,
    trend_seconds: float = 300.0,
    public_view: bool | None = None,
    users_check_interval: float = 1.0,
    clock: Callable[[], float] = time.monotonic,
) -> FastAPI:
    """The faceplate application for ``runtime``.

    Parameters
    ----------
    runtime : ctrlblocks.runtime.Runtime
        The runtime whose loops are shown (its in-process API: ``loop_names``,
        ``loops``, ``state``, ``states``, ``command``/``submit``, ``event_loop``,
        ``audit``, ``historian``, ``on_sample``, ``config``).
    users : UserStore, optional
        The users; default none (nobody can log in).
    start_runtime : bool
        Start the runtime when the application starts (unless it is running
        already: ``ctrlblocks serve`` starts it first, to report a start
        error on one line) and stop it when the application stops (on the
        server's event loop).  False when the runtime is run by someone else.
    push_period : float
        WebSocket push period [s]; 0.1 s gives the required 10 Hz.
    trend_seconds : float
        Length of the live trend kept per loop [s].
    public_view : bool, optional
        Live state without a login; default the configuration's
        ``[web] public_view`` (false when not given).
    users_check_interval : float
        How often the users file is checked for changes [s] (a removed,
        disabled or changed user's sessions end at the next request after it).
    clock : callable
        Time source of the rate limits and the lockout [s] (tests inject one).
    """
    users = users if users is not None else UserStore(None)
    web_cfg = getattr(runtime.config, "web", None)
    if public_view is None:
        public_view = bool(getattr(web_cfg, "public_view", False))
    confirm_step = float(getattr(web_cfg, "confirm_step", 0.1))
    sessions = SessionStore()
    guard = LoginGuard(LOCKOUT_FAILURES, CLIENT_LOGINS, LOCKOUT_SECONDS, clock)
    login_rate = SlidingWindow(*LOGIN_REQUESTS, clock)
    command_rate = SlidingWindow(*COMMAND_REQUESTS, clock)
    audit_rate = SlidingWindow(*AUDIT_REFUSALS, clock)
    suppressed: dict[str, int] = {}  # client -> refusals not written to the audit trail
    hub = LiveHub(runtime, seconds=trend_seconds)
    # the loops' own engineering ranges (they check every command), with the page's step
    bounds = {
        n: runtime.loops[n].bounds.with_confirm_step(confirm_step) for n in runtime.loop_names()
    }
    hashing: dict[str, Any] = {"pool": None, "pending": 0}
    last_users_check = [-math.inf]

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        if start_runtime and not runtime.running:  # (the command line starts it first)
            await runtime.start()
        # the live tuning's libraries (scipy: seconds) load beside the cycles now, so that
        # starting a test later does not stall the runtime's event loop while they import
        threading.Thread(target=importlib.import_module, args=("ctrlblocks.tuning.live",),
                         name="ctrlblocks-import", daemon=True).start()  # fmt: skip
        try:
            yield
        finally:
            if start_runtime:
                await runtime.stop()
            hub.detach()
            if hashing["pool"] is not None:
                hashing["pool"].shutdown(wait=False, cancel_futures=True)
                hashing["pool"] = None

    app = FastAPI(title="ctrlblocks faceplate", lifespan=lifespan, docs_url=None, redoc_url=None)
    app.state.runtime = runtime
    app.state.hub = hub
    app.state.users = users
    app.state.sessions = sessions
    app.state.bounds = bounds
    app.state.guard = guard
    static = resources.files("ctrlblocks.web") / "static"
    app.mount("/static", StaticFiles(directory=str(static)), name="static")

    @app.middleware("http")
    async def security_headers(request: Request, call_next: Any) -> Response:
        response = await call_next(request)
        for k, v in _SECURITY_HEADERS.items():
            response.headers.setdefault(k, v)
        return response

    # -- helpers ------------------------------------------------------------------

    def check_users() -> None:
        """Read a changed users file; end the sessions it invalidated (throttled)."""
        now = clock()
        if now - last_users_check[0] >= users_check_interval:
            last_users_check[0] = now
            users.reload_if_changed()
        for name in sessions.revoke_stale(users.fingerprint):
            log.warning("sessions of %r ended: the user was removed, disabled or changed", name)

    def session_of(conn: Request | WebSocket) -> Any:
        check_users()
        return sessions.get(conn.cookies.get(COOKIE))

    def may_view(conn: Request | WebSocket) -> bool:
        return public_view or session_of(conn) is not None

    def client_of(conn: Request | WebSocket) -> str:
        return (conn.client.host if conn.client else "unknown")[:64]

    def audit_refusal(client: str, **row: Any) -> None:
        """An audit row of a refused request, at most AUDIT_REFUSALS per client and window."""
        if not audit_rate.hit(client):
            suppressed[client] = suppressed.get(client, 0) + 1
            if len(suppressed) > 10_000:
                suppressed.clear()
            return
        n = suppressed.pop(client, 0)
        if n:
            row["message"] = f"{row.get('message', '')} ({n} more not recorded)"
        runtime.audit(**row)

    def not_logged_in() -> JSONResponse:
        return _error(401, "log in to see this", "login")

    async def json_body(request: Request) -> dict[str, Any] | JSONResponse:
        ctype = request.headers.get("content-type", "")
        if not ctype.startswith("application/json"):
            # a cross-site form cannot send JSON without a CORS preflight (CSRF guard)
            return _error(415, "send the body as application/json")
        raw = await read_body(request)
        if raw is None:
            return _error(413, "the body is too large", "body")
        try:
            body = json.loads(raw)
        except (ValueError, RecursionError):
            return _error(400, "the body is not valid JSON")
        if not isinstance(body, dict):
            return _error(400, "the body must be a JSON object")
        problem = json_problem(body)
        if problem is not None:
            return _error(400, f"the body is {problem}", "body")
        return body

    async def on_runtime(fn: Callable[..., Any], *args: Any, **kw: Any) -> Any:
        """``fn(*args, **kw)`` on the runtime's event loop (it may be another thread's)."""
        rt_loop = runtime.event_loop
        if rt_loop is None or rt_loop is asyncio.get_running_loop():
            return fn(*args, **kw)

        async def call() -> Any:
            return fn(*args, **kw)

        return await asyncio.wrap_future(asyncio.run_coroutine_threadsafe(call(), rt_loop))

    async def run_command(loop: str, user: str, changes: dict[str, Any]) -> dict[str, Any]:
        return await on_runtime(runtime.command, loop, user=user, **changes)  # type: ignore[no-any-return]

    def loop_state(name: str) -> dict[str, Any]:
        if name not in runtime.loop_names():
            raise KeyError(name)
        return hub.state(name)

    def unknown_loop(name: str) -> JSONResponse:
        return _error(404, f"unknown loop {name[:64]!r}", "loop")

    def historian_or_error() -> Any:
        h = runtime.historian
        if h is None:
            return _error(404, "this runtime has no historian ([historian] backend = 'none')")
        return h

    async def history_rows(name: str, start: float | None, end: float | None) -> Any:
        h = historian_or_error()
        if isinstance(h, JSONResponse):
            return h
        end = time.time() if end is None else end
        start = end - 600.0 if start is None else start
        if not (math.isfinite(start) and math.isfinite(end)) or start > end:
            return _error(400, "need finite start <= end (s since the epoch)", "start")
        await asyncio.to_thread(h.flush)  # include the samples still in the buffer
        samples = await asyncio.to_thread(h.samples, name, start, end)
        return [tuple(s[c] for c in HISTORY_COLUMNS) for s in samples]

    # -- page ---------------------------------------------------------------------

    @app.get("/", include_in_schema=False)
    async def index() -> FileResponse:
        return FileResponse(str(static / "index.html"), media_type="text/html")

    @app.get("/favicon.ico", include_in_schema=False)
    async def favicon() -> Response:
        return Response(status_code=204)

    # -- read-only API -------------------------------------------------------------

    @app.get("/api/info")
    async def info(request: Request) -> dict[str, Any]:
        s = session_of(request)
        role = None if s is None else s.role
        out: dict[str, Any] = {
            "name": runtime.config.name,
            "user": None if s is None else s.user,
            "role": role,
            "may_change": sorted(PERMISSIONS.get(role or "", ())),
            "public_view": public_view,
            "may_view": public_view or s is not None,
            "push_period": push_period,
            "trend_seconds": trend_seconds,
            "historian": runtime.historian is not None,
        }
        if out["may_view"]:
            out["loops"] = runtime.loop_names()
            out["engineering"] = {n: b.as_json() for n, b in bounds.items()}
        return out

    @app.get("/api/loops", response_model=None)
    async def loops(request: Request) -> Any:
        if not may_view(request):
            return not_logged_in()
        return hub.states()

    @app.get("/api/loops/{name}", response_model=None)
    async def one_loop(name: str, request: Request) -> Any:
        if not may_view(request):
            return not_logged_in()
        try:
            return loop_state(name)
        except KeyError:
            return unknown_loop(name)

    @app.get("/api/loops/{name}/history", response_model=None)
    async def history(
        request: Request,
        name: str,
        start: float | None = None,
        end: float | None = None,
        max_points: int = 5000,
    ) -> Any:
        if session_of(request) is None:
            return not_logged_in()
        if name not in runtime.loop_names():
            return unknown_loop(name)
        rows = await history_rows(name, start, end)
        if isinstance(rows, JSONResponse):
            return rows
        n = len(rows)
        stride = max(1, math.ceil(n / max(1, max_points)))
        cols = {c: [json_safe(r[i]) for r in rows[::stride]] for i, c in enumerate(HISTORY_COLUMNS)}
        return {
            "loop": name,
            "rows": n,
            "stride": stride,
            "columns": cols,
            "units": bounds[name].units,
        }

    @app.get("/api/loops/{name}/history.csv", response_model=None)
    async def history_csv(
        request: Request, name: str, start: float | None = None, end: float | None = None
    ) -> Any:
        if session_of(request) is None:
            return not_logged_in()
        if name not in runtime.loop_names():
            return unknown_loop(name)
        rows = await history_rows(name, start, end)
        if isinstance(rows, JSONResponse):
            return rows
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(csv_header(bounds[name].units))
        for r in rows:  # NULL (SQLite's NaN) as an empty field
            w.writerow(
                ["" if v is None or (isinstance(v, float) and math.isnan(v)) else v for v in r]
            )
        fname = f"{name}-{int(rows[0][0]) if rows else 0}.csv"
        return Response(
            buf.getvalue(),
            media_type="text/csv",
            headers={"Content-Disposition": f'attachment; filename="{fname}"'},
        )

    @app.get("/api/audit", response_model=None)
    async def audit_trail(request: Request, limit: int = 50, loop: str | None = None) -> Any:
        if session_of(request) is None:
            return not_logged_in()
        h = historian_or_error()
        if isinstance(h, JSONResponse):
            return h
        rows = await asyncio.to_thread(h.audit_rows, loop, max(1, min(int(limit), 1000)))
        out = []
        for d in reversed(rows):  # newest first
            for k in ("old", "new"):
                with contextlib.suppress(TypeError, ValueError):
                    d[k] = json.loads(d[k]) if d[k] is not None else None
            d["ok"] = bool(d["ok"])
            out.append(json_safe(d))
        return out

    # -- login ---------------------------------------------------------------------

    @app.post("/api/login", response_model=None)
    async def login(request: Request) -> Any:
        client = client_of(request)
        if not login_rate.hit(client):
            return _error(429, "too many requests from this address: wait a minute", "login")
        body = await json_body(request)
        if isinstance(body, JSONResponse):
            return body
        user, password = body.get("user"), body.get("password")
        if not isinstance(user, str) or not isinstance(password, str):
            return _error(400, "give user and password as strings", "user")
        if len(password) > 1024:
            return _error(400, "the password is too long", "password")
        check_users()
        # a name that is not a user is never written down: it may be a password
        known = bool(NAME_RE.match(user)) and users.exists(user)
        who = user if known else "unknown user"
        key = user if NAME_RE.match(user) else "(invalid name)"
        refused = guard.admit(key, client)
        if refused is not None:
            audit_refusal(
                client,
                who=who,
                action="login",
                ok=False,
                message=f"refused: {refused}",
                new=summary(client, "/api/login", {}),
            )
            return _error(429, f"{refused}: try again in {LOCKOUT_SECONDS:g} s", "user")
        if hashing["pending"] >= MAX_PENDING_HASHES:
            guard.withdraw(key, client)
            return _error(503, "too many logins at once: try again", "login")
        if hashing["pool"] is None:
            # its own thread: a burst of logins never waits in (or takes) the default executor
            hashing["pool"] = concurrent.futures.ThreadPoolExecutor(
                1, "ctrlblocks-password", initializer=_lower_priority
            )
        hashing["pending"] += 1
        try:
            loop = asyncio.get_running_loop()
            ok = await loop.run_in_executor(hashing["pool"], users.verify, user, password)
        finally:
            hashing["pending"] -= 1
        if not ok:
            audit_refusal(
                client,
                who=who,
                action="login",
                ok=False,
                message="wrong user name or password",
                new=summary(client, "/api/login", {}),
            )
            return _error(401, "wrong user name or password", "password")
        guard.succeeded(key, client)
        runtime.audit(user, "login", ok=True, new={"client": client})
        role = users.role(user) or "operator"
        token = sessions.create(user, role, users.fingerprint(user))
        resp = JSONResponse({"ok": True, "user": user, "role": role})
        resp.set_cookie(
            COOKIE,
            token,
            httponly=True,
            samesite="strict",
            secure=request.url.scheme == "https",
            max_age=int(3600 * sessions.hours),
            path="/",
        )
        return resp

    @app.post("/api/logout")
    async def logout(request: Request) -> JSONResponse:
        s = session_of(request)
        if s is not None:
            runtime.audit(s.user, "logout")
        sessions.end(request.cookies.get(COOKIE))
        resp = JSONResponse({"ok": True})
        resp.delete_cookie(COOKIE, path="/")
        return resp

    # -- commands ------------------------------------------------------------------

    async def admitted(
        name: str, request: Request, action: str, route: str, who_may: str
    ) -> tuple[Any, dict[str, Any]] | JSONResponse:
        """(session, body) of a command-like request, or the refusal (rate, loop, body, login).

        A request without a login is audited (bounded, :func:`audit_refusal`).
        """
        client = client_of(request)
        if not command_rate.hit(client):
            return _error(429, "too many commands from this address: slow down", "command")
        if name not in runtime.loop_names():
            return unknown_loop(name)
        body = await json_body(request)
        if isinstance(body, JSONResponse):
            return body
        s = session_of(request)
        if s is None:
            audit_refusal(
                client,
                who="anonymous",
                action=action,
                loop=name,
                new=summary(client, f"/api/loops/{name}/{route}", body),
                ok=False,
                message="refused: not logged in",
            )
            return _error(401, f"log in as {who_may}", "login")
        return s, body

    @app.post("/api/loops/{name}/command", response_model=None)
    async def command(name: str, request: Request) -> Any:
        got = await admitted(name, request, "command", "command",
                             "an operator to change a loop")  # fmt: skip
        if isinstance(got, JSONResponse):
            return got
        s, body = got
        action = ",".join(sorted(str(k)[:32] for k in body))
        may = PERMISSIONS.get(s.role, frozenset())
        denied = sorted(str(k) for k in body if k in PERMISSIONS["engineer"] and k not in may)
        if denied:
            msg = f"refused: a {s.role} may not change {denied[0][:32]}"
            runtime.audit(s.user, action, loop=name, new=json_safe(body), ok=False, message=msg)
            allowed = ", ".join(sorted(PERMISSIONS.get(s.role, ()))) or "nothing"
            return _error(
                403,
                f"a {s.role} may not change {denied[0][:32]} (may change: {allowed})",
                denied[0][:32],
            )
        changes = coerce_command(body, runtime.state(name))
        try:  # the loop checks the engineering ranges and audits a refusal
            old = await run_command(name, s.user, changes)
        except CommandError as exc:
            return _error(422, exc.message, exc.field, exc.code)
        except Exception as exc:  # the block accepted what it could not compute with
            field = exc.field if isinstance(exc, ParameterError) else next(iter(body), "")
            code = exc.code if isinstance(exc, ParameterError) else ErrorCode.BAD_PARAMETER
            msg = f"refused: {type(exc).__name__}: {str(exc)[:200]}"
            log.warning("loop %s: command %s failed: %s", name, action, msg)
            runtime.audit(s.user, action, loop=name, new=json_safe(changes), ok=False, message=msg)
            return _error(422, msg, str(field), code)
        return {"ok": True, "old": json_safe(old), "state": loop_state(name)}

    # -- process alarms (ctrlblocks.runtime.health) ------------------------------------

    @app.get("/api/alarms", response_model=None)
    async def alarms_all(request: Request) -> Any:
        """Every loop's alarm state at a glance and its annunciated alarms."""
        if not may_view(request):
            return not_logged_in()
        out = {}
        for name in runtime.health.loops:
            st = runtime.health.status(name)
            st["alarms"] = [a for a in st["alarms"] if a["state"] != "NORMAL"]
            out[name] = json_safe(st)
        return {"loops": out}

    @app.post("/api/loops/{name}/alarms/{action}", response_model=None)
    async def alarm_action(name: str, action: str, request: Request) -> Any:
        """Acknowledge (``{"alarm": "H"}``, or all without it), shelve or unshelve an alarm."""
        if action not in ("ack", "shelve", "unshelve"):
            return _error(404, f"unknown alarm action {action[:32]!r}", "action")
        audit_action = f"alarm-{action}"
        got = await admitted(name, request, audit_action, f"alarms/{action}",
                             "an operator to acknowledge alarms")  # fmt: skip
        if isinstance(got, JSONResponse):
            return got
        s, body = got
        if s.role not in ALARM_ROLES:
            msg = f"refused: a {s.role} may not {action} alarms"
            runtime.audit(s.user, audit_action, loop=name, new=json_safe(body), ok=False,
                          message=msg)  # fmt: skip
            return _error(403, f"a {s.role} may not {action} alarms (operators may)", "alarm")
        alarm = body.get("alarm")
        if alarm is not None and (not isinstance(alarm, str) or alarm not in ALARM_NAMES):
            return _error(422, f"alarm must be one of {', '.join(ALARM_NAMES)}", "alarm")
        try:
            if action == "ack":
                changed = runtime.health.acknowledge(name, alarm, s.user)
            elif alarm is None:
                return _error(422, "name the alarm to shelve or unshelve", "alarm")
            elif action == "shelve":
                seconds = body.get("seconds")
                if isinstance(seconds, bool) or not isinstance(seconds, (int, float)):
                    return _error(422, "seconds must be a number", "seconds")
                runtime.health.shelve(name, alarm, float(seconds), s.user)
                changed = [alarm]
            else:
                runtime.health.unshelve(name, alarm, s.user)
                changed = [alarm]
        except KeyError:
            return _error(404, f"loop {name[:64]!r} has no alarms", "loop")
        except ParameterError as exc:
            return _error(422, exc.message, "seconds", exc.code)
        return {"ok": True, "changed": changed, "status": json_safe(runtime.health.status(name))}

    # -- live auto-tuning (engineer) ---------------------------------------------------

    @app.get("/api/loops/{name}/tune", response_model=None)
    async def tune_status(name: str, request: Request) -> Any:
        if not may_view(request):
            return not_logged_in()
        if name not in runtime.loop_names():
            return unknown_loop(name)
        return json_safe(runtime.tuning.status(name))

    @app.post("/api/loops/{name}/tune", response_model=None)
    async def tune_start(name: str, request: Request) -> Any:
        return await tune_action(name, request, "start")

    @app.post("/api/loops/{name}/tune/{action}", response_model=None)
    async def tune_decide(name: str, action: str, request: Request) -> Any:
        if action not in ("abort", "accept", "reject"):
            return _error(404, f"unknown tuning action {action[:32]!r}", "action")
        return await tune_action(name, request, action)

    async def tune_action(name: str, request: Request, action: str) -> Any:
        """Start, abort, accept or reject a live tuning (checks as for a command)."""
        audit_action = f"tune-{action}"
        got = await admitted(name, request, audit_action, "tune", "an engineer to tune a loop")
        if isinstance(got, JSONResponse):
            return got
        s, body = got
        if "tune" not in PERMISSIONS.get(s.role, frozenset()):
            msg = f"refused: a {s.role} may not tune a loop"
            runtime.audit(s.user, audit_action, loop=name, new=json_safe(body), ok=False,
                          message=msg)  # fmt: skip
            return _error(403, f"a {s.role} may not tune a loop (engineers may)", "tune")
        try:
            if action == "start":
                try:
                    kw = tune_options(body, bounds[name])
                except CommandError as exc:
                    runtime.audit(s.user, audit_action, loop=name, new=json_safe(body),
                                  ok=False, message=str(exc))  # fmt: skip
                    raise
                st = await on_runtime(runtime.tuning.start, name, user=s.user, **kw)
            elif action == "abort":
                reason = str(body.get("reason", ""))[:200]
                st = await on_runtime(runtime.tuning.abort, name, user=s.user, reason=reason)
            elif action == "reject":
                st = await on_runtime(runtime.tuning.reject, name, user=s.user)
            else:
                proposal = body.get("proposal")
                if not isinstance(proposal, str):
                    raise CommandError("proposal", "give the name of a proposal")
                outside = proposal_outside(runtime, name, proposal[:64], bounds[name])
                if outside is not None:
                    field, msg, code = outside
                    runtime.audit(s.user, audit_action, loop=name, ok=False,
                                  new={"proposal": proposal[:64]},
                                  message=f"{field}: {msg}")  # fmt: skip
                    return _error(422, msg, field, code)
                await on_runtime(runtime.tuning.accept, name, user=s.user, proposal=proposal[:64],
                                 force=body.get("force") is True)  # fmt: skip
                st = runtime.tuning.status(name)
        except CommandError as exc:
            return _error(422, exc.message, exc.field, exc.code)
        return {"ok": True, "tuning": json_safe(st), "state": loop_state(name)}

    # -- live push -------------------------------------------------------------------

    def same_origin(websocket: WebSocket) -> bool:
        """A browser sends its page's Origin: it must be this server (no cross-site socket)."""
        origin = websocket.headers.get("origin")
        return origin is None or urlsplit(origin).netloc == websocket.headers.get("host")

    @app.websocket("/ws")
    async def ws(websocket: WebSocket) -> None:
        if not same_origin(websocket) or not may_view(websocket):
            await websocket.close(code=1008)
            return
        token = websocket.cookies.get(COOKIE)
        await websocket.accept()
        cursor = hub.cursor()

        async def sender() -> None:
            await websocket.send_text(
                json.dumps(
                    {
                        "type": "hello",
                        "name": runtime.config.name,
                        "loops": runtime.loop_names(),
                        "push_period": push_period,
                    }
                )
            )
            while True:
                check_users()
                if not public_view and sessions.get(token) is None:
                    await websocket.close(code=1008)  # logged out, revoked or expired
                    return
                msg = {
                    "type": "update",
                    "t": time.time(),
                    "loops": hub.states(),
                    "samples": hub.since(cursor),
                }
                await websocket.send_text(json.dumps(msg, allow_nan=False))
                await asyncio.sleep(push_period)

        async def reader() -> None:
            while True:
                m = await websocket.receive()
                if m["type"] == "websocket.disconnect":
                    return

        tasks = [asyncio.create_task(sender()), asyncio.create_task(reader())]
        try:
            await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        finally:
            for t in tasks:
                t.cancel()
            for t in tasks:
                with contextlib.suppress(asyncio.CancelledError, WebSocketDisconnect, Exception):
                    await t

    return app
