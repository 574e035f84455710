"""Command line of the faceplate: ``serve`` (runtime + web UI) and ``operator`` (users file).

``ctrlblocks serve`` without a configuration file runs the shipped demo (a
simulated three-tank and a fast flow loop, see :mod:`ctrlblocks.web.demo`)
and opens the faceplate at http://127.0.0.1:8000.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

import click

from .server import DEFAULT_HOST, DEFAULT_PORT

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
    check: bool,
    verbose: int,
) -> None:
    """Run the loops of CONFIG (runtime TOML) with the web faceplate.

    Without CONFIG: the demo, a simulated plant in real time (ADRC on the
    three-tank process and a PI flow loop).  Open the printed address in a
    browser; anyone can watch, operators log in to change loops (create one
    with 'ctrlblocks operator add NAME').  Ctrl-C stops: every MV goes to its
    stop (else safe) value and the historian flushes.  --no-web runs the
    loops only.
    """
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
            )
        except ImportError:
            raise _missing_web() from None
        shown = f"[{host}]" if ":" in host else host
        click.echo(f"faceplate: http://{shown}:{port}/   (Ctrl-C stops)")
        if not users.names():
            click.echo(
                f"no operators in {users_file}: everybody can only watch; "
                "add one with: ctrlblocks operator add NAME"
            )
        # uvicorn stops gracefully on Ctrl-C / SIGTERM (lifespan: runtime.stop) and then
        # re-raises the interrupt: that is a normal end here
        with contextlib.suppress(KeyboardInterrupt):
            server.run()
    finally:
        if tmp is not None:
            tmp.cleanup()


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
def operator_add(name: str, users_file: Path, password_env: str | None) -> None:
    """Create operator NAME (or set a new password); asks for the password."""
    from .auth import UserError, UserStore

    if password_env is not None:
        password = os.environ.get(password_env)
        if password is None:
            raise click.ClickException(f"environment variable {password_env} is not set")
    else:
        password = click.prompt("password", hide_input=True, confirmation_prompt=True)
    store = UserStore(users_file)
    try:
        store.add(name, password)
    except UserError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(f"operator {name!r} saved in {users_file}")


@operator.command("remove")
@click.argument("name")
@_USERS_OPTION
def operator_remove(name: str, users_file: Path) -> None:
    """Delete operator NAME."""
    from .auth import UserError, UserStore

    store = UserStore(users_file)
    try:
        store.remove(name)
    except UserError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(f"operator {name!r} removed from {users_file}")


@operator.command("list")
@_USERS_OPTION
def operator_list(users_file: Path) -> None:
    """List the operators."""
    from .auth import UserStore

    for n in UserStore(users_file).names():
        click.echo(n)
