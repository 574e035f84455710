"""Command line of the faceplate: ``serve`` (runtime + web UI) and ``operator`` (users file).

``ctrlblocks serve`` without a configuration file runs the shipped demo (a
simulated three-tank and a fast flow loop, see :mod:`ctrlblocks.web.demo`)
and opens the faceplate at http://127.0.0.1:8000.
"""

from __future__ import annotations

import asyncio
import contextlib
import errno
import os
import socket
import tempfile
from pathlib import Path
from typing import Any

import click

from .server import DEFAULT_HOST, DEFAULT_PORT, is_loopback

__all__ = ["DEFAULT_USERS", "operator", "serve"]

DEFAULT_USERS = "ctrlblocks-users.json"
"""Users file used when ``--users`` and ``CTRLBLOCKS_USERS`` are not given."""

_USERS_OPTION = click.option(
    "--users",
    "users_file",
    type=click.Path(dir_okay=False, path_type=Path),
    envvar="CTRLBLOCKS_USERS",
    default=DEFAULT_USERS,
    show_default=True,
    help="Operators file (scrypt hashes); also $CTRLBLOCKS_USERS.",
)


def _missing_web() -> click.ClickException:
    return click.ClickException(
        "the web faceplate needs FastAPI and uvicorn: pip install 'ctrlblocks[web]' "
        "(or run with --no-web)"
    )


@click.command()
@click.argument("config", required=False, type=click.Path(exists=True, dir_okay=False))
@click.option("--host", default=DEFAULT_HOST, show_default=True, help="Address to listen on.")
@click.option("--port", default=DEFAULT_PORT, show_default=True, type=int, help="TCP port.")
@click.option(
    "--web/--no-web", default=True, show_default=True, help="Serve the faceplate (web UI)."
)
@click.option(
    "--history",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="Demo only: historian SQLite file (default: a temporary file).",
)
@_USERS_OPTION
@click.option(
    "--certfile",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="TLS certificate (PEM): serve HTTPS; needs --keyfile.",
)
@click.option(
    "--keyfile",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="Private key (PEM) of --certfile.",
)
@click.option("--check", is_flag=True, help="Only load and check CONFIG.")
@click.option("-v", "--verbose", count=True, help="More log output (-v info, -vv debug).")
@click.pass_context
def serve(
    ctx: click.Context,
    config: str | None,
    host: str,
    port: int,
    web: bool,
    history: Path | None,
    users_file: Path,
    certfile: str | None,
    keyfile: str | None,
    check: bool,
    verbose: int,
) -> None:
    """Run the loops of CONFIG (runtime TOML) with the web faceplate.

    Without CONFIG: the demo, a simulated plant in real time (ADRC on the
    three-tank process and a PI flow loop).  Open the printed address in a
    browser; anyone can watch, operators log in to change loops (create one
    with 'ctrlblocks operator add NAME').  Ctrl-C stops: every MV goes to its
    stop (else safe) value and the historian flushes.  --no-web runs the
    loops only.  --certfile/--keyfile serve HTTPS.
    """
    if (certfile is None) != (keyfile is None):
        raise click.UsageError("give --certfile and --keyfile together")
    if config is not None and (check or not web):
        from ..runtime.cli import serve as runtime_serve  # the runtime's own command

        ctx.invoke(runtime_serve, config=Path(config), check=check, verbose=verbose)
        return
    from ..runtime.cli import configure_logging

    configure_logging(verbose)  # -vv never shows a password; -v not the libraries' requests
    from .auth import UserError, UserStore

    try:
        users = UserStore(users_file)
    except (UserError, ValueError) as exc:
        raise click.ClickException(f"{users_file}: {exc}") from None
    tmp = None
    if config is None:
        from .demo import demo_runtime

        if history is None:
            tmp = tempfile.TemporaryDirectory(prefix="ctrlblocks-demo-")
            history = Path(tmp.name) / "history.sqlite"
        runtime, _ = demo_runtime(history)
    else:
        from ..runtime import Runtime, RuntimeConfigError, load_config
        from ..runtime.cli import describe_files

        try:
            cfg = load_config(config)
            runtime = Runtime(cfg)
        except RuntimeConfigError as exc:
            raise click.ClickException(str(exc)) from None
        describe_files(cfg)
    try:
        if check:
            click.echo(f"demo: {len(runtime.loop_names())} loop(s): OK")
            return
        if not web:
            click.echo(f"running {len(runtime.loop_names())} loop(s); Ctrl-C stops")
            from ..runtime.cli import run_until_stopped

            run_until_stopped(runtime)
            return
        try:
            from .server import make_server

            server = make_server(
                runtime,
                host=host,
                port=port,
                users=users,
                log_level="info" if verbose else "warning",
                certfile=certfile,
                keyfile=keyfile,
            )
        except ImportError:
            raise _missing_web() from None
        sock = _listen(server, host, port, certfile, keyfile)

        def announce() -> None:
            shown = f"[{host}]" if ":" in host else host
            scheme = "https" if certfile else "http"
            click.echo(f"faceplate: {scheme}://{shown}:{port}/   (Ctrl-C stops)")
            if certfile is None and not is_loopback(host):
                click.echo(
                    f"warning: {host} is reachable from the network and there is no TLS: "
                    "give --certfile/--keyfile or use a TLS reverse proxy (docs/faceplate.md)",
                    err=True,
                )
            if not users.names():
                click.echo(
                    f"no operators in {users_file}: nobody can log in; "
                    "add one with: ctrlblocks operator add NAME --role operator"
                )

        _serve_web(runtime, server, sock, announce)
    finally:
        if tmp is not None:
            tmp.cleanup()


