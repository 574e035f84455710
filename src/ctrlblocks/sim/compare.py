"""``ctrlblocks compare``: ADRC or PID on *your* process, from one bump test.

The workflow (one function, :func:`compare`):

1. **identify** an FOPDT and an SOPDT by least squares and keep the one with
   the smaller Bayesian information criterion on the residuals
   (:func:`ctrlblocks.tuning.select.select_model`; the numbers are reported).
   That model is the one everything below is designed, analysed and
   simulated on;
2. **design** every candidate to the same robustness target and the same
   MV-noise budget (:mod:`ctrlblocks.tuning.design`: the largest integral gain
   with ``Ms <= ms``, default 1.6, and an MV noise standard deviation from the
   record's PV noise of at most ``mv_noise``, default 5 % of the bump):
   ``PI`` and ``PID`` (MIGO; the derivative filter from the noise budget, the
   set-point weight ``b`` for tracking), ``PID + Smith`` (the same inside a
   Smith predictor on the model), ``ADRC n=1..3`` (``b0``, ``omega_c`` and the
   observer ratio searched) and ``ADRC n=N + delayed ESO`` (its observer fed
   the MV delayed by the model's dead time: predictive ADRC, Zhao & Gao 2014;
   N the model's number of lags, the order of what the observer then sees).  Each
   with its exact margins on the model (predictor and delayed observer
   included), integral gain and MV noise; one whose design failed is listed
   with the reason and left out of the verdict;
3. **simulate** them as a plant runs the experiment: a generated scenario
   (the exact TOML is written: ``compare.toml``, and ``compare_smith.toml``
   for the Smith-predictor candidates; edit and re-run with ``ctrlblocks run``)
   in deviation variables around the operating point, the loop held in MANUAL
   at steady state during the warm-up, released to AUTO at t = 0 with
   ``SP = PV`` and left in AUTO until the event at ``t_event``, five times
   the slowest closed-loop time constant of the candidates on the model (the
   release's transient has died out: :func:`event_time`): case
   ``setpoint``, a set-point step of the bump's PV change, case ``load``, an
   input load of half the bump.  The metrics are those of the event's window
   (from ``t_event`` on), so the MAN->AUTO release is no part of any
   experiment.  PV noise of the standard deviation of the fit's residuals, MV limits
   from the data (the recorded range widened by twice the bump on each side)
   or given.  On the model, on its 8 uncertainty corners (gain +-20 %, time
   constants +-30 %, dead time +-30 %; the predictor's and the delayed
   observer's model stay the nominal one) and, optionally, on ``monte_carlo``
   models drawn uniformly from that box (seeded);
4. **trade-off**: the best PID-family and the best ADRC-family candidate
   designed again at Ms 1.3 and 2.0 (``levels``), their load IAE on the model
   (linear loop, no noise, no limits) and MV noise against Ms: ``tradeoff.png``;
5. **verdict**: ``winners = {"setpoint": ..., "load": ...}``, each
   ``"PID"``, ``"ADRC"`` or ``"tie"`` (the best of each family on the model
   within ``tie``, default 10 %, of each other), and sentences each listing
   the numbers of ``compare.json`` it quotes (``quotes``: JSON path, scale
   and format), starting with the robustness and noise level they hold at.
"""

from __future__ import annotations

import json
import logging
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..tuning.bump import fopdt_of as _fopdt_of
from ..tuning.design import MS_DEFAULT, MV_NOISE_FRACTION, default_ts
from ..tuning.identify import SOPDT

__all__ = ["BOX", "LEVELS", "REST", "TIE", "compare", "scenario_toml"]

log = logging.getLogger("ctrlblocks.compare")

BOX = {"gain": 0.2, "time_constant": 0.3, "dead_time": 0.3}
"""The uncertainty box: relative half-widths of gain, time constants and dead time."""

TIE = 0.10
"""Default tie band: the best PID and the best ADRC within this fraction of each other tie."""

LEVELS = (1.3, 1.6, 2.0)
"""The robustness levels (Ms) of the trade-off picture (the design's own ``ms`` is added)."""

_CORNERS = [
    (1 + g * BOX["gain"], 1 + t * BOX["time_constant"], 1 + d * BOX["dead_time"])
    for g in (-1, 1)
    for t in (-1, 1)
    for d in (-1, 1)
]

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


# ---------------------------------------------------------------------------
# The candidates
# ---------------------------------------------------------------------------


