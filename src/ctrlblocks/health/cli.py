"""``ctrlblocks assess``: the performance assessment of loops from a historian file or a CSV.

::

    ctrlblocks assess history.sqlite [--loop NAME ...] [--start T] [--end T]
    ctrlblocks assess record.csv --time t --sp sp --y pv --u mv [--mode mode]
        [--delimiter ';'] [--decimal ','] [--encoding cp1252] [--start T] [--end T]

    common: [--out DIR] [--json] [--no-plots] [--jobs N] [--u-min U --u-max U]
        [--pv-span S] [--ti TI] [--tu TU] [--dead-time L]
        [--gain K --time-constant T]  (the tuning's model, for the model drift)

Writes ``DIR/report.md`` and a PNG per loop; ``--json`` prints the summary of
the findings (kind, loop, time span, figures).  A user mistake (unreadable file,
unknown loop or column) exits with status 1 and one line; bad option syntax
with status 2.
"""

from __future__ import annotations

import datetime
import math
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import click

from ..tuning.csv_options import csv_options
from ..tuning.records import shown


def _time_bound(text: str | None, what: str) -> float | None:
    """``--start``/``--end``: seconds, or an ISO 8601 time (Unix time for a historian)."""
    if text is None:
        return None
    try:
        return float(text)
    except ValueError:
        pass
    try:
        stamp = datetime.datetime.fromisoformat(text)
    except ValueError:
        raise click.BadParameter(
            f"{shown(text)} is neither seconds nor an ISO 8601 time", param_hint=what
        ) from None
    if stamp.tzinfo is None:
        stamp = stamp.astimezone()  # local time, as a user types it
    return stamp.timestamp()


def _is_sqlite(path: Path) -> bool:
    try:
        with path.open("rb") as f:
            return f.read(16) == b"SQLite format 3\x00"
    except OSError:
        return False


