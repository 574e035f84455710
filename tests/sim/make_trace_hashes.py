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
for one numeric stack: the file records the numpy and scipy versions, and the
test skips (with the reason) under other versions.
"""

from __future__ import annotations

import hashlib
import json
import logging
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


def stack_versions() -> dict[str, str]:
    """The numeric stack the hashes are valid for."""
    return {"numpy": np.__version__, "scipy": scipy.__version__}


def compute_hashes() -> dict[str, str]:
    """Run every shipped scenario (full length) and hash every run."""
    out: dict[str, str] = {}
    for sc in load_shipped([p.stem for p in shipped_scenarios()]):
        log.info("running %s", sc.name)
        for run in run_scenario(sc).runs:
            out[run_key(run)] = run_hash(run)
    return out


def load_hash_file() -> dict[str, Any]:
    """The stored file: ``{"versions": {...}, "hashes": {key: sha256}}``."""
    return json.loads(HASH_FILE.read_text(encoding="utf-8"))


def main() -> int:
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    new = compute_hashes()
    old = load_hash_file()["hashes"] if HASH_FILE.exists() else {}
    for key in sorted(set(old) | set(new)):
        if old.get(key) != new.get(key):
            what = "new" if key not in old else "gone" if key not in new else "changed"
            log.info("%-8s %s", what, key)
    data = {"versions": stack_versions(), "hashes": dict(sorted(new.items()))}
    HASH_FILE.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    log.info("wrote %d hashes to %s", len(new), HASH_FILE.name)
    return 0


if __name__ == "__main__":
    sys.exit(main())