def adrc_has_input_delay() -> bool:
    """True when the ADRC block takes ``input_delay`` (the delay-compensated observer)."""
    import dataclasses

    from ..blocks.adrc import ADRCConfig

    return any(f.name == "input_delay" for f in dataclasses.fields(ADRCConfig))


def candidates(
    model: Any,
    ts: float,
    *,
    ms: float = MS_DEFAULT,
    noise_std: float = 0.0,
    mv_noise_max: float | None = None,
    say: Callable[[str], None] | None = None,
) -> list[dict[str, Any]]:
    """Every candidate of ``compare``, designed to ``ms`` and the noise budget (module docstring).

    Each a dict: ``name``, ``type`` (``"PID"``/``"ADRC"``, the family),
    ``structure`` (``"single"``/``"smith"``), ``params`` (block keywords, None
    when the design failed, then ``error``), ``margins`` (``ms, gm, pm,
    wc_crossover, stable``, ``ki`` and ``mv_noise``), ``design`` (the design's
    remarks) and ``eligible``.
    """
    say = say or (lambda _msg: None)
    kw = {"noise_std": noise_std, "mv_noise_max": mv_noise_max}
    names = ["PI", "PID", "PID + Smith", "ADRC n=1", "ADRC n=2", "ADRC n=3"]
    out = [_candidate(n, lambda n=n: design_candidate(n, model, ts, ms=ms, **kw), say)
           for n in names]  # fmt: skip
    if adrc_has_input_delay() and model.dead_time > 0.0:
        # the observer fed the MV delayed by the model's dead time sees the delay-free
        # part: its order is the model's number of lags
        order = 2 if isinstance(model, SOPDT) else 1
        name = f"ADRC n={order} + delayed ESO"
        out.append(_candidate(name, lambda: design_candidate(name, model, ts, ms=ms, **kw),
                              say))  # fmt: skip
    return out


def design_candidate(name: str, model: Any, ts: float, **kw: Any) -> Any:
    """The :class:`~ctrlblocks.tuning.design.Design` of the candidate called ``name``."""
    from ..tuning.design import design_adrc, design_pid

    if name == "PI":
        return design_pid(model, ts, controller="pi", **kw)
    if name == "PID":
        return design_pid(model, ts, **kw)
    if name == "PID + Smith":
        return design_pid(model, ts, smith=True, **kw)
    order = int(name.split("=")[1][0])
    delay = model.dead_time if name.endswith("delayed ESO") else 0.0
    return design_adrc(model, order, ts, input_delay=delay, **kw)


def _in_smith(c: dict[str, Any]) -> bool:
    """The candidate runs inside a Smith predictor (``compare_smith.toml``)."""
    return bool(c.get("structure") == "smith")


def _candidate(name: str, make: Callable[[], Any], say) -> dict[str, Any]:
    from ..blocks.base import ParameterError

    kind = "ADRC" if name.startswith("ADRC") else "PID"
    try:
        d = make()
    except (ParameterError, ValueError) as exc:
        say(f"designed {name}: {exc}")
        return {"name": name, "type": kind, "structure": "single", "params": None,
                "margins": None, "eligible": False, "error": str(exc), "design": []}  # fmt: skip
    mg: dict[str, Any] = dict(d.margins.as_dict())
    mg["ki"], mg["mv_noise"] = d.ki, d.mv_noise
    ok = bool(mg["stable"] and mg["ms"] <= d.ms_target * (1 + 2e-3))
    say(f"designed {name}: Ms {mg['ms']:.3f}, ki {d.ki:.4g}")
    return {"name": name, "type": d.family, "structure": d.structure, "params": dict(d.params),
            "margins": mg, "eligible": ok, "design": list(d.warnings),
            "_design": d}  # fmt: skip


# ---------------------------------------------------------------------------
# The scenarios
# ---------------------------------------------------------------------------


def _plant_dict(model: Any, gain: float = 1.0, tc: Sequence[float] = (1.0, 1.0),
                dt: float = 1.0) -> dict[str, Any]:  # fmt: skip
    """The ``[plant]`` table of ``model`` with its parameters scaled by the factors."""
    if isinstance(model, SOPDT):
        return {"type": "PT2", "k": model.gain * gain, "t1": model.time_constant * tc[0],
                "t2": model.time_constant_2 * tc[1], "dead_time": model.dead_time * dt}  # fmt: skip
    return {"type": "FOPDT", "k": model.gain * gain, "t": model.time_constant * tc[0],
            "dead_time": model.dead_time * dt}  # fmt: skip


