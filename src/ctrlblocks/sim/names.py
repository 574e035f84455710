"""File names of a run's results: slugs of controller and case names, made distinct.

:func:`slug` turns a name into a file-name-safe form (``Tt = 0.05`` ->
``Tt_0.05``); :func:`unique_slugs` numbers collisions (``-2``, ``-3``, ...)
so that every run and every case has its own file.  The trace writer
(:mod:`.results`), the plots (:mod:`.plot`) and the report use them.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .loop import Run

__all__ = ["plot_names", "slug", "trace_names", "unique_slugs"]


def slug(text: str) -> str:
    """A file-name-safe form of ``text`` (letters, digits, ``-``, ``_``, ``.``)."""
    s = re.sub(r"[^A-Za-z0-9_.\-]+", "_", text).strip("_")
    return s or "x"


def unique_slugs(names: Sequence[str]) -> list[str]:
    """:func:`slug` of each name, made distinct by ``-2``, ``-3``, ... in order of appearance."""
    out: list[str] = []
    seen: set[str] = set()
    for name in names:
        base = s = slug(name)
        n = 1
        while s.lower() in seen:  # case-insensitive file systems
            n += 1
            s = f"{base}-{n}"
        seen.add(s.lower())
        out.append(s)
    return out


def trace_names(runs: Sequence[Run]) -> list[str]:
    """The trace file name (without suffix) of each run: ``trace_<ctrl>__<case>``, all distinct."""
    return unique_slugs([f"trace_{slug(r.controller)}__{slug(r.case)}" for r in runs])


def plot_names(case_names: Sequence[str]) -> list[str]:
    """The PNG file name (without suffix) of each case: its slug, all distinct."""
    return unique_slugs(case_names)
