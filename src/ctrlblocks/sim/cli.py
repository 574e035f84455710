"""``ctrlblocks run``, ``reproduce`` and ``compare``: the simulator on the command line."""

from __future__ import annotations

import concurrent.futures as cf
import json
import os
import sys
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from types import TracebackType
from typing import IO, TYPE_CHECKING, Any

import click

from ..tuning.csv_options import csv_options, echo_notes

if TYPE_CHECKING:  # pragma: no cover
    from .runner import ScenarioResult
    from .scenario import Scenario

# the simulator is imported by the commands, not by this module: ``--help`` stays cheap
ENGINES = ("auto", "compiled", "python")
"""``ctrlblocks.sim.dispatch.ENGINES`` (a test keeps them equal)."""

_FORMAT = click.option(
    "--format",
    "fmt",
    type=click.Choice(["auto", "csv", "parquet"]),
    default="auto",
    show_default=True,
    help="Trace file format (auto: Parquet when pyarrow is installed, else CSV).",
)

ENGINE = click.option(
    "--engine",
    type=click.Choice(ENGINES),
    default="auto",
    show_default=True,
    help="Where runs are simulated: auto = the compiled lane for every run it can do "
    "(same traces), else the Python path; python = the reference path only; "
    "compiled = refuse a run the lane cannot do.",
)


class Progress:
    """Progress of a long command: a bar on a terminal, plain lines otherwise.

    On a terminal :func:`click.progressbar` draws the bar.  When the output
    is a file or a pipe (a CI log, ``| tee``) nothing is redrawn; instead
    :meth:`note` lines are printed as they come and :meth:`step` prints a
    line ``LABEL: DONE/TOTAL ... (T s)`` every ``every`` steps and at the end
    (``every=None``: no step lines, only the notes).
    """

    def __init__(
        self,
        total: int,
        label: str,
        *,
        every: int | None = 1,
        file: IO[str] | None = None,
        tty: bool | None = None,
    ) -> None:
        self.total, self.label = total, label
        self.every = None if every is None else max(1, every)
        self.file = file
        stream = file if file is not None else sys.stdout
        self.tty = bool(getattr(stream, "isatty", lambda: False)()) if tty is None else tty
        self.done = 0
        self._t0 = time.perf_counter()
        self._bar: Any = None

    def __enter__(self) -> Progress:
        if self.tty:
            self._bar = click.progressbar(
                length=self.total,
                label=self.label,
                show_pos=True,
                item_show_func=lambda s: s,
                file=self.file,
            ).__enter__()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self._bar is not None:
            self._bar.__exit__(exc_type, exc, tb)

    @property
    def seconds(self) -> float:
        """Time since the start [s]."""
        return time.perf_counter() - self._t0

    def step(self, n: int = 1, item: str = "") -> None:
        """``n`` more units done (``item``: what was just done)."""
        before, self.done = self.done, self.done + n
        if self._bar is not None:
            self._bar.update(n, item)
        elif self.every is None:
            return
        elif self.done // self.every > before // self.every or self.done >= self.total:
            what = f" {item}" if item else ""
            self._line(f"{self.label}: {self.done}/{self.total}{what} ({self.seconds:.1f} s)")

    def note(self, line: str) -> None:
        """A line for the log (printed only when not on a terminal: the bar shows it there)."""
        if self._bar is None:
            self._line(line)

    def _line(self, text: str) -> None:
        click.echo(text, file=self.file)


def output_dir(path: Path, what: str = "--out") -> Path:
    """Make directory ``path`` (and its parents) and check it is writable, before any work.

    A directory that cannot be made or written (``/proc/xx``, a read-only
    mount, a file in the way) is a :class:`click.ClickException` naming it
    and the reason, not a traceback after the runs.
    """
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise click.ClickException(
            f"{what} {path}: cannot make the directory ({exc.strerror or exc})"
        ) from None
    if not os.access(path, os.W_OK | os.X_OK):
        raise click.ClickException(f"{what} {path}: the directory is not writable")
    return path


def _echo_claims(result: ScenarioResult) -> None:
    for c in result.claims:
        mark = {True: "holds", False: "DOES NOT HOLD", None: "undecided"}[c.holds]
        click.echo(f"  [{mark}] {result.quoted(c.claim.text)}: {c.detail}")


