"""``ctrlblocks identify`` and ``ctrlblocks tune``: from a bump-test CSV to settings.

::

    ctrlblocks identify bump.csv --time t --u mv --y pv [--method lsq] [--json] [--plot fit.png]
        [--u-before U] [--y-unit bar] [--u-unit %] [the CSV options of .csv_options:
        --delimiter --decimal --encoding --time-format --tz --bad-rows --gaps --start --end]
    ctrlblocks tune adrc --gain K --time-constant T --dead-time L --order N [--settling-time S]
    ctrlblocks tune pid  --gain K --time-constant T --dead-time L [--rule migo|simc|amigo|zn|lambda]
    ctrlblocks tune pid  --ku KU --pu PU --rule zn|tyreus-luyben

Without ``--settling-time`` (ADRC) and with ``--rule migo`` (PID, the default)
the tunings are the designs of ``ctrlblocks compare``
(:mod:`ctrlblocks.tuning.design`): the smallest load IAE with ``Ms <= --ms``
and, with ``--noise-std`` and ``--u-noise-max``, the MV noise within that
budget, on the FOPDT (or with ``--time-constant-2`` the SOPDT) model.

``tune`` prints the margins of the tuning on its model (``ms``, ``gm``,
``pm`` [deg], ``wc_crossover`` [rad/s], ``stable``; :mod:`.margins`).

``--json`` prints one JSON object; otherwise a readable table.  Bad input
(unreadable file, bad column, impossible model) exits with status 1 and one
clear message; bad option syntax exits with status 2 (click's usage error).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from pathlib import Path

import click

from .csv_options import csv_options, echo_notes

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
@csv_options
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
    csv: dict,
    y_unit: str | None,
    u_unit: str | None,
) -> None:
    """Identify a process model from a bump test in FILE (CSV with a header row).

    Time in seconds or as historians write stamps (ISO 8601, dd.mm.yyyy,
    mm/dd/yyyy AM/PM, PI, Excel, epoch); ',' ';' or tab delimiters and
    decimal commas are detected; a unit in a header cell ('pv [degC]') labels
    the plot and the JSON.  Local-time stamps, bad cells, gaps and a window:
    --tz, --bad-rows, --gaps, --start/--end (docs/tuning.md).
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
            **csv,
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
    echo_notes(file, data.notes)
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


ADRC_INFO_KEYS = (
    "b0_min", "b0_max", "settling_time", "settling_time_model", "settling_time_loop",
    "fastest_settling_time", "ms_target", "ms", "gm", "pm", "wc_crossover", "stable",
    "ki", "mv_noise", "model", "warnings", "plot", "kp_eq", "ti_eq", "td_eq", "b_eq",
)  # fmt: skip
"""Informational keys of ``tune adrc --json``: drop them and ``ADRC(**rest, u_min=, u_max=)``."""

PID_INFO_KEYS = (
    "rule", "note", "margins_ts", "ms_target", "ms", "gm", "pm", "wc_crossover", "stable", "ki",
    "mv_noise", "model", "warnings", "plot",
)  # fmt: skip
"""Informational keys of ``tune pid --json``: drop them and ``PID(**rest, ts=, u_min=, u_max=)``."""


def _model_options(required: bool):
    need = " (with --ku/--pu: optional, for the margins)" if not required else ""
    opts = [
        click.option("--gain", type=float, required=required,
                     help=f"Process gain K [PV unit / MV unit]{need}."),
        click.option("--time-constant", type=float, required=required,
                     help="Time constant T [s]."),
        click.option("--dead-time", type=float, required=required, help="Dead time L [s]."),
    ]  # fmt: skip

    def deco(f):
        for opt in reversed(opts):
            f = opt(f)
        return f

    return deco


def _plot_option(f):
    return click.option(
        "--plot", "plot_path", type=click.Path(dir_okay=False),
        help="Write a PNG: Nyquist curve with the Ms circle, |S| and |T|, step and load "
        "responses on the model.",
    )(f)  # fmt: skip


def _margin_keys(mg) -> dict:
    return mg.as_dict()


