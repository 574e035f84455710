"""``ctrlblocks sweep``: run a scenario for many parameter sets in parallel."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from ..loops.toml import KeyPathError
from ..sim.cli import ENGINE, Progress, output_dir
from ..sim.dispatch import CompiledLaneError
from ..sim.sweep import SweepError, dask_executor, parameter_sets, process_pool, sweep, write_rows


def parse_value(text: str) -> Any:
    """A TOML-like scalar: int, float, true/false, else the string itself."""
    t = text.strip()
    if t.lower() in ("true", "false"):
        return t.lower() == "true"
    for conv in (int, float):
        try:
            return conv(t)
        except ValueError:
            pass
    return t.strip("\"'")


def parse_vary(items: tuple[str, ...]) -> dict[str, list[Any]]:
    """``("controllers[1].kp=1,2", ...)`` -> ``{"controllers[1].kp": [1, 2]}``."""
    vary: dict[str, list[Any]] = {}
    for item in items:
        key, sep, values = item.partition("=")
        if not sep or not key.strip() or not values.strip():
            raise click.BadParameter(f"expected KEY=v1,v2,... got {item!r}", param_hint="--vary")
        vary[key.strip()] = [parse_value(v) for v in values.split(",")]
    return vary


@click.command()
@click.argument("scenario")
@click.option(
    "--vary",
    "vary_items",
    multiple=True,
    required=True,
    metavar="KEY=v1,v2,...",
    help="A scenario key path and its values, e.g. controllers[1].kp=4,5,6 (repeatable: "
    "all combinations run).",
)
@click.option(
    "--out",
    type=click.Path(dir_okay=False, path_type=Path),
    default=Path("results/sweep.parquet"),
    show_default=True,
    help="Result table: Parquet (CSV when pyarrow is missing or the name ends in .csv).",
)
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=None,
    help="Processes (default: one per core; never more than the parameter sets).",
)
@click.option("--serial", is_flag=True, help="Run in this process, one after the other.")
@click.option(
    "--dask",
    "dask_address",
    default=None,
    metavar="ADDRESS|local",
    help="Run on a Dask cluster: 'local' for a LocalCluster, or a scheduler address.",
)
@click.option("--quick", is_flag=True, help="Cut every case to the scenario's quick_duration.")
@click.option("--duration", type=float, default=None, help="Cut every case to this time [s].")
@ENGINE
def sweep_command(
    scenario: str,
    vary_items: tuple[str, ...],
    out: Path,
    workers: int | None,
    serial: bool,
    dask_address: str | None,
    quick: bool,
    duration: float | None,
    engine: str,
) -> None:
    """Run SCENARIO (a TOML file or a shipped name) for every combination of --vary values."""
    vary = parse_vary(vary_items)
    try:
        total = len(parameter_sets(vary))
    except SweepError as exc:
        raise click.ClickException(str(exc)) from None
    output_dir(out.parent, "--out")
    executor: Any
    if serial:
        executor = "serial"
    elif dask_address is not None:
        executor = dask_executor(None if dask_address == "local" else dask_address)
    else:
        executor = process_pool(workers, total)
    # on a terminal a bar; in a log a line per chunk of about a tenth of the runs
    bar = Progress(total, "sweep", every=-(-total // 10))
    try:
        with bar:
            rows = sweep(
                scenario,
                vary,
                executor=executor,
                quick=quick,
                duration=duration,
                engine=engine,
                progress=lambda done, _total: bar.step(done - bar.done) if done else None,
            )
    except (SweepError, CompiledLaneError, KeyPathError) as exc:  # KeyPathError: the file
        raise click.ClickException(str(exc)) from None
    finally:
        if executor not in (None, "serial"):
            executor.shutdown()
    try:
        path = write_rows(rows, out)
    except OSError as exc:
        raise click.ClickException(f"--out {out}: cannot write the table ({exc})") from None
    click.echo(f"{total} parameter sets, {len(rows)} rows -> {path}")
