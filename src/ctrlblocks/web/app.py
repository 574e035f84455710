"""The faceplate web application (FastAPI): a page, a WebSocket push and a small REST API.

Routes (all JSON unless said otherwise; ``docs/faceplate.md`` has examples):

======================================  ========  ===============================================
route                                   who       what
======================================  ========  ===============================================
``GET /``                               anyone    the faceplate page (plain HTML/JS, uPlot)
``WS /ws``                              anyone    push every ``push_period`` (0.1 s): the state
                                                  of every loop and the samples not yet sent
``GET /api/info``                       anyone    runtime name, loops, who is logged in
``GET /api/loops``, ``/api/loops/NAME``  anyone    loop states (SP, PV, MV, mode, error, limits,
                                                  tunings, I/O status, alarms)
``GET /api/loops/NAME/history``         anyone    samples from the historian, ``start``/``end``
                                                  in s since the epoch (default: last 10 min)
``GET /api/loops/NAME/history.csv``     anyone    the same as a CSV download (every sample)
``GET /api/audit``                      anyone    the audit trail (who changed what, when)
``POST /api/login``, ``/api/logout``    anyone    ``{"user": .., "password": ..}``; a cookie
                                                  (5 failures in 60 s lock the name for 60 s)
``POST /api/loops/NAME/command``        operator  ``{"mode": "manual", "manual_value": 40}``,
                                                  ``{"sp": 2.0}``, ``{"u_min": 0, "u_max": 80}``,
                                                  ``{"tunings": {"kp": 1.5}}`` (any together)
======================================  ========  ===============================================

A command goes to :meth:`Runtime.command <ctrlblocks.runtime.Runtime.command>`,
so the loop and the block validate it (the block's own ``configure`` and
bumpless rules), a refused command changes nothing, and the runtime writes it
(accepted or refused, with the operator's name) to the historian's audit
table.  Answers: 200 ``{"ok": true, "old": {...}, "state": {...}}``; 401 when
nobody is logged in (also written to the audit table, as ``anonymous``); 422
with the block's error ``{"error": {"field", "code", "code_hex", "name",
"message"}}`` (for example ``16#8203 BAD_PARAMETER``, ``tunings.kp: must be >
0``); 404 for an unknown loop.

Text from input fields is accepted for numbers (``"1.5"``, ``"inf"``): a
string is converted to the type of the value in force (int, float, ``None``
for "" when the parameter may be unset); what does not convert goes to the
block unchanged and the block refuses it with its code.
"""

from __future__ import annotations

import asyncio
import contextlib
import csv
import io
import json
import logging
import math
import time
from collections.abc import AsyncIterator, Mapping
from importlib import resources
from typing import Any

from fastapi import FastAPI, Request, WebSocket
from fastapi.responses import FileResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles
from starlette.websockets import WebSocketDisconnect

from ..blocks.base import ErrorCode
from ..runtime.historian import SAMPLE_COLUMNS
from ..runtime.loop import CommandError
from .auth import SessionStore, UserStore
from .live import LiveHub, json_safe

__all__ = ["COOKIE", "create_app"]

log = logging.getLogger(__name__)

COOKIE = "ctrlblocks_session"
"""Name of the session cookie."""

LOCKOUT_FAILURES = 5
LOCKOUT_SECONDS = 60.0
"""After LOCKOUT_FAILURES failed logins of one user name within LOCKOUT_SECONDS, further
logins of that name are refused (429) until the oldest failure is LOCKOUT_SECONDS old."""

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


