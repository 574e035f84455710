"""The reproduction report: every shipped scenario, its plots, metrics and claims.

``ctrlblocks reproduce`` runs the scenarios shipped in
``ctrlblocks/scenarios/`` and writes ``report.md`` beside one folder per
scenario (traces, ``metrics.json``, ``claims.json``, PNGs).  The report sets
each result beside what the source printed: the claims of the source are
checked on the metrics and marked as holding or not, honestly.
"""

from __future__ import annotations

import dataclasses
import importlib.resources
from collections.abc import Sequence
from pathlib import Path

from .. import __version__
from .names import plot_names, slug
from .runner import TABLE_UNITS, ScenarioResult, in_table_unit, metric_table
from .scenario import Scenario, load_scenario

__all__ = [
    "REPORT_METRICS",
    "TableCheck",
    "claims_holding",
    "margins_rows",
    "render_report",
    "shipped_scenarios",
    "table1_inverse_half_rule",
]

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
    files = shipped_scenarios()
    if names and {p.stem for p in files} >= set(names):  # a file is named after its scenario
        files = [p for p in files if p.stem in names]
    scenarios = [load_scenario(p) for p in files]
    if names:
        known = {s.name for s in scenarios}
        missing = [n for n in names if n not in known]
        if missing:
            raise KeyError(
                f"unknown scenario(s): {', '.join(missing)}; shipped: {', '.join(sorted(known))}"
            )
        scenarios = [s for s in scenarios if s.name in names]
    return scenarios


@dataclasses.dataclass
class TableCheck:
    """One number of a source's table recomputed by ctrlblocks."""

    text: str
    holds: bool
    detail: str


def table1_inverse_half_rule() -> tuple[str, list[TableCheck]]:
    """Nowak et al. 2018, Table 1: the inverse half-rule applied to the FOPDT models (10a)/(10b).

    Recomputed with :func:`ctrlblocks.tuning.halfrule.inverse_half_rule` from the
    FOPDT parameters printed in (10a)/(10b); the "true" b0 from the transfer
    functions.  A printed value holds when it equals ours rounded to the
    printed digits.
    """
    from ..tuning.halfrule import inverse_half_rule

    k1 = inverse_half_rule(0.56, 11.0, 3.3, 2)
    k2 = inverse_half_rule(0.73, 8.3, 3.0, 3)
    true1 = 0.56 / (9.5 * 4.2)
    true2 = 0.73 / (7.3 * 2.2 * 1.4)
    rows = [
        ("K1 (10a), true b0 = k/(T1 T2)", true1, 0.014, 3),
        ("K1 (10a), inverse half-rule, n = 2", k1.b0, 0.011, 3),
        ("K2 (10b), true b0 = k/(T1 T2 T3)", true2, 0.0325, 4),
        ("K2 (10b), inverse half-rule b0_min, n = 3", k2.b0_min, 0.0236, 4),
        ("K2 (10b), inverse half-rule b0_max, n = 3", k2.b0_max, 0.1022, 4),
    ]
    lines = [
        "| quantity | paper | ctrlblocks |",
        "|---|---|---|",
    ]
    checks = []
    for text, ours, paper, digits in rows:
        lines.append(f"| {text} | {paper:g} | {ours:.5f} |")
        holds = round(ours, digits) == round(paper, digits)
        checks.append(
            TableCheck(
                f"Table 1: {text} = {paper:g}", holds, f"{ours:.5f} rounds to {ours:.{digits}f}"
            )
        )
    inside = k2.b0_min <= true2 <= k2.b0_max
    checks.append(
        TableCheck(
            "Table 1: the true b0 of K2 falls inside [b0_min, b0_max], closer to b0_min",
            inside and (true2 - k2.b0_min) < (k2.b0_max - true2),
            f"{k2.b0_min:.4f} <= {true2:.4f} <= {k2.b0_max:.4f}",
        )
    )
    return "\n".join(lines), checks


def window_tables(result: ScenarioResult, metric: str = "iae") -> list[str]:
    """Markdown lines: ``metric`` per event window (columns) and controller (rows), per case.

    Only for cases with more than one window.
    """
    out: list[str] = []
    for case in result.scenario.cases:
        rows = [m for m in result.metrics if m["case"] == case.name]
        if not rows or len(rows[0]["windows"]) < 2:
            continue
        wins = rows[0]["windows"]
        head = [f"{w['label']} ({w['t0']:g} s)" for w in wins]
        name = TABLE_UNITS[metric][0].capitalize() if metric in TABLE_UNITS else metric.upper()
        title = f"{name} per event window" + (
            f" — {case.name}" if len(result.scenario.cases) > 1 else ""
        )
        out += ["", f"{title}:", ""]
        out.append("| controller | " + " | ".join(head) + " |")
        out.append("|---|" + "---|" * len(head))
        for m in rows:
            vals = [in_table_unit(metric, w[metric]) for w in m["windows"]]
            cells = ["–" if v is None else f"{v:.4g}" for v in vals]
            out.append(f"| {m['controller']} | " + " | ".join(cells) + " |")
    return out


