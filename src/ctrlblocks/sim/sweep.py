"""Sweeps: run a scenario for many parameter sets on a ``concurrent.futures`` executor.

A sweep varies keys of a scenario file (TOML) over lists of values and runs
every combination with :func:`ctrlblocks.sim.run_scenario` (the simulator's
own loading, wiring and metrics; nothing is re-implemented here).  Each run is
independent and seeded by the scenario, so the order and the place of
execution do not change the numbers: a sweep on a process pool, on a Dask
cluster or in a plain loop gives the same rows.

Keys are the key paths of the scenario file, as its error messages print them:
``controllers[1].kp``, ``plant.substeps``, ``sensor.noise``,
``cases[0].events[1].value``, ``scenario.seed``.

Executors
---------
* default: :class:`concurrent.futures.ProcessPoolExecutor` with one process
  per core (near-linear scaling: the runs share nothing);
* ``executor="serial"``: in this process, one after the other;
* any :class:`concurrent.futures.Executor` you pass, e.g. a thread pool, or
* a Dask cluster: :func:`dask_executor` (``pip install 'ctrlblocks[dask]'``)
  returns the ``concurrent.futures`` executor of a ``distributed.Client`` --
  a ``LocalCluster`` by default, or the scheduler at ``address`` to go beyond
  one machine.  The sweep code is the same for all of them.

Example
-------
>>> from ctrlblocks.sim import sweep
>>> rows = sweep("nowak_fig7", {"controllers[2].kp": [5.0, 6.31]},
...              duration=20.0, executor="serial")                  # doctest: +SKIP
>>> sorted({r["controllers[2].kp"] for r in rows})                   # doctest: +SKIP
[5.0, 6.31]
"""

from __future__ import annotations

import concurrent.futures as cf
import copy
import functools
import itertools
import logging
import math
import os
import re
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

__all__ = [
    "SweepError",
    "apply_key",
    "batch_size",
    "dask_executor",
    "parameter_sets",
    "process_pool",
    "read_scenario_text",
    "run_batch",
    "run_one",
    "sweep",
    "write_rows",
]

log = logging.getLogger("ctrlblocks.sim.sweep")

_KEY_RE = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)((?:\[\d+\])*)")


class SweepError(ValueError):
    """A sweep key or value does not fit the scenario."""


def read_scenario_text(scenario: str | Path) -> tuple[str, str]:
    """``(text, file)`` of a scenario file, or of a shipped scenario given by name."""
    p = Path(scenario)
    if p.is_file():
        from ..loops.toml import read_text
        from .scenario import ScenarioError

        return read_text(p, ScenarioError), str(p)  # not UTF-8: file, line and byte
    name = p.name[:-5] if p.name.endswith(".toml") else p.name
    shipped = resources.files("ctrlblocks") / "scenarios" / f"{name}.toml"
    if shipped.is_file():
        return shipped.read_text(encoding="utf-8"), f"{name}.toml"
    raise SweepError(f"no scenario file {scenario!s} (and no shipped scenario {name!r})")


def apply_key(doc: dict[str, Any], key: str, value: Any) -> None:
    """Set ``doc[key path] = value`` in a parsed scenario document (in place).

    ``key`` is dotted with list indices, e.g. ``controllers[1].kp``.  Every
    step but the last must exist; the last may be new (the scenario parser
    then judges it).
    """
    parts = key.split(".")
    node: Any = doc
    for n, part in enumerate(parts):
        m = _KEY_RE.fullmatch(part)
        if m is None:
            raise SweepError(f"bad key {key!r} (expected e.g. controllers[1].kp)")
        name, idx = m.group(1), [int(i) for i in re.findall(r"\[(\d+)\]", m.group(2))]
        last = n == len(parts) - 1
        if not isinstance(node, dict):
            raise SweepError(f"{key}: {'.'.join(parts[:n])} is not a table")
        if last and not idx:
            node[name] = value
            return
        if name not in node:
            from ..loops.toml import unknown_key_problem

            where = ".".join(parts[:n]) or "the scenario"
            raise SweepError(f"{key}: {where}: {unknown_key_problem(name, node)}")
        node = node[name]
        for j, i in enumerate(idx):
            if not isinstance(node, list) or i >= len(node):
                raise SweepError(f"{key}: index [{i}] is out of range")
            if last and j == len(idx) - 1:
                node[i] = value
                return
            node = node[i]


