"""Run the faceplate: uvicorn serving :func:`~ctrlblocks.web.app.create_app`, with the runtime.

The runtime and the web server share one asyncio event loop: the
application's start starts the runtime and its stop (Ctrl-C, SIGTERM) stops it
gracefully (safe/stop values written, historian flushed).  The server binds
to 127.0.0.1 unless told otherwise; anything else is reachable from the
network: give it a certificate (``certfile``/``keyfile``: uvicorn serves
HTTPS and the session cookie is ``Secure``) or put it behind a TLS reverse
proxy -- without either it warns, because the session cookie and the
passwords would cross the network in clear text.
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


def is_loopback(host: str) -> bool:
    """True for ``localhost`` and loopback addresses (127.0.0.0/8, ::1)."""
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
    certfile: str | None = None,
    keyfile: str | None = None,
    **app_kw: Any,
) -> Any:
    """A ``uvicorn.Server`` serving the faceplate of ``runtime`` (not started yet).

    Run it with ``server.run()`` (blocking; handles Ctrl-C) or ``await
    server.serve()``; pass ``sockets=[sock]`` to serve on a socket you bound
    yourself (tests bind 127.0.0.1 port 0).  ``certfile`` and ``keyfile``
    (PEM) serve HTTPS (and WSS).
    """
    import uvicorn

    from .app import create_app

    if (certfile is None) != (keyfile is None):
        raise ValueError("TLS needs both a certificate file and its key file")
    if not is_loopback(host) and certfile is None:
        log.warning(
            "the faceplate listens on %s without TLS: it is reachable from the network and "
            "passwords and session cookies would travel in clear text; give --certfile and "
            "--keyfile or put it behind a TLS reverse proxy",
            host,
        )
    app = create_app(runtime, users=users, start_runtime=start_runtime, **app_kw)
    config = uvicorn.Config(
        app,
        host=host,
        port=port,
        log_level=log_level,
        lifespan="on",
        ws="auto",
        ssl_certfile=certfile,
        ssl_keyfile=keyfile,
        # the application reads X-Forwarded-For itself, only from [web] trusted_proxies
        # (uvicorn would believe it from 127.0.0.1 by default)
        proxy_headers=False,
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