@click.command()
@click.argument("history", type=click.Path(dir_okay=False))
@click.option("--loop", "loops", multiple=True, help="Loop to assess (repeat; default all).")
@click.option("--start", help="From this time: seconds, or ISO 8601 (historian: Unix time).")
@click.option("--end", help="Up to this time: seconds, or ISO 8601.")
@click.option("--time", "time_col", help="CSV: name of the time column [s] or timestamps.")
@click.option("--sp", "sp_col", help="CSV: name of the setpoint column.")
@click.option("--y", "y_col", help="CSV: name of the PV column.")
@click.option("--u", "u_col", help="CSV: name of the MV column.")
@click.option("--mode", "mode_col", help="CSV: name of the mode column (AUTO/MAN or 0/1).")
@click.option(
    "--out",
    "out_dir",
    default="assess",
    show_default=True,
    help="Folder of report.md and the PNGs.",
)
@click.option("--json", "as_json", is_flag=True, help="Print the JSON summary of the findings.")
@click.option("--no-plots", is_flag=True, help="Write the report without PNGs.")
@click.option(
    "--jobs",
    type=click.IntRange(1, 64),
    default=1,
    show_default=True,
    help="Loops assessed in parallel (processes).",
)
@click.option("--u-min", type=float, help="MV low limit (default: the record's minimum).")
@click.option("--u-max", type=float, help="MV high limit (default: the record's maximum).")
@click.option("--pv-span", type=float, help="PV range [PV units] (Hägglund's a = 1 % of it).")
@click.option("--ti", type=float, help="The controller's integral time [s].")
@click.option("--tu", type=float, help="The ultimate period [s], if known.")
@click.option("--dead-time", type=float, help="Dead time [s] (Harris' benchmark).")
@click.option("--gain", type=float, help="The tuning's model: gain [PV unit / MV unit].")
@click.option("--time-constant", type=float, help="The tuning's model: time constant [s].")
@csv_options(without=("start", "end"))
def assess_command(
    history: str,
    loops: tuple[str, ...],
    start: str | None,
    end: str | None,
    time_col: str | None,
    sp_col: str | None,
    y_col: str | None,
    u_col: str | None,
    mode_col: str | None,
    out_dir: str,
    as_json: bool,
    no_plots: bool,
    jobs: int,
    u_min: float | None,
    u_max: float | None,
    pv_span: float | None,
    ti: float | None,
    tu: float | None,
    dead_time: float | None,
    gain: float | None,
    time_constant: float | None,
    csv: dict[str, Any],
) -> None:
    """Assess the performance of loops from a historian file or a CSV; write a report.

    HISTORY is the runtime's historian (SQLite file) or a CSV with a header row
    (then --time, --sp, --y and --u name its columns).  Findings: time in MAN,
    MV at a limit, bad PV, valve wear, oscillation (Hägglund 1995), stiction
    (Horch 1999), Harris' (1989) index, model drift against --gain,
    --time-constant and --dead-time.
    """
    from .assess import AssessOptions, Model

    path = Path(history)
    t0 = _time_bound(start, "--start")
    t1 = _time_bound(end, "--end")
    model = None
    given = [x is not None for x in (gain, time_constant, dead_time)]
    if any(given[:2]):
        if not all(given):
            raise click.UsageError("the model needs --gain, --time-constant and --dead-time")
        assert gain is not None and time_constant is not None and dead_time is not None
        if gain == 0 or time_constant <= 0 or dead_time < 0:
            _fail("the model needs a non-zero --gain, --time-constant > 0 and --dead-time >= 0")
        model = Model(gain, time_constant, dead_time)
    for name, v in (("--u-min", u_min), ("--u-max", u_max), ("--gain", gain),
                    ("--time-constant", time_constant), ("--dead-time", dead_time)):  # fmt: skip
        if v is not None and not math.isfinite(v):
            _fail(f"{name} must be a finite number, got {v:g}")
    if dead_time is not None and dead_time < 0:
        _fail(f"--dead-time must be >= 0, got {dead_time:g}")
    for name, v in (("--pv-span", pv_span), ("--ti", ti), ("--tu", tu)):
        if v is not None and not (math.isfinite(v) and v > 0):
            _fail(f"{name} must be > 0, got {v:g}")
    if u_min is not None and u_max is not None and not u_min < u_max:
        _fail(f"--u-min {u_min:g} must be below --u-max {u_max:g}")
    opts = AssessOptions(
        u_min=u_min, u_max=u_max, pv_span=pv_span, model=model, ti=ti, tu=tu, dead_time=dead_time
    )
    if not path.is_file():
        _fail(f"{path}: no such file")
    if _is_sqlite(path):
        records = _from_historian(path, loops, t0, t1)
    else:
        missing = [
            o
            for o, v in (("--time", time_col), ("--sp", sp_col), ("--y", y_col), ("--u", u_col))
            if v is None
        ]
        if missing:
            _fail(f"{path} is not a historian file; as a CSV it needs {', '.join(missing)}")
        records = [
            _from_csv(
                path,
                time_col,
                sp_col,
                y_col,
                u_col,
                mode_col,
                csv,
                loops[0] if loops else path.stem,
                t0,
                t1,
            )
        ]
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        _fail(f"--out {out}: {exc.strerror or exc}")
    from .report import png_names, summary_json, write_report

    pngs = [None if no_plots else out / n for n in png_names([r.name for r in records])]
    results = _assess_all(records, opts, pngs, jobs)
    report = write_report(results, records, out, plots=not no_plots, plotted=True)
    if as_json:
        click.echo(summary_json(results))
        return
    for a in results:
        kinds = ", ".join(f.kind for f in a.findings) or "no finding"
        click.echo(f"{a.loop}: {kinds}")
        for f in a.findings:
            click.echo(f"  {f.kind}: {f.message}")
    click.echo(f"wrote {report}")


def _fail(message: str) -> None:
    click.echo(f"Error: {message}", err=True)
    sys.exit(1)


def _assess_one(args: tuple[Any, Any, Path | None]) -> Any:
    """Assess one record and draw its PNG (in a worker process with ``--jobs``)."""
    from .assess import assess
    from .report import plot_loop

    record, opts, png = args
    a = assess(record, opts)
    if png is not None:
        plot_loop(a, record, png)
    return a