@click.command()
@click.argument("scenario_file", type=click.Path(dir_okay=False, path_type=Path))
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    default=Path("results"),
    show_default=True,
    help="Output directory (a folder per scenario is made in it).",
)
@click.option("--quick", is_flag=True, help="Cut every case to the scenario's quick_duration.")
@_FORMAT
@ENGINE
def run(scenario_file: Path, out_dir: Path, quick: bool, fmt: str, engine: str) -> None:
    """Run SCENARIO_FILE (TOML): every controller in every case; write traces, metrics, plots."""
    from .dispatch import CompiledLaneError
    from .results import write_result
    from .runner import metric_table, run_scenario
    from .scenario import ScenarioError, load_scenario

    try:
        sc = load_scenario(scenario_file)
    except ScenarioError as exc:
        raise click.ClickException(str(exc)) from None
    output_dir(out_dir)
    n = len(sc.controllers) * len(sc.cases)
    try:
        with Progress(n, sc.name) as bar:
            result = run_scenario(
                sc, quick=quick, progress=lambda what: bar.step(1, what), engine=engine
            )
    except CompiledLaneError as exc:
        raise click.ClickException(str(exc)) from None
    try:
        files = write_result(result, out_dir, fmt=fmt)
    except OSError as exc:
        raise click.ClickException(f"cannot write the results: {exc}") from None
    click.echo(metric_table(result))
    _echo_claims(result)
    click.echo(f"wrote {out_dir / sc.name}/ ({sum(len(v) for v in files.values())} files)")


@click.command()
@click.argument("names", nargs=-1)
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    default=Path("report"),
    show_default=True,
    help="Output directory for report.md and a folder per scenario.",
)
@click.option("--quick", is_flag=True, help="Short runs (each case cut to its quick_duration).")
@click.option("--list", "list_only", is_flag=True, help="List the shipped scenarios and exit.")
@_FORMAT
@click.option(
    "--jobs",
    "-j",
    type=click.IntRange(min=1),
    default=None,
    help="Scenarios run (and plotted) in this many processes at once [default: one per core].",
)
@click.option("--no-plots", is_flag=True, help="Skip the PNG plots (traces and metrics only).")
@ENGINE
def reproduce(
    names: tuple[str, ...],
    out_dir: Path,
    quick: bool,
    list_only: bool,
    fmt: str,
    jobs: int | None,
    no_plots: bool,
    engine: str,
) -> None:
    """Run the shipped scenarios (all, or NAMES) and write report.md with plots and metrics."""
    from .dispatch import CompiledLaneError
    from .report import claims_holding, load_shipped, render_report
    from .runner import ScenarioResult
    from .scenario import ScenarioError

    try:
        scenarios = load_shipped(names)
    except KeyError as exc:
        raise click.ClickException(str(exc.args[0])) from None
    except ScenarioError as exc:  # pragma: no cover - shipped files are tested
        raise click.ClickException(str(exc)) from None
    if list_only:
        for sc in scenarios:
            click.echo(f"{sc.name:28s} {sc.source}: {sc.title}")
        return
    output_dir(out_dir)
    t0 = time.perf_counter()
    done: dict[int, ScenarioResult] = {}
    n = sum(len(sc.controllers) * len(sc.cases) for sc in scenarios)
    # on a terminal a bar; in a log one line per scenario
    with Progress(n, "reproducing", every=None) as bar:
        bar.note(f"reproducing {len(scenarios)} scenarios ({n} runs) into {out_dir}/")
        try:
            for i, result, took in run_scenarios(
                scenarios, out_dir, quick=quick, fmt=fmt, plots=not no_plots, jobs=jobs,
                engine=engine,
            ):  # fmt: skip
                done[i] = result
                sc = result.scenario
                bar.step(len(result.runs), f"{sc.name}: done")
                bar.note(
                    f"[{len(done)}/{len(scenarios)}] {sc.name}: {len(result.runs)} run(s), "
                    f"{took:.1f} s"
                )
        except OSError as exc:
            raise click.ClickException(f"cannot write the results: {exc}") from None
        except CompiledLaneError as exc:
            raise click.ClickException(str(exc)) from None
    results = [done[i] for i in range(len(scenarios))]  # the report keeps the shipped order
    seconds = time.perf_counter() - t0
    report = out_dir / "report.md"
    text = render_report(results, quick=quick, seconds=seconds, tables=not names)
    report.write_text(text, encoding="utf-8")
    n_hold, n_claims = claims_holding(results, tables=not names)
    for r in results:
        bad = [c for c in r.claims if not c.holds]
        if bad:
            click.echo(f"{r.scenario.name}:")
            _echo_claims(ScenarioResult(r.scenario, r.runs, r.metrics, bad, r.quick))
    click.echo(f"{n_hold}/{n_claims} claims hold; report: {report} ({seconds:.1f} s)")


