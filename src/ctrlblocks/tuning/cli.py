"""``ctrlblocks identify`` and ``ctrlblocks tune``: from a bump-test CSV to settings.

::

    ctrlblocks identify bump.csv --time t --u mv --y pv [--method lsq] [--json] [--plot fit.png]
    ctrlblocks tune adrc --gain K --time-constant T --dead-time L --order N [--settling-time S]
    ctrlblocks tune pid  --gain K --time-constant T --dead-time L --rule simc|amigo|zn|lambda

``--json`` prints one JSON object; otherwise a readable table.  Bad input
(unreadable file, bad column, impossible model) exits with status 1 and one
clear message; bad option syntax exits with status 2 (click's usage error).
"""

from __future__ import annotations

import json
import math

import click

_METHODS = ("two-point", "sk", "lsq", "lsq-sopdt", "integrating")


def _emit(data: dict, as_json: bool, title: str) -> None:
    if as_json:
        click.echo(json.dumps(data, indent=2, default=_json_default))
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
def identify(
    file: str,
    time_col: str,
    u_col: str,
    y_col: str,
    method: str,
    as_json: bool,
    plot_path: str | None,
) -> None:
    """Identify a process model from a bump test in FILE (CSV with a header row)."""
    from . import identify as ident

    try:
        data = ident.read_step_csv(file, time=time_col, u=u_col, y=y_col)
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
    result = model.as_dict()
    if plot_path:
        from .plot import plot_identification

        plot_identification(data.t, data.u, data.y, model, plot_path)
        result["plot"] = plot_path
    _emit(_finite(result), as_json, f"{file}: {result['model'].upper()} model ({method})")


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