def _tuned_lines(sc: Scenario) -> list[str]:
    from ..tuning.bump import tuned_model

    out = []
    for c in sc.controllers:
        for spec in c.blocks.values():
            info = getattr(spec, "extra", {}).get("tuned") if not isinstance(spec, list) else None
            if not info:
                continue
            params = ", ".join(f"{k} = {v:.4g}" for k, v in info["parameters"].items())
            line = (
                f"- {c.name}: bump {info['du']:+g} from u = {info['u0']:.4g}; FOPDT k = "
                f"{info['gain']:.4g}, T = {info['time_constant']:.4g} s, T0 = "
                f"{info['dead_time']:.4g} s"
            )
            if (info.get("model") or {}).get("model") == "sopdt":
                line += f"; tuned on the {tuned_model(info)[1]} ({info['why']})"
            out.append(f"{line}; rule {info['rule']}: {params}")
    return out


def margins_rows(sc: Scenario) -> list[tuple[str, str, dict | None, bool]]:
    """``(controller, model, margins, tuned)`` for every controller whose loop has a linear model.

    A controller tuned by ``[controllers.tune]`` is analysed as configured (the
    table with the tuned parameters) on the fit of its bump test it was tuned on
    (the FOPDT, or the SOPDT for an ADRC's safe default); a controller
    set by the source (``tuned`` False) in a ``single`` loop on a linear plant
    is analysed on that plant itself, exactly (:mod:`ctrlblocks.tuning.margins`).
    Other loops (nonlinear plants, cascades, Smith predictors) have no row.
    """
    from ..blocks.registry import is_controller_type
    from ..loops.spec import build
    from ..loops.structures import STRUCTURES
    from ..plants.linear import LinearPlant
    from ..tuning.bump import block_margins, tuned_model

    rows: list[tuple[str, str, dict | None, bool]] = []
    for c in sc.controllers:
        spec = c.blocks.get("main")
        if spec is None or isinstance(spec, list):
            continue
        info = spec.extra.get("tuned")
        if info:
            fit, model = tuned_model(info)
            rows.append((c.name, model, block_margins(fit, spec.type, spec.params, sc.ts), True))
            continue
        if not STRUCTURES[sc.structure].margins_on_plant or sc.plant is None:
            continue
        if not is_controller_type(spec.type):
            continue
        plant = build(sc.plant, sc.ts, kind="plant", file=sc.file)  # checked when loaded
        if not isinstance(plant, LinearPlant):
            continue
        mg = block_margins(plant, spec.type, spec.params, sc.ts)
        rows.append((c.name, f"the plant ({sc.plant.type}, exact)", mg, False))
    return rows


def _margins_lines(sc: Scenario) -> list[str]:
    rows = margins_rows(sc)
    if not rows:
        return []
    out = [
        "",
        "Robustness of each tuning on its model (sampled loop, dead time exact, "
        "`docs/tuning.md`; a dash: set-point or output ramps or a dead band, not analysed):",
        "",
        "| controller | model | Ms | GM | PM [deg] | crossover [rad/s] | stable |",
        "|---|---|---|---|---|---|---|",
    ]
    warn = []

    def cell(v: float | None, fmt: str) -> str:
        return "∞" if v is None or v == float("inf") else format(v, fmt)

    for name, model, mg, tuned in rows:
        if mg is None:
            out.append(f"| {name} | {model} | – | – | – | – | – |")
            continue
        stable = "yes" if mg["stable"] else "**no**"
        out.append(
            f"| {name} | {model} | {cell(mg['ms'] if mg['stable'] else None, '.3f')} | "
            f"{cell(mg['gm'], '.3g')} | {cell(mg['pm'], '.1f')} | "
            f"{cell(mg['wc_crossover'], '.4g')} | {stable} |"
        )
        warn += [f"- ⚠️ {name}: {w}." for w in mg.get("warnings", ())]
        if not mg["stable"] or mg["ms"] > 2.0:
            who = "the tuning found" if tuned else "the source's tuning"
            how = "is unstable" if not mg["stable"] else f"has Ms = {mg['ms']:.3g} > 2 (fragile)"
            warn.append(f"- ⚠️ {name}: {who} {how} on {model}.")
    return out + (["", *warn] if warn else [])


