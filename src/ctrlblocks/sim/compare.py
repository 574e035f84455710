"""``ctrlblocks compare``: ADRC or PID on *your* process, from one bump test.

The workflow (one function, :func:`compare`):

1. **identify** an FOPDT and an SOPDT by least squares
   (:func:`ctrlblocks.tuning.fit_fopdt`, :func:`~ctrlblocks.tuning.fit_sopdt`);
   the SOPDT is used when its normalised RMS error is below 0.8 times the
   FOPDT's (the second lag explains the record, not only the noise), else
   the FOPDT; the reason is reported;
2. **tune** on that model: PID by SIMC and AMIGO, the PID_Compact-like
   pre-tuning (AMIGO PI on the FOPDT, as :func:`~ctrlblocks.tuning.step_pretune`
   applies it), ADRC of orders 1, 2 and 3 (n = 3 with ``b0 = b0_min`` of the
   inverse half-rule's range; an order the rule refuses is listed with the
   reason) by the safe default of :func:`~ctrlblocks.tuning.adrc_tuning`
   (``Ms <= 1.6`` on the model); every tuning with its margins on the model
   (:mod:`ctrlblocks.tuning.margins`); one with ``Ms > 2`` or unstable is
   shown, marked and left out of the verdict;
3. **simulate** them in a generated scenario (the exact TOML is written, so it
   can be edited and re-run with ``ctrlblocks run``): a set-point step of the
   size of the bump's PV change, then an input load of half the bump, PV noise
   of the standard deviation of the fit's residuals, MV limits from the data
   (the recorded MV range widened by twice the bump on each side) or given;
   on the model and on its uncertainty corners (gain +-20 %, time constants
   +-30 %, dead time +-30 %: 8 corners);
4. **report**: ``compare.md`` with the fit plot, the margins table, the metrics
   (IAE, overshoot, settling time of the set-point step; IAE of the load; MV
   travel), the spread over the corners and a verdict whose every sentence
   quotes a number of ``compare.json``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..tuning import adrc_tuning, amigo, fit_fopdt, fit_sopdt, simc
from ..tuning.adrc import _nice_floor
from ..tuning.bump import block_margins
from ..tuning.identify import FOPDT, SOPDT

__all__ = ["SOPDT_GAIN", "compare", "scenario_toml"]

SOPDT_GAIN = 0.8
"""The SOPDT is used when its fit error is below this fraction of the FOPDT's."""

_MS_LIMIT = 2.0
_CORNERS = [(g, t, d) for g in (0.8, 1.2) for t in (0.7, 1.3) for d in (0.7, 1.3)]


def _choose(t, u, y) -> tuple[FOPDT, SOPDT | None, Any, str]:
    fo = fit_fopdt(t, u, y)
    try:
        so: SOPDT | None = fit_sopdt(t, u, y)
    except ValueError:
        so = None
    if so is not None and so.fit < SOPDT_GAIN * fo.fit:
        why = (f"SOPDT: its fit error {100 * so.fit:.3g} % is below {SOPDT_GAIN:g} times the "
               f"FOPDT's {100 * fo.fit:.3g} %")  # fmt: skip
        return fo, so, so, why
    why = "FOPDT: " + (
        "the SOPDT fit failed"
        if so is None
        else f"the SOPDT's fit error {100 * so.fit:.3g} % is not below {SOPDT_GAIN:g} times "
        f"the FOPDT's {100 * fo.fit:.3g} %"
    )
    return fo, so, fo, why


def _fopdt_of(model: Any) -> tuple[float, float, float]:
    """``(k, T, L)``: the model itself, or the half rule of an SOPDT (Skogestad 2003)."""
    if isinstance(model, SOPDT):
        t2 = model.time_constant_2
        return model.gain, model.time_constant + t2 / 2, model.dead_time + t2 / 2
    return model.gain, model.time_constant, model.dead_time


