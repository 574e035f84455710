"""Numbers of a run quoted in a scenario's texts: written by the run, never typed.

A scenario's ``description``, ``notes`` and claim texts may quote a number the
run produces with a placeholder, which the report and ``ctrlblocks run`` fill
from the run they print::

    {iae:tracking:PID_FT}                 IAE of PID_FT over the case "tracking"
    {overshoot:tracking:PID_FT:1|%}       ... in event window 1, in percent
    {max(y):main:no anti-windup}          the largest y of the run (max, min, final,
                                          mean, max_step of any signal, as in claims)

``metric:case:controller[:window][|format]``; the format is a Python format
spec (default ``.4g``) or ``%`` (the value times 100, two significant digits,
with " %").  The parser checks every placeholder when the scenario is loaded
(:func:`check_quotes`: a metric, case, controller or window that does not
exist is an error at the text's key), so a quote cannot point at nothing; a
number the run leaves undefined is written "–".

Before this, ``nowak_fig7``'s notes typed PID_FT's tracking IAE as 4.8 and
its overshoot as 14 % while the run gave 4.445 and 7.3 %.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Sequence
from typing import Any

from .metrics import METRIC_NAMES

__all__ = ["QUOTE", "check_quotes", "fill", "quotes"]

QUOTE = re.compile(r"\{([^{}:|]+):([^{}:|]+):([^{}:|]+)(?::(\d+))?(?:\|([^{}]+))?\}")
"""A placeholder: ``{metric:case:controller[:window][|format]}``."""

_STAT = re.compile(r"(max|min|final|mean|max_step)\((\w+)\)")


def quotes(text: str) -> list[re.Match[str]]:
    """The placeholders of ``text``."""
    return list(QUOTE.finditer(text))


def check_quotes(
    text: str,
    controllers: Sequence[str],
    cases: Sequence[str],
    windows: Callable[[str], int | None],
) -> str | None:
    """What is wrong with the first bad placeholder of ``text`` (None: all good).

    ``windows(case)`` is the number of event windows of a case (None: not known).
    """
    for m in quotes(text):
        metric, case, ctrl, window, fmt = (g.strip() if g else g for g in m.groups())
        if metric not in METRIC_NAMES and not _STAT.fullmatch(metric):
            return (f"{m.group(0)}: unknown metric {metric!r}; expected one of "
                    f"{', '.join(METRIC_NAMES)}, or max(y), min(u), final(y), ...")  # fmt: skip
        if case not in cases:
            return f"{m.group(0)}: no case {case!r}; the cases: {', '.join(cases)}"
        if ctrl not in controllers:
            have = ", ".join(controllers)
            return f"{m.group(0)}: no controller {ctrl!r}; the controllers: {have}"
        n = windows(case)
        if window is not None and n is not None and int(window) >= n:
            return f"{m.group(0)}: case {case!r} has event windows 0..{n - 1}"
        if fmt and fmt != "%":
            try:
                format(1.5, fmt)
            except ValueError:
                return f"{m.group(0)}: {fmt!r} is no number format (e.g. .3g, .1f or %)"
    return None


Lookup = Callable[[str, str, str, "int | None", "str | None"], float]
"""``(metric, case, controller, window, signal) -> value`` (``signal`` for a signal
statistic such as ``max(y)``: metric ``max``, signal ``y``); may raise KeyError/IndexError."""


def fill(text: str, value: Lookup) -> str:
    """``text`` with every placeholder replaced by the number ``value`` gives for it."""

    def number(m: re.Match[str]) -> str:
        metric, case, ctrl, window, fmt = (g.strip() if g else g for g in m.groups())
        w = None if window is None else int(window)
        stat = _STAT.fullmatch(metric)
        try:
            if stat:
                v = value(stat.group(1), case, ctrl, w, stat.group(2))
            else:
                v = value(metric, case, ctrl, w, None)
        except (KeyError, IndexError):
            return "–"
        return _formatted(v, fmt)

    return QUOTE.sub(number, text)


def _formatted(v: Any, fmt: str | None) -> str:
    if v is None or not math.isfinite(v):
        return "–"
    if fmt == "%":
        return f"{100.0 * v:.2g} %"
    return format(v, fmt or ".4g")
