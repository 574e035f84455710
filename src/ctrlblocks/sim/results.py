"""Result files of a scenario run: traces, ``metrics.json``, plots.

Layout of an output directory for scenario ``NAME``::

    NAME/metrics.json            a list: one object per controller and case
    NAME/claims.json             the source's claims, checked on the metrics
    NAME/trace_<ctrl>__<case>.csv  one per run (or .parquet when pyarrow is importable)
    NAME/<case>.png              upper: CV and SP, lower: MV

``<ctrl>`` and ``<case>`` are :func:`slug` forms of the names (``Tt = 0.05``
-> ``Tt_0.05``); two runs whose names give the same slug get ``-2``, ``-3``,
... so that every run has its own file (:func:`trace_names`).

``metrics.json`` holds a list of objects with the keys ``scenario``,
``controller``, ``case``, ``iae``, ``ise``, ``itae``, ``overshoot``,
``settling_time``, ``tv_u`` (and the other metrics of
:mod:`ctrlblocks.sim.metrics`; NaN as ``null``) and ``windows``, the same
metrics per event window.
"""

from __future__ import annotations

import csv
import importlib.util
import json
from pathlib import Path

from .loop import Run
from .names import plot_names, slug, trace_names, unique_slugs
from .runner import ScenarioResult

__all__ = [
    "plot_names",
    "slug",
    "trace_names",
    "unique_slugs",
    "write_claims",
    "write_metrics",
    "write_result",
    "write_trace",
]


def write_trace(run: Run, path: Path, fmt: str = "auto") -> Path:
    """Write the signals of ``run`` to ``path`` + ``.csv``/``.parquet``; return the file written.

    The suffix is appended (a dot in ``path``'s name, as in ``trace_Tt_0.05``,
    is kept).

    ``fmt`` is ``"csv"``, ``"parquet"`` (needs pyarrow) or ``"auto"`` (Parquet
    when pyarrow is importable, else CSV).
    """
    if fmt == "auto":
        fmt = "parquet" if importlib.util.find_spec("pyarrow") is not None else "csv"
    names = ["t", *[n for n in run.signals if n != "t"]]
    if fmt == "parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        out = path.with_name(path.name + ".parquet")
        pq.write_table(pa.table({n: run.signals[n] for n in names}), out)
        return out
    if fmt != "csv":
        raise ValueError(f"unknown trace format {fmt!r} (csv, parquet, auto)")
    out = path.with_name(path.name + ".csv")
    cols = [run.signals[n].tolist() for n in names]
    with out.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(names)
        for row in zip(*cols, strict=True):
            w.writerow([repr(x) for x in row])
    return out


def write_metrics(result: ScenarioResult, path: Path) -> Path:
    """Write ``result.metrics`` (a list, one object per controller and case) to ``path``."""
    path.write_text(json.dumps(result.metrics, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    return path


def write_claims(result: ScenarioResult, path: Path) -> Path:
    """Write the checked claims of ``result`` as a JSON list to ``path``."""
    doc = [
        {
            "text": result.quoted(c.claim.text),
            "source": c.claim.source,
            "metric": c.claim.metric,
            "case": c.claim.case,
            "window": c.claim.window,
            "holds": c.holds,
            "detail": c.detail,
        }
        for c in result.claims
    ]
    path.write_text(json.dumps(doc, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    return path


def write_result(
    result: ScenarioResult, out_dir: Path, *, fmt: str = "auto", plots: bool = True
) -> dict[str, list[Path]]:
    """Write traces, ``metrics.json`` and plots of ``result`` under ``out_dir/NAME``.

    Returns the written files grouped as ``{"traces", "metrics", "plots"}``.
    """
    d = Path(out_dir) / result.scenario.name
    d.mkdir(parents=True, exist_ok=True)
    files: dict[str, list[Path]] = {"traces": [], "metrics": [], "plots": []}
    for run, name in zip(result.runs, trace_names(result.runs), strict=True):
        files["traces"].append(write_trace(run, d / name, fmt))
    files["metrics"].append(write_metrics(result, d / "metrics.json"))
    files["metrics"].append(write_claims(result, d / "claims.json"))
    if plots:
        from .plot import plot_result

        files["plots"].extend(plot_result(result, d))
    return files