def _tunings(model: Any, ts: float) -> list[dict[str, Any]]:
    k, T, L = _fopdt_of(model)
    out: list[dict[str, Any]] = []
    t2 = getattr(model, "time_constant_2", 0.0)
    for name, tun in (
        ("PID SIMC", simc(k, model.time_constant, model.dead_time, time_constant_2=t2)
         if isinstance(model, SOPDT) else simc(k, T, L)),
        ("PID AMIGO", amigo(k, T, L)),
        ("PI pretune (AMIGO PI)", amigo(k, T, L, controller="pi")),
    ):  # fmt: skip
        params = {**tun.as_kwargs(), "n": 10.0}
        out.append({"name": name, "type": "PID", "params": params, "rule": tun.rule})
    for order in (1, 2, 3):
        try:
            r = adrc_tuning(k, T, L, order, ts=ts, model=model)
        except ValueError as exc:
            out.append({"name": f"ADRC n={order}", "type": "ADRC", "params": None,
                        "rule": "adrc", "error": str(exc)})  # fmt: skip
            continue
        params = {"order": order, "b0": r.b0, "omega_c": r.omega_c, "omega_o": r.omega_o}
        out.append({"name": f"ADRC n={order}", "type": "ADRC", "params": params, "rule": "adrc",
                    "warnings": r.warnings})  # fmt: skip
    for c in out:
        if c["params"] is not None:
            c["margins"] = block_margins(model, c["type"], c["params"], ts)
            mg = c["margins"]
            c["eligible"] = bool(mg and mg["stable"] and mg["ms"] <= _MS_LIMIT)
        else:
            c["margins"], c["eligible"] = None, False
    return out


def _plant_table(model: Any, gain: float = 1.0, tc: float = 1.0, dt: float = 1.0) -> str:
    if isinstance(model, SOPDT):
        return (
            f'type = "PT2"\nk = {model.gain * gain!r}\nt1 = {model.time_constant * tc!r}\n'
            f"t2 = {model.time_constant_2 * tc!r}\ndead_time = {model.dead_time * dt!r}\n"
        )
    return (f'type = "FOPDT"\nk = {model.gain * gain!r}\nt = {model.time_constant * tc!r}\n'
            f"dead_time = {model.dead_time * dt!r}\n")  # fmt: skip


def scenario_toml(
    model: Any,
    controllers: Sequence[dict[str, Any]],
    *,
    ts: float,
    step: float,
    load: float,
    noise: float,
    u_min: float,
    u_max: float,
    duration: float,
    name: str = "compare",
    corner: tuple[float, float, float] = (1.0, 1.0, 1.0),
) -> str:
    """The scenario TOML ``compare`` runs (``ctrlblocks run`` takes it as it is).

    In deviation variables around the bump test's operating point: MV and PV
    start at 0, the set point steps by ``step`` at 10 s, the input load
    ``load`` comes at half the run; ``u_min``/``u_max`` are relative to the
    operating MV.
    """
    g, tc, dt = corner
    lines = [
        "# written by `ctrlblocks compare`: edit and re-run with `ctrlblocks run FILE`",
        "[scenario]",
        f'name = "{name}"',
        'title = "ADRC or PID on the identified process"',
        'source = "ctrlblocks compare"',
        f"ts = {ts!r}",
        f"duration = {duration!r}",
        f"quick_duration = {duration!r}",
        "seed = 1",
        "",
        "[plant]",
        _plant_table(model, g, tc, dt),
        "[actuator]",
        f"u_min = {u_min!r}",
        f"u_max = {u_max!r}",
        "",
        "[sensor]",
        f"noise = {noise!r}",
        'noise_kind = "gaussian"',
        "",
        "[initial]",
        "u = 0.0",
        "warmup = 5.0",
        "",
    ]
    for c in controllers:
        if c["params"] is None:
            continue
        lines += ["[[controllers]]", f'name = "{c["name"]}"', f'type = "{c["type"]}"']
        lines += [f"{k} = {_toml_value(v)}" for k, v in c["params"].items()]
        lines += [f"u_min = {u_min!r}", f"u_max = {u_max!r}", ""]
    lines += [
        "[[events]]", "t = 10.0", 'do = "setpoint"', f"value = {step!r}", "",
        "[[events]]", f"t = {10.0 + duration / 2:.6g}", 'do = "load"', f"value = {load!r}",
        'label = "input load"', "",
    ]  # fmt: skip
    return "\n".join(lines)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    return repr(float(v))


