"""Run the faceplate: uvicorn serving :func:`~ctrlblocks.web.app.create_app`, with the runtime.

The runtime and the web server share one asyncio event loop: the
application's start starts the runtime and its stop (Ctrl-C, SIGTERM) stops it
gracefully (safe/stop values written, historian flushed).  The server binds
to 127.0.0.1 unless told otherwise; anything else is reachable from the
network and should sit behind a TLS reverse proxy (the session cookie travels
with every request).
"""

from __future__ import annotations

import ipaddress
import logging
import socket
from typing import Any

from .auth import UserStore

__all__ = ["DEFAULT_HOST", "DEFAULT_PORT", "make_server", "serve_runtime"]

log = logging.getLogger(__name__)

DEFAULT_HOST = "127.0.0.1"
"""The faceplate listens on the loopback interface unless told otherwise."""

DEFAULT_PORT = 8000
"""Default TCP port of the faceplate."""


def _is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def make_server(
    runtime: Any,
    *,
    host: str = DEFAULT_HOST,
    port: int = DEFAULT_PORT,
    users: UserStore | None = None,
    start_runtime: bool = True,
    log_level: str = "warning",
    **app_kw: Any,
) -> Any:
    """A ``uvicorn.Server`` serving the faceplate of ``runtime`` (not started yet).

    Run it with ``server.run()`` (blocking; handles Ctrl-C) or ``await
    server.serve()``; pass ``sockets=[sock]`` to serve on a socket you bound
    yourself (tests bind 127.0.0.1 port 0).
    """
    import uvicorn

    from .app import create_app

    if not _is_loopback(host):
        log.warning(
            "the faceplate listens on %s: it is reachable from the network; "
            "put it behind a TLS reverse proxy",
            host,
        )
    app = create_app(runtime, users=users, start_runtime=start_runtime, **app_kw)
    config = uvicorn.Config(
        app, host=host, port=port, log_level=log_level, lifespan="on", ws="auto"
    )
    return uvicorn.Server(config)


async def serve_runtime(
    runtime: Any,
    *,
    host: str = DEFAULT_HOST,
    port: int = DEFAULT_PORT,
    users: UserStore | None = None,
    **app_kw: Any,
) -> None:
    """Serve the faceplate of a runtime that is already running on this event loop.

    For a runtime command that starts its loops itself (``await
    runtime.start()``) and wants the web UI next to them: returns when the
    server stops; it does not stop the runtime.
    """
    server = make_server(runtime, host=host, port=port, users=users, start_runtime=False, **app_kw)
    await server.serve()


def bind_socket(host: str = DEFAULT_HOST, port: int = 0) -> socket.socket:
    """A listening TCP socket on ``host``:``port`` (port 0: a free one)."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind((host, port))
    sock.listen(64)
    return sock
