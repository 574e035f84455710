"""Loop health: the fault campaign's rates and the cost of the assessment.

    python benchmarks/health.py campaign [--seeds 60] [--jobs 2]
    python benchmarks/health.py offline [--loops 100] [--jobs 2]
    python benchmarks/health.py live [--loops 200]

* ``campaign``: simulate and assess ``seeds`` loops of each fault kind
  (ctrlblocks.health.faults) and print the detection and false-alarm rates
  (docs/health.md states them);
* ``offline``: a day of 1 s data for ``loops`` loops, written to a historian
  file, assessed by ``ctrlblocks assess`` with ``--jobs``; prints the wall time
  (target: under a minute on 2 cores);
* ``live``: the cost of the sliding-window assessment (ctrlblocks.health.live)
  of ``loops`` loops at 100 ms against the cost of the runtime's cycle of those
  loops (target: at most 10 % added).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from ctrlblocks.health.faults import EXPECTED, KINDS, assess_case, simulate


def _one(job: tuple[str, int]) -> tuple[str, int, list[str]]:
    kind, seed = job
    a = assess_case(simulate(kind, seed))
    return kind, seed, sorted({f.kind for f in a.findings})


def campaign(seeds: int, jobs: int) -> dict:
    todo = [(k, s) for k in KINDS for s in range(seeds)]
    rows = []
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=jobs) as ex:
        for i, r in enumerate(ex.map(_one, todo, chunksize=4)):
            rows.append(r)
            if (i + 1) % 30 == 0:
                print(f"  {i + 1}/{len(todo)} loops", file=sys.stderr, flush=True)
    out = {"seeds": seeds, "seconds": time.perf_counter() - t0, "kinds": {}}
    for kind in KINDS:
        found = [f for k, _, f in rows if k == kind]
        exp = EXPECTED[kind]
        hits = sum(bool(f) for f in found) if exp is None else sum(exp in f for f in found)
        counts: dict[str, int] = {}
        for f in found:
            for x in f:
                counts[x] = counts.get(x, 0) + 1
        out["kinds"][kind] = {
            "loops": len(found),
            "hits": hits,
            "findings": counts,
            "missed": [s for k, s, f in rows if k == kind and exp and exp not in f],
            "false": [s for k, s, f in rows if k == kind and not exp and f],
        }
    return out


def offline(loops: int, jobs: int) -> dict:
    import sqlite3

    from ctrlblocks.runtime.historian import SQLiteHistorian  # noqa: F401  (the file format)

    n = 86400
    np.random.default_rng(1)
    with tempfile.TemporaryDirectory() as d:
        db = Path(d) / "day.sqlite"
        con = sqlite3.connect(db)
        con.executescript(
            "CREATE TABLE runs (run_id INTEGER PRIMARY KEY, started REAL NOT NULL, stopped REAL, "
            "name TEXT); CREATE TABLE samples (run_id INTEGER NOT NULL, loop TEXT NOT NULL, "
            "cycle INTEGER NOT NULL, t_wall REAL NOT NULL, t REAL, dt REAL, sp REAL, pv REAL, "
            "mv REAL, mode TEXT, error_id INTEGER, pv_ok INTEGER, write_ok INTEGER, overrun "
            "INTEGER, PRIMARY KEY (run_id, cycle, loop)); CREATE INDEX samples_loop_time ON "
            "samples (loop, t_wall); CREATE TABLE audit (id INTEGER PRIMARY KEY AUTOINCREMENT, "
            "t_wall REAL NOT NULL, who TEXT, loop TEXT, action TEXT, old TEXT, new TEXT, ok "
            "INTEGER, message TEXT);"
        )
        con.execute("INSERT INTO runs VALUES (1, 0, NULL, 'bench')")
        t0 = 1.7e9
        kinds = KINDS
        for j in range(loops):
            c = simulate(kinds[j % len(kinds)], j, hours=24.0)
            dd = c.data
            rows = (
                (
                    1,
                    f"loop{j:03d}",
                    i,
                    t0 + dd.t[i],
                    dd.t[i],
                    1.0,
                    dd.sp[i],
                    dd.y[i],
                    dd.u[i],
                    dd.mode[i].lower(),
                    0,
                    1,
                    1,
                    0,
                )
                for i in range(n)
            )
            con.executemany("INSERT INTO samples VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?)", rows)
            print(f"  wrote loop {j + 1}/{loops}", file=sys.stderr, flush=True)
        con.commit()
        con.close()
        cmd = [
            sys.executable,
            "-c",
            "from ctrlblocks.cli import main; main()",
            "assess",
            str(db),
            "--jobs",
            str(jobs),
            "--out",
            str(Path(d) / "out"),
            "--u-min",
            "0",
            "--u-max",
            "100",
            "--pv-span",
            "100",
            "--json",
        ]
        t = time.perf_counter()
        c0 = os.times()
        p = subprocess.run(cmd, capture_output=True, text=True, check=True)
        wall = time.perf_counter() - t
        c1 = os.times()
        cpu = (c1.children_user + c1.children_system) - (c0.children_user + c0.children_system)
        found = json.loads(p.stdout)["findings"]
    return {
        "loops": loops,
        "samples_per_loop": n,
        "jobs": jobs,
        "wall_s": wall,
        "cpu_s": cpu,
        "findings": len(found),
        "cpus": os.cpu_count(),
    }


def live(loops: int) -> dict:
    from ctrlblocks.health.live import LiveAssessor

    return LiveAssessor.benchmark(loops)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("what", choices=("campaign", "offline", "live"))
    ap.add_argument("--seeds", type=int, default=60)
    ap.add_argument("--loops", type=int, default=None)
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args(argv)
    if a.what == "campaign":
        res = campaign(a.seeds, a.jobs)
    elif a.what == "offline":
        res = offline(a.loops or 100, a.jobs)
    else:
        res = live(a.loops or 200)
    print(json.dumps(res, indent=2))


if __name__ == "__main__":
    main()
