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

The command prints which runs changed.

**Which operations depend on the CPU, and how the hashes are made independent
of it.**  Two libraries choose their code by the CPU they run on: numpy's
transcendental and power ufuncs (``exp``, ``log``, ``expm1``, ``power``, ...)
dispatch to SIMD kernels by the CPU's vector level (``X86_V3`` = AVX2/FMA,
``X86_V4`` = AVX-512), and OpenBLAS (numpy's and scipy's BLAS/LAPACK: the
least-squares fits of ``[controllers.tune]``, ``expm`` of the plant
discretisation) picks its kernels by the CPU core type.  Results differ in the
last bit between kernels: measured on an AVX-512 machine with the same numpy
and scipy, 17 of 19 shipped scenarios moved with numpy's AVX-512 kernels and
the other two with OpenBLAS's SkylakeX kernels; with both pinned every run
equals the hashes recorded on an AVX2 machine.  So the hashes are recorded and
checked under one pinned configuration (:data:`PINNED_ENV`: numpy at dispatch
level ``X86_V3``, OpenBLAS with its Haswell kernels), which every x86-64
machine with AVX2 and FMA can run: the test runs the simulator in a
subprocess with that environment, and this command re-runs itself in it.  A
machine that cannot (another architecture, a CPU without AVX2) has a stack of
its own (numpy and scipy versions and CPU level); the file keeps one set of
hashes per stack, the command replaces the set of the stack it runs on and
drops from the other sets every run whose hash moved here (a change of
behaviour makes them stale); the test skips, with the reason, on a stack with
no set.  Users get the same traces on such machines only when they pin the
same way; unpinned, a trace may differ in the last bits of a few samples.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import platform
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import scipy

from ctrlblocks.sim import run_scenario
from ctrlblocks.sim.loop import Run
from ctrlblocks.sim.report import load_shipped, shipped_scenarios

HASH_FILE = Path(__file__).with_name("trace_hashes.json")
ROOT = Path(__file__).resolve().parents[2]

PINNED_ENV = {
    # numpy's SIMD kernels of the X86_V3 level (AVX2/FMA): the AVX-512 ones are switched off
    "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR",
    # OpenBLAS's kernels for Haswell (AVX2/FMA), whatever core it runs on
    "OPENBLAS_CORETYPE": "Haswell",
    "OPENBLAS_NUM_THREADS": "1",
}
"""The numeric configuration the hashes are recorded in on x86-64 (module docstring)."""

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


def can_pin() -> bool:
    """True on an x86-64 machine whose CPU has numpy's ``X86_V3`` level (AVX2 and FMA)."""
    if platform.machine() not in ("x86_64", "AMD64"):
        return False
    try:
        from numpy._core._multiarray_umath import __cpu_features__
    except ImportError:
        return False
    return bool(__cpu_features__.get("X86_V3") or __cpu_features__.get("X86_V4"))


def is_pinned() -> bool:
    """True when this process runs in :data:`PINNED_ENV`."""
    return all(os.environ.get(k) == v for k, v in PINNED_ENV.items())


def pinned_run(*args: str, timeout: float = 600.0) -> subprocess.CompletedProcess[str]:
    """Run ``python -m tests.sim.make_trace_hashes ARGS`` in :data:`PINNED_ENV` (or as is)."""
    env = dict(os.environ)
    if can_pin():
        env.update(PINNED_ENV)
    src = str(ROOT / "src")
    env["PYTHONPATH"] = os.pathsep.join(p for p in (src, str(ROOT), env.get("PYTHONPATH")) if p)
    return subprocess.run(
        [sys.executable, "-m", "tests.sim.make_trace_hashes", *args],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=timeout, check=False,
    )


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


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if can_pin() and not is_pinned():  # record in the pinned configuration, whatever the CPU
        done = pinned_run(*args, timeout=3600.0)
        sys.stdout.write(done.stdout)
        sys.stderr.write(done.stderr)
        return done.returncode
    if args == ["--json"]:  # what the test reads: the stack and its hashes, nothing written
        json.dump({"stack": stack_versions(), "hashes": compute_hashes()}, sys.stdout)
        return 0
    if args:
        sys.stderr.write("usage: python -m tests.sim.make_trace_hashes [--json]\n")
        return 2
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