def _write_plot(lp, mg, path: str, title: str) -> None:
    from .plot import plot_loop

    try:
        plot_loop(lp, mg, path, title=title)
    except OSError as exc:
        raise click.ClickException(f"cannot write {path}: {exc}") from None


@tune.command("adrc")
@_model_options(True)
@click.option("--order", type=int, required=True, help="ADRC order n (1, 2 or 3).")
@click.option(
    "--time-constant-2", type=float, default=0.0,
    help="SOPDT second time constant [s]: the design and the margins are on the SOPDT.",
)  # fmt: skip
@click.option(
    "--settling-time",
    type=float,
    help="Desired settling time [s] (the rule's tau_set, Nowak et al. 2018); refused when the "
    "loop on the model is unstable or has Ms > 2 (see --force). Default: the design of "
    "ctrlblocks compare (b0, omega_c and omega_o searched for the smallest load IAE with "
    "Ms <= --ms).",
)
@click.option(
    "--ms", "ms", type=float, default=1.6, show_default=True,
    help="Maximum sensitivity of the default tuning (1.1..2; 1.4 robust, 2 aggressive).",
)  # fmt: skip
@click.option("--force", is_flag=True, help="Keep a fragile or unstable --settling-time.")
@click.option("--ts", type=float, help="Controller sample time [s]; suggested if not given.")
@click.option(
    "--observer-ratio", type=float, default=None,
    help="omega_o / omega_c (default: 3, 5 and 10 searched; with --settling-time 5).",
)  # fmt: skip
@click.option(
    "--discretisation", type=click.Choice(("euler", "exact")), default="euler",
    show_default=True, help="The ADRC block's discretisation the margins are computed for.",
)  # fmt: skip
@click.option("--noise-std", type=float, help="PV noise standard deviation (with --u-noise-max).")
@click.option("--u-noise-max", type=float, help="Acceptable MV noise standard deviation.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@_plot_option
def tune_adrc(
    gain: float,
    time_constant: float,
    dead_time: float,
    order: int,
    time_constant_2: float,
    settling_time: float | None,
    ms: float,
    force: bool,
    ts: float | None,
    observer_ratio: float | None,
    discretisation: str,
    noise_std: float | None,
    u_noise_max: float | None,
    as_json: bool,
    plot_path: str | None,
) -> None:
    """ADRC: the design of ctrlblocks compare, or the paper's bandwidth rule with --settling-time.

    The margins (Ms, gain margin, phase margin [deg], crossover [rad/s],
    closed-loop stability) are those of the sampled loop on the model
    (FOPDT, or SOPDT with --time-constant-2), dead time exact.
    """
    from .adrc import adrc_tuning

    if settling_time is None:
        _tune_adrc_designed(gain, time_constant, dead_time, order, time_constant_2, ms, ts,
                            observer_ratio, discretisation, noise_std, u_noise_max, as_json,
                            plot_path)  # fmt: skip
        return
    if time_constant_2:
        raise click.UsageError(
            "--time-constant-2 goes with the designed tuning (no --settling-time): the paper's "
            "rule works on the FOPDT"
        )
    try:
        r = adrc_tuning(
            gain, time_constant, dead_time, order,
            settling_time=settling_time, ts=ts,
            observer_ratio=5.0 if observer_ratio is None else observer_ratio,
            noise_std=noise_std, u_noise_max=u_noise_max, ms=ms, force=force,
            discretisation=discretisation,
        )  # fmt: skip
    except ValueError as exc:
        raise click.ClickException(str(exc)) from None
    assert r.margins is not None
    out = {
        "order": r.order,
        "b0": r.b0,
        "b0_min": r.b0_min,
        "b0_max": r.b0_max,
        "omega_c": r.omega_c,
        "omega_o": r.omega_o,
        "ts": r.ts,
        **({"reverse": True} if r.reverse else {}),  # a process with a negative gain
        "discretisation": discretisation,
        "settling_time": r.settling_time,
        "settling_time_model": r.settling_time_model,
        "settling_time_loop": r.settling_time_loop,
        "ms_target": r.ms_target,
        **_margin_keys(r.margins),
        "warnings": r.warnings,
    }
    if not math.isnan(r.fastest_settling_time):
        out["fastest_settling_time"] = r.fastest_settling_time
    eq = _adrc_as_pid(r, discretisation)
    out.update(eq.as_dict())
    if plot_path:
        from ..blocks.adrc import ADRC
        from .identify import FOPDT
        from .margins import Loop

        block = ADRC(**r.config(discretisation=discretisation))
        lp = Loop(FOPDT(gain, time_constant, dead_time), block)
        _write_plot(lp, r.margins, plot_path,
                    f"ADRC n = {r.order}: b0 = {r.b0:.4g}, omega_c = {r.omega_c:.4g} rad/s, "
                    f"omega_o = {r.omega_o:.4g} rad/s, ts = {r.ts:g} s")  # fmt: skip
        out["plot"] = plot_path
    _emit(_finite(out), as_json, f"ADRC order {r.order} (Nowak et al. 2018, section 3.3); "
          f"margins on the model: {r.margins.summary()}; {eq.summary()}")  # fmt: skip


def _adrc_as_pid(r, discretisation: str):
    """The tuned ADRC read as a PID (:func:`.equivalent.equivalent_pid` of the block's law)."""
    from ..blocks.adrc import ADRC
    from .equivalent import equivalent_pid
    from .margins import controller_ss

    return equivalent_pid(controller_ss(ADRC(**r.config(discretisation=discretisation))))


def _model(gain: float, time_constant: float, dead_time: float, time_constant_2: float):
    """The FOPDT, or with a second time constant the SOPDT (refused as a ClickException)."""
    from .identify import FOPDT, SOPDT

    given = {"--gain": gain, "--time-constant": time_constant, "--dead-time": dead_time,
             "--time-constant-2": time_constant_2}  # fmt: skip
    for name, v in given.items():
        if not math.isfinite(v):
            raise click.ClickException(f"{name}: must be a finite number, got {v!r}")
    if gain == 0.0:
        raise click.ClickException("--gain: must be non-zero")
    if time_constant <= 0.0 or dead_time < 0.0 or time_constant_2 < 0.0:
        raise click.ClickException(
            "--time-constant must be > 0, --dead-time and --time-constant-2 >= 0 [s]"
        )
    if time_constant_2 > 0.0:
        t1, t2 = max(time_constant, time_constant_2), min(time_constant, time_constant_2)
        return SOPDT(gain, t1, dead_time, t2)
    return FOPDT(gain, time_constant, dead_time)


def _design_inputs(gain, time_constant, dead_time, time_constant_2, noise_std, u_noise_max,
                   ts):  # fmt: skip
    """``(model, ts)`` of a designed tuning: the options checked, ``ts`` by default
    :func:`~ctrlblocks.tuning.design.default_ts` of the model's FOPDT (half rule)."""
    from .design import default_ts

    model = _model(gain, time_constant, dead_time, time_constant_2)
    if (noise_std is None) != (u_noise_max is None):
        raise click.UsageError("give both --noise-std and --u-noise-max, or neither")
    t_lag = time_constant + time_constant_2 / 2
    h = default_ts(t_lag, dead_time + time_constant_2 / 2) if ts is None else ts
    if not (math.isfinite(h) and h > 0.0):
        raise click.ClickException(f"--ts: must be a finite number > 0 [s], got {ts!r}")
    return model, h


def _design_out(d, model) -> dict:
    """The keys of a designed tuning: the block's, then the informational ones."""
    mg = d.margins
    out = {**d.params, "ts": d.ts, "ms_target": d.ms_target, **_margin_keys(mg), "ki": d.ki}
    if math.isfinite(d.mv_noise):
        out["mv_noise"] = d.mv_noise
    out["model"] = model.as_dict()["model"]
    out["warnings"] = list(d.warnings)
    return out


def _tune_adrc_designed(gain, time_constant, dead_time, order, time_constant_2, ms, ts,
                        observer_ratio, discretisation, noise_std, u_noise_max, as_json,
                        plot_path) -> None:  # fmt: skip
    """``tune adrc`` without a settling time: :func:`~ctrlblocks.tuning.design.design_adrc`."""
    from .design import OBSERVER_RATIOS, design_adrc

    model, h = _design_inputs(gain, time_constant, dead_time, time_constant_2, noise_std,
                              u_noise_max, ts)  # fmt: skip
    ratios = OBSERVER_RATIOS if observer_ratio is None else (observer_ratio,)
    try:
        d = design_adrc(model, order, h, ms=ms, noise_std=noise_std, mv_noise_max=u_noise_max,
                        ratios=ratios, discretisation=discretisation)  # fmt: skip
    except ValueError as exc:
        raise click.ClickException(str(exc)) from None
    out = _design_out(d, model)
    out["discretisation"] = discretisation
    from .equivalent import equivalent_pid

    eq = equivalent_pid(d.loop(model).ctrl)  # the designed ADRC's law read as a PID
    out.update(eq.as_dict())
    if plot_path:
        _write_plot(d.loop(model), d.margins, plot_path,
                    f"ADRC n = {order}: b0 = {d.params['b0']:.4g}, omega_c = "
                    f"{d.params['omega_c']:.4g} rad/s, omega_o = {d.params['omega_o']:.4g} rad/s, "
                    f"ts = {h:g} s")  # fmt: skip
        out["plot"] = plot_path
    _emit(_finite(out), as_json, f"ADRC order {order} designed for the smallest load IAE with "
          f"Ms <= {ms:g} on the {model.as_dict()['model'].upper()} (as ctrlblocks compare); "
          f"margins: {d.margins.summary()}; {eq.summary()}")  # fmt: skip


_PID_RULES = ("migo", "simc", "amigo", "zn", "lambda", "tyreus-luyben")


@tune.command("pid")
@_model_options(False)
@click.option(
    "--rule",
    type=click.Choice(_PID_RULES),
    default="migo",
    show_default=True,
    help="migo: the design of ctrlblocks compare (smallest load IAE with Ms <= --ms); or a "
    "rule; zn and tyreus-luyben take --ku/--pu (zn without them: the step-response rule).",
)
@click.option("--ku", type=float, help="Ultimate gain (relay experiment) [MV unit / PV unit].")
@click.option("--pu", type=float, help="Ultimate period [s].")
@click.option(
    "--controller", type=click.Choice(("pi", "pid")), default="pid", show_default=True,
    help="Controller type (SIMC gives PID only with --time-constant-2).",
)  # fmt: skip
@click.option(
    "--time-constant-2", type=float, default=0.0,
    help="SOPDT second time constant [s]: migo designs on the SOPDT, SIMC uses it as tau_D, "
    "AMIGO, zn and lambda take the SOPDT's half-rule FOPDT; the margins are on the SOPDT.",
)  # fmt: skip
@click.option("--ms", "ms", type=float, default=1.6, show_default=True,
              help="migo: maximum sensitivity target (1.4 robust, 2 aggressive).")  # fmt: skip
@click.option("--noise-std", type=float, help="migo: PV noise standard deviation.")
@click.option("--u-noise-max", type=float, help="migo: acceptable MV noise standard deviation.")
@click.option("--smith", is_flag=True, help="migo: the PID inside a Smith predictor.")
@click.option("--tau-c", type=float, help="Closed-loop time constant [s] (SIMC tau_c, lambda).")
@click.option("--n", "n_filter", type=float, default=None,
              help="Derivative filter N (Tf = Td/N) of the PID, for the margins of a rule "
              "(default 10; migo chooses it).")  # fmt: skip
@click.option("--ts", type=float, help="Sample time [s] of the design and the margins; default "
              "min(T, L)/40 for migo, min(T, L)/10 for a rule.")  # fmt: skip
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@_plot_option
def tune_pid(
    gain: float | None,
    time_constant: float | None,
    dead_time: float | None,
    rule: str,
    ku: float | None,
    pu: float | None,
    controller: str,
    time_constant_2: float,
    ms: float,
    noise_std: float | None,
    u_noise_max: float | None,
    smith: bool,
    tau_c: float | None,
    n_filter: float | None,
    ts: float | None,
    as_json: bool,
    plot_path: str | None,
) -> None:
    """PID (ISA form: kp, ti, td) by the design of compare (migo) or a rule.

    migo (the default): the smallest load IAE with Ms <= --ms (and the MV
    noise within --u-noise-max for --noise-std), derivative filter and
    set-point weight included, as ctrlblocks compare designs it; or SIMC,
    AMIGO, Ziegler-Nichols, Tyreus-Luyben, lambda.

    kp is printed as a magnitude with reverse = true for a negative process
    gain, ready for ctrlblocks.PID(kp=, ti=, td=, reverse=, form=) (drop the
    informational keys of --json: rule, note, margins_ts and the margins).
    With a model, the margins of the PID block (its discretisation at
    --ts, derivative filter --n, set-point weight) on the sampled model,
    dead time exact.
    """
    from . import pid_rules as r

    model_given = [v is not None for v in (gain, time_constant, dead_time)]
    ultimate = ku is not None or pu is not None
    if any(model_given) and not all(model_given):
        raise click.UsageError("give all of --gain, --time-constant and --dead-time, or none")
    if ultimate and (ku is None or pu is None):
        raise click.UsageError("give both --ku and --pu")
    if not all(model_given) and not ultimate:
        raise click.UsageError("give the model (--gain, --time-constant, --dead-time) or --ku/--pu")
    if rule == "tyreus-luyben" and not ultimate:
        raise click.UsageError("the Tyreus-Luyben rule needs --ku and --pu")
    if ultimate and rule not in ("zn", "tyreus-luyben"):
        raise click.UsageError(f"--ku/--pu go with --rule zn or tyreus-luyben, not {rule}")
    if ultimate and time_constant_2:
        raise click.UsageError(
            "--time-constant-2 is a model's, and the ultimate-point rules do not use a model: "
            "give the SOPDT (--gain, --time-constant, --dead-time, --time-constant-2) with "
            "--rule migo, simc, amigo, zn or lambda"
        )
    if rule != "migo" and (smith or noise_std is not None or u_noise_max is not None):
        raise click.UsageError("--smith, --noise-std and --u-noise-max go with --rule migo")
    if rule == "migo" and n_filter is not None:
        raise click.UsageError("--rule migo chooses the derivative filter itself; leave out --n")
    if rule == "migo":
        _tune_pid_designed(gain, time_constant, dead_time, time_constant_2, ms, noise_std,
                           u_noise_max, smith, controller, ts, as_json, plot_path)  # fmt: skip
        return
    n_filter = 10.0 if n_filter is None else n_filter
    try:
        if ultimate:
            assert ku is not None and pu is not None
            fn = r.ziegler_nichols_closed if rule == "zn" else r.tyreus_luyben
            tun = fn(ku, pu, controller=controller)
        elif rule == "simc":
            tun = r.simc(
                gain, time_constant, dead_time, time_constant_2=time_constant_2, tau_c=tau_c
            )
        else:
            # an SOPDT: the rule's FOPDT by Skogestad's half rule (as pid_from_model)
            k, t_h, l_h = gain, time_constant + time_constant_2 / 2, dead_time + time_constant_2 / 2
            if rule == "amigo":
                tun = r.amigo(k, t_h, l_h, controller=controller)
            elif rule == "zn":
                tun = r.ziegler_nichols_open(k, t_h, l_h, controller=controller)
            else:
                tun = r.lambda_tuning(k, t_h, l_h, lam=tau_c, controller=controller)
            if time_constant_2:
                half = (f"on the SOPDT's half-rule FOPDT (T = {t_h:.4g} s, L = {l_h:.4g} s; "
                        "Skogestad 2003)")  # fmt: skip
                tun = dataclasses.replace(tun, note="; ".join(x for x in (tun.note, half) if x))
        out: dict = {**tun.as_kwargs(), "form": tun.form, "rule": tun.rule}
        if tun.note:
            out["note"] = tun.note
        warnings: list[str] = []
        title = f"PID ({tun.rule}, {tun.form.upper()} form)"
        if all(model_given):
            lp, mg, h = _pid_margins(tun, gain, time_constant, dead_time, time_constant_2,
                                     n_filter, ts)  # fmt: skip
            out.update({"margins_ts": h, **_margin_keys(mg)})
            title += f"; margins on the model at ts = {h:g} s: {mg.summary()}"
            if not mg.stable or mg.ms > 2.0:
                warnings.append(
                    f"the {tun.rule} tuning is {'unstable' if not mg.stable else 'fragile'} on "
                    f"this model (Ms > 2): detune (SIMC --tau-c, lambda) or check the model"
                )
            if plot_path:
                reverse = ", reverse" if out.get("reverse") else ""  # kp as printed: |kp|
                _write_plot(lp, mg, plot_path, f"{title.split(';')[0]}: kp = {out['kp']:.4g}"
                            f"{reverse}, ti = {tun.ti:.4g} s, td = {tun.td:.4g} s, "
                            f"ts = {h:g} s")  # fmt: skip
                out["plot"] = plot_path
        else:
            warnings.append("no model given: margins need --gain, --time-constant, --dead-time")
            if plot_path:
                raise click.UsageError("--plot needs the model (--gain, --time-constant, ...)")
    except ValueError as exc:
        raise click.ClickException(str(exc)) from None
    out["warnings"] = warnings
    _emit(_finite(out), as_json, title)


def _tune_pid_designed(gain, time_constant, dead_time, time_constant_2, ms, noise_std,
                       u_noise_max, smith, controller, ts, as_json, plot_path) -> None:  # fmt: skip
    """``tune pid --rule migo``: :func:`~ctrlblocks.tuning.design.design_pid`."""
    from .design import design_pid

    if gain is None:
        raise click.UsageError("--rule migo needs the model (--gain, --time-constant, --dead-time)")
    model, h = _design_inputs(gain, time_constant, dead_time, time_constant_2, noise_std,
                              u_noise_max, ts)  # fmt: skip
    try:
        d = design_pid(model, h, ms=ms, noise_std=noise_std, mv_noise_max=u_noise_max,
                       controller=controller, smith=smith)  # fmt: skip
    except ValueError as exc:
        raise click.ClickException(str(exc)) from None
    out = {**d.params, "reverse": bool(d.params.get("reverse", False)), "form": "isa",
           "rule": "migo"}  # fmt: skip
    rest = _design_out(d, model)
    rest.pop("ts")
    out.update({"margins_ts": d.ts, **{k: v for k, v in rest.items() if k not in out}})
    if smith:
        out["note"] = "inside a Smith predictor on the model (structure = \"smith\")"
    title = (f"PID (migo: the smallest load IAE with Ms <= {ms:g} on the "
             f"{model.as_dict()['model'].upper()}, as ctrlblocks compare; ISA form); margins at "
             f"ts = {d.ts:g} s: {d.margins.summary()}")  # fmt: skip
    if plot_path:
        _write_plot(d.loop(model), d.margins, plot_path,
                    f"PID (migo): kp = {d.params['kp']:.4g}, ti = {d.params['ti']:.4g} s, "
                    f"td = {d.params['td']:.4g} s, ts = {d.ts:g} s")  # fmt: skip
        out["plot"] = plot_path
    _emit(_finite(out), as_json, title)


def _pid_margins(tun, gain, time_constant, dead_time, time_constant_2, n_filter, ts):
    """The loop, margins and sample time of a PID tuning on its FOPDT/SOPDT model."""
    from ..blocks.pid import PID
    from .adrc import _nice_floor
    from .identify import FOPDT, SOPDT
    from .margins import Loop

    if time_constant_2 > 0.0:
        model = SOPDT(gain, time_constant, dead_time, time_constant_2)
    else:
        model = FOPDT(gain, time_constant, dead_time)
    if ts is None:
        scale = min(time_constant, dead_time) if dead_time > 0.0 else time_constant
        ts = _nice_floor(scale / 10.0)
    block = PID(**tun.as_kwargs(), form=tun.form, n=n_filter, ts=ts,
                u_min=-math.inf, u_max=math.inf)  # fmt: skip
    lp = Loop(model, block)
    return lp, lp.margins(), ts
