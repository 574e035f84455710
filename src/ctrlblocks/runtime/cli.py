"""``ctrlblocks serve``, ``ctrlblocks plant-server`` and ``ctrlblocks history``."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import signal
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import click

__all__ = ["history", "plant_server", "run_until_stopped", "serve"]


def _install_stop(loop: asyncio.AbstractEventLoop, stop: Callable[[], None]) -> None:
    """Call ``stop`` on SIGINT and SIGTERM."""
    for sig in (signal.SIGINT, signal.SIGTERM):
        try:
            loop.add_signal_handler(sig, stop)
        except (NotImplementedError, RuntimeError):  # pragma: no cover - non-Unix
            signal.signal(sig, lambda *_: loop.call_soon_threadsafe(stop))


class SecretFilter(logging.Filter):
    """Hide log records that carry a user identity token (asyncua logs the password at DEBUG)."""

    MARKERS = ("UserNameIdentityToken", "Password=", "password=")

    def filter(self, record: logging.LogRecord) -> bool:
        try:
            msg = record.getMessage()
        except Exception:  # a malformed record: leave it to logging
            return True
        if any(m in msg for m in self.MARKERS):
            record.msg, record.args = "(a message with a user identity token: not shown)", ()
        return True


def configure_logging(verbose: int) -> None:
    """Log levels of ``-v`` (info) and ``-vv`` (debug), secrets filtered out.

    The protocol libraries log every request at INFO (asyncua: two lines per
    cycle); they show at ``-vv`` only.
    """
    logging.basicConfig(
        level=[logging.WARNING, logging.INFO, logging.DEBUG][min(verbose, 2)],
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    for h in logging.getLogger().handlers:
        if not any(isinstance(f, SecretFilter) for f in h.filters):
            h.addFilter(SecretFilter())
    libs = logging.DEBUG if verbose >= 2 else logging.WARNING
    for name in ("asyncua", "pymodbus"):
        logging.getLogger(name).setLevel(libs)


def run_until_stopped(runtime: Any) -> None:
    """Run ``runtime`` on a new event loop until SIGINT/SIGTERM, then stop it gracefully."""


    async def main() -> None:
        _install_stop(asyncio.get_running_loop(), runtime.request_stop)
        await runtime.run()

    with start_errors():
        asyncio.run(main())


@contextlib.contextmanager
def start_errors() -> Iterator[None]:
    """What refuses a runtime's start, as one line: the historian or the retain file.

    E.g. a historian file in a folder that does not exist, a PostgreSQL server
    that does not answer (never its DSN), a retain file that cannot be written.
    """
    from .config import RuntimeConfigError
    from .historian import HistoryError

    try:
        yield
    except (HistoryError, RuntimeConfigError) as exc:
        raise click.ClickException(str(exc)) from None


@click.command()
@click.argument("config", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--check", is_flag=True, help="Only load and check the configuration.")
@click.option("-v", "--verbose", count=True, help="More log output (-v info, -vv debug).")
def serve(config: Path, check: bool, verbose: int) -> None:
    """Run the loops of CONFIG (TOML) against their process I/O until SIGINT/SIGTERM.

    On stop every MV goes to its stop value (else its safe value) and the
    historian is flushed.  See docs/runtime.md for the file format.
    """
    from .config import RuntimeConfigError, load_config, require_packages
    from .runtime import Runtime

    configure_logging(verbose)
    try:
        cfg = load_config(config)
        require_packages(cfg)
    except RuntimeConfigError as exc:
        raise click.ClickException(str(exc)) from None
    if check:
        click.echo(f"{config}: {len(cfg.loops)} loop(s), {len(cfg.connections)} connection(s): OK")
        return
    describe_files(cfg)
    run_until_stopped(Runtime(cfg))


def describe_files(cfg: Any) -> None:
    """Say where the historian and the retain file are (the user exports from there)."""
    h = cfg.historian
    if h.backend == "sqlite":
        click.echo(f"historian: {h.path}")
    elif h.backend == "postgresql":
        click.echo("historian: PostgreSQL (historian.dsn)")
    if cfg.retain.enabled:
        click.echo(f"retain: {cfg.retain.path}")


@click.command("plant-server")
@click.argument("scenario", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--case", default=None, help="Case of the scenario whose events to play.")
@click.option("--host", default="127.0.0.1", show_default=True, help="Address to bind.")
@click.option("--opcua-port", type=int, default=4840, show_default=True, help="0 = off.")
@click.option("--modbus-port", type=int, default=5020, show_default=True, help="0 = off.")
@click.option(
    "--sync",
    type=click.Choice(["clock", "write"]),
    default="clock",
    show_default=True,
    help="clock: the plant steps every ts; write: one step per MV write (lock-step).",
)
@click.option("--float", "float_signals", multiple=True, help="OPC UA variable served as Float.")
@click.option(
    "--word-order", type=click.Choice(["big", "little"]), default="big", show_default=True
)
@click.option("--certificate", type=click.Path(exists=True, dir_okay=False), default=None)
@click.option("--private-key", type=click.Path(exists=True, dir_okay=False), default=None)
@click.option("--trust", multiple=True, type=click.Path(exists=True), help="Trusted client cert.")
@click.option("--user", "users", multiple=True, help="USER:PASSWORD (with security).")
@click.option(
    "--watchdog",
    type=click.FloatRange(min=0.0, min_open=True),
    default=None,
    help="Seconds without a new heartbeat (variable hb) before the plant's safe MV applies.",
)
@click.option(
    "--watchdog-mv",
    type=float,
    default=0.0,
    show_default=True,
    help="The plant's own safe MV while the watchdog is tripped.",
)
def plant_server(
    scenario: Path,
    case: str | None,
    host: str,
    opcua_port: int,
    modbus_port: int,
    sync: str,
    float_signals: tuple[str, ...],
    word_order: str,
    certificate: str | None,
    private_key: str | None,
    trust: tuple[str, ...],
    users: tuple[str, ...],
    watchdog: float | None,
    watchdog_mv: float,
) -> None:
    """Serve the plant of SCENARIO over OPC UA and Modbus TCP until SIGINT/SIGTERM.

    Variables: pv, mv (written by the controller), sp, mode, manual_value,
    u_min, u_max, k, pv2 (inner plant output), dv (input load), mv2 (a split
    range's actuator B, written), wild (a ratio loop's wild flow), hb (the
    runtime's heartbeat, written), tripped (1 while the watchdog holds the
    safe MV) -- OPC UA ns=2;s=NAME, Modbus holding registers 0, 2, 4, ..., 26
    (FLOAT32).  With --watchdog, no new hb value for that many seconds puts
    the plant on --watchdog-mv until the heartbeat moves again.  See
    docs/runtime.md.
    """
    from ..sim import ScenarioError, load_scenario
    from ..sim.plant_process import PlantProcess
    from .plant_server import PlantServer

    logging.basicConfig(level=logging.WARNING)
    if not opcua_port and not modbus_port:
        raise click.UsageError("nothing to serve: --opcua-port and --modbus-port are both 0")
    _require_server_packages(opcua_port, modbus_port)
    try:
        sc = load_scenario(scenario)  # unreadable, not UTF-8, a bad key: file, line, key path
    except ScenarioError as exc:
        raise click.ClickException(str(exc)) from None
    except ValueError as exc:
        raise click.ClickException(f"{scenario}: {exc}") from None
    if case is not None and case not in [c.name for c in sc.cases]:
        raise click.BadParameter(
            f"{scenario} has no case {case!r}; its cases: {', '.join(c.name for c in sc.cases)}",
            param_hint="--case",
        )
    try:
        process = PlantProcess(sc, case)
    except (ScenarioError, ValueError, KeyError) as exc:
        raise click.ClickException(str(exc)) from None
    user_map = {}
    for u in users:
        name, sep, pw = u.partition(":")
        if not sep:
            # the value is not echoed: it may be a password typed without its user
            raise click.BadParameter("expected USER:PASSWORD (no ':' found)", param_hint="--user")
        user_map[name] = pw
    try:
        server = PlantServer(
            process,
            host=host,
            opcua_port=opcua_port or None,
            modbus_port=modbus_port or None,
            sync=sync,
            float_signals=float_signals,
            word_order=word_order,
            certificate=certificate,
            private_key=private_key,
            trusted=trust,
            users=user_map,
            watchdog=watchdog,
            watchdog_mv=watchdog_mv,
        )
    except ValueError as exc:
        raise click.ClickException(str(exc)) from None

    async def main() -> None:
        stop = asyncio.Event()
        _install_stop(asyncio.get_running_loop(), stop.set)
        try:
            await server.start()
        except ValueError as exc:  # a --certificate/--private-key that does not load
            with contextlib.suppress(Exception):
                await server.stop()
            raise click.ClickException(str(exc)) from None
        except OSError as exc:  # a busy port, an address not on this machine
            with contextlib.suppress(Exception):
                await server.stop()
            raise click.ClickException(
                f"cannot serve on {host} (OPC UA port {opcua_port or 'off'}, Modbus port "
                f"{modbus_port or 'off'}): {exc.strerror or exc}; is another server running? "
                "choose other ports with --opcua-port/--modbus-port"
            ) from None
        if server.opcua_url:
            click.echo(f"OPC UA: {server.opcua_url}")
        if server.modbus_port:
            click.echo(f"Modbus TCP: {host}:{server.modbus_port}")
        if watchdog is not None:
            click.echo(f"watchdog: {watchdog:g} s without a heartbeat (hb) -> MV {watchdog_mv:g}")
        try:
            await stop.wait()
        finally:
            await server.stop()

    asyncio.run(main())


def _require_server_packages(opcua_port: int, modbus_port: int) -> None:
    """Refuse to start the plant server without the libraries of the protocols it serves."""
    import importlib.util

    for port, pkg, what in ((opcua_port, "asyncua", "OPC UA"), (modbus_port, "pymodbus", "Modbus")):
        if port and importlib.util.find_spec(pkg) is None:
            raise click.ClickException(
                f"the {what} server needs the {pkg} package, which is not installed: "
                "pip install 'ctrlblocks[runtime]'"
                + (" (or switch it off with --opcua-port 0)" if pkg == "asyncua" else "")
            )


@click.command()
@click.argument("database")
@click.argument("out", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--loop", default=None, help="Only this loop.")
@click.option("--postgres", is_flag=True, help="DATABASE is a PostgreSQL DSN.")
def history(database: str, out: Path, loop: str | None, postgres: bool) -> None:
    """Export the historian DATABASE (SQLite file) to OUT (.csv or .parquet)."""
    from .historian import HistoryError, export_history

    if not postgres and not Path(database).exists() and ("://" in database or "=" in database):
        raise click.ClickException(  # (not echoed: a DSN may hold a password)
            "DATABASE looks like a PostgreSQL DSN, not a file: add --postgres"
        )
    try:
        path = export_history(database, out, loop=loop, postgres=postgres)
    except (HistoryError, ImportError) as exc:
        raise click.ClickException(str(exc)) from None
    except OSError as exc:
        raise click.ClickException(f"{out}: cannot write ({exc.strerror or exc})") from None
    click.echo(f"wrote {path}")
