"""Run a whole scenario: every controller in every case, metrics, claims.

>>> from ctrlblocks.sim import load_scenario, run_scenario   # doctest: +SKIP
>>> result = run_scenario(load_scenario("my.toml"))          # doctest: +SKIP
>>> result.metrics[0]["iae"]                                 # doctest: +SKIP
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from .dispatch import simulate
from .loop import Run, event_times
from .metrics import METRIC_NAMES, Window, run_metrics, window_index, windows_from_events
from .scenario import Claim, Scenario

__all__ = ["ClaimResult", "ScenarioResult", "check_claim", "run_scenario"]


@dataclasses.dataclass
class ClaimResult:
    """A claim of the source with the numbers that decide it."""

    claim: Claim
    holds: bool | None  # None: could not be decided (a metric was NaN)
    detail: str


@dataclasses.dataclass
class ScenarioResult:
    """All runs of a scenario with their metrics and the checked claims.

    ``metrics`` is a list of dicts, one per controller and case, with the
    keys ``scenario``, ``controller``, ``case`` and every metric of
    :data:`~ctrlblocks.sim.metrics.METRIC_NAMES` over the whole run, plus
    ``windows``: the same metrics per event window (with ``label``, ``t0``,
    ``t1``).
    """

    scenario: Scenario
    runs: list[Run]
    metrics: list[dict[str, Any]]
    claims: list[ClaimResult]
    quick: bool

    def metric(self, controller: str, case: str, name: str, window: int | None = None) -> float:
        """One metric value (whole run, or of event window number ``window``)."""
        for m in self.metrics:
            if m["controller"] == controller and m["case"] == case:
                src = m if window is None else m["windows"][window]
                v = src[name]
                return math.nan if v is None else float(v)
        raise KeyError((controller, case))

    def quoted(self, text: str) -> str:
        """``text`` with its quotes of this run's numbers filled in (:mod:`.quotes`)."""
        from .quotes import fill

        def value(metric: str, case: str, ctrl: str, window: int | None, signal: str | None):
            if signal is not None:
                return signal_stat(self, ctrl, case, signal, metric, window)
            return self.metric(ctrl, case, metric, window)

        return fill(text, value)

    @property
    def all_claims_hold(self) -> bool:
        """True when every claim holds (undecided claims count as failures)."""
        return all(c.holds for c in self.claims)


def check_duration(duration: Any, ts: float | None = None) -> None:
    """Refuse a run duration [s] that is not a number > 0 (``inf``: no cut; None: the case's),
    or, given the sample time ``ts``, one shorter than a sample (a run of no sample)."""
    if duration is None:
        return
    if isinstance(duration, bool) or not isinstance(duration, (int, float)) or not duration > 0:
        raise ValueError(f"duration: must be a number of seconds > 0, got {duration!r}")
    if ts is not None and duration < ts:
        raise ValueError(f"duration: {duration!r} s is a run of no sample (ts {ts!r} s)")


def run_scenario(
    scenario: Scenario,
    *,
    quick: bool = False,
    duration: float | None = None,
    progress: Callable[[str], None] | None = None,
    engine: str = "auto",
) -> ScenarioResult:
    """Run every controller of ``scenario`` in every case.

    Parameters
    ----------
    scenario : Scenario
        The loaded scenario.
    quick : bool
        Stop each case at ``scenario.quick_duration`` (used by
        ``reproduce --quick`` and the tests).
    duration : float, optional
        Stop each case at this time [s] (overrides ``quick``); > 0 (``inf``:
        no cut), else ``ValueError``.
    progress : callable, optional
        Called with ``"controller / case"`` after each run (for a progress bar).
    engine : {"auto", "compiled", "python"}
        Where the runs are simulated (:mod:`ctrlblocks.sim.dispatch`): ``auto``
        puts every run the compiled lane can do on it (same traces) and the
        others on the Python path; ``python`` forces the reference path;
        ``compiled`` refuses a run the lane cannot do (``CompiledLaneError``).
    """
    if duration is None and quick:
        duration = scenario.quick_duration
    check_duration(duration, scenario.ts)
    band = float(scenario.metrics.get("band", 0.02))
    want_windows = bool(scenario.metrics.get("windows", True))
    runs: list[Run] = []
    table: list[dict[str, Any]] = []
    lane_cache: dict[Any, Any] = {}  # the compiled lane's per-case arrays
    for case in scenario.cases:
        for ctrl in scenario.controllers:
            run = simulate(scenario, ctrl, case, duration=duration, engine=engine, cache=lane_cache)
            runs.append(run)
            s = run.signals
            # the whole run and every event window in one pass (metrics.run_metrics)
            wins = []
            if want_windows:
                wins = _windows(scenario, run)
            whole, per_window = run_metrics(s["t"], s["sp"], s["y"], s["u"], run.ts, wins,
                                            band=band)  # fmt: skip
            row: dict[str, Any] = {
                "scenario": scenario.name,
                "controller": ctrl.name,
                "case": case.name,
                **_json_metrics(whole),
            }
            row["windows"] = [
                {"label": w.label, "t0": w.t0, "t1": w.t1, **_json_metrics(m)}
                for w, m in zip(wins, per_window, strict=True)
            ]
            table.append(row)
            if progress is not None:
                progress(f"{ctrl.name} / {case.name}")
    result = ScenarioResult(scenario, runs, table, [], quick or duration is not None)
    result.claims = [check_claim(result, c) for c in scenario.claims]
    return result