def parameter_sets(vary: Mapping[str, Sequence[Any]]) -> list[dict[str, Any]]:
    """Every combination of the varied values (Cartesian product, first key slowest)."""
    keys = list(vary)
    for k in keys:
        if len(vary[k]) == 0:
            raise SweepError(f"{k}: no values to vary")
    return [dict(zip(keys, combo, strict=True)) for combo in itertools.product(*vary.values())]


@functools.lru_cache(maxsize=4)
def _document(text: str, file: str) -> dict[str, Any]:
    """The TOML document of a scenario, read once per process (never modified: copied)."""
    from ..loops.toml import read_toml
    from .scenario import ScenarioError

    return read_toml(text, file, ScenarioError)


def _scenario(text: str, file: str, params: Mapping[str, Any]) -> Any:
    """The scenario of ``text`` with the keys of ``params`` set (the simulator's parser).

    The text is read once per process (:func:`_document`; reading the TOML was
    about 60 % of a set's parsing, paid for every set in the parent's check and
    again in the worker), each set works on a deep copy of it.  The text is
    scanned for the line of a key path only when a set is refused.
    """
    from .scenario import parse_scenario_doc

    doc = copy.deepcopy(_document(text, file))
    for k, v in params.items():
        apply_key(doc, k, v)
    return parse_scenario_doc(doc, file=file, text=text)  # an error: the line of its key


def run_one(
    text: str,
    file: str,
    params: Mapping[str, Any],
    quick: bool = False,
    duration: float | None = None,
    engine: str = "auto",
) -> list[dict[str, Any]]:
    """Run one parameter set; one row per controller and case (metrics, no traces).

    A module-level function of plain arguments, so that any executor (process
    pool, Dask) can ship it to a worker.
    """
    from .runner import run_scenario

    sc = _checked(text, file, params)
    result = run_scenario(sc, quick=quick, duration=duration, engine=engine)
    claims = {
        f"claim {i}": (None if c.holds is None else bool(c.holds))
        for i, c in enumerate(result.claims)
    }
    rows = []
    for m in result.metrics:
        row = dict(params)
        row.update({k: v for k, v in m.items() if k not in ("windows", "scenario")})
        row.update(claims)
        rows.append(row)
    return rows


def sweep(
    scenario: str | Path,
    vary: Mapping[str, Sequence[Any]],
    *,
    executor: cf.Executor | str | None = None,
    quick: bool = False,
    duration: float | None = None,
    progress: Callable[[int, int], None] | None = None,
    batch: int | None = None,
    engine: str = "auto",
) -> list[dict[str, Any]]:
    """Run ``scenario`` for every combination of the values in ``vary``.

    Parameters
    ----------
    scenario : str or Path
        A scenario file, or the name of a shipped scenario (``"nowak_fig7"``).
    vary : mapping
        Key path -> list of values (see the module docstring).
    executor : Executor, "serial" or None
        Where the runs go; None = a process pool with one worker per core
        (made and shut down here).
    quick, duration, engine
        As :func:`ctrlblocks.sim.run_scenario`.
    progress : callable, optional
        Called as ``progress(0, total)`` once every parameter set has been
        checked, then as ``progress(done, total)`` after each finished run.
    batch : int, optional
        Parameter sets per task sent to the executor.  Default: sized from
        the time of the first run (measured in the worker) to about
        :data:`TASK_SECONDS` of work per task, but no larger than gives
        every worker a task -- so the per-task cost of the executor (a few
        ms on a process pool or Dask) stays small against the work.

    Returns
    -------
    list of dict
        One row per parameter set, controller and case, in the order of
        :func:`parameter_sets`: the varied values, ``controller``, ``case``,
        every metric and ``claim i`` (True/False/None).
    """
    from .runner import check_duration

    try:
        check_duration(duration)
    except ValueError as exc:
        raise SweepError(str(exc)) from None
    text, file = read_scenario_text(scenario)
    sets = parameter_sets(vary)
    for params in _probes(sets, vary):  # a bad key or value before sending work anywhere
        sc = _checked(text, file, params)
        try:
            check_duration(duration, sc.ts)  # a run of no sample
        except ValueError as exc:
            raise SweepError(str(exc)) from None
    if progress is not None:
        progress(0, len(sets))
    return _flatten(_run_sets(text, file, sets, executor, quick, duration, progress, batch, engine))