def _listen(
    server: Any, host: str, port: int, certfile: str | None, keyfile: str | None
) -> socket.socket:
    """Load the TLS certificate and bind the port before any loop starts (errors: one line)."""
    import ssl

    from .server import bind_socket

    try:
        server.config.load()  # the application and, with --certfile, the certificate and key
    except (ssl.SSLError, OSError) as exc:
        if certfile is None:
            raise
        why = getattr(exc, "reason", None) or exc.strerror or exc  # (OpenSSL's own words)
        raise click.ClickException(
            f"--certfile {certfile} / --keyfile {keyfile}: not a TLS certificate and its "
            f"private key in PEM, or they do not match ({why})"
        ) from None
    try:
        return bind_socket(host, port)
    except OSError as exc:
        shown = f"[{host}]" if ":" in host else host
        hint = (
            "is another faceplate running there? choose another port with --port"
            if exc.errno == errno.EADDRINUSE
            else "check --host (an address of this machine) and --port"
        )
        raise click.ClickException(
            f"cannot listen on {shown}:{port}: {exc.strerror or exc}; {hint}"
        ) from None


def _serve_web(runtime: Any, server: Any, sock: socket.socket, announce: Any) -> None:
    """Start the runtime, then serve the page on ``sock`` until Ctrl-C/SIGTERM.

    The runtime starts first, so a historian or retain file that cannot be
    opened ends the command with one line (:func:`~ctrlblocks.runtime.cli.start_errors`)
    before the page serves; the application's shutdown stops it (safe/stop
    values, historian flushed).
    """
    from ..runtime.cli import start_errors

    async def main() -> None:
        await runtime.start()
        announce()
        try:
            await server.serve(sockets=[sock])
        finally:
            if runtime.running:  # the server did not get to its shutdown
                await runtime.stop()

    try:
        # uvicorn stops gracefully on Ctrl-C / SIGTERM (lifespan: runtime.stop) and then
        # re-raises the interrupt: that is a normal end here
        with start_errors(), contextlib.suppress(KeyboardInterrupt):
            asyncio.run(main())
    finally:
        sock.close()


@click.group()
def operator() -> None:
    """Manage the operators of the faceplate (users file with scrypt password hashes)."""


@operator.command("add")
@click.argument("name")
@_USERS_OPTION
@click.option(
    "--password-env",
    default=None,
    help="Read the password from this environment variable instead of asking.",
)
@click.option(
    "--role",
    type=click.Choice(["viewer", "operator", "engineer"]),
    default="operator",
    show_default=True,
    help="viewer: watch; operator: also mode, SP, manual value; engineer: also limits, tunings.",
)
def operator_add(name: str, users_file: Path, password_env: str | None, role: str) -> None:
    """Create user NAME (or give it a new password and role); asks for the password.

    A running faceplate sees the change within seconds: the user's sessions end.
    """
    from .auth import UserError

    if password_env is not None:
        password = os.environ.get(password_env)
        if password is None:
            raise click.ClickException(f"environment variable {password_env} is not set")
    else:
        password = click.prompt("password", hide_input=True, confirmation_prompt=True)
    store = _store(users_file, exists=False)
    try:
        store.add(name, password, role=role)
    except UserError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(f"{role} {name!r} saved in {users_file}")


@operator.command("remove")
@click.argument("name")
@_USERS_OPTION
def operator_remove(name: str, users_file: Path) -> None:
    """Delete user NAME (a running faceplate ends its sessions within seconds)."""
    from .auth import UserError

    try:
        _store(users_file).remove(name)
    except UserError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(f"user {name!r} removed from {users_file}")


@operator.command("disable")
@click.argument("name")
@_USERS_OPTION
@click.option("--enable", is_flag=True, help="Enable NAME again.")
def operator_disable(name: str, users_file: Path, enable: bool) -> None:
    """Disable user NAME: no login, its sessions end within seconds (--enable: undo)."""
    from .auth import UserError

    try:
        _store(users_file).set_disabled(name, not enable)
    except UserError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(f"user {name!r} {'enabled' if enable else 'disabled'} in {users_file}")


@operator.command("list")
@_USERS_OPTION
def operator_list(users_file: Path) -> None:
    """List the users: name, role (and "disabled")."""
    store = _store(users_file)
    for n in store.names():
        click.echo(f"{n} {store.role(n)}" + (" disabled" if store.disabled(n) else ""))


def _store(users_file: Path, *, exists: bool = True) -> Any:
    """The users file, or a clear error when it cannot be read (or, ``exists``, is not there)."""
    from .auth import UserError, UserStore

    if exists and not users_file.exists():
        raise click.ClickException(
            f"{users_file}: no such users file (--users or $CTRLBLOCKS_USERS); "
            "'ctrlblocks operator add NAME' creates it"
        )
    try:
        return UserStore(users_file)
    except (UserError, ValueError, OSError) as exc:
        raise click.ClickException(f"{users_file}: {exc}") from None
