"""Plots in the style of the sources' figures.

One PNG per case: the upper axes show the controlled variable of every
controller with the setpoint, the lower axes the manipulated variable
(Nowak et al. 2018, Figs. 5-7: "The upper diagram shows the controlled variable and the
lower – manipulating variable"; Åström's (1987) Simnon plots likewise).  One colour
per controller; dotted vertical lines mark the events, each labelled (the
event's ``label``) in a strip above the upper axes, where no label hides a trace or
another label; the legends sit right of the axes, where they hide no data either.
``[plot]`` in the scenario chooses the signals (``upper``, ``lower``), the axis
labels, and ``lower_per_controller`` (one lower axes per controller).

matplotlib is used with the non-interactive Agg backend, so plotting works
without a display.  Long traces are drawn decimated (:func:`decimate`: the
minimum and the maximum of every bin of samples, about two points per pixel
column), which leaves the picture the same and makes drawing -- and the
legend's placement, which scans every point -- cheaper; the trace files keep
every sample.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from .names import plot_names
from .runner import ScenarioResult

__all__ = ["case_figure", "decimate", "label_rows", "plot_result"]

PLOT_POINTS = 1500
"""Points drawn per line at most (the figures are 750 pixels wide at 100 dpi)."""


def decimate(
    t: np.ndarray, x: np.ndarray, points: int = PLOT_POINTS
) -> tuple[np.ndarray, np.ndarray]:
    """``(t, x)`` reduced to about ``points`` samples that draw the same line.

    The samples are cut into ``points / 2`` bins of equal length; of each bin
    the minimum and the maximum are kept (in time order), and the first and
    last samples always.  A NaN in a bin is kept (it is the minimum), so gaps
    stay gaps.  Shorter traces are returned as they are.
    """
    n = len(x)
    if n <= points:
        return t, x
    b = math.ceil(n / max(1, points // 2))
    m = n // b * b
    bins = x[:m].reshape(-1, b)
    base = np.arange(bins.shape[0]) * b
    keep = np.concatenate(([0], base + bins.argmin(axis=1), base + bins.argmax(axis=1),
                           np.arange(m, n), [n - 1]))  # fmt: skip
    idx = np.unique(keep)
    return t[idx], x[idx]


_STYLES = ["-", "--", "-.", ":"]
_COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#17becf"]
_SIGNAL_STYLE = {
    "sp": {"color": "black", "linestyle": "--", "linewidth": 1.0},
}
_LABELS = {
    "sp": "setpoint",
    "y": "y",
    "ym": "y measured",
    "u": "u",
    "v": "controller output v",
    "y2": "y2 (inner)",
    "sp2": "secondary setpoint",
    "ff": "feed-forward",
    "y_pred": "predictor output",
    "load": "load",
}


def plot_result(result: ScenarioResult, out_dir: Path, *, dpi: int = 100) -> list[Path]:
    """Draw one PNG per case of ``result`` into ``out_dir``; return the files."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    sc = result.scenario
    files = []
    case_names = [c.name for c in sc.cases]
    names_png = dict(zip(case_names, plot_names(case_names), strict=True))
    for case in sc.cases:
        fig = case_figure(result, case.name)
        if fig is None:
            continue
        path = out_dir / f"{names_png[case.name]}.png"
        fig.savefig(path, dpi=dpi)
        plt.close(fig)
        files.append(path)
    return files


LEGEND_WIDTH = 1.9
"""Width of the legend column right of the axes [inch]: legends sit outside the data."""


