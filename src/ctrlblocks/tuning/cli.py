"""``ctrlblocks identify`` and ``ctrlblocks tune``: from a bump-test CSV to settings.

::

    ctrlblocks identify bump.csv --time t --u mv --y pv [--method lsq] [--json] [--plot fit.png]
        [--u-before U] [--delimiter ';'] [--decimal ','] [--encoding cp1252]
        [--y-unit bar] [--u-unit %]
    ctrlblocks tune adrc --gain K --time-constant T --dead-time L --order N [--settling-time S]
    ctrlblocks tune pid  --gain K --time-constant T --dead-time L --rule simc|amigo|zn|lambda

``--json`` prints one JSON object; otherwise a readable table.  Bad input
(unreadable file, bad column, impossible model) exits with status 1 and one
clear message; bad option syntax exits with status 2 (click's usage error).
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import click

_METHODS = ("two-point", "sk", "lsq", "lsq-sopdt", "integrating")


def _emit(data: dict, as_json: bool, title: str) -> None:
    if as_json:
        click.echo(json.dumps(data, indent=2, default=_json_default, ensure_ascii=False))
        return
    click.echo(title)
    width = max(len(k) for k in data)
    for key, value in data.items():
        if key == "warnings":
            continue
        click.echo(f"  {key:<{width}}  {_fmt(value)}")
    for w in data.get("warnings", []):
        click.echo(f"  warning: {w}")


def _json_default(x: object) -> object:
    return float(x)  # numpy scalars


def _fmt(value: object) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def _finite(d: dict) -> dict:
    """JSON has no inf: write it as null (e.g. an unbounded ``b0_max``)."""
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}


@click.command()
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--time", "time_col", required=True, help="Name of the time column [s].")
@click.option("--u", "u_col", required=True, help="Name of the MV column.")
@click.option("--y", "y_col", required=True, help="Name of the PV column.")
@click.option(
    "--method",
    type=click.Choice(_METHODS),
    default="lsq",
    show_default=True,
    help="two-point (Marlin 28.3/63.2 %), sk (Sundaresan-Krishnaswamy 35.3/85.3 %), "
    "lsq (FOPDT least squares), lsq-sopdt, integrating.",
)
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@click.option(
    "--plot", "plot_path", type=click.Path(dir_okay=False), help="Write a PNG of data vs model."
)
@click.option(
    "--u-before",
    type=float,
    default=None,
    help="The MV before the record, when the step is at the first sample "
    "(MV constant from t = 0, PV at rest there).",
)
@click.option(
    "--delimiter",
    type=click.Choice([",", ";", "tab"]),
    default=None,
    help="Column delimiter (default: detected from the header).",
)
@click.option(
    "--decimal",
    type=click.Choice([".", ","]),
    default=None,
    help="Decimal mark (default: ',' when the delimiter is not ',' and the cells use commas).",
)
@click.option(
    "--encoding",
    default=None,
    help="Text encoding, e.g. cp1252 (default: UTF-8, else Windows-1252, with a note).",
)
@click.option("--y-unit", default=None, help="PV unit (default: from a header like 'pv [degC]').")
@click.option("--u-unit", default=None, help="MV unit (default: from a header like 'mv [%]').")
def identify(
    file: str,
    time_col: str,
    u_col: str,
    y_col: str,
    method: str,
    as_json: bool,
    plot_path: str | None,
    u_before: float | None,
    delimiter: str | None,
    decimal: str | None,
    encoding: str | None,
    y_unit: str | None,
    u_unit: str | None,
) -> None:
    """Identify a process model from a bump test in FILE (CSV with a header row).

    Time in seconds (or ISO 8601 timestamps); ',' ';' or tab delimiters and
    decimal commas are detected; a unit in a header cell ('pv [degC]') labels
    the plot and the JSON.
    """
    from . import identify as ident

    if plot_path:
        _check_writable(Path(plot_path), "--plot")
    try:
        data = ident.read_step_csv(
            file,
            time=time_col,
            u=u_col,
            y=y_col,
            u_before=u_before,
            delimiter="\t" if delimiter == "tab" else delimiter,
            decimal=decimal,
            encoding=encoding,
        )
        fitter = {
            "two-point": ident.two_point,
            "sk": ident.sundaresan_krishnaswamy,
            "lsq": ident.fit_fopdt,
            "lsq-sopdt": ident.fit_sopdt,
            "integrating": ident.fit_integrating,
        }[method]
        model = fitter(data.t, data.u, data.y)
    except ValueError as exc:  # DataFileError, or a record the method cannot use
        raise click.ClickException(str(exc)) from None
    for note in data.notes:
        click.echo(f"note: {file}: {note}", err=True)
    y_unit = y_unit if y_unit is not None else data.y_unit
    u_unit = u_unit if u_unit is not None else data.u_unit
    result = model.as_dict()
    result["y_unit"], result["u_unit"] = y_unit, u_unit
    result["gain_unit"] = _gain_unit(result["model"], y_unit, u_unit)
    if data.encoding != "utf-8":
        result["encoding"] = data.encoding
    if data.start:
        result["start"] = data.start
    if plot_path:
        from .plot import plot_identification

        try:
            plot_identification(
                data.t,
                data.u,
                data.y,
                model,
                plot_path,
                y_label=_axis_label("PV", y_col, y_unit),
                u_label=_axis_label("MV", u_col, u_unit),
                gain_unit=result["gain_unit"],
            )
        except OSError as exc:
            raise click.ClickException(
                f"--plot {plot_path}: cannot write the plot ({exc.strerror or exc})"
            ) from None
        result["plot"] = plot_path
    if not as_json:  # the table shows units only when known
        result = {k: v for k, v in result.items() if not (k.endswith("_unit") and v is None)}
    _emit(_finite(result), as_json, f"{file}: {result['model'].upper()} model ({method})")


def _check_writable(path: Path, option: str) -> None:
    """Refuse an output file whose directory does not exist or is not writable (before work)."""
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise click.ClickException(f"{option} {path}: no such directory {parent}")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise click.ClickException(f"{option} {path}: the directory {parent} is not writable")


def _axis_label(role: str, column: str, unit: str | None) -> str:
    """``"PV: pv [degC]"`` -- role, column name (without its header unit) and unit."""
    from .identify import split_unit

    name = split_unit(column)[0]
    return f"{role}: {name}" + (f" [{unit}]" if unit else "")


def _gain_unit(model: str, y_unit: str | None, u_unit: str | None) -> str | None:
    """Unit of the process gain: ``y_unit/u_unit`` (per second for an integrating model)."""
    if y_unit is None and u_unit is None:
        return None
    unit = f"{y_unit or '1'}/{u_unit or '1'}"
    return unit + "/s" if model == "integrating" else unit


@click.group()
def tune() -> None:
    """Controller settings from an FOPDT model (gain, time constant, dead time)."""


_model_options = [
    click.option("--gain", type=float, required=True, help="Process gain K [PV unit / MV unit]."),
    click.option("--time-constant", type=float, required=True, help="Time constant T [s]."),
    click.option("--dead-time", type=float, required=True, help="Dead time L [s]."),
]


def _with_model(f):
    for opt in reversed(_model_options):
        f = opt(f)
    return f


@tune.command("adrc")
@_with_model
@click.option("--order", type=int, required=True, help="ADRC order n (1, 2 or 3).")
@click.option(
    "--settling-time",
    type=float,
    help="Desired closed-loop settling time [s]; default 1.5 (T + L).",
)
@click.option("--ts", type=float, help="Controller sample time [s]; suggested if not given.")
@click.option(
    "--observer-ratio", type=float, default=5.0, show_default=True, help="omega_o / omega_c."
)
@click.option("--noise-std", type=float, help="PV noise standard deviation (with --u-noise-max).")
@click.option("--u-noise-max", type=float, help="Acceptable MV noise standard deviation.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def tune_adrc(
    gain: float,
    time_constant: float,
    dead_time: float,
    order: int,
    settling_time: float | None,
    ts: float | None,
    observer_ratio: float,
    noise_std: float | None,
    u_noise_max: float | None,
    as_json: bool,
) -> None:
    """ADRC: b0 by the inverse half-rule, omega_c and omega_o by bandwidth tuning."""
    from .adrc import adrc_tuning

    try:
        r = adrc_tuning(
            gain, time_constant, dead_time, order,
            settling_time=settling_time, ts=ts, observer_ratio=observer_ratio,
            noise_std=noise_std, u_noise_max=u_noise_max,
        )  # fmt: skip
    except ValueError as exc:
        raise click.ClickException(str(exc)) from None
    out = {
        "order": r.order,
        "b0": r.b0,
        "b0_min": r.b0_min,
        "b0_max": r.b0_max,
        "omega_c": r.omega_c,
        "omega_o": r.omega_o,
        "ts": r.ts,
        "settling_time": r.settling_time,
        "settling_time_model": r.settling_time_model,
        "warnings": r.warnings,
    }
    _emit(_finite(out), as_json, f"ADRC order {r.order} (Nowak et al. 2018, section 3.3)")


@tune.command("pid")
@_with_model
@click.option(
    "--rule",
    type=click.Choice(("simc", "amigo", "zn", "lambda")),
    required=True,
    help="Tuning rule.",
)
@click.option(
    "--controller", type=click.Choice(("pi", "pid")), default="pid", show_default=True,
    help="Controller type (SIMC gives PID only with --time-constant-2).",
)  # fmt: skip
@click.option(
    "--time-constant-2", type=float, default=0.0, help="SOPDT second time constant [s] (SIMC)."
)
@click.option("--tau-c", type=float, help="Closed-loop time constant [s] (SIMC tau_c, lambda).")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def tune_pid(
    gain: float,
    time_constant: float,
    dead_time: float,
    rule: str,
    controller: str,
    time_constant_2: float,
    tau_c: float | None,
    as_json: bool,
) -> None:
    """PID (ISA form: kp, ti, td) by SIMC, AMIGO, Ziegler-Nichols or lambda tuning.

    kp is printed as a magnitude with reverse = true for a negative process
    gain, ready for ctrlblocks.PID(kp=, ti=, td=, reverse=).
    """
    from . import pid_rules as r

    try:
        if rule == "simc":
            tun = r.simc(
                gain, time_constant, dead_time, time_constant_2=time_constant_2, tau_c=tau_c
            )
        elif rule == "amigo":
            tun = r.amigo(gain, time_constant, dead_time, controller=controller)
        elif rule == "zn":
            tun = r.ziegler_nichols_open(gain, time_constant, dead_time, controller=controller)
        else:
            tun = r.lambda_tuning(gain, time_constant, dead_time, lam=tau_c, controller=controller)
    except ValueError as exc:
        raise click.ClickException(str(exc)) from None
    out = {**tun.as_kwargs(), "rule": tun.rule, "form": tun.form}
    if tun.note:
        out["note"] = tun.note
    _emit(out, as_json, f"PID ({tun.rule}, {tun.form} form)")
