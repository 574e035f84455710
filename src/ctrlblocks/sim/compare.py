"""``ctrlblocks compare``: ADRC or PID on *your* process, from one bump test.

The workflow (one function, :func:`compare`):

1. **identify** an FOPDT and an SOPDT by least squares
   (:func:`ctrlblocks.tuning.fit_fopdt`, :func:`~ctrlblocks.tuning.fit_sopdt`);
   the SOPDT is used when its normalised RMS error is below 0.8 times the
   FOPDT's (the second lag explains the record, not only the noise), else
   the FOPDT; the reason is reported.  That model is the one everything
   below is tuned, analysed and simulated on;
2. **tune** on that model: PID by SIMC and AMIGO, the PID_Compact-like
   pre-tuning (AMIGO PI on the FOPDT, as :func:`~ctrlblocks.tuning.step_pretune`
   applies it), ADRC of orders 1, 2 and 3 by the safe default of
   :func:`~ctrlblocks.tuning.adrc_tuning` with ``b0`` searched jointly with
   the bandwidths (``b0_search``: the largest integral gain with
   ``Ms <= 1.6`` on the model, the inverse half-rule's b0 as the start; an
   order the rule refuses is listed with the reason); every tuning with its
   margins and integral gain on the model (:mod:`ctrlblocks.tuning.margins`);
   one with ``Ms > 2`` or unstable is shown, marked and left out of the verdict;
3. **simulate** them in a generated scenario (the exact TOML is written, so it
   can be edited and re-run with ``ctrlblocks run``) of two cases, in
   deviation variables around the operating point: ``setpoint``, a set-point
   step of the size of the bump's PV change at t = 0, and ``load``, an input
   load of half the bump at t = 0; PV noise of the standard deviation of the
   fit's residuals, MV limits from the data (the recorded MV range widened by
   twice the bump on each side) or given.  On the model, on its 8 uncertainty
   corners (gain +-20 %, time constants +-30 %, dead time +-30 %) and,
   optionally, on ``monte_carlo`` models drawn uniformly from that box
   (seeded; each time constant drawn on its own).  Corners and Monte-Carlo
   models are run by ``run_models``: the command passes one
   :func:`ctrlblocks.fast.sweep` over the ``plant`` table (serial, or on a
   process pool with ``--jobs``);
4. **report**: ``compare.md`` with the fit plot, the margins table, the
   metrics (IAE, overshoot, settling time and MV travel of the step; IAE,
   peak error and MV travel of the load), the spread over the corners and the
   Monte-Carlo models (median, worst) and a verdict whose every sentence
   lists the numbers of ``compare.json`` it quotes (``quotes``: the JSON path,
   scale and format of each).
"""

from __future__ import annotations

import json
import logging
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..tuning import adrc_tuning, amigo, simc
from ..tuning.adrc import _nice_floor
from ..tuning.bump import SOPDT_GAIN, better_model
from ..tuning.bump import fopdt_of as _fopdt_of
from ..tuning.identify import SOPDT

__all__ = ["BOX", "MS_LIMIT", "SOPDT_GAIN", "compare", "scenario_toml"]

log = logging.getLogger("ctrlblocks.compare")

MS_LIMIT = 2.0
"""A tuning with a larger maximum sensitivity on the model is left out of the verdict."""

BOX = {"gain": 0.2, "time_constant": 0.3, "dead_time": 0.3}
"""The uncertainty box: relative half-widths of gain, time constants and dead time."""

_CORNERS = [
    (1 + g * BOX["gain"], 1 + t * BOX["time_constant"], 1 + d * BOX["dead_time"])
    for g in (-1, 1)
    for t in (-1, 1)
    for d in (-1, 1)
]
_TIE = 0.05  # relative difference below which two numbers are called the same
_SIMILAR_TV = 0.2  # MV travels within 20 % are "similar"

