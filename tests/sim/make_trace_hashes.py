"""Record the hashes of every shipped scenario's simulated traces.

``tests/sim/test_trace_hashes.py`` runs every scenario of
``src/ctrlblocks/scenarios/*.toml`` through the simulator and compares the
SHA-256 of each run's signals (the raw float64 bytes, signal by signal in
name order) with ``tests/sim/trace_hashes.json``.  A refactoring must leave
every hash unchanged.

When a change is MEANT to change behaviour (a fixed block defect, a new event
handling), regenerate the file and say so in the commit message, naming the
scenarios whose hashes moved::

    PYTHONPATH=$PWD/src python -m tests.sim.make_trace_hashes

The command prints which runs changed.  The hashes are bit-exact, so they hold
for one numeric stack: the numpy and scipy versions **and the CPU's vector
level** (numpy's dispatch level, ``X86_V3`` = AVX2/FMA, ``X86_V4`` = AVX-512:
numpy's and the C library's ``exp``, ``log``, ... take other code paths on
another level: two of the shipped scenarios moved in the last bit between the
machine the hashes were first recorded on and an AVX2 one, same versions).  The file keeps one
set of hashes per stack; the command replaces the set of the stack it runs on,
and drops from the other sets every run whose hash moved here (a change of
behaviour makes them stale; run the command on such a machine to restore
them).  The test compares with the set of its own stack and skips (with the
reason) when there is none.
"""

from __future__ import annotations

import hashlib
import json
import logging
import platform
import sys
from pathlib import Path
from typing import Any

import numpy as np
import scipy

from ctrlblocks.sim import run_scenario
from ctrlblocks.sim.loop import Run
from ctrlblocks.sim.report import load_shipped, shipped_scenarios

HASH_FILE = Path(__file__).with_name("trace_hashes.json")

log = logging.getLogger(__name__)


def run_key(run: Run) -> str:
    """``scenario / controller / case``: the key of a run in the hash file."""
    return f"{run.scenario} / {run.controller} / {run.case}"


def run_hash(run: Run) -> str:
    """SHA-256 over the run's signal names and their float64 bytes, in name order."""
    h = hashlib.sha256()
    for name in sorted(run.signals):
        arr = np.ascontiguousarray(run.signals[name], dtype=np.float64)
        h.update(name.encode())
        h.update(str(arr.shape).encode())
        h.update(arr.tobytes())
    return h.hexdigest()


def cpu_level() -> str:
    """The highest of numpy's CPU dispatch levels this machine has (``X86_V3``, ``X86_V4``, ...)."""
    try:
        from numpy._core._multiarray_umath import (
            __cpu_baseline__,
            __cpu_dispatch__,
            __cpu_features__,
        )
    except ImportError:  # another numpy layout: the machine name only
        return platform.machine()
    have = [t for t in (*__cpu_baseline__, *__cpu_dispatch__) if __cpu_features__.get(t)]
    return f"{platform.machine()} {have[-1] if have else 'baseline'}"


def stack_versions() -> dict[str, str]:
    """The numeric stack the hashes are valid for: versions and CPU level (module docstring)."""
    return {"numpy": np.__version__, "scipy": scipy.__version__, "cpu": cpu_level()}


def compute_hashes() -> dict[str, str]:
    """Run every shipped scenario (full length) and hash every run."""
    out: dict[str, str] = {}
    for sc in load_shipped([p.stem for p in shipped_scenarios()]):
        log.info("running %s", sc.name)
        for run in run_scenario(sc).runs:
            out[run_key(run)] = run_hash(run)
    return out


def load_hash_file() -> list[dict[str, Any]]:
    """The stored sets: ``[{"versions": {...}, "hashes": {key: sha256}}, ...]``, one per stack."""
    if not HASH_FILE.exists():
        return []
    return list(json.loads(HASH_FILE.read_text(encoding="utf-8"))["stacks"])


def hashes_for(stack: dict[str, str]) -> dict[str, str] | None:
    """The stored hashes of ``stack``, None if none were recorded on it."""
    for entry in load_hash_file():
        if entry["versions"] == stack:
            return dict(entry["hashes"])
    return None


def main() -> int:
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    here = stack_versions()
    new = compute_hashes()
    old = hashes_for(here) or {}
    for key in sorted(set(old) | set(new)):
        if old.get(key) != new.get(key):
            what = "new" if key not in old else "gone" if key not in new else "changed"
            log.info("%-8s %s", what, key)
    # a run whose hash moved on this stack changed its behaviour: its hashes on the others are
    # stale (a run new to this stack says nothing about the others)
    moved = {k for k in old if old[k] != new.get(k)}
    stacks = [{"versions": here, "hashes": dict(sorted(new.items()))}]
    for entry in load_hash_file():
        if entry["versions"] == here:
            continue
        kept = {k: v for k, v in entry["hashes"].items() if k in new and k not in moved}
        if len(kept) < len(entry["hashes"]):
            log.info("dropped %d stale hashes of %s", len(entry["hashes"]) - len(kept),
                     entry["versions"])  # fmt: skip
        if kept:
            stacks.append({"versions": entry["versions"], "hashes": dict(sorted(kept.items()))})
    HASH_FILE.write_text(json.dumps({"stacks": stacks}, indent=1) + "\n", encoding="utf-8")
    log.info("wrote %d hashes for %s to %s", len(new), here, HASH_FILE.name)
    return 0


if __name__ == "__main__":
    sys.exit(main())
