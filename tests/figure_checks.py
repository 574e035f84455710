"""Checks of a drawn matplotlib figure: what a reader would trip over.

:func:`figure_problems` finds a legend that covers data (any line of its
axes runs through the legend's box) and raw TeX in a text (``e^{jωh}`` outside
``$...$``, which matplotlib prints as typed).  The tests run it on every figure
the package saves (``watch_savefig``).
"""

from __future__ import annotations

import re
from typing import Any

RAW_TEX = re.compile(r"[\^_]\{|\\[A-Za-z]+")


def _outside_math(text: str) -> str:
    """The text without its ``$...$`` (mathtext) parts."""
    parts = re.split(r"(?<!\\)\$", text)
    return "".join(parts[0::2]) if len(parts) % 2 == 1 else text


def figure_problems(fig: Any) -> list[str]:
    """What is wrong with ``fig`` as a reader sees it (empty: nothing)."""
    from matplotlib.lines import Line2D
    from matplotlib.text import Text

    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    problems = []
    for t in fig.findobj(Text):
        s = t.get_text()
        if t.get_visible() and s and RAW_TEX.search(_outside_math(s)):
            problems.append(f"raw TeX in a text: {s!r}")
    for ax in fig.axes:
        leg = ax.get_legend()
        if leg is None or not leg.get_visible():
            continue
        box = leg.get_window_extent(renderer)
        for line in ax.get_lines():
            if not isinstance(line, Line2D) or not line.get_visible() or len(line.get_xdata()) < 1:
                continue
            path = line.get_transform().transform_path(line.get_path())
            if path.intersects_bbox(box, filled=False):
                problems.append(f"the legend of {ax.get_ylabel()!r} covers {line.get_label()!r}")
    return problems


def watch_savefig(monkeypatch: Any) -> list[str]:
    """Check every figure saved from now on; the problems found go to the returned list."""
    from matplotlib.figure import Figure

    found: list[str] = []
    real = Figure.savefig

    def savefig(self: Any, *args: Any, **kwargs: Any) -> Any:
        found.extend(f"{args[0] if args else ''}: {p}" for p in figure_problems(self))
        return real(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", savefig)
    return found