TASK_SECONDS = 0.1
"""Work per task the automatic batch size of :func:`sweep` aims at [s]."""


def _probes(sets: list[dict[str, Any]], vary: Mapping[str, Sequence[Any]]) -> list[dict[str, Any]]:
    """The sets the parent checks before any run: the first, and each other value of a key in it.

    Every key and every value is so checked once, in ``1 + sum(len(values) - 1)``
    parses instead of one per set: checking all of them in the parent was a
    serial share that capped what more workers could gain (480 sets: about 1 s
    of 4).  A value that is refused only in combination with another (``u_min``
    above a ``u_max`` varied too) is found by the worker that runs that set, and
    the sweep stops with the same error (:func:`run_batch`).
    """
    if not sets:
        return []
    first = sets[0]
    probes = [first]
    for key, values in vary.items():
        probes += [{**first, key: v} for v in values if v != first[key]]
    return probes


def _checked(text: str, file: str, params: Mapping[str, Any]) -> Any:
    """:func:`_scenario`, a refusal as a :class:`SweepError` naming the set's values."""
    from .scenario import ScenarioError

    try:
        return _scenario(text, file, params)
    except ScenarioError as exc:
        given = ", ".join(f"{k} = {v!r}" for k, v in params.items())
        raise SweepError(f"with {given}: {exc}") from None


def _run_sets(
    text: str,
    file: str,
    sets: list[dict[str, Any]],
    executor: cf.Executor | str | None,
    quick: bool,
    duration: float | None,
    progress: Callable[[int, int], None] | None,
    batch: int | None,
    engine: str = "auto",
) -> list[list[dict[str, Any]]]:
    """The rows of every parameter set, in order; batches of sets go to the executor.

    Without a given ``batch`` the first task per worker is one set; the time
    the first one took (measured in the worker) sizes the batches of the
    rest (:func:`batch_size`), and towards the end a task never takes more
    than ``1 / (2 workers)`` of the sets left (guided self-scheduling,
    Polychronopoulos & Kuck 1987), so that the workers finish together
    instead of one waiting for the other's last large batch.  At most two
    tasks per worker are in flight, so the workers never wait for the next
    task.
    """
    total = len(sets)
    rows: list[list[dict[str, Any]] | None] = [None] * total

    def report(n: int) -> None:
        if progress is not None:
            progress(n, total)

    if executor == "serial":
        for i, params in enumerate(sets):
            rows[i] = run_one(text, file, params, quick, duration, engine)
            report(i + 1)
        return rows  # type: ignore[return-value]
    own = executor is None
    workers = min(total, os.cpu_count() or 1) if own else _workers(executor)
    ex: cf.Executor = (
        cf.ProcessPoolExecutor(max_workers=workers) if own else executor  # type: ignore[assignment]
    )
    size = None if batch is None else max(1, int(batch))
    nxt, done = 0, 0
    running: dict[cf.Future[Any], tuple[int, int]] = {}

    def submit(n: int) -> None:
        nonlocal nxt
        if batch is None:  # guided: never more than an even share of what is left
            n = max(1, min(n, math.ceil((total - nxt) / (2 * workers))))
        chunk = sets[nxt : nxt + n]
        fut = ex.submit(_timed_batch, text, file, chunk, quick, duration, engine)
        running[fut] = (nxt, len(chunk))
        nxt += len(chunk)

    try:
        for _ in range(min(workers, total)):
            submit(1 if size is None else size)
        while running:
            finished, _pending = cf.wait(running, return_when=cf.FIRST_COMPLETED)
            for fut in finished:
                start, n = running.pop(fut)
                batch_rows, seconds = fut.result()
                rows[start : start + n] = batch_rows
                done += n
                if size is None:
                    size = batch_size(seconds / n, total - nxt, workers)
                    log.debug("sweep: %.3f s per set -> %d sets per task", seconds / n, size)
                report(done)
            while nxt < total and len(running) < 2 * workers:
                submit(size or 1)
    finally:
        if own:
            ex.shutdown(cancel_futures=True)
    return rows  # type: ignore[return-value]


