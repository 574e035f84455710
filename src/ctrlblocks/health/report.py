"""The assessment report: Markdown and a PNG per loop, and the JSON summary of the findings.

``write_report(assessments, data, out_dir)`` writes ``out_dir/report.md`` (a table of
every loop's figures, its findings and notes, the plot beneath) and
``out_dir/<loop>.png``: setpoint and PV, MV with its limits, the mode, the spans of
a detected oscillation shaded, and for an oscillating loop the cross-correlation
of Horch's test.  ``summary(assessments)`` is the ``--json`` document.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .assess import Assessment, LoopData

__all__ = ["summary", "write_report"]

_POINTS = 1500
"""Points drawn per line at most (a 750-pixel-wide figure)."""


def summary(assessments: Sequence[Assessment]) -> dict[str, Any]:
    """The ``--json`` summary: every finding (kind, loop, time span, figures), then each loop."""
    return {
        "findings": [f.as_dict() for a in assessments for f in a.findings],
        "loops": [a.as_dict() for a in assessments],
    }


def summary_json(assessments: Sequence[Assessment]) -> str:
    """:func:`summary` as JSON text (no NaN: null)."""
    return json.dumps(summary(assessments), indent=2, ensure_ascii=False, allow_nan=False)


def slug(name: str) -> str:
    """A file name for a loop name."""
    s = re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("._") or "loop"
    return s[:80]


def png_names(loops: Sequence[str]) -> list[str]:
    """The PNG file name of each loop (unique, from :func:`slug`)."""
    names: list[str] = []
    for loop in loops:
        name = slug(loop)
        while f"{name}.png" in names:
            name += "_"
        names.append(f"{name}.png")
    return names


def write_report(
    assessments: Sequence[Assessment],
    records: Sequence[LoopData],
    out_dir: str | Path,
    *,
    plots: bool = True,
    plotted: bool = False,
) -> Path:
    """Write ``report.md`` (and a PNG per loop) into ``out_dir``; return the report's path.

    ``plotted``: the PNGs are there already (:func:`png_names`, drawn by the workers
    that assessed the loops); only link them.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    lines = ["# Loop health report", ""]
    n_find = sum(len(a.findings) for a in assessments)
    lines += [
        f"{len(assessments)} loop(s), {n_find} finding(s).  Definitions and sources of "
        "every figure: docs/health.md of ctrlblocks.",
        "",
    ]
    lines += ["| loop | findings |", "| --- | --- |"]
    for a in assessments:
        kinds = ", ".join(sorted({f.kind for f in a.findings})) or "none"
        lines.append(f"| {a.loop} | {kinds} |")
    lines.append("")
    for a, d, name in zip(assessments, records, png_names([a.loop for a in assessments]),
                          strict=True):  # fmt: skip
        lines += _loop_section(a, d)
        if plots:
            png = out / name
            if not plotted:
                plot_loop(a, d, png)
            lines += [f"![{a.loop}]({png.name})", ""]
    path = out / "report.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _fmt(v: Any) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return "-" if not math.isfinite(v) else f"{v:.4g}"
    if isinstance(v, dict):
        return ", ".join(f"{k} {100 * x:.1f} %" for k, x in v.items())
    return str(v)


_ROWS = (
    ("duration_s", "duration [s]", 1.0),
    ("time_in_mode", "time in each mode", None),
    ("time_at_u_min", "time at the MV low limit [%]", 100.0),
    ("time_at_u_max", "time at the MV high limit [%]", 100.0),
    ("time_bad_pv", "time with a bad PV [%]", 100.0),
    ("mv_travel_per_hour", "MV travel per hour [MV units]", 1.0),
    ("reversals_per_hour", "MV reversals per hour", 1.0),
    ("oscillation", "oscillation (Hägglund 1995)", None),
    ("oscillation_period_s", "oscillation period [s]", 1.0),
    ("oscillation_amplitude", "oscillation amplitude [PV units]", 1.0),
    ("stiction_test", "stiction test (Horch 1999)", None),
    ("ccf_asymmetry", "CCF asymmetry (0 even, +-1 odd)", 1.0),
    ("harris_index", "Harris index (1 = minimum variance)", 1.0),
    ("drift_gain", "re-identified gain", 1.0),
    ("drift_time_constant", "re-identified time constant [s]", 1.0),
    ("drift_dead_time", "re-identified dead time [s]", 1.0),
)