REST = 5.0
"""The loop rests in AUTO this many of its slowest time constants before each event."""


def event_time(ts: float, T: float, L: float, tau_slow: float = 0.0) -> float:
    """When the event comes [s]: the loop rests in AUTO from t = 0 until then.

    ``max(10 ts, 0.1 (T + L), REST tau_slow)`` rounded up to a whole sample,
    ``tau_slow`` the slowest closed-loop time constant of the candidates
    (:func:`slowest_time_constant`).  What the release to AUTO leaves behind --
    the difference between the loop released at t = 0 and one that had been
    in AUTO for ever, with the same noise: the states the noise had not yet
    moved, the ADRC's handover offset of its reference -- is a free response
    of the loop, so after ``REST = 5`` of its slowest time constants it is
    below ``e^-5`` (0.7 %) of its size at the release (which is of the order
    of the noise); the event then finds the loop at rest.
    """
    return ts * math.ceil(max(10.0, 0.1 * (T + L) / ts, REST * tau_slow / ts) - 1e-9)


def slowest_time_constant(ctrls: Sequence[dict[str, Any]], model: Any) -> dict[str, float]:
    """``{candidate: its slowest time constant [s]}`` on ``model`` for the eligible candidates.

    The slowest closed-loop pole ``p`` of the loop on the model (predictor
    included) as ``-ts/ln|p|``, and for an ADRC also its handover offset's
    ``1/omega_c`` (the reference offset ``q`` of the MAN->AUTO handover decays
    as ``exp(-omega_c t)``).
    """
    out: dict[str, float] = {}
    for c in ctrls:
        d = c.get("_design")
        if not c["eligible"] or d is None:
            continue
        r = float(np.max(np.abs(d.loop(model).poles())))
        tau = -d.ts / math.log(r) if 0.0 < r < 1.0 else 0.0
        if d.family == "ADRC":
            tau = max(tau, 1.0 / float(d.params["omega_c"]))
        out[c["name"]] = tau
    return out


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
    t_event: float = 0.0,
    smith: bool = False,
    name: str = "compare",
    operating_point: tuple[float, float] | None = None,
    corner: tuple[float, float, float] = (1.0, 1.0, 1.0),
    y_label: str = "PV (units of the data)",
    u_label: str = "MV (units of the data)",
) -> str:
    """The scenario TOML ``compare`` runs (``ctrlblocks run`` takes it as it is).

    In deviation variables around the bump test's operating point: MV and PV
    start at 0, the loop held in MANUAL there during the warm-up and released
    to AUTO at t = 0; case ``setpoint``: the set point steps by ``step`` at
    ``t_event``; case ``load``: the input load ``load`` comes at ``t_event``;
    each case lasts ``duration`` [s] from t = 0.  ``u_min``/``u_max`` are
    relative to the operating MV; ``corner`` scales gain, time constants and
    dead time.  ``smith`` writes the Smith-predictor candidates in that
    structure (``[controllers.main]``, ``[controllers.model]`` = the model); without
    it the single-loop candidates.
    """
    g, tc, dt = corner
    plant = _plant_dict(model, g, (tc, tc), dt)
    lines = [
        "# written by `ctrlblocks compare`: edit and re-run with `ctrlblocks run FILE`",
        "# (deviation variables around the operating point of the bump test; the loop is",
        f"# released to AUTO at t = 0 and rests there until the event at t = {t_event:g} s)",
        "[scenario]",
        f'name = "{name}"',
        "title = " + json.dumps(
            "ADRC or PID on the identified process" + (
                "" if operating_point is None else
                f" (deviations from the operating point PV {operating_point[1]:.4g}, "
                f"MV {operating_point[0]:.4g})")),
        'source = "ctrlblocks compare"',
        *(['structure = "smith"'] if smith else []),
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
        if c["params"] is None or _in_smith(c) != smith:
            continue
        lines += ["[[controllers]]", f'name = "{c["name"]}"']
        params = [f"{k} = {_toml_value(v)}" for k, v in c["params"].items()]
        limits = [f"u_min = {u_min!r}", f"u_max = {u_max!r}"]
        if smith:
            pred = [f"{k} = {_toml_value(v)}" for k, v in _plant_dict(model).items()]
            lines += ["[controllers.main]", f'type = "{c["type"]}"', *params, *limits,
                      "[controllers.model]", *pred, ""]  # fmt: skip
        else:
            lines += [f'type = "{c["type"]}"', *params, *limits, ""]
    lines += [
        "[[cases]]", 'name = "setpoint"', "", "[[cases.events]]", f"t = {t_event!r}",
        'do = "setpoint"', f"value = {step!r}", "",
        "[[cases]]", 'name = "load"', "", "[[cases.events]]", f"t = {t_event!r}", 'do = "load"',
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


def deviation_label(label: str) -> str:
    """``"PV: p3 [bar]"`` -> ``"ΔPV: p3 [bar]"``: the plots show deviations from the operating
    point (the scenario's title says which)."""
    return "Δ" + label


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
    """``{controller: {summary metric: value}}`` from the rows of one model (both cases).

    The numbers of the event's window (the last window: the loop rested in
    AUTO before it), so the release to AUTO is not part of any experiment.
    """
    by = {(r["controller"], r["case"]): r["windows"][-1] for r in rows}
    out: dict[str, dict[str, float]] = {}
    for ctrl, _case in by:
        out.setdefault(ctrl, {})
    for ctrl, per in out.items():
        for key, (case, m) in _FROM_ROW.items():
            v = by[(ctrl, case)].get(m)
            per[key] = math.nan if v is None else float(v)
    return out


def _check_options(u_min: float | None, u_max: float | None, ts: float | None, ms: float,
                   tie: float, mv_noise: float | None) -> None:  # fmt: skip
    """Refuse options that no comparison can use (ValueError)."""
    for name, v in (("u_min", u_min), ("u_max", u_max)):
        if v is not None and not math.isfinite(v):
            raise ValueError(f"{name}: must be a finite number [MV units], got {v!r}")
    if u_min is not None and u_max is not None and not u_min < u_max:
        raise ValueError(f"u_min = {u_min!r} must be below u_max = {u_max!r}")
    if ts is not None and not (math.isfinite(ts) and ts > 0.0):
        raise ValueError(f"ts: must be a finite number > 0 [s], got {ts!r}")
    if not (math.isfinite(ms) and 1.1 <= ms <= 3.0):
        raise ValueError(f"ms: must be 1.1..3 (1.4 robust, 2 aggressive), got {ms!r}")
    if not (math.isfinite(tie) and 0.0 <= tie < 1.0):
        raise ValueError(f"tie: must be a fraction 0..1 (0.1 = 10 %), got {tie!r}")
    if mv_noise is not None and not (math.isfinite(mv_noise) and mv_noise > 0.0):
        raise ValueError(f"mv_noise: must be a finite number > 0 [MV units], got {mv_noise!r}")


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


def _check_designed(ctrls: Sequence[dict[str, Any]], ms: float, budget: float,
                   noise: float) -> None:  # fmt: skip
    """Refuse a comparison without a candidate: every design failed (an MV-noise budget or an
    Ms no controller meets), so there is nothing to simulate or to judge (ValueError)."""
    if any(c["params"] is not None for c in ctrls):
        return
    why = "; ".join(f"{c['name']}: {c.get('error', '?')}" for c in ctrls)
    raise ValueError(
        f"no candidate can be designed to Ms <= {ms:g} and an MV noise of at most {budget:.3g} "
        f"(standard deviation, from the record's PV noise of {noise:.3g}): {why}. "
        f"Allow more MV noise (--mv-noise) or a larger Ms (--ms)"
    )


def _check_rest(duration: float, ts: float, taus: dict[str, float]) -> None:
    """Refuse runs too long to simulate: a candidate so slow (a tight MV-noise budget) that
    resting the loop :data:`REST` of its time constants before the event needs more samples
    than a scenario holds (ValueError, naming the candidate)."""
    from .scenario import MAX_SAMPLES

    if duration / ts <= MAX_SAMPLES:
        return
    slow = max(taus, key=lambda n: taus[n])
    raise ValueError(
        f"{slow}'s loop on the model has a time constant of {taus[slow]:.4g} s: resting it "
        f"{REST:g} of them in AUTO before each event gives runs of {duration / ts:.3g} samples "
        f"of ts = {ts:g} s, at most {MAX_SAMPLES:,}. Allow more MV noise (--mv-noise) or a "
        f"larger Ms (--ms)"
    )


ModelRunner = Callable[[Path, list[dict[str, Any]], Callable[[int, int], None]], list[Any]]
"""``(scenario file, plant tables, progress(done, total)) -> metric rows`` (see :func:`compare`);
each row a ``ScenarioResult.metrics`` entry, its ``windows`` included."""


def compare(
    t: Any,
    u: Any,
    y: Any,
    out_dir: str | Path,
    *,
    u_min: float | None = None,
    u_max: float | None = None,
    ts: float | None = None,
    ms: float = MS_DEFAULT,
    mv_noise: float | None = None,
    tie: float = TIE,
    levels: Sequence[float] = LEVELS,
    corners: bool = True,
    monte_carlo: int = 0,
    seed: int = 1,
    y_label: str = "PV (units of the data)",
    u_label: str = "MV (units of the data)",
    progress: Callable[[str], None] | None = None,
    run_models: ModelRunner | None = None,
) -> dict[str, Any]:
    """Identify, design, simulate and judge; writes ``compare.md``, ``compare.json``,
    ``compare.toml`` (and ``compare_smith.toml``) and PNGs to ``out_dir``; returns the JSON
    summary (module docstring).

    Parameters
    ----------
    t, u, y : array_like
        The bump test: time [s], MV and PV.
    out_dir : str or Path
        Where the report goes (created).
    u_min, u_max : float, optional
        MV limits [MV units]; default from the data.
    ts : float, optional
        Controller sample time [s]; default
        :func:`~ctrlblocks.tuning.design.default_ts` of the model's FOPDT.
    ms : float
        The robustness target of every design (maximum sensitivity on the model).
    mv_noise : float, optional
        The MV-noise budget [MV units, standard deviation]; default 5 % of the bump.
    tie : float
        The tie band of the verdict (0.1: within 10 % is a tie).
    levels : sequence of float
        The Ms of the trade-off picture.
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
        metric rows of the scenario run with each ``[plant]`` table, in order
        (``ctrlblocks compare --jobs`` passes a process pool's).  Default:
        one run after the other in this process (the same numbers).
    """
    from ..tuning.select import select_model
    from .compare_report import report, tradeoff
    from .compare_verdict import verdict, winners
    from .runner import run_scenario
    from .scenario import parse_scenario

    say = progress or (lambda msg: log.info("%s", msg))
    _check_options(u_min, u_max, ts, ms, tie, mv_noise)  # before any work
    t, u, y = (np.asarray(v, float) for v in (t, u, y))
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    choice = select_model(t, u, y)
    model = choice.model
    say(f"identified: {choice.why}")
    k, T, L = _fopdt_of(model)
    if ts is not None:
        _check_ts(ts, T, L)
    noise = float(np.std(y - model.response(t, u)))
    du = float(u[-1] - u[0])
    span = float(np.max(u) - np.min(u))
    lo = float(np.min(u) - 2 * span) if u_min is None else float(u_min)
    hi = float(np.max(u) + 2 * span) if u_max is None else float(u_max)
    if ts is None:
        ts = default_ts(T, L)
    step = float(k * du) if du != 0 else 1.0
    budget = float(mv_noise) if mv_noise is not None else MV_NOISE_FRACTION * abs(du or 1.0)
    u_op = float(model.u0)
    if not lo < u_op < hi:
        raise ValueError(
            f"the MV limits {lo:g} .. {hi:g} do not contain the operating point of the bump "
            f"test (the MV before the step, {u_op:g}): no controller could hold the process there"
        )
    ctrls = candidates(model, ts, ms=ms, noise_std=noise, mv_noise_max=budget, say=say)
    _check_designed(ctrls, ms, budget, noise)
    say(f"designed: {sum(c['eligible'] for c in ctrls)} of {len(ctrls)} candidates with "
        f"Ms <= {ms:g} and MV noise <= {budget:.3g}")  # fmt: skip
    taus = slowest_time_constant(ctrls, model)
    t_ev = event_time(ts, T, L, max(taus.values(), default=0.0))
    duration = float(t_ev + max(10.0 * (T + L), 50.0 * ts))
    _check_rest(duration, ts, taus)
    common = dict(ts=ts, step=step, load=-du / 2, noise=noise, u_min=lo - u_op, u_max=hi - u_op,
                  duration=duration, t_event=t_ev, y_label=deviation_label(y_label),
                  u_label=deviation_label(u_label),
                  operating_point=(u_op, float(model.y0)))  # fmt: skip
    files: list[tuple[Path, Any]] = []
    for smith, fname in ((False, "compare.toml"), (True, "compare_smith.toml")):
        if not any(c["params"] is not None and _in_smith(c) == smith for c in ctrls):
            continue
        text = scenario_toml(model, ctrls, smith=smith, name=fname.removesuffix(".toml"),
                             **common)  # fmt: skip
        path = out / fname
        path.write_text(text, encoding="utf-8")
        files.append((path, run_scenario(parse_scenario(text, file=str(path)))))
    say("simulated on the model")
    per_model: dict[str, dict[str, Any]] = {"model": {}}
    for _path, res in files:
        per_model["model"].update(_row_metrics(res.metrics))
    tables: list[dict[str, Any]] = []
    labels: list[str] = []
    if corners:
        tables += [_plant_dict(model, g, (tc, tc), dt) for g, tc, dt in _CORNERS]
        labels += [f"gain x{g:g}, T x{tc:g}, L x{dt:g}" for g, tc, dt in _CORNERS]
    if monte_carlo > 0:
        tables += _box_models(model, int(monte_carlo), int(seed))
        labels += [f"monte carlo {i}" for i in range(int(monte_carlo))]
    if tables:
        runner = run_models or _serial_models
        for lab in labels:
            per_model[lab] = {}
        for path, _res in files:
            got = _run_models(path, tables, runner, say)
            for lab, m in zip(labels, got, strict=True):
                per_model[lab].update(m)
    results = _metrics(ctrls, per_model, corners, int(monte_carlo))
    summary: dict[str, Any] = {
        "fopdt": choice.fopdt.as_dict(),
        "sopdt": None if choice.sopdt is None else choice.sopdt.as_dict(),
        "model_used": "sopdt" if model is choice.sopdt else "fopdt",
        "why": choice.why,
        "model_choice": choice.criterion,
        "ms_target": ms,
        "noise_std": noise,
        "mv_noise_max": budget,
        "tie": tie,
        "ts": ts,
        "t_event": t_ev,
        "rest": {"times": REST, "time_constants": taus},
        "u_min": lo,
        "u_max": hi,
        "operating_point": {"u": u_op, "y": float(model.y0)},
        "step": step,
        "load": -du / 2,
        "box": dict(BOX),
        "monte_carlo": {"n": int(monte_carlo), "seed": int(seed)} if monte_carlo else None,
        "controllers": [{k2: v for k2, v in c.items() if k2 != "_design"} for c in ctrls],
        "metrics": results,
    }
    say("trade-off: the best of each family at Ms " + ", ".join(f"{v:g}" for v in levels))
    summary["tradeoff"] = tradeoff(model, summary, levels, design_candidate,
                                   {c["name"]: c.get("_design") for c in ctrls})  # fmt: skip
    summary["winners"] = winners(summary)
    summary["verdict"] = verdict(summary)
    (out / "compare.json").write_text(json.dumps(jsonable(summary), indent=2), encoding="utf-8")
    report(out, summary, t, u, y, model, [res for _p, res in files], y_label, u_label)
    say(f"report: {out / 'compare.md'}")
    return summary


def _serial_models(path: Path, tables: list[dict[str, Any]],
                   progress: Callable[[int, int], None]) -> list[dict[str, Any]]:  # fmt: skip
    """The metric rows of the scenario at ``path`` with each plant table, one after the other."""
    text = path.read_text(encoding="utf-8")
    rows: list[dict[str, Any]] = []
    for i, plant in enumerate(tables):
        rows += model_rows(text, str(path), plant)
        progress(i + 1, len(tables))
    return rows


def model_rows(text: str, file: str, plant: dict[str, Any]) -> list[dict[str, Any]]:
    """The metric rows (windows included) of the scenario ``text`` run with ``plant``.

    A module-level function of plain arguments: a process pool can ship it.
    """
    from ..loops.toml import read_toml
    from .runner import run_scenario
    from .scenario import ScenarioError, parse_scenario_doc

    doc = read_toml(text, file, ScenarioError)
    doc["plant"] = plant
    return [{k: v for k, v in m.items() if k != "scenario"}
            for m in run_scenario(parse_scenario_doc(doc, file=file)).metrics]  # fmt: skip


def _run_models(path: Path, tables: list[dict[str, Any]], runner: ModelRunner,
                say: Callable[[str], None]) -> list[dict[str, dict[str, float]]]:  # fmt: skip
    """The summary metrics of every plant table (``runner``: see :func:`compare`)."""
    marks = {max(1, round(len(tables) * f / 10)) for f in range(1, 11)}

    def progress(done: int, total: int) -> None:
        if done in marks:
            say(f"uncertain models ({path.name}): {done}/{total} run")

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