def compare(
    t: Any,
    u: Any,
    y: Any,
    out_dir: str | Path,
    *,
    u_min: float | None = None,
    u_max: float | None = None,
    ts: float | None = None,
    corners: bool = True,
) -> dict[str, Any]:
    """Identify, tune, simulate and judge; writes ``compare.md``, ``compare.json``,
    ``compare.toml`` and PNGs to ``out_dir``; returns the JSON summary (module docstring)."""
    from .runner import run_scenario
    from .scenario import parse_scenario

    t, u, y = (np.asarray(v, float) for v in (t, u, y))
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    fo, so, model, why = _choose(t, u, y)
    k, T, L = _fopdt_of(model)
    noise = float(np.std(y - model.response(t, u)))
    du = float(u[-1] - u[0])
    span = float(np.max(u) - np.min(u))
    lo = float(np.min(u) - 2 * span) if u_min is None else float(u_min)
    hi = float(np.max(u) + 2 * span) if u_max is None else float(u_max)
    if ts is None:
        ts = _nice_floor(max(min(T, L) if L > 0 else T, 1e-6) / 10.0)
    ctrls = _tunings(model, ts)
    duration = float(max(20.0 * (T + L), 100.0 * ts))
    step = float(k * du) if du != 0 else 1.0
    u_op = float(model.u0)
    common = dict(ts=ts, step=step, load=-du / 2, noise=noise, u_min=lo - u_op,
                  u_max=hi - u_op, duration=duration)  # fmt: skip
    text = scenario_toml(model, ctrls, **common)
    (out / "compare.toml").write_text(text, encoding="utf-8")
    runs = {"model": run_scenario(parse_scenario(text, file=str(out / "compare.toml")))}
    if corners:
        for c in _CORNERS:
            sc = parse_scenario(scenario_toml(model, ctrls, corner=c, **common))
            runs[f"gain x{c[0]:g}, T x{c[1]:g}, L x{c[2]:g}"] = run_scenario(sc)
    results = _metrics(ctrls, runs)
    summary = {
        "fopdt": fo.as_dict(),
        "sopdt": None if so is None else so.as_dict(),
        "model_used": "sopdt" if model is so else "fopdt",
        "why": why,
        "noise_std": noise,
        "ts": ts,
        "u_min": lo,
        "u_max": hi,
        "controllers": [{k2: v for k2, v in c.items() if k2 != "warnings"} for c in ctrls],
        "metrics": results,
    }
    summary["verdict"] = _verdict(ctrls, results)
    (out / "compare.json").write_text(json.dumps(jsonable(summary), indent=2), encoding="utf-8")
    _report(out, summary, t, u, y, model, runs["model"])
    return summary


def _metrics(ctrls, runs) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for c in ctrls:
        if c["params"] is None:
            continue
        name = c["name"]
        per = {}
        for label, res in runs.items():
            per[label] = {
                "iae_tracking": res.metric(name, "main", "iae", 1),
                "overshoot": res.metric(name, "main", "overshoot", 1),
                "settling_time": res.metric(name, "main", "settling_time", 1),
                "iae_load": res.metric(name, "main", "iae", 2),
                "tv_u": res.metric(name, "main", "tv_u"),
            }
        corner_vals = [v for lab, v in per.items() if lab != "model"]
        spread = {}
        if corner_vals:
            for m in ("iae_tracking", "overshoot", "iae_load"):
                vals = [v[m] for v in corner_vals if v[m] is not None and math.isfinite(v[m])]
                spread[m] = [min(vals), max(vals)] if vals else None
        out[name] = {"model": per["model"], "corners": spread}
    return out


def _verdict(ctrls, results) -> list[dict[str, Any]]:
    """Sentences, each with the metric (controller, key) it quotes."""
    ok = [c["name"] for c in ctrls if c["eligible"]]
    said: list[dict[str, Any]] = []
    for c in ctrls:
        if c["params"] is not None and not c["eligible"]:
            mg = c["margins"]
            what = (
                "unstable"
                if mg and not mg["stable"]
                else f"Ms = {mg['ms']:.3g} > 2"
                if mg
                else "no margins"
            )
            said.append({"text": f"{c['name']} is left out: {what} on the model.",
                         "controller": c["name"], "metric": "ms"})  # fmt: skip
    if not ok:
        return said
    for key, what in (
        ("iae_tracking", "tracks the set-point step"),
        ("iae_load", "rejects the load"),
    ):
        vals = {n: results[n]["model"][key] for n in ok if results[n]["model"][key] is not None}
        if not vals:
            continue
        best = min(vals, key=vals.get)
        others = {n: v for n, v in vals.items() if n != best}
        text = f"{best} {what} best on the model (IAE {vals[best]:.4g}"
        if others:
            nxt = min(others, key=others.get)
            gain = 100.0 * (1.0 - vals[best] / others[nxt]) if others[nxt] > 0 else 0.0
            text += f"; {gain:.0f} % less than {nxt}, {others[nxt]:.4g}"
        said.append({"text": text + ").", "controller": best, "metric": key})
        spread = results[best]["corners"].get(key) if results[best]["corners"] else None
        if spread:
            said.append({"text": f"Over the uncertainty corners its IAE ranges {spread[0]:.4g}.."
                         f"{spread[1]:.4g}.", "controller": best, "metric": key})  # fmt: skip
    kinds = {
        "ADRC": [n for n in ok if n.startswith("ADRC")],
        "PID": [n for n in ok if n.startswith("PI")],
    }
    if kinds["ADRC"] and kinds["PID"]:
        for key in ("iae_tracking", "iae_load"):
            a = min(kinds["ADRC"], key=lambda n: results[n]["model"][key])
            p = min(kinds["PID"], key=lambda n: results[n]["model"][key])
            va, vp = results[a]["model"][key], results[p]["model"][key]
            winner = "PID" if vp < va else "ADRC"
            text = f"{winner} wins on {key}: best PID {p} {vp:.4g}, best ADRC {a} {va:.4g}."
            said.append({"text": text, "controller": p if winner == "PID" else a, "metric": key})
    return said


def jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {k: jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, np.floating):
        return jsonable(float(x))
    return x


def _range(v: Any, scale: float) -> str:
    return "–" if not v else f"{_cell(v[0], '.4g', scale)} .. {_cell(v[1], '.4g', scale)}"


def _cell(x: Any, fmt: str = ".4g", scale: float = 1.0) -> str:
    return "–" if x is None or not math.isfinite(x) else format(scale * x, fmt)


def _report(out: Path, summary, t, u, y, model, nominal) -> None:
    from ..tuning.plot import plot_identification
    from .plot import plot_result

    plot_identification(t, u, y, model, out / "fit.png")
    (png,) = plot_result(nominal, out)
    lines = [
        "# ctrlblocks compare: ADRC or PID on the identified process",
        "",
        f"Model used: {summary['why']}.",
        "",
        "![fit](fit.png)",
        "",
        "## Tunings and margins on the model",
        "",
        "| controller | parameters | Ms | GM | PM [deg] | in the verdict |",
        "|---|---|---|---|---|---|",
    ]
    for c in summary["controllers"]:
        mg = c.get("margins") or {}
        params = ", ".join(f"{k} = {v:.4g}" for k, v in (c["params"] or {}).items()
                           if not isinstance(v, bool))  # fmt: skip
        lines.append(
            f"| {c['name']} | {params or c.get('error', '')} | {_cell(mg.get('ms'), '.3f')} | "
            f"{_cell(mg.get('gm'), '.3g')} | {_cell(mg.get('pm'), '.1f')} | "
            f"{'yes' if c['eligible'] else '**no**'} |"
        )
    lines += ["", "## Metrics on the model (set-point step, then an input load)", "",
              "| controller | IAE step | overshoot [%] | settling [s] | IAE load | MV travel |",
              "|---|---|---|---|---|---|"]  # fmt: skip
    for name, m in summary["metrics"].items():
        v = m["model"]
        lines.append(
            f"| {name} | {_cell(v['iae_tracking'])} | {_cell(v['overshoot'], '.3g', 100)} | "
            f"{_cell(v['settling_time'])} | {_cell(v['iae_load'])} | {_cell(v['tv_u'])} |"
        )
    if any(m["corners"] for m in summary["metrics"].values()):
        lines += [
            "",
            "## Spread over the uncertainty corners (gain ±20 %, T ±30 %, L ±30 %)",
            "",
            "| controller | IAE step | overshoot [%] | IAE load |",
            "|---|---|---|---|",
        ]
        for name, m in summary["metrics"].items():
            c = m["corners"] or {}
            cells = [_range(c.get(k), scale) for k, scale in
                     (("iae_tracking", 1.0), ("overshoot", 100.0), ("iae_load", 1.0))]  # fmt: skip
            lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines += ["", f"![simulation on the model]({png.name})", "", "## Verdict", ""]
    lines += [f"- {s['text']}" for s in summary["verdict"]]
    lines += ["", "The scenario that was run: `compare.toml` (edit it and run `ctrlblocks run "
              "compare.toml`); all numbers: `compare.json`.", ""]  # fmt: skip
    (out / "compare.md").write_text("\n".join(lines), encoding="utf-8")