def _loop_section(a: Assessment, d: LoopData) -> list[str]:
    figs = a.figures()
    lines = [
        f"## {a.loop}",
        "",
        f"{d.start + ', ' if d.start else ''}t = {a.start:g} .. {a.end:g} s",
        "",
        "| figure | value |",
        "| --- | --- |",
    ]
    for key, label, scale in _ROWS:
        if key not in figs:
            continue
        v = figs[key]
        if scale is not None and isinstance(v, (int, float)) and not isinstance(v, bool):
            v = float(v) * scale
        lines.append(f"| {label} | {_fmt(v)} |")
    lines.append("")
    if a.findings:
        lines += ["Findings:", ""]
        lines += [f"- **{f.kind}** ({f.start:g} .. {f.end:g} s): {f.message}" for f in a.findings]
    else:
        lines.append("No finding.")
    lines.append("")
    if a.notes:
        lines += ["Notes:", ""] + [f"- {n}" for n in a.notes] + [""]
    return lines


def _decimate(t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Min and max of each bin: about ``_POINTS`` points that draw the same line."""
    n = t.size
    if n <= _POINTS:
        return t, x
    m = math.ceil(n / (_POINTS / 2))
    k = (n // m) * m
    tb = t[:k].reshape(-1, m)
    xb = x[:k].reshape(-1, m)
    lo = np.nanargmin(np.where(np.isfinite(xb), xb, np.inf), axis=1)
    hi = np.nanargmax(np.where(np.isfinite(xb), xb, -np.inf), axis=1)
    idx = np.sort(np.stack([lo, hi], axis=1), axis=1)
    rows = np.arange(tb.shape[0])[:, None]
    return tb[rows, idx].ravel(), xb[rows, idx].ravel()


def plot_loop(a: Assessment, d: LoopData, path: Path) -> None:
    """The loop's PNG: SP/PV, MV with limits, mode; Horch's CCF when it oscillates."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    ccf = a.horch is not None and a.horch.ccf.size > 0
    n_ax = 3 if ccf else 2
    fig, axes = plt.subplots(
        n_ax,
        1,
        figsize=(7.5, 2.2 * n_ax + 0.8),
        dpi=100,
        gridspec_kw={"height_ratios": [3, 2, 2][:n_ax]},
    )
    ax1, ax2 = axes[0], axes[1]
    t = d.t - d.t[0]
    unit = "h" if t[-1] > 7200 else "s"
    ts = t / 3600.0 if unit == "h" else t
    ax1.plot(*_decimate(ts, d.y), lw=0.7, color="C0", label="PV")
    ax1.plot(*_decimate(ts, d.sp), lw=1.0, color="k", ls="--", label="SP")
    for s0, s1 in a.osc.spans:
        f = 3600.0 if unit == "h" else 1.0
        ax1.axvspan((s0 - d.t[0]) / f, (s1 - d.t[0]) / f, color="C3", alpha=0.12, lw=0)
    ax1.set_ylabel("PV, SP [PV units]")
    kinds = ", ".join(sorted({f.kind for f in a.findings})) or "no finding"
    ax1.set_title(f"{a.loop}: {kinds}", fontsize=10)
    ax1.legend(loc="upper right", fontsize=8)
    ax2.plot(*_decimate(ts, d.u), lw=0.7, color="C2", label="MV")
    s = a.service
    ax2.axhline(s.u_min, color="C3", lw=0.8, ls=":", label="MV limits")
    ax2.axhline(s.u_max, color="C3", lw=0.8, ls=":")
    if d.mode is not None:
        man = ~d.auto
        if man.any():
            ax2.fill_between(
                ts,
                s.u_min,
                s.u_max,
                where=man,
                color="0.6",
                alpha=0.25,
                lw=0,
                label="not in AUTO",
                step="post",
            )
    ax2.set_ylabel("MV [MV units]")
    ax2.set_xlabel(f"time [{unit}]")
    ax2.legend(loc="upper right", fontsize=8)
    if ccf:
        assert a.horch is not None
        ax3 = axes[2]
        ax3.plot(a.horch.lags, a.horch.ccf, color="C4", lw=1.0)
        ax3.axhline(0.0, color="k", lw=0.5)
        ax3.axvline(0.0, color="k", lw=0.5, ls=":")
        ax3.set_xlabel("lag [s]")
        ax3.set_ylabel("r_uy")
        ax3.set_title(
            f"Horch (1999): cross-correlation MV-PV, {a.horch.verdict} "
            f"(asymmetry {a.horch.asymmetry:+.2f})",
            fontsize=9,
        )
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
