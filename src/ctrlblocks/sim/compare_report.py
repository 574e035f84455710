"""The report of ``ctrlblocks compare``: ``compare.md``, the plots and the trade-off picture."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

__all__ = ["report", "tradeoff"]


def tradeoff(model: Any, s: dict[str, Any], levels: Sequence[float], design: Any,
             designs: dict[str, Any] | None = None) -> dict[str, Any]:  # fmt: skip
    """The best candidate of each family designed again at each Ms of ``levels``.

    The family's best is its eligible candidate with the smallest load IAE on
    the model; at each level (the summary's own ``ms_target`` added) the same
    kind of candidate is designed with that Ms and the same noise budget, and
    its load IAE (a step of the summary's load at the process input, the linear
    loop on the model: no noise, no limits) and MV noise are recorded.
    ``{"levels": [...], "PID": {"name", "ms", "iae_load", "mv_noise", "ki"}, "ADRC": ...}``;
    a level where the design fails has None.  ``design(name, model, ts, **kw)`` designs a
    candidate (:func:`ctrlblocks.sim.compare.design_candidate`); ``designs``: the
    candidates' designs at the summary's own Ms (not designed again).
    """
    from ..blocks.base import ParameterError

    lv = sorted({*(float(v) for v in levels), float(s["ms_target"])})
    out: dict[str, Any] = {"levels": lv}
    res = s["metrics"]
    for fam in ("PID", "ADRC"):
        names = [c["name"] for c in s["controllers"] if c["eligible"] and c["type"] == fam]
        if not names:
            continue
        best = min(names, key=lambda n: _finite_or_inf(res[n]["model"]["iae_load"]))
        row: dict[str, Any] = {"name": best, "ms": [], "iae_load": [], "mv_noise": [], "ki": []}
        for ms in lv:
            try:
                d = (designs or {}).get(best) if ms == s["ms_target"] else None
                d = d or design(best, model, s["ts"], ms=ms, noise_std=s["noise_std"],
                                mv_noise_max=s["mv_noise_max"])  # fmt: skip
            except (ParameterError, ValueError):
                for k in ("ms", "iae_load", "mv_noise", "ki"):
                    row[k].append(None)
                continue
            row["ms"].append(d.margins.ms)
            row["iae_load"].append(d.load_iae(model, abs(s["load"]) or 1.0))
            row["mv_noise"].append(d.mv_noise)
            row["ki"].append(d.ki)
        out[fam] = row
    return out


def _finite_or_inf(v: Any) -> float:
    return math.inf if v is None or not math.isfinite(v) else float(v)


def plot_tradeoff(tr: dict[str, Any], path: Path, iae_unit: str, mv_unit: str) -> Path | None:
    """Load IAE and MV noise against Ms for the best of each family (PNG)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fams = [f for f in ("PID", "ADRC") if tr.get(f)]
    if not fams:
        return None
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(9.0, 3.6))
    for fam, style in zip(fams, ("o-", "s--"), strict=False):
        f = tr[fam]
        pts = [(m, i, n) for m, i, n in zip(f["ms"], f["iae_load"], f["mv_noise"], strict=True)
               if m is not None]  # fmt: skip
        if not pts:
            continue
        ms, iae, noise = zip(*pts, strict=True)
        a1.plot(ms, iae, style, label=f"{fam}: {f['name']}")
        if any(n is not None and math.isfinite(n) for n in noise):
            a2.plot(ms, [math.nan if n is None else n for n in noise], style,
                    label=f"{fam}: {f['name']}")  # fmt: skip
    a1.set_xlabel("Ms (maximum sensitivity on the model)")
    a1.set_ylabel(f"IAE of the load step [{iae_unit}]")
    a1.set_title("Load rejection against robustness", fontsize=9)
    a2.set_xlabel("Ms (maximum sensitivity on the model)")
    a2.set_ylabel(f"MV noise, standard deviation [{mv_unit}]")
    a2.set_title("Valve wear against robustness", fontsize=9)
    for a in (a1, a2):
        a.grid(True, alpha=0.3)
        a.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def _range(v: Any, scale: float) -> str:
    return "–" if not v else f"{_cell(v[0], '.4g', scale)} .. {_cell(v[1], '.4g', scale)}"


