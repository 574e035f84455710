"""The reproduction report: every shipped scenario, its plots, metrics and claims.

``ctrlblocks reproduce`` runs the scenarios shipped in
``ctrlblocks/scenarios/`` and writes ``report.md`` beside one folder per
scenario (traces, ``metrics.json``, ``claims.json``, PNGs).  The report sets
each result beside what the source printed: the claims of the source are
checked on the metrics and marked as holding or not, honestly.
"""

from __future__ import annotations

import importlib.resources
from collections.abc import Sequence
from pathlib import Path

from .. import __version__
from .results import slug
from .runner import ScenarioResult, metric_table
from .scenario import Scenario, load_scenario

__all__ = ["REPORT_METRICS", "render_report", "shipped_scenarios"]

REPORT_METRICS = ("iae", "ise", "itae", "overshoot", "settling_time", "tv_u", "max_rate_u")
"""Columns of the per-scenario tables in the report."""


def shipped_scenarios() -> list[Path]:
    """Paths of the scenario files shipped inside the package, sorted by name."""
    root = importlib.resources.files("ctrlblocks") / "scenarios"
    return sorted(
        (Path(str(p)) for p in root.iterdir() if p.name.endswith(".toml")), key=lambda p: p.name
    )


def load_shipped(names: Sequence[str] = ()) -> list[Scenario]:
    """Load the shipped scenarios (all, or those whose name is in ``names``)."""
    scenarios = [load_scenario(p) for p in shipped_scenarios()]
    if names:
        known = {s.name for s in scenarios}
        missing = [n for n in names if n not in known]
        if missing:
            raise KeyError(
                f"unknown scenario(s): {', '.join(missing)}; shipped: {', '.join(sorted(known))}"
            )
        scenarios = [s for s in scenarios if s.name in names]
    return scenarios


def render_report(results: Sequence[ScenarioResult], *, quick: bool, seconds: float) -> str:
    """The markdown of ``report.md`` (paths of plots are relative to the report)."""
    lines = [
        "# ctrlblocks: the sources' experiments, reproduced",
        "",
        f"Produced by `ctrlblocks reproduce{' --quick' if quick else ''}` "
        f"(ctrlblocks {__version__}) in {seconds:.1f} s.",
    ]
    if quick:
        lines += [
            "",
            "**Quick mode:** every case was cut to its `quick_duration`; numbers and "
            "claims refer to the shortened runs.  Run `ctrlblocks reproduce` for the full report.",
        ]
    n_claims = sum(len(r.claims) for r in results)
    n_hold = sum(1 for r in results for c in r.claims if c.holds)
    lines += [
        "",
        f"**{n_hold} of {n_claims} claims of the sources hold in simulation.** "
        "Each claim is checked on the metrics below; a claim that does not hold is "
        "reported as such, not hidden.",
        "",
        "| scenario | source | runs | claims holding |",
        "|---|---|---|---|",
    ]
    for r in results:
        held = sum(1 for c in r.claims if c.holds)
        lines.append(
            f"| [{r.scenario.title}](#{slug(r.scenario.name).lower()}) | {r.scenario.source} "
            f"| {len(r.runs)} | {held}/{len(r.claims)} |"
        )
    lines += [
        "",
        "Metrics (definitions in `docs/simulator.md`): IAE, ISE, ITAE of the error "
        "e = SP − y; overshoot as a fraction of the step; settling time to the 2 % band; "
        "total variation (tv_u) and largest rate of the MV.  A dash means undefined "
        "(e.g. no setpoint step).",
    ]
    for r in results:
        sc = r.scenario
        lines += ["", f'<a id="{slug(sc.name).lower()}"></a>', "", f"## {sc.title}", ""]
        lines.append(f"*Source:* {sc.source}  ·  *scenario:* `{sc.name}`")
        if sc.description:
            lines += ["", " ".join(sc.description.split())]
        if sc.notes:
            lines += ["", "*Notes:* " + " ".join(sc.notes.split())]
        for case in sc.cases:
            png = f"{sc.name}/{slug(case.name)}.png"
            lines += ["", f"![{sc.title} — {case.name}]({png})"]
        lines += ["", metric_table(r, REPORT_METRICS)]
        if r.claims:
            lines += ["", "Claims:", ""]
            for c in r.claims:
                mark = {True: "✅ holds", False: "❌ does not hold", None: "❔ undecided"}[c.holds]
                src = f" ({c.claim.source})" if c.claim.source else ""
                lines.append(f"- {mark}: {c.claim.text}{src} — {c.detail}")
    return "\n".join(lines) + "\n"
