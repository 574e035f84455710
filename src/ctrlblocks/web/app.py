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
``WS /ws``                              live      push every ``push_period`` (0.1 s): what
                                                  changed of the loops on screen, the samples
                                                  not yet sent (:mod:`.routes.push`)
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
Answers: 200 ``{"ok": true, "old": {...}, "retained": true, "state": {...}}``
once the change is in the retain file (fsync'd; :meth:`Runtime.execute
<ctrlblocks.runtime.Runtime.execute>`), 503 when it is in force but could not
be retained; 401 without a
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
typed into the wrong field).  A logged-in user's refusals are bounded the
same way (here per client address for the role's refusals, in the runtime per
user for the loop's and the block's).  The client address is the peer's;
``X-Forwarded-For`` counts only from a proxy in ``[web] trusted_proxies``.

The routes live in :mod:`.routes` (one module per concern) and share one
:class:`~ctrlblocks.web.context.Faceplate`.

Text from input fields is accepted for numbers (``"1.5"``, ``"inf"``):
:func:`~ctrlblocks.web.routes.commands.coerce_command`.
"""

from __future__ import annotations

import contextlib
import importlib
import threading
import time
from collections.abc import AsyncIterator, Callable
from typing import Any

from fastapi import FastAPI, Request
from fastapi.responses import Response
from fastapi.staticfiles import StaticFiles

from .auth import UserStore
from .context import (
    AUDIT_REFUSALS,
    CLIENT_LOGINS,
    COMMAND_REQUESTS,
    COOKIE,
    HASH_NICE,
    HISTORY_COLUMNS,
    LOCKOUT_FAILURES,
    LOCKOUT_SECONDS,
    LOGIN_REQUESTS,
    MAX_PENDING_HASHES,
    Faceplate,
)
from .routes import alarms, commands, pages, push, session
from .routes.commands import TUNE_OPTIONS, coerce_command, proposal_outside, tune_options
from .routes.pages import STATIC, csv_header

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
    "TUNE_OPTIONS",
    "coerce_command",
    "create_app",
    "csv_header",
    "proposal_outside",
    "tune_options",
]

_SECURITY_HEADERS = {
    "Content-Security-Policy": (
        "default-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data:; "
        "connect-src 'self'; frame-ancestors 'none'"
    ),
    "X-Frame-Options": "DENY",
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
}


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
    trusted_proxies: tuple[str, ...] | None = None,
) -> FastAPI:
    """The faceplate application for ``runtime``.

    Parameters
    ----------
    runtime : ctrlblocks.runtime.Runtime
        The runtime whose loops are shown (its in-process API: ``loop_names``,
        ``loops``, ``state``, ``states``, ``execute``/``submit``, ``event_loop``,
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
    trusted_proxies : tuple of str, optional
        Reverse proxies whose ``X-Forwarded-For`` is believed (addresses or
        networks); default the configuration's ``[web] trusted_proxies`` (none).
    """
    web_cfg = getattr(runtime.config, "web", None)
    if public_view is None:
        public_view = bool(getattr(web_cfg, "public_view", False))
    if trusted_proxies is None:
        trusted_proxies = tuple(getattr(web_cfg, "trusted_proxies", ()))
    fp = Faceplate(
        runtime,
        users=users if users is not None else UserStore(None),
        push_period=push_period,
        trend_seconds=trend_seconds,
        public_view=public_view,
        users_check_interval=users_check_interval,
        clock=clock,
        trusted_proxies=trusted_proxies,
    )

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
            fp.close()

    app = FastAPI(title="ctrlblocks faceplate", lifespan=lifespan, docs_url=None, redoc_url=None)
    app.state.faceplate = fp
    # (the attributes tests and tools look at)
    app.state.runtime, app.state.hub, app.state.users = runtime, fp.hub, fp.users
    app.state.sessions, app.state.bounds, app.state.guard = fp.sessions, fp.bounds, fp.guard
    app.mount("/static", StaticFiles(directory=str(STATIC)), name="static")

    @app.middleware("http")
    async def security_headers(request: Request, call_next: Any) -> Response:
        response = await call_next(request)
        for k, v in _SECURITY_HEADERS.items():
            response.headers.setdefault(k, v)
        return response

    for module in (pages, session, commands, alarms, push):
        app.include_router(module.router)
    return app