def _cell(x: Any, fmt: str = ".4g", scale: float = 1.0) -> str:
    return "–" if x is None or not math.isfinite(x) else format(scale * x, fmt)


def _unit(label: str, role: str) -> str:
    """``"PV: p3 [bar]"`` -> ``"bar"``; no unit -> ``role`` (``"PV"``: in the units of the data)."""
    return label[label.rindex("[") + 1 : -1] if label.endswith("]") else role


def _merged(results: list[Any]) -> Any:
    """One result of the runs of every scenario (for the plots: one PNG per case)."""
    first = results[0]
    if len(results) == 1:
        return first
    sc = dataclasses.replace(
        first.scenario,
        controllers=[c for r in results for c in r.scenario.controllers],
    )
    return dataclasses.replace(first, scenario=sc, runs=[run for r in results for run in r.runs])


def report(out: Path, summary, t, u, y, model, results, y_label: str, u_label: str) -> None:
    """Write ``compare.md``, ``fit.png``, one PNG per case and ``tradeoff.png``."""
    from ..tuning.plot import plot_identification
    from .plot import plot_result

    yu, uu = _unit(y_label, "PV"), _unit(u_label, "MV")
    known = (yu, uu) != ("PV", "MV")
    plot_identification(t, u, y, model, out / "fit.png", y_label=y_label, u_label=u_label,
                        gain_unit=f"{yu}/{uu}" if known else None)  # fmt: skip
    pngs = plot_result(_merged(results), out)
    iae_u, mv_u, ki_u = f"{yu}·s", uu, f"{uu}/({yu}·s)"
    plot_tradeoff(summary.get("tradeoff") or {}, out / "tradeoff.png", iae_u, mv_u)
    units = "" if known else " PV and MV in the units of the data."
    mc = summary["model_choice"]
    crit = ""
    if mc.get("fopdt") and mc.get("sopdt"):
        crit = (f" (BIC = N ln(RSS/N) + p ln N: FOPDT RSS {mc['fopdt']['rss']:.4g}, "
                f"BIC {mc['fopdt']['bic']:.1f}; SOPDT RSS {mc['sopdt']['rss']:.4g}, "
                f"BIC {mc['sopdt']['bic']:.1f}; N = {mc['n']})")  # fmt: skip
    lines = [
        "# ctrlblocks compare: ADRC or PID on the identified process",
        "",
        f"Model used: {summary['why']}{crit}; designs, margins and simulations are all on "
        f"it.{units}",
        "",
        "![fit](fit.png)",
        "",
        f"## Candidates: designed to Ms <= {summary['ms_target']:g} and MV noise <= "
        f"{summary['mv_noise_max']:.3g} {mv_u}",
        "",
        f"PV noise of the record (the fit's residuals): {summary['noise_std']:.3g} {yu} "
        f"(standard deviation); sample time {summary['ts']:g} s.",
        "",
        f"| controller | structure | parameters | Ms | GM | PM [deg] | ki [{ki_u}] | MV noise "
        f"[{mv_u}] | IAE step [{iae_u}] | IAE load [{iae_u}] | in the verdict |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for c in summary["controllers"]:
        mg = c.get("margins") or {}
        params = ", ".join(f"{k} = {v:.4g}" for k, v in (c["params"] or {}).items()
                           if not isinstance(v, bool))  # fmt: skip
        m = summary["metrics"].get(c["name"], {}).get("model", {})
        lines.append(
            f"| {c['name']} | {c['structure']} | {params or c.get('error', '')} | "
            f"{_cell(mg.get('ms'), '.3f')} | {_cell(mg.get('gm'), '.3g')} | "
            f"{_cell(mg.get('pm'), '.1f')} | {_cell(mg.get('ki'), '.4g')} | "
            f"{_cell(mg.get('mv_noise'), '.3g')} | {_cell(m.get('iae_tracking'))} | "
            f"{_cell(m.get('iae_load'))} | {'yes' if c['eligible'] else '**no**'} |"
        )
    notes = [f"- {c['name']}: " + "; ".join(c["design"]) for c in summary["controllers"]
             if c.get("design")]  # fmt: skip
    if notes:
        lines += ["", "Design remarks:", "", *notes]
    lines += [
        "",
        f"## Metrics on the model (set-point step {summary['step']:.4g} {yu}, input load "
        f"{summary['load']:.4g} {uu}, each {summary['t_event']:g} s after the release to AUTO)",
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
    box_ = summary["box"]
    box = (f"gain ±{100 * box_['gain']:g} %, T ±{100 * box_['time_constant']:g} %, "
           f"L ±{100 * box_['dead_time']:g} %")  # fmt: skip
    heads = (f"| controller | IAE step [{iae_u}] | overshoot [%] | IAE load [{iae_u}] | "
             f"MV travel load [{mv_u}] |")  # fmt: skip
    cols = (("iae_tracking", 1.0), ("overshoot", 100.0), ("iae_load", 1.0), ("tv_u_load", 1.0))
    if any(m["corners"] for m in summary["metrics"].values()):
        lines += ["", f"## Spread over the 8 uncertainty corners ({box}): min .. max", "",
                  "The Smith predictor's and the delayed observer's model stay the nominal one.",
                  "", heads, "|---|---|---|---|---|"]  # fmt: skip
        for name, m in summary["metrics"].items():
            cells = [_range(m["corners"].get(k), scale) for k, scale in cols]
            lines.append(f"| {name} | " + " | ".join(cells) + " |")
    mc_s = summary.get("monte_carlo")
    if mc_s:
        lines += ["", f"## Over {mc_s['n']} models drawn uniformly from the box (seed "
                  f"{mc_s['seed']}): median / worst", "", heads,
                  "|---|---|---|---|---|"]  # fmt: skip
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
    tr = summary.get("tradeoff") or {}
    if any(tr.get(f) for f in ("PID", "ADRC")):
        lines += ["", "## Trade-off: robustness, load rejection and valve wear", "",
                  "The best of each family designed again at each Ms (same noise budget); load "
                  "IAE of the linear loop on the model.", "",
                  f"| family | candidate | Ms | IAE load [{iae_u}] | MV noise [{mv_u}] |",
                  "|---|---|---|---|---|"]  # fmt: skip
        for fam in ("PID", "ADRC"):
            f = tr.get(fam)
            if not f:
                continue
            for ms, iae, nz in zip(f["ms"], f["iae_load"], f["mv_noise"], strict=True):
                lines.append(f"| {fam} | {f['name']} | {_cell(ms, '.3f')} | {_cell(iae)} | "
                             f"{_cell(nz, '.3g')} |")  # fmt: skip
        lines += ["", "![trade-off](tradeoff.png)"]
    w = summary["winners"]
    lines += ["", "## Verdict", "",
              f"Winners (tie within {100 * w['band']:g} %): set-point step **{w['setpoint']}**, "
              f"load **{w['load']}**.", ""]  # fmt: skip
    lines += [f"- {s['text']}" for s in summary["verdict"]]
    files = ", ".join(f"`{p.name}`" for p in sorted(out.glob("compare*.toml")))
    lines += ["", f"The scenarios that were run: {files} (edit and run them with `ctrlblocks run "
              "FILE`); all numbers: `compare.json`.", ""]  # fmt: skip
    (out / "compare.md").write_text("\n".join(lines), encoding="utf-8")
