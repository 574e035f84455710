"""The operator's faceplate in the browser for every loop of a runtime (``ctrlblocks serve``).

* :func:`create_app` -- the FastAPI application: the page, a WebSocket push
  of SP/PV/MV/mode/error of every loop (10 Hz), REST actions (mode, manual
  value, setpoint, limits, tunings) that go through the loop's and the block's
  own validation, history and CSV from the historian, the audit trail;
* :class:`UserStore` -- operators with scrypt password hashes; viewers need no
  login and can only watch;
* :func:`make_server` / :func:`serve_runtime` -- uvicorn around the app;
* :mod:`.demo` -- a simulated plant behind the in-memory adapter (the demo of
  ``ctrlblocks serve`` without a configuration file).

FastAPI and uvicorn are the ``web`` extra (``pip install 'ctrlblocks[web]'``);
they are imported only when the app is made.  See ``docs/faceplate.md``.
"""

from __future__ import annotations

from typing import Any

from .auth import SessionStore, UserError, UserStore, hash_password, verify_password
from .server import DEFAULT_HOST, DEFAULT_PORT, make_server, serve_runtime

__all__ = [
    "DEFAULT_HOST",
    "DEFAULT_PORT",
    "SessionStore",
    "UserError",
    "UserStore",
    "create_app",
    "hash_password",
    "make_server",
    "serve_runtime",
    "verify_password",
]


def create_app(runtime: Any, **kw: Any) -> Any:
    """The faceplate application (see :func:`ctrlblocks.web.app.create_app`)."""
    try:
        from .app import create_app as _create
    except ImportError as exc:  # pragma: no cover - depends on the install
        raise ImportError(
            "the web faceplate needs FastAPI and uvicorn: pip install 'ctrlblocks[web]'"
        ) from exc
    return _create(runtime, **kw)