_EXPERIMENTS = {
    "setpoint": ("iae_tracking", "overshoot", "settling_time", "tv_u_tracking"),
    "load": ("iae_load", "peak_load", "tv_u_load"),
}
_FROM_ROW = {  # summary metric -> (case, metric of the simulator)
    "iae_tracking": ("setpoint", "iae"),
    "overshoot": ("setpoint", "overshoot"),
    "settling_time": ("setpoint", "settling_time"),
    "tv_u_tracking": ("setpoint", "tv_u"),
    "iae_load": ("load", "iae"),
    "peak_load": ("load", "peak_error"),
    "tv_u_load": ("load", "tv_u"),
}
METRICS = tuple(_FROM_ROW)


def _loop_numbers(model: Any, block_type: str, params: dict[str, Any], ts: float):
    """Margins (``Margins.as_dict()``) and integral gain ``ki`` on ``model``; None if refused."""
    from ..blocks.adrc import ADRC
    from ..blocks.base import ParameterError
    from ..blocks.pid import PID
    from ..tuning.margins import Loop

    try:
        lp = Loop(model, {"PID": PID, "ADRC": ADRC}[block_type](**{**params, "ts": ts}))
        mg: dict[str, Any] = dict(lp.margins().as_dict())
    except (ParameterError, TypeError):
        return None
    mg["ki"] = lp.integral_gain() if mg["stable"] else math.nan
    return mg


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
            r = adrc_tuning(k, T, L, order, ts=ts, model=model, b0_search=True)
        except ValueError as exc:
            out.append({"name": f"ADRC n={order}", "type": "ADRC", "params": None,
                        "rule": "adrc", "error": str(exc)})  # fmt: skip
            continue
        params = r.settings()
        out.append({"name": f"ADRC n={order}", "type": "ADRC", "params": params,
                    "rule": "adrc, b0 searched", "b0_rule": r.b0_rule,
                    "warnings": r.warnings})  # fmt: skip
    for c in out:
        if c["params"] is not None:
            c["margins"] = _loop_numbers(model, c["type"], c["params"], ts)
            mg = c["margins"]
            c["eligible"] = bool(mg and mg["stable"] and mg["ms"] <= MS_LIMIT)
        else:
            c["margins"], c["eligible"] = None, False
    return out


def _plant_dict(model: Any, gain: float = 1.0, tc: Sequence[float] = (1.0, 1.0),
                dt: float = 1.0) -> dict[str, Any]:  # fmt: skip
    """The ``[plant]`` table of ``model`` with its parameters scaled by the factors."""
    if isinstance(model, SOPDT):
        return {"type": "PT2", "k": model.gain * gain, "t1": model.time_constant * tc[0],
                "t2": model.time_constant_2 * tc[1], "dead_time": model.dead_time * dt}  # fmt: skip
    return {"type": "FOPDT", "k": model.gain * gain, "t": model.time_constant * tc[0],
            "dead_time": model.dead_time * dt}  # fmt: skip


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
    y_label: str = "PV (units of the data)",
    u_label: str = "MV (units of the data)",
) -> str:
    """The scenario TOML ``compare`` runs (``ctrlblocks run`` takes it as it is).

    In deviation variables around the bump test's operating point: MV and PV
    start at 0; case ``setpoint``: the set point steps by ``step`` at t = 0;
    case ``load``: the input load ``load`` comes at t = 0; each case lasts
    ``duration`` [s].  ``u_min``/``u_max`` are relative to the operating MV;
    ``corner`` scales gain, time constants and dead time.
    """
    g, tc, dt = corner
    plant = _plant_dict(model, g, (tc, tc), dt)
    lines = [
        "# written by `ctrlblocks compare`: edit and re-run with `ctrlblocks run FILE`",
        "# (deviation variables around the operating point of the bump test)",
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
        *(f"{k} = {_toml_value(v)}" for k, v in plant.items()),
        "",
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
        "[[cases]]", 'name = "setpoint"', "", "[[cases.events]]", "t = 0.0", 'do = "setpoint"',
        f"value = {step!r}", "",
        "[[cases]]", 'name = "load"', "", "[[cases.events]]", "t = 0.0", 'do = "load"',
        f"value = {load!r}", 'label = "input load"', "",
        "[plot]", 'upper = ["sp", "y"]', 'lower = ["u"]', f"upper_label = {json.dumps(y_label)}",
        f"lower_label = {json.dumps(u_label)}", "",
    ]  # fmt: skip
    return "\n".join(lines)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return json.dumps(v)
    return repr(float(v))