def _json_metrics(m: dict[str, float]) -> dict[str, float | None]:
    """A :func:`run_metrics` dict (all floats) for JSON: NaN and inf as None (``null``)."""
    isfinite = math.isfinite
    return {k: v if isfinite(v) else None for k, v in m.items()}


def check_claim(result: ScenarioResult, claim: Claim) -> ClaimResult:
    """Decide ``claim`` on the metrics of ``result``."""
    refs = claim.args["refs"]
    case = claim.case or result.scenario.cases[0].name

    signal = claim.args.get("signal")

    def val(name: str) -> float:
        try:
            if signal is not None:
                return signal_stat(result, name, case, signal, claim.metric, claim.window)
            return result.metric(name, case, claim.metric, claim.window)
        except (IndexError, KeyError):
            return math.nan

    m = claim.metric if signal is None else f"{claim.metric}({signal})"
    where = f" (window {claim.window})" if claim.window is not None else ""
    k = claim.kind
    if k == "best":
        vals = {c.name: val(c.name) for c in result.scenario.controllers}
        if any(math.isnan(v) for v in vals.values()):
            return ClaimResult(claim, None, f"{m}{where}: undefined for some controller")
        best = min(vals, key=vals.__getitem__)
        detail = ", ".join(f"{n}: {v:.4g}" for n, v in vals.items())
        return ClaimResult(claim, best == refs[0], f"{m}{where} lowest for {best!r} ({detail})")
    if k == "less":
        a, b = val(refs[0]), val(refs[1])
        f = claim.args.get("factor", 1.0)
        if math.isnan(a) or math.isnan(b):
            return ClaimResult(claim, None, f"{m}{where}: {refs[0]} {a}, {refs[1]} {b}")
        rhs = f"{f:g} x " if f != 1.0 else ""
        return ClaimResult(
            claim, a < f * b, f"{m}{where}: {refs[0]} {a:.4g} < {rhs}{refs[1]} {b:.4g}"
        )
    a = val(refs[0])
    if math.isnan(a):
        return ClaimResult(claim, None, f"{m}{where} of {refs[0]} is undefined")
    x = claim.args["value"]
    if k == "below":
        return ClaimResult(claim, a < x, f"{m}{where} of {refs[0]}: {a:.4g} < {x:g}")
    if k == "above":
        return ClaimResult(claim, a > x, f"{m}{where} of {refs[0]}: {a:.4g} > {x:g}")
    if k == "between":
        lo, hi = x
        return ClaimResult(
            claim, lo <= a <= hi, f"{m}{where} of {refs[0]}: {a:.4g} in [{lo:g}, {hi:g}]"
        )
    tol = claim.args["tol"]
    return ClaimResult(
        claim, abs(a - x) <= tol, f"{m}{where} of {refs[0]}: {a:.6g} = {x:g} ± {tol:g}"
    )


def signal_stat(
    result: ScenarioResult, controller: str, case: str, signal: str, stat: str, window: int | None
) -> float:
    """``max``/``min``/``final``/``mean``/``max_step`` of a trace signal (run or event window)."""
    run = next(r for r in result.runs if r.controller == controller and r.case == case)
    x = run.signals[signal]
    t = run.signals["t"]
    if window is not None:
        w = _windows(result.scenario, run)[window]
        idx = window_index(t, run.ts, w.t0, w.t1)
        if stat == "max_step" and len(idx) and idx[0] > 0:
            idx = np.concatenate(([idx[0] - 1], idx))  # the step into the window counts
        x = x[idx]
    if len(x) == 0:
        return math.nan
    if stat == "max":
        return float(np.max(x))
    if stat == "min":
        return float(np.min(x))
    if stat == "final":
        return float(x[-1])
    if stat == "max_step":
        return float(np.max(np.abs(np.diff(x)))) if len(x) > 1 else 0.0
    return float(np.mean(x))


def _windows(scenario: Scenario, run: Run) -> list[Window]:
    """The event windows of a run (the first opens with the loop in control unless it
    starts in MAN)."""
    auto = scenario.initial.get("mode", "auto") == "auto"
    return windows_from_events(event_times(run.events), run.duration, start_switch=auto)


TABLE_UNITS: dict[str, tuple[str, float]] = {"overshoot": ("overshoot [%]", 100.0)}
"""Metrics shown in another unit in tables: name -> (column title, factor).

``metrics.json`` keeps the overshoot as a fraction of the step; every table
(``run``'s, the report's whole-run and per-window tables) shows percent.
"""


def metric_table(result: ScenarioResult, names: tuple[str, ...] = METRIC_NAMES) -> str:
    """The comparison table of a scenario (one row per controller and case) as markdown."""
    heads = [TABLE_UNITS.get(n, (n, 1.0))[0] for n in names]
    cols = ["controller", "case", *heads]
    lines = ["| " + " | ".join(cols) + " |", "|" + "|".join("---" for _ in cols) + "|"]
    for m in result.metrics:
        cells = [m["controller"], m["case"]] + [_fmt(in_table_unit(n, m[n])) for n in names]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def in_table_unit(name: str, v: Any) -> Any:
    factor = TABLE_UNITS.get(name, (name, 1.0))[1]
    return v * factor if isinstance(v, float) and factor != 1.0 else v


def _fmt(v: Any) -> str:
    if v is None:
        return "–"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)