def case_figure(result: ScenarioResult, case: str) -> Any:
    """The matplotlib figure of one case (None when the case has no run).

    The upper axes show ``[plot] upper`` (default set point and ``y``), the
    lower ones ``lower`` (default ``u``) -- with ``lower_per_controller`` one
    lower axes per controller, so that an MV held flat is not hidden inside
    another controller's noisy one.  Legends sit right of the axes, never on
    the data; with several controllers and several signals the colour names
    the controller and the line style the signal.
    """
    import matplotlib.pyplot as plt

    sc = result.scenario
    cfg: dict[str, Any] = dict(sc.plot)
    upper = list(cfg.get("upper", ["sp", "y"]))
    lower = list(cfg.get("lower", ["u"]))
    runs = [r for r in result.runs if r.case == case]
    if not runs:
        return None
    per_ctrl = bool(cfg.get("lower_per_controller")) and lower and len(runs) > 1
    groups: list[tuple[list[str], list[Any], str]] = [(upper, runs, "upper_label")]
    if per_ctrl:
        groups += [(lower, [r], "lower_label") for r in runs]
    elif lower:
        groups.append((lower, runs, "lower_label"))
    heights = [2.4 if i == 0 else (2.0 if not per_ctrl else 1.35) for i in range(len(groups))]
    fig, axes = plt.subplots(
        len(groups), 1, sharex=True, figsize=(7.5 + LEGEND_WIDTH, 0.8 + sum(heights)),
        squeeze=False, height_ratios=heights,
    )  # fmt: skip
    ax_list = [a[0] for a in axes]
    colors = {
        c.name: (c.options.get("color") or _COLORS[i % len(_COLORS)])
        for i, c in enumerate(sc.controllers)
    }
    for ax, (names, group, label_key) in zip(ax_list, groups, strict=True):
        single = len(runs) == 1
        _draw(ax, group, names, colors, single=single, legend=cfg.get("legend", {}))
        ax.set_ylabel(cfg.get(label_key, _default_label(names)), fontsize=8 if per_ctrl else None)
        ax.grid(True, alpha=0.3)
        for ev in runs[0].events:
            if ev.t > 0:
                ax.axvline(ev.t, color="0.6", linestyle=":", linewidth=0.8)
        _legend(ax, group, names, colors, single, cfg.get("legend", {}))
    if "ylim_upper" in cfg:
        ax_list[0].set_ylim(*cfg["ylim_upper"])
    if "ylim_lower" in cfg:
        for ax in ax_list[1:]:
            ax.set_ylim(*cfg["ylim_lower"])
    ax_list[-1].set_xlabel("t [s]")
    ax_list[-1].set_xlim(0.0, runs[0].duration)
    fig.tight_layout()
    label_rows_used = _label_events(ax_list[0], runs[0].events)
    title = cfg.get("title", sc.title)
    if len(sc.cases) > 1:
        title += f" — {case}"
    if result.quick:
        title += " (quick)"
    ax_list[0].set_title(f"{title}\n{sc.source}", fontsize=9, pad=6.0 + label_rows_used * _ROW_PT)
    fig.tight_layout()
    return fig


def _legend(ax: Any, runs: list, names: list[str], colors: dict[str, str], single: bool,
            legend: dict[str, str]) -> None:  # fmt: skip
    """The legend of ``ax``, right of it (outside the data).

    Several controllers with several signals each: one entry per controller
    (its colour) and one per signal (its line style), instead of one per line.
    """
    from matplotlib.lines import Line2D

    kw = {"fontsize": 7, "loc": "upper left", "bbox_to_anchor": (1.01, 1.0), "borderaxespad": 0.0}
    drawn = [n for n in names if n != "sp" and any(n in r.signals for r in runs)]
    if single or len(drawn) <= 1:
        ax.legend(**kw)
        return
    labels = _LABELS | dict(legend)
    handles = [h for h in ax.get_lines() if h.get_label() == labels["sp"]][:1]
    handles += [Line2D([], [], color=colors[r.controller], label=r.controller) for r in runs]
    handles += [
        Line2D([], [], color="0.25", linestyle=_STYLES[k % len(_STYLES)], label=labels.get(n, n))
        for k, n in enumerate(drawn)
    ]
    ax.legend(handles=handles, **kw)