def create_app(
    runtime: Any,
    *,
    users: UserStore | None = None,
    start_runtime: bool = True,
    push_period: float = 0.1,
    trend_seconds: float = 300.0,
) -> FastAPI:
    """The faceplate application for ``runtime``.

    Parameters
    ----------
    runtime : ctrlblocks.runtime.Runtime
        The runtime whose loops are shown (its in-process API: ``loop_names``,
        ``state``, ``states``, ``command``/``submit``, ``event_loop``, ``audit``,
        ``historian``, ``on_sample``).
    users : UserStore, optional
        The operators; default none (everybody is a viewer).
    start_runtime : bool
        Start the runtime when the application starts and stop it when the
        application stops (on the server's event loop).  False when the
        runtime is run by someone else.
    push_period : float
        WebSocket push period [s]; 0.1 s gives the required 10 Hz.
    trend_seconds : float
        Length of the live trend kept per loop [s].
    """
    users = users if users is not None else UserStore(None)
    sessions = SessionStore()
    failures: dict[str, list[float]] = {}  # user name -> times of failed logins
    hub = LiveHub(runtime, seconds=trend_seconds)

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        if start_runtime:
            await runtime.start()
        try:
            yield
        finally:
            if start_runtime:
                await runtime.stop()
            hub.detach()

    app = FastAPI(title="ctrlblocks faceplate", lifespan=lifespan, docs_url=None, redoc_url=None)
    app.state.runtime = runtime
    app.state.hub = hub
    app.state.users = users
    app.state.sessions = sessions
    static = resources.files("ctrlblocks.web") / "static"
    app.mount("/static", StaticFiles(directory=str(static)), name="static")

    @app.middleware("http")
    async def security_headers(request: Request, call_next: Any) -> Response:
        response = await call_next(request)
        for k, v in _SECURITY_HEADERS.items():
            response.headers.setdefault(k, v)
        return response

    # -- helpers ------------------------------------------------------------------

    def session_of(request: Request) -> Any:
        return sessions.get(request.cookies.get(COOKIE))

    async def json_body(request: Request) -> dict[str, Any] | JSONResponse:
        ctype = request.headers.get("content-type", "")
        if not ctype.startswith("application/json"):
            # a cross-site form cannot send JSON without a CORS preflight (CSRF guard)
            return _error(415, "send the body as application/json")
        try:
            body = await request.json()
        except ValueError:
            return _error(400, "the body is not valid JSON")
        if not isinstance(body, dict):
            return _error(400, "the body must be a JSON object")
        return body

    async def run_command(loop: str, user: str, changes: dict[str, Any]) -> dict[str, Any]:
        rt_loop = runtime.event_loop
        if rt_loop is None or rt_loop is asyncio.get_running_loop():
            return runtime.command(loop, user=user, **changes)
        return await asyncio.wrap_future(runtime.submit(loop, user=user, **changes))

    def loop_state(name: str) -> dict[str, Any]:
        if name not in runtime.loop_names():
            raise KeyError(name)
        return hub.state(name)

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
        return {
            "name": runtime.config.name,
            "loops": runtime.loop_names(),
            "user": None if s is None else s.user,
            "role": "viewer" if s is None else s.role,
            "operators_defined": bool(users.names()),
            "push_period": push_period,
            "trend_seconds": trend_seconds,
            "historian": runtime.historian is not None,
        }

    @app.get("/api/loops")
    async def loops() -> list[dict[str, Any]]:
        return hub.states()

    @app.get("/api/loops/{name}", response_model=None)
    async def one_loop(name: str) -> Any:
        try:
            return loop_state(name)
        except KeyError:
            return _error(404, f"unknown loop {name!r}", "loop")

    @app.get("/api/loops/{name}/history", response_model=None)
    async def history(
        name: str, start: float | None = None, end: float | None = None, max_points: int = 5000
    ) -> Any:
        if name not in runtime.loop_names():
            return _error(404, f"unknown loop {name!r}", "loop")
        rows = await history_rows(name, start, end)
        if isinstance(rows, JSONResponse):
            return rows
        n = len(rows)
        stride = max(1, math.ceil(n / max(1, max_points)))
        cols = {c: [json_safe(r[i]) for r in rows[::stride]] for i, c in enumerate(HISTORY_COLUMNS)}
        return {"loop": name, "rows": n, "stride": stride, "columns": cols}

    @app.get("/api/loops/{name}/history.csv", response_model=None)
    async def history_csv(name: str, start: float | None = None, end: float | None = None) -> Any:
        if name not in runtime.loop_names():
            return _error(404, f"unknown loop {name!r}", "loop")
        rows = await history_rows(name, start, end)
        if isinstance(rows, JSONResponse):
            return rows
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(HISTORY_COLUMNS)
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
    async def audit_trail(limit: int = 50, loop: str | None = None) -> Any:
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
        body = await json_body(request)
        if isinstance(body, JSONResponse):
            return body
        user, password = body.get("user"), body.get("password")
        if not isinstance(user, str) or not isinstance(password, str):
            return _error(400, "give user and password as strings", "user")
        now = time.time()
        recent = [t for t in failures.get(user, []) if now - t < LOCKOUT_SECONDS]
        failures[user] = recent
        if len(recent) >= LOCKOUT_FAILURES:
            runtime.audit(user, "login", ok=False, message="refused: too many failed logins")
            return _error(
                429, f"too many failed logins: try again in {LOCKOUT_SECONDS:g} s", "user"
            )
        ok = await asyncio.to_thread(users.verify, user, password)
        runtime.audit(user, "login", ok=ok, message="" if ok else "wrong user name or password")
        if not ok:
            recent.append(now)
            return _error(401, "wrong user name or password", "password")
        failures.pop(user, None)
        role = users.role(user) or "operator"
        token = sessions.create(user, role)
        resp = JSONResponse({"ok": True, "user": user, "role": role})
        resp.set_cookie(
            COOKIE,
            token,
            httponly=True,
            samesite="strict",
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

    @app.post("/api/loops/{name}/command", response_model=None)
    async def command(name: str, request: Request) -> Any:
        if name not in runtime.loop_names():
            return _error(404, f"unknown loop {name!r}", "loop")
        body = await json_body(request)
        if isinstance(body, JSONResponse):
            return body
        s = session_of(request)
        if s is None or s.role != "operator":
            runtime.audit(
                "anonymous",
                ",".join(sorted(body)),
                loop=name,
                new=json_safe(body),
                ok=False,
                message="refused: not logged in as an operator",
            )
            return _error(401, "log in as an operator to change a loop", "login")
        changes = coerce_command(body, runtime.state(name))
        try:
            old = await run_command(name, s.user, changes)
        except CommandError as exc:
            return _error(422, exc.message, exc.field, exc.code)
        return {"ok": True, "old": json_safe(old), "state": loop_state(name)}

    # -- live push -------------------------------------------------------------------

    @app.websocket("/ws")
    async def ws(websocket: WebSocket) -> None:
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