def run_scenarios(
    scenarios: Sequence[Scenario],
    out_dir: Path,
    *,
    quick: bool = False,
    fmt: str = "auto",
    plots: bool = True,
    jobs: int | None = None,
    engine: str = "auto",
) -> Iterator[tuple[int, ScenarioResult, float]]:
    """Run every scenario and write its results; yield ``(index, result, seconds)`` as each ends.

    ``jobs`` processes (default: one per core) each run a whole scenario --
    simulation, traces, metrics and plots -- so the scenarios and their
    matplotlib work use all cores; the largest are started first.  With one
    job (or one scenario) everything runs in this process.  The runs are
    seeded by the scenarios, so the results do not depend on ``jobs``.
    ``engine`` is :func:`~ctrlblocks.sim.run_scenario`'s.
    """
    jobs = max(1, min(jobs or os.cpu_count() or 1, len(scenarios)))
    if jobs == 1:
        for i, sc in enumerate(scenarios):
            yield (i, *_run_and_write(sc, out_dir, quick, fmt, plots, engine))
        return
    order = sorted(range(len(scenarios)), key=lambda i: -_work(scenarios[i], quick))
    pool = cf.ProcessPoolExecutor(max_workers=jobs)
    try:
        futures = {
            pool.submit(_run_and_write, scenarios[i], out_dir, quick, fmt, plots, engine): i
            for i in order
        }
        for fut in cf.as_completed(futures):
            yield (futures[fut], *fut.result())
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _run_and_write(
    sc: Scenario, out_dir: Path, quick: bool, fmt: str, plots: bool, engine: str = "auto"
) -> tuple[ScenarioResult, float]:
    """One scenario: run, write (traces, metrics, plots); the result and the seconds it took."""
    from .results import write_result
    from .runner import run_scenario

    t0 = time.perf_counter()
    result = run_scenario(sc, quick=quick, engine=engine)
    write_result(result, out_dir, fmt=fmt, plots=plots)
    return result, time.perf_counter() - t0


def _work(sc: Scenario, quick: bool) -> float:
    """A rough size of a scenario: samples simulated, plus ~3000 samples' worth per plot."""
    samples = sum(
        min(case.duration, sc.quick_duration) if quick else case.duration for case in sc.cases
    )
    return len(sc.controllers) * samples / sc.ts + 3000.0 * len(sc.cases)


def _models_runner(jobs: int) -> Any:
    """``run_models`` of :func:`ctrlblocks.sim.compare.compare`: the scenario with each plant.

    Serial for ``jobs = 1``, else on a process pool of ``jobs`` workers (never
    more than models); each worker runs :func:`ctrlblocks.sim.compare.model_rows`.
    """
    from .compare import _serial_models, model_rows
    from .sweep import process_pool

    def run(path: Path, tables: list[dict[str, Any]], progress: Any) -> list[dict[str, Any]]:
        if jobs <= 1:
            return _serial_models(path, tables, progress)
        text = path.read_text(encoding="utf-8")
        rows: list[list[dict[str, Any]]] = [[] for _ in tables]
        with process_pool(jobs, len(tables)) as ex:
            futures = {ex.submit(model_rows, text, str(path), p): i for i, p in enumerate(tables)}
            for done, fut in enumerate(cf.as_completed(futures), 1):
                rows[futures[fut]] = fut.result()
                progress(done, len(tables))
        return [r for rs in rows for r in rs]

    return run


@click.command("compare")
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--time", "time_col", required=True, help="Name of the time column [s].")
@click.option("--u", "u_col", required=True, help="Name of the MV column.")
@click.option("--y", "y_col", required=True, help="Name of the PV column.")
@click.option("--out", "out_dir", default="compare", show_default=True,
              type=click.Path(file_okay=False), help="Output folder.")  # fmt: skip