def _assess_all(records: list[Any], opts: Any, pngs: list[Path | None], jobs: int) -> list[Any]:
    """Assess every record (and plot it), in ``jobs`` processes, with progress on stderr."""
    out = []
    n = len(records)
    todo = [(r, opts, p) for r, p in zip(records, pngs, strict=True)]
    try:
        if jobs > 1 and n > 1:
            with ProcessPoolExecutor(max_workers=jobs) as ex:
                for i, a in enumerate(ex.map(_assess_one, todo)):
                    out.append(a)
                    click.echo(f"assessed {i + 1}/{n}: {a.loop}", err=True)
        else:
            for i, job in enumerate(todo):
                out.append(_assess_one(job))
                click.echo(f"assessed {i + 1}/{n}: {job[0].name}", err=True)
    except ValueError as exc:
        _fail(str(exc))
    return out


def _from_historian(
    path: Path, loops: tuple[str, ...], t0: float | None, t1: float | None
) -> list[Any]:
    import numpy as np

    from ..runtime.historian import SQLiteHistorian
    from .assess import LoopData

    try:
        with SQLiteHistorian(path).reading() as h:
            names = [r[0] for r in h.query("SELECT DISTINCT loop FROM samples ORDER BY loop")]
            unknown = [n for n in loops if n not in names]
            if unknown:
                _fail(
                    f"{path}: no loop {', '.join(unknown)}; its loops: {', '.join(names) or 'none'}"
                )
            records = []
            for name in loops or tuple(names):
                rows = h.query(
                    "SELECT t_wall, sp, pv, mv, mode, pv_ok FROM samples WHERE loop = ? AND "
                    "t_wall >= ? AND t_wall <= ? ORDER BY t_wall, run_id, cycle",
                    (name, -math.inf if t0 is None else t0, math.inf if t1 is None else t1),
                )
                if len(rows) < 10:
                    _fail(f"loop {name!r}: {len(rows)} samples in the time window; need >= 10")
                cols = list(zip(*rows, strict=True))
                # NULL floats (SQLite's NaN) as NaN
                num = {c: np.array([np.nan if v is None else v for v in cols[i]], dtype=float)
                       for i, c in ((0, "t"), (1, "sp"), (2, "pv"), (3, "mv"))}  # fmt: skip
                t = num["t"]
                keep = np.append(True, np.diff(t) > 0)  # a restart may repeat a time stamp
                pv_ok = np.array(cols[5], dtype=bool)[keep]
                mode = [str(m) for m, k in zip(cols[4], keep, strict=True) if k]
                start = datetime.datetime.fromtimestamp(t[0]).astimezone()
                records.append(LoopData(t[keep], num["sp"][keep], num["pv"][keep],
                                        num["mv"][keep], mode, pv_ok, name,
                                        start.isoformat(timespec="seconds")))  # fmt: skip
    except Exception as exc:  # sqlite3 errors and a file that is no historian
        _fail(f"{path}: cannot read the historian: {exc}")
    if not records:
        _fail(f"{path}: the historian holds no samples")
    return records


def _from_csv(
    path: Path,
    time_col: str,
    sp_col: str,
    y_col: str,
    u_col: str,
    mode_col: str | None,
    csv: dict[str, Any],
    name: str,
    t0: float | None,
    t1: float | None,
) -> Any:
    from ..tuning.csv_options import echo_notes
    from ..tuning.records import DataFileError, read_record
    from .assess import LoopData

    try:
        cols = read_record(
            path,
            time_col,
            (sp_col, y_col, u_col),
            text_columns=(mode_col,) if mode_col else (),
            hold=(sp_col, u_col),
            **csv,
        )
    except (DataFileError, ValueError, OSError) as exc:
        _fail(str(exc))
    echo_notes(str(path), cols.notes)
    v = cols.values
    mode = cols.text[mode_col] if mode_col else None
    data = LoopData(cols.t, v[sp_col], v[y_col], v[u_col], mode, None, name, cols.start)
    if t0 is not None or t1 is not None:
        data = data.window(t0, t1)
    return data