def claims_holding(results: Sequence[ScenarioResult], *, tables: bool = True) -> tuple[int, int]:
    """``(holding, total)`` claims of ``results`` (with ``tables``: and the Table 1 checks)."""
    return _count_claims(results, table1_inverse_half_rule()[1] if tables else [])


def _count_claims(
    results: Sequence[ScenarioResult], table_checks: Sequence[TableCheck]
) -> tuple[int, int]:
    checks = [c.holds for r in results for c in r.claims] + [c.holds for c in table_checks]
    return sum(1 for h in checks if h), len(checks)


def render_report(
    results: Sequence[ScenarioResult], *, quick: bool, seconds: float, tables: bool = True
) -> str:
    """The markdown of ``report.md`` (paths of plots are relative to the report).

    ``tables``: add the recomputed tables of the sources (Nowak et al. 2018, Table 1).
    """
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
    table1, table_checks = table1_inverse_half_rule() if tables else ("", [])
    n_hold, n_claims = _count_claims(results, table_checks)
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
    if table_checks:
        held = sum(1 for c in table_checks if c.holds)
        lines.append(
            f"| [Inverse half-rule, Table 1](#table1) | Nowak et al. 2018, Table 1 | – "
            f"| {held}/{len(table_checks)} |"
        )
    lines += [
        "",
        "Metrics (definitions in `docs/simulator.md`): IAE, ISE, ITAE of the error "
        "e = SP − y; overshoot in % of the step (in every table); settling time to the "
        "2 % band; "
        "total variation (tv_u) and largest rate of the MV.  A dash means undefined: "
        "an overshoot only where the loop was asked to step (a setpoint change, the "
        "switch to AUTO), not after a load or at steady state.",
    ]
    for r in results:
        sc = r.scenario
        lines += ["", f'<a id="{slug(sc.name).lower()}"></a>', "", f"## {sc.title}", ""]
        lines.append(f"*Source:* {sc.source}  ·  *scenario:* `{sc.name}`")
        if sc.description:
            lines += ["", r.quoted(" ".join(sc.description.split()))]
        if sc.notes:
            lines += ["", "*Notes:* " + r.quoted(" ".join(sc.notes.split()))]
        tuned = _tuned_lines(sc)
        if tuned:
            lines += ["", "Tuned from a simulated bump test when the scenario was loaded:", ""]
            lines += tuned
        lines += _margins_lines(sc)
        for case, png_name in zip(sc.cases, plot_names([c.name for c in sc.cases]), strict=True):
            png = f"{sc.name}/{png_name}.png"
            lines += ["", f"![{sc.title} — {case.name}]({png})"]
        multi = any(len(m["windows"]) > 1 for m in r.metrics)
        if multi:  # overshoot/settling of a whole run mixing several events would mislead
            cols = tuple(n for n in REPORT_METRICS if n not in ("overshoot", "settling_time"))
            lines += ["", "Whole run:", "", metric_table(r, cols)]
            lines += window_tables(r, "iae")
            if any(w["overshoot"] is not None for m in r.metrics for w in m["windows"]):
                lines += window_tables(r, "overshoot")
        else:
            lines += ["", metric_table(r, REPORT_METRICS)]
        if r.claims:
            lines += ["", "Claims:", ""]
            for c in r.claims:
                mark = {True: "✅ holds", False: "❌ does not hold", None: "❔ undecided"}[c.holds]
                src = f" ({c.claim.source})" if c.claim.source else ""
                lines.append(f"- {mark}: {r.quoted(c.claim.text)}{src} — {c.detail}")
    if table_checks:
        lines += [
            "",
            '<a id="table1"></a>',
            "",
            "## Inverse half-rule (Table 1)",
            "",
            "*Source:* Nowak et al. 2018, section 3.3, Table 1  ·  b0 from the FOPDT "
            "approximations printed in (10a)/(10b), computed by "
            "`ctrlblocks.tuning.inverse_half_rule`.",
            "",
            table1,
            "",
            "Claims:",
            "",
        ]
        for c in table_checks:
            mark = "✅ holds" if c.holds else "❌ does not hold"
            lines.append(f"- {mark}: {c.text} — {c.detail}")
    return "\n".join(lines) + "\n"