def process_pool(workers: int | None, tasks: int) -> cf.ProcessPoolExecutor:
    """A process pool of ``workers`` processes (None: one per core), never more than ``tasks``.

    The pool forks all its workers at the first task: ``--workers 100000`` for
    one parameter set would fork a hundred thousand processes.
    """
    want = (os.cpu_count() or 1) if workers is None else int(workers)
    if want < 1:
        raise SweepError(f"workers: must be at least 1, got {workers!r}")
    return cf.ProcessPoolExecutor(max_workers=max(1, min(want, tasks)))


def batch_size(seconds_per_set: float, n_sets: int, workers: int) -> int:
    """Sets per task: about :data:`TASK_SECONDS` of work, but at least one task per worker."""
    want = math.ceil(TASK_SECONDS / max(seconds_per_set, 1e-6))
    return max(1, min(want, math.ceil(n_sets / max(workers, 1))))


def _workers(executor: Any) -> int:
    """Workers behind ``executor`` (a pool's ``_max_workers``, a Dask client's threads)."""
    n = getattr(executor, "_max_workers", None)
    client = getattr(executor, "_client", None)
    if n is None and client is not None:
        try:
            n = sum(client.nthreads().values())
        except Exception:  # pragma: no cover - a client without workers yet
            n = None
    return int(n) if n else os.cpu_count() or 1


def run_batch(
    text: str,
    file: str,
    sets: Sequence[Mapping[str, Any]],
    quick: bool = False,
    duration: float | None = None,
    engine: str = "auto",
) -> list[list[dict[str, Any]]]:
    """:func:`run_one` for each parameter set of ``sets``, in order (one executor task)."""
    return [run_one(text, file, params, quick, duration, engine) for params in sets]


def _timed_batch(
    text: str,
    file: str,
    sets: Sequence[Mapping[str, Any]],
    quick: bool,
    duration: float | None,
    engine: str = "auto",
) -> tuple[list[list[dict[str, Any]]], float]:
    """:func:`run_batch` and the seconds it took in the worker."""
    t0 = time.perf_counter()
    out = run_batch(text, file, sets, quick, duration, engine)
    return out, time.perf_counter() - t0


def _flatten(results: Iterable[list[dict[str, Any]]]) -> list[dict[str, Any]]:
    return [row for rows in results for row in rows]


def dask_executor(address: str | None = None, **cluster_kwargs: Any) -> cf.Executor:
    """A ``concurrent.futures`` executor on a Dask cluster (``pip install 'ctrlblocks[dask]'``).

    ``address`` of a running scheduler (``"tcp://host:8786"``), or None for a
    ``distributed.LocalCluster`` on this machine (``cluster_kwargs`` go to
    it, e.g. ``n_workers=2, processes=True``).  The executor's ``shutdown()``
    closes the client (and the local cluster).
    """
    try:
        from distributed import Client, LocalCluster
    except ImportError:  # pragma: no cover - depends on the environment
        raise ImportError(
            "the Dask executor needs the 'dask' extra: pip install 'ctrlblocks[dask]'"
        ) from None
    if address is None:
        cluster = LocalCluster(**cluster_kwargs)
        client = Client(cluster)
    else:
        cluster = None
        client = Client(address)
    ex = client.get_executor()
    base_shutdown = ex.shutdown

    def shutdown(wait: bool = True, **kw: Any) -> None:
        base_shutdown(wait=wait)
        client.close()
        if cluster is not None:
            cluster.close()

    ex.shutdown = shutdown  # type: ignore[method-assign]
    return ex


def write_rows(rows: Sequence[Mapping[str, Any]], path: str | Path) -> Path:
    """Write the sweep rows to Parquet (pyarrow), or to CSV when pyarrow is absent.

    A path ending in ``.csv`` always gives CSV.  Returns the path written
    (``.csv`` instead of ``.parquet`` on the fallback).
    """
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    cols: list[str] = []
    for r in rows:
        cols.extend(k for k in r if k not in cols)
    if p.suffix != ".csv":
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:
            log.warning("pyarrow is not installed: writing CSV instead of Parquet")
            p = p.with_suffix(".csv")
        else:
            table = pa.Table.from_pylist([{c: r.get(c) for c in cols} for r in rows])
            pq.write_table(table, p)
            return p
    import csv

    with p.open("w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=cols)
        w.writeheader()
        for r in rows:
            w.writerow({c: "" if r.get(c) is None else r.get(c) for c in cols})
    return p