def _box_models(model: Any, n: int, seed: int) -> list[dict[str, Any]]:
    """``n`` plant tables drawn uniformly from the uncertainty box (:data:`BOX`), seeded."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        g = 1.0 + rng.uniform(-BOX["gain"], BOX["gain"])
        tc = 1.0 + rng.uniform(-BOX["time_constant"], BOX["time_constant"], 2)
        dt = 1.0 + rng.uniform(-BOX["dead_time"], BOX["dead_time"])
        out.append(_plant_dict(model, float(g), (float(tc[0]), float(tc[1])), float(dt)))
    return out


def _row_metrics(rows: Sequence[dict[str, Any]]) -> dict[str, dict[str, float]]:
    """``{controller: {summary metric: value}}`` from rows of one model (both cases)."""
    by = {(r["controller"], r["case"]): r for r in rows}
    out: dict[str, dict[str, float]] = {}
    for (ctrl, _case), _r in by.items():
        out.setdefault(ctrl, {})
    for ctrl, per in out.items():
        for key, (case, m) in _FROM_ROW.items():
            v = by[(ctrl, case)].get(m)
            per[key] = math.nan if v is None else float(v)
    return out


def _check_options(u_min: float | None, u_max: float | None, ts: float | None) -> None:
    """Refuse MV limits and a sample time that no comparison can use (ValueError)."""
    for name, v in (("u_min", u_min), ("u_max", u_max)):
        if v is not None and not math.isfinite(v):
            raise ValueError(f"{name}: must be a finite number [MV units], got {v!r}")
    if u_min is not None and u_max is not None and not u_min < u_max:
        raise ValueError(f"u_min = {u_min!r} must be below u_max = {u_max!r}")
    if ts is not None and not (math.isfinite(ts) and ts > 0.0):
        raise ValueError(f"ts: must be a finite number > 0 [s], got {ts!r}")


def _check_ts(ts: float, T: float, L: float) -> None:
    """Refuse a sample time the identified process (lag ``T``, dead time ``L``) makes useless."""
    from .scenario import MAX_SAMPLES

    if ts > T + L:
        raise ValueError(
            f"ts = {ts:g} s is longer than the identified process's lag and dead time together "
            f"({T + L:.3g} s): a sampled controller would see it only after it has moved"
        )
    runs = max(10.0 * (T + L), 50.0 * ts) / ts
    if runs > MAX_SAMPLES:
        raise ValueError(
            f"ts = {ts:g} s gives {runs:.3g} samples per run (10 x the process's lag and dead "
            f"time of {T + L:.3g} s); at most {MAX_SAMPLES:,}"
        )


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
    monte_carlo: int = 0,
    seed: int = 1,
    y_label: str = "PV (units of the data)",
    u_label: str = "MV (units of the data)",
    progress: Callable[[str], None] | None = None,
    run_models: ModelRunner | None = None,
) -> dict[str, Any]:
    """Identify, tune, simulate and judge; writes ``compare.md``, ``compare.json``,
    ``compare.toml`` and PNGs to ``out_dir``; returns the JSON summary (module docstring).

    Parameters
    ----------
    t, u, y : array_like
        The bump test: time [s], MV and PV.
    out_dir : str or Path
        Where the report goes (created).
    u_min, u_max : float, optional
        MV limits [MV units]; default from the data.
    ts : float, optional
        Controller sample time [s]; default ``min(T, L)/10`` of the model's FOPDT.
    corners : bool
        Also run the 8 corners of the uncertainty box.
    monte_carlo, seed : int
        Also run this many models drawn from the box with this seed.
    y_label, u_label : str
        Axis labels of the plots, with units.
    progress : callable, optional
        Called with one line of text per step (also when not on a terminal).
    run_models : callable, optional
        ``run_models(scenario_file, plant_tables, progress)`` returns the
        metric rows (controller, case, metrics) of the scenario run with each
        ``[plant]`` table, in order; ``ctrlblocks compare`` passes a
        :func:`ctrlblocks.fast.sweep` over the ``plant`` key.  Default: one
        run after the other in this process (the same numbers).
    """
    from .runner import run_scenario
    from .scenario import parse_scenario

    say = progress or (lambda msg: log.info("%s", msg))
    _check_options(u_min, u_max, ts)  # before any work: a mistake is named as the user wrote it
    t, u, y = (np.asarray(v, float) for v in (t, u, y))
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    fo, so, model, why = better_model(t, u, y)
    say(f"identified: {why}")
    k, T, L = _fopdt_of(model)
    if ts is not None:
        _check_ts(ts, T, L)
    noise = float(np.std(y - model.response(t, u)))
    du = float(u[-1] - u[0])
    span = float(np.max(u) - np.min(u))
    lo = float(np.min(u) - 2 * span) if u_min is None else float(u_min)
    hi = float(np.max(u) + 2 * span) if u_max is None else float(u_max)
    if ts is None:
        ts = _nice_floor(max(min(T, L) if L > 0 else T, 1e-6) / 10.0)
    ctrls = _tunings(model, ts)
    say(f"tuned: {sum(c['params'] is not None for c in ctrls)} tunings with their margins "
        f"({sum(c['eligible'] for c in ctrls)} with Ms <= {MS_LIMIT:g})")  # fmt: skip
    duration = float(max(10.0 * (T + L), 50.0 * ts))
    step = float(k * du) if du != 0 else 1.0
    u_op = float(model.u0)
    if not lo < u_op < hi:
        raise ValueError(
            f"the MV limits {lo:g} .. {hi:g} do not contain the operating point of the bump "
            f"test (the MV before the step, {u_op:g}): no controller could hold the process there"
        )
    common = dict(ts=ts, step=step, load=-du / 2, noise=noise, u_min=lo - u_op,
                  u_max=hi - u_op, duration=duration, y_label=y_label, u_label=u_label)  # fmt: skip
    text = scenario_toml(model, ctrls, **common)
    path = out / "compare.toml"
    path.write_text(text, encoding="utf-8")
    nominal = run_scenario(parse_scenario(text, file=str(path)))
    say("simulated on the model")
    per_model = {"model": _row_metrics(nominal.metrics)}
    tables = []
    labels = []
    if corners:
        tables += [_plant_dict(model, g, (tc, tc), dt) for g, tc, dt in _CORNERS]
        labels += [f"gain x{g:g}, T x{tc:g}, L x{dt:g}" for g, tc, dt in _CORNERS]
    if monte_carlo > 0:
        tables += _box_models(model, int(monte_carlo), int(seed))
        labels += [f"monte carlo {i}" for i in range(int(monte_carlo))]
    if tables:
        runner = run_models or _serial_models
        per_model.update(zip(labels, _run_models(path, tables, runner, say), strict=True))
    results = _metrics(ctrls, per_model, corners, int(monte_carlo))
    summary = {
        "fopdt": fo.as_dict(),
        "sopdt": None if so is None else so.as_dict(),
        "model_used": "sopdt" if model is so else "fopdt",
        "why": why,
        "noise_std": noise,
        "ts": ts,
        "u_min": lo,
        "u_max": hi,
        "step": step,
        "load": -du / 2,
        "box": dict(BOX),
        "monte_carlo": {"n": int(monte_carlo), "seed": int(seed)} if monte_carlo else None,
        "controllers": [{k2: v for k2, v in c.items() if k2 != "warnings"} for c in ctrls],
        "metrics": results,
    }
    summary["verdict"] = _verdict(summary)
    (out / "compare.json").write_text(json.dumps(jsonable(summary), indent=2), encoding="utf-8")
    _report(out, summary, t, u, y, model, nominal, y_label, u_label)
    say(f"report: {out / 'compare.md'}")
    return summary


ModelRunner = Callable[[Path, list[dict[str, Any]], Callable[[int, int], None]], list[Any]]
"""``(scenario file, plant tables, progress(done, total)) -> metric rows`` (see :func:`compare`)."""


def _serial_models(path: Path, tables: list[dict[str, Any]],
                   progress: Callable[[int, int], None]) -> list[dict[str, Any]]:  # fmt: skip
    """The metric rows of the scenario at ``path`` with each plant table, one after the other."""
    from ..loops.toml import read_toml
    from .runner import run_scenario
    from .scenario import ScenarioError, parse_scenario_doc

    text = path.read_text(encoding="utf-8")
    rows: list[dict[str, Any]] = []
    for i, plant in enumerate(tables):
        doc = read_toml(text, str(path), ScenarioError)
        doc["plant"] = plant
        rows += run_scenario(parse_scenario_doc(doc, file=str(path))).metrics
        progress(i + 1, len(tables))
    return rows


def _run_models(path: Path, tables: list[dict[str, Any]], runner: ModelRunner,
                say: Callable[[str], None]) -> list[dict[str, dict[str, float]]]:  # fmt: skip
    """The summary metrics of every plant table (``runner``: see :func:`compare`)."""
    marks = {max(1, round(len(tables) * f / 10)) for f in range(1, 11)}

    def progress(done: int, total: int) -> None:
        if done in marks:
            say(f"uncertain models: {done}/{total} run")

    rows = runner(path, tables, progress)
    per = len(rows) // len(tables)
    return [_row_metrics(rows[i * per : (i + 1) * per]) for i in range(len(tables))]


def _finite(vals: Sequence[float]) -> list[float]:
    return [v for v in vals if v is not None and math.isfinite(v)]


def _metrics(ctrls, per_model, corners: bool, n_mc: int) -> dict[str, Any]:
    out: dict[str, Any] = {}
    labels = list(per_model)
    corner_labels = labels[1 : 1 + len(_CORNERS)] if corners else []
    mc_labels = labels[1 + len(corner_labels) :]
    for c in ctrls:
        if c["params"] is None:
            continue
        name = c["name"]
        entry: dict[str, Any] = {"model": per_model["model"][name]}
        runs = {lab: per_model[lab][name] for lab in corner_labels}
        entry["corners"] = {}
        entry["corner_runs"] = runs
        entry["dead_time_plus"] = {}
        if runs:
            for m in METRICS:
                vals = _finite([v[m] for v in runs.values()])
                entry["corners"][m] = [min(vals), max(vals)] if vals else None
            up = [v for lab, v in runs.items() if lab.endswith(f"L x{1 + BOX['dead_time']:g}")]
            for m in METRICS:  # the worst of the corners with the longer dead time
                vals = [v[m] for v in up]
                entry["dead_time_plus"][m] = (
                    math.inf if any(not math.isfinite(x) for x in vals) else max(vals)
                )
        if mc_labels:
            mc: dict[str, Any] = {}
            for m in METRICS:
                vals = [per_model[lab][name][m] for lab in mc_labels]
                fin = _finite(vals)
                mc[m] = {
                    "median": float(np.median(fin)) if fin else math.nan,
                    "worst": math.inf if len(fin) < len(vals) else max(fin),
                    "not_finite": len(vals) - len(fin),
                }
            entry["monte_carlo"] = mc
        out[name] = entry
    return out


# ---------------------------------------------------------------------------
# The verdict: sentences, each with the numbers of compare.json it quotes
# ---------------------------------------------------------------------------


def _q(path: Sequence[Any], value: float, scale: float = 1.0, fmt: str = ".4g") -> dict[str, Any]:
    return {"path": list(path), "scale": scale, "fmt": fmt, "shown": _num(value, scale, fmt)}


def _num(value: float, scale: float = 1.0, fmt: str = ".4g") -> str:
    if value is None or not math.isfinite(value):
        return "not finite"
    return format(scale * value, fmt)


def _less(a: float, b: float) -> float:
    """``100 (1 - a/b)``: how many per cent ``a`` is below ``b``."""
    return 100.0 * (1.0 - a / b) if b > 0 else 0.0


_WORDS = {
    "iae_tracking": ("tracks the set-point step", "the set-point step", "IAE"),
    "iae_load": ("rejects the load", "the load rejection", "IAE"),
}


def _verdict(s: dict[str, Any]) -> list[dict[str, Any]]:
    """Plain-words sentences; each lists the JSON paths of the numbers it quotes."""
    ctrls, res = s["controllers"], s["metrics"]
    said: list[dict[str, Any]] = []
    for i, c in enumerate(ctrls):
        if c["params"] is not None and not c["eligible"]:
            mg = c["margins"]
            if mg and mg["stable"]:
                q = [_q(["controllers", i, "margins", "ms"], mg["ms"], fmt=".3g")]
                text = f"{c['name']} is left out: Ms = {q[0]['shown']} > {MS_LIMIT:g} on the model."
            else:
                q, text = [], f"{c['name']} is left out: {'unstable' if mg else 'no margins'} "
                text += "on the model."
            said.append({"text": text, "quotes": q})
        elif c["params"] is None:
            said.append({"text": f"{c['name']} is not tuned: {c['error']}", "quotes": []})
    ok = [c["name"] for c in ctrls if c["eligible"]]
    kinds = {t: [c["name"] for c in ctrls if c["eligible"] and c["type"] == t]
             for t in ("PID", "ADRC")}  # fmt: skip
    if not ok:
        said.append({"text": "No tuning is stable with Ms <= 2 on the model: no verdict.",
                     "quotes": []})  # fmt: skip
        return said

    def val(name: str, m: str, where: str = "model") -> float:
        v = res[name][where][m]
        return math.inf if v is None or not math.isfinite(v) else v

    for key, (does, _what, iae) in _WORDS.items():
        best = min(ok, key=lambda n: val(n, key))
        q = [_q(["metrics", best, "model", key], val(best, key))]
        text = f"{best} {does} best on the model ({iae} {q[0]['shown']}"
        others = [n for n in ok if n != best]
        if others:
            nxt = min(others, key=lambda n: val(n, key))
            q.append(_q(["metrics", nxt, "model", key], val(nxt, key)))
            text += f"; {_less(val(best, key), val(nxt, key)):.0f} % less than {nxt}, "
            text += q[1]["shown"]
        said.append({"text": text + ").", "quotes": q})
        spread = res[best]["corners"].get(key)
        if spread:
            q = [_q(["metrics", best, "corners", key, j], spread[j]) for j in (0, 1)]
            said.append({"text": f"Over the uncertainty corners its {iae} ranges "
                         f"{q[0]['shown']}..{q[1]['shown']}.", "quotes": q})  # fmt: skip
    for kind in ("PID", "ADRC"):
        if not kinds[kind]:
            tuned = [c for c in ctrls if c["type"] == kind and c["params"] is not None]
            why = (f"none is stable with Ms <= {MS_LIMIT:g} on the model" if tuned
                   else "none could be tuned, as said above")  # fmt: skip
            said.append({"text": f"No {kind} tuning is in the verdict ({why}).", "quotes": []})
    if kinds["ADRC"] and kinds["PID"]:
        for key, tv in (("iae_tracking", "tv_u_tracking"), ("iae_load", "tv_u_load")):
            said.append(_kind_sentence(res, kinds, key, tv, val))
    contenders = [min(kinds[k], key=lambda n: val(n, "iae_load")) for k in kinds if kinds[k]]
    said += _corner_overshoot(res, contenders, val)
    if s.get("monte_carlo"):
        said += _monte_carlo_sentences(s, res, contenders)
    return said


def _kind_sentence(res, kinds, key: str, tv: str, val) -> dict[str, Any]:
    """Best ADRC against best PID on one experiment, with their MV travel."""
    _does, what, iae = _WORDS[key]
    a = min(kinds["ADRC"], key=lambda n: val(n, key))
    p = min(kinds["PID"], key=lambda n: val(n, key))
    va, vp, ta, tp = val(a, key), val(p, key), val(a, tv), val(p, tv)
    qa, qp = _q(["metrics", a, "model", key], va), _q(["metrics", p, "model", key], vp)
    qta, qtp = _q(["metrics", a, "model", tv], ta), _q(["metrics", p, "model", tv], tp)
    if abs(va - vp) <= _TIE * max(va, vp):
        text = (f"PID and ADRC tie on {what} ({key}): {a} {iae} {qa['shown']}, {p} "
                f"{qp['shown']}")  # fmt: skip
        win_t, lose_t, win_q, lose_q = ta, tp, qta, qtp
    else:
        (w, vw, qw, win_t, win_q), (lo, vl, ql, lose_t, lose_q) = sorted(
            [(a, va, qa, ta, qta), (p, vp, qp, tp, qtp)], key=lambda x: x[1]
        )
        kind = "ADRC" if w == a else "PID"
        text = (f"{kind} wins {what} ({key}): {w} has {_less(vw, vl):.0f} % less {iae} than "
                f"{lo} ({qw['shown']} against {ql['shown']})")  # fmt: skip
    first = "ADRC" if win_q is qta else "PID"
    if abs(win_t - lose_t) <= _SIMILAR_TV * max(win_t, lose_t):
        how = "at similar MV travel"
    elif win_t < lose_t:
        how = f"with {_less(win_t, lose_t):.0f} % less MV travel"
    elif win_t < 2.0 * lose_t:
        how = f"with {100.0 * (win_t / lose_t - 1.0):.0f} % more MV travel"
    elif lose_t > 0.0:
        how = f"with {win_t / lose_t:.2g} times the MV travel"
    else:  # the other controller did not move the MV at all in these windows
        how = "moving the MV where the other does not"
    text += f", {how} ({first} {win_q['shown']} against {lose_q['shown']})."
    return {"text": text, "quotes": [qa, qp, qta, qtp]}


def _corner_overshoot(res, contenders, val) -> list[dict[str, Any]]:
    """The overshoot of the contenders under +30 % dead time (worst of those corners)."""
    out = []
    pct = round(100 * BOX["dead_time"])
    for n in contenders:
        worst = res[n]["dead_time_plus"].get("overshoot")
        if worst is None:
            continue
        q = [
            _q(["metrics", n, "dead_time_plus", "overshoot"], worst, 100.0, ".3g"),
            _q(["metrics", n, "model", "overshoot"], val(n, "overshoot"), 100.0, ".3g"),
        ]
        verb = "grows to" if worst > val(n, "overshoot") else "stays at"
        out.append({"text": f"Under +{pct} % dead time (the worst of the corners with it) the "
                    f"set-point overshoot of {n} {verb} {q[0]['shown']} % ({q[1]['shown']} % on "
                    "the model).", "quotes": q})  # fmt: skip
    return out


def _monte_carlo_sentences(s, res, contenders) -> list[dict[str, Any]]:
    mc = s["monte_carlo"]
    out = []
    for key in ("iae_load", "iae_tracking"):
        _does, what, iae = _WORDS[key]
        parts, q = [], []
        for n in contenders:
            st = res[n]["monte_carlo"][key]
            qm = _q(["metrics", n, "monte_carlo", key, "median"], st["median"])
            qw = _q(["metrics", n, "monte_carlo", key, "worst"], st["worst"])
            q += [qm, qw]
            parts.append(f"{n} median {qm['shown']}, worst {qw['shown']}")
        out.append({"text": f"Over {mc['n']} models drawn from the uncertainty box (seed "
                    f"{mc['seed']}) the {iae} of {what}: " + "; ".join(parts) + ".",
                    "quotes": q})  # fmt: skip
    return out


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


# ---------------------------------------------------------------------------
# The report
# ---------------------------------------------------------------------------


def _range(v: Any, scale: float) -> str:
    return "–" if not v else f"{_cell(v[0], '.4g', scale)} .. {_cell(v[1], '.4g', scale)}"


def _cell(x: Any, fmt: str = ".4g", scale: float = 1.0) -> str:
    return "–" if x is None or not math.isfinite(x) else format(scale * x, fmt)


def _unit(label: str, role: str) -> str:
    """``"PV: p3 [bar]"`` -> ``"bar"``; no unit -> ``role`` (``"PV"``: in the units of the data)."""
    return label[label.rindex("[") + 1 : -1] if label.endswith("]") else role


def _report(out: Path, summary, t, u, y, model, nominal, y_label: str, u_label: str) -> None:
    from ..tuning.plot import plot_identification
    from .plot import plot_result

    yu, uu = _unit(y_label, "PV"), _unit(u_label, "MV")
    known = (yu, uu) != ("PV", "MV")
    plot_identification(t, u, y, model, out / "fit.png", y_label=y_label, u_label=u_label,
                        gain_unit=f"{yu}/{uu}" if known else None)  # fmt: skip
    pngs = plot_result(nominal, out)
    iae_u, mv_u, ki_u = f"{yu}·s", uu, f"{uu}/({yu}·s)"
    units = "" if known else " PV and MV in the units of the data."
    lines = [
        "# ctrlblocks compare: ADRC or PID on the identified process",
        "",
        f"Model used: {summary['why']}; tunings, margins and simulations are all on it.{units}",
        "",
        "![fit](fit.png)",
        "",
        "## Tunings and margins on the model",
        "",
        f"| controller | parameters | Ms | GM | PM [deg] | ki [{ki_u}] | in the verdict |",
        "|---|---|---|---|---|---|---|",
    ]
    for c in summary["controllers"]:
        mg = c.get("margins") or {}
        params = ", ".join(f"{k} = {v:.4g}" for k, v in (c["params"] or {}).items()
                           if not isinstance(v, bool))  # fmt: skip
        if c.get("b0_rule"):
            params += f" (inverse half-rule b0 {c['b0_rule']:.4g})"
        lines.append(
            f"| {c['name']} | {params or c.get('error', '')} | {_cell(mg.get('ms'), '.3f')} | "
            f"{_cell(mg.get('gm'), '.3g')} | {_cell(mg.get('pm'), '.1f')} | "
            f"{_cell(mg.get('ki'), '.4g')} | {'yes' if c['eligible'] else '**no**'} |"
        )
    lines += [
        "",
        f"## Metrics on the model (set-point step {summary['step']:.4g} {yu}, input load "
        f"{summary['load']:.4g} {uu})",
        "",
        f"| controller | IAE step [{iae_u}] | overshoot [%] | settling [s] | MV travel step "
        f"[{mv_u}] | IAE load [{iae_u}] | peak error load [{yu}] | MV travel load [{mv_u}] |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, m in summary["metrics"].items():
        v = m["model"]
        lines.append(
            f"| {name} | {_cell(v['iae_tracking'])} | {_cell(v['overshoot'], '.3g', 100)} | "
            f"{_cell(v['settling_time'])} | {_cell(v['tv_u_tracking'])} | "
            f"{_cell(v['iae_load'])} | {_cell(v['peak_load'])} | {_cell(v['tv_u_load'])} |"
        )
    box = (f"gain ±{100 * BOX['gain']:g} %, T ±{100 * BOX['time_constant']:g} %, "
           f"L ±{100 * BOX['dead_time']:g} %")  # fmt: skip
    heads = (f"| controller | IAE step [{iae_u}] | overshoot [%] | IAE load [{iae_u}] | "
             f"MV travel load [{mv_u}] |")  # fmt: skip
    cols = (("iae_tracking", 1.0), ("overshoot", 100.0), ("iae_load", 1.0), ("tv_u_load", 1.0))
    if any(m["corners"] for m in summary["metrics"].values()):
        lines += ["", f"## Spread over the 8 uncertainty corners ({box}): min .. max", "",
                  heads, "|---|---|---|---|---|"]  # fmt: skip
        for name, m in summary["metrics"].items():
            cells = [_range(m["corners"].get(k), scale) for k, scale in cols]
            lines.append(f"| {name} | " + " | ".join(cells) + " |")
    mc = summary.get("monte_carlo")
    if mc:
        lines += ["", f"## Over {mc['n']} models drawn uniformly from the box (seed "
                  f"{mc['seed']}): median / worst", "", heads, "|---|---|---|---|---|"]  # fmt: skip
        for name, m in summary["metrics"].items():
            cells = []
            for k, scale in cols:
                st = m["monte_carlo"][k]
                cell = f"{_cell(st['median'], '.4g', scale)} / {_cell(st['worst'], '.4g', scale)}"
                if st["not_finite"]:
                    cell += f" ({st['not_finite']} not finite)"
                cells.append(cell)
            lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines += [""]
    lines += [f"![{p.stem} on the model]({p.name})" for p in pngs]
    lines += ["", "## Verdict", ""]
    lines += [f"- {s['text']}" for s in summary["verdict"]]
    lines += ["", "The scenario that was run: `compare.toml` (edit it and run `ctrlblocks run "
              "compare.toml`); all numbers: `compare.json`.", ""]  # fmt: skip
    (out / "compare.md").write_text("\n".join(lines), encoding="utf-8")