@click.option("--u-min", type=float, help="MV low limit; default from the data.")
@click.option("--u-max", type=float, help="MV high limit; default from the data.")
@click.option("--ts", type=float, help="Controller sample time [s]; default min(T, L)/40.")
@click.option("--ms", type=float, default=1.6, show_default=True,
              help="Robustness target of every design: maximum sensitivity on the model "
              "(1.4 robust, 2 aggressive).")  # fmt: skip
@click.option("--mv-noise", type=float, default=None,
              help="MV-noise budget of every design [MV units, standard deviation]; default "
              "5 % of the bump.")  # fmt: skip
@click.option("--tie", type=float, default=0.1, show_default=True,
              help="Tie band of the verdict (0.1: within 10 % is a tie).")  # fmt: skip
@click.option("--no-corners", is_flag=True, help="Skip the 8 uncertainty corners.")
@click.option("--monte-carlo", type=click.IntRange(0, 100000), default=0,
              help="Also run N models drawn from the uncertainty box.")  # fmt: skip
@click.option("--seed", type=int, default=1, show_default=True,
              help="Seed of the Monte-Carlo draw.")  # fmt: skip
@click.option("--jobs", type=click.IntRange(1, 256), default=1, show_default=True,
              help="Worker processes for the uncertain models.")  # fmt: skip
@click.option("--u-before", type=float, default=None,
              help="The MV before the record (as for identify).")  # fmt: skip
@csv_options
@click.option("--y-unit", default=None, help="PV unit (default: from a header 'pv [degC]').")
@click.option("--u-unit", default=None, help="MV unit (default: from a header 'mv [%]').")
@click.option("--json", "as_json", is_flag=True, help="Print the JSON summary.")
def compare_command(file, time_col, u_col, y_col, out_dir, u_min, u_max, ts, ms, mv_noise, tie,
                    no_corners, monte_carlo, seed, jobs, u_before, csv, y_unit, u_unit,
                    as_json) -> None:  # fmt: skip
    """Compare ADRC and PID tunings on the process of a bump test in FILE (CSV).

    Identifies FOPDT and SOPDT models (the one with the smaller BIC is used),
    designs PI, PID, PID + Smith predictor and ADRC n = 1..3 to the same
    robustness (--ms) and MV-noise budget (--mv-noise), simulates set-point
    and load steps taken in AUTO on the model, its uncertainty corners and on
    --monte-carlo N drawn models, and writes compare.md/json/toml and plots to --out
    (``ctrlblocks.sim.compare``).  Progress lines go to stderr; the verdict
    (or with --json the summary) to stdout.
    """
    from ..tuning import read_step_csv
    from ..tuning.cli import _axis_label
    from .compare import compare, jsonable

    try:
        data = read_step_csv(file, time=time_col, u=u_col, y=y_col, u_before=u_before, **csv)
        echo_notes(file, data.notes)
        yl = _axis_label("PV", y_col, y_unit if y_unit is not None else data.y_unit)
        ul = _axis_label("MV", u_col, u_unit if u_unit is not None else data.u_unit)
        summary = compare(
            data.t, data.u, data.y, out_dir, u_min=u_min, u_max=u_max, ts=ts, ms=ms,
            mv_noise=mv_noise, tie=tie, corners=not no_corners, monte_carlo=monte_carlo, seed=seed,
            y_label=yl if yl.endswith("]") else yl + " (units of the data)",
            u_label=ul if ul.endswith("]") else ul + " (units of the data)",
            progress=lambda msg: click.echo(f"compare: {msg}", err=True),
            run_models=_models_runner(jobs),
        )  # fmt: skip
    except ValueError as exc:
        raise click.ClickException(str(exc)) from None
    except OSError as exc:
        raise click.ClickException(f"--out {out_dir}: {exc.strerror or exc}") from None
    if as_json:
        click.echo(json.dumps(jsonable(summary), indent=2))
        return
    click.echo(f"{file}: {summary['why']}")
    w = summary["winners"]
    click.echo(f"  winners (tie within {100 * w['band']:g} %): set-point step {w['setpoint']}, "
               f"load {w['load']}")
    for s in summary["verdict"]:
        click.echo(f"  {s['text']}")
    click.echo(f"report: {Path(out_dir) / 'compare.md'}")