EVENT_FONT = 6.0
"""Font size of the event labels [pt]."""
_ROW_PT = 8.0
"""Height of one row of event labels above the axes [pt]."""


def label_rows(x0: list[float], widths: list[float], gap: float = 0.01) -> list[int]:
    """The row of each label in a strip above the axes, so that none overlaps another.

    ``x0`` are the labels' left edges and ``widths`` their widths, both as
    fractions of the axes' width, in any order.  A label goes into the lowest
    row whose last label ends (plus ``gap``) before it starts: the greedy
    interval-partitioning rule, which uses as few rows as the labels' largest
    pile-up needs.
    """
    rows = [0] * len(x0)
    ends: list[float] = []
    for i in sorted(range(len(x0)), key=lambda k: x0[k]):
        free = [r for r, end in enumerate(ends) if end + gap <= x0[i]]
        if free:
            r = free[0]
        else:
            r = len(ends)
            ends.append(-math.inf)
        ends[r] = x0[i] + widths[i]
        rows[i] = r
    return rows


def _label_events(ax: Any, events: Any) -> int:
    """Write each event's label in a strip above ``ax``, starting at its line.

    Labels sit outside the plotting area, so they never hide a trace; labels
    that would run into each other go into further rows (:func:`label_rows`).
    Events at the same time share one label (joined with "; "); events at
    t = 0 are initial conditions and get none.  Returns the number of rows.
    """
    at: dict[float, list[str]] = {}
    for ev in events:
        if ev.t > 0 and ev.label:
            at.setdefault(ev.t, []).append(ev.label)
    if not at:
        return 0
    fig = ax.figure
    x_lo, x_hi = ax.get_xlim()
    width_pt = ax.get_position().width * fig.get_figwidth() * 72.0
    texts = {t_ev: "; ".join(labels) for t_ev, labels in at.items()}
    times = sorted(texts)
    x0 = [(t_ev - x_lo) / (x_hi - x_lo) for t_ev in times]
    # Width of a label: about 0.55 em per character of the sans-serif font.
    widths = [(len(texts[t_ev]) * 0.55 * EVENT_FONT + 4.0) / width_pt for t_ev in times]
    rows = label_rows(x0, widths)
    for t_ev, row in zip(times, rows, strict=True):
        ax.annotate(
            texts[t_ev],
            xy=(t_ev, 1.0),
            xycoords=("data", "axes fraction"),
            xytext=(1.5, 2.0 + row * _ROW_PT),
            textcoords="offset points",
            va="bottom",
            ha="left",
            fontsize=EVENT_FONT,
            color="0.3",
            annotation_clip=False,
        )
    return max(rows) + 1


def _default_label(names: list[str]) -> str:
    return ", ".join(_LABELS.get(n, n) for n in names if n != "sp") or "signal"


def _draw(
    ax: Any,
    runs: list,
    names: list[str],
    colors: dict[str, str],
    single: bool,
    legend: dict[str, str],
) -> None:
    labels = _LABELS | dict(legend)
    sp_drawn = False
    for run in runs:
        t = run.signals["t"]
        k = 0
        for name in names:
            if name not in run.signals:
                continue
            if name == "sp":
                if not sp_drawn:
                    ax.plot(*decimate(t, run.signals["sp"]), label=labels["sp"],
                            **_SIGNAL_STYLE["sp"])  # fmt: skip
                    sp_drawn = True
                continue
            if single:
                color = _COLORS[k % len(_COLORS)]
                label = labels.get(name, name)
                ls = "-"
            else:
                color = colors[run.controller]
                label = run.controller if k == 0 else f"{run.controller}: {labels.get(name, name)}"
                ls = _STYLES[k % len(_STYLES)]
            lw = 1.2 if single or name not in ("u", "u_act", "v") else 0.9
            ax.plot(
                *decimate(t, run.signals[name]),
                color=color,
                linestyle=ls,
                linewidth=lw,
                label=label,
                alpha=1.0 if single else 0.85,
            )
            k += 1
