"""The blocks compiled from their own source, per call (issue 18, goal 6).

Usage (from the repository root; needs Cython and a C compiler, and the
``bench`` extra for the peers)::

    python benchmarks/compiled_blocks.py             # build, check, time: a few minutes
    python benchmarks/compiled_blocks.py --rounds 9 --steps 20000
    python benchmarks/compiled_blocks.py --mypyc     # also try mypyc on the same files

What it does, in a temporary folder (the package itself is never touched):

1. copies ``src/ctrlblocks`` and compiles every module of ``blocks/`` (but the
   package ``__init__`` and the fuzz driver) with Cython in pure-Python mode:
   the ``.py`` files as they are, ``-ffp-contract=off`` so that the C
   compiler fuses no multiply-add the interpreter would round twice;
2. runs the fuzz campaign's seeded random actions (``ctrlblocks.blocks.fuzz``:
   inputs with NaN/inf, modes, limits, reconfiguration, snapshot/restore,
   reset) on every exported block with the interpreted and with the compiled
   blocks and compares ``out`` and ``error_id`` after every action (1e-12),
   against an uncompiled copy of the same files;
3. times one call of ``PID`` and ``ADRC`` against simple-pid and pyadrc, in
   fresh processes, interpreted and compiled rounds interleaved, and prints
   the medians and the ratios with the load average.

With ``--mypyc`` it also runs mypyc on the same modules and prints what it
refuses.  Why the package ships no compiled build is in docs/performance.md
("Compiled blocks (goal 6)").
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PY = sys.executable
SKIP = ("__init__.py", "fuzz.py")  # the package's re-exports and the campaign's driver

BUILD = """
import sys
from setuptools import Extension, setup
from Cython.Build import cythonize
typing, mods = sys.argv[1] == "True", sys.argv[2:]
sys.argv[1:] = ["build_ext", "--inplace"]
exts = [Extension(m[:-3].replace("/", "."), [m], extra_compile_args=["-ffp-contract=off", "-O2"])
        for m in mods]
directives = {"language_level": 3, "annotation_typing": typing}
setup(ext_modules=cythonize(exts, compiler_directives=directives, nthreads=2, quiet=True))
"""

TRACES = """
import json, math, sys
import ctrlblocks.blocks.pid as pid_module
from ctrlblocks.blocks.fuzz import BLOCKS, RandomRun
steps, seeds = int(sys.argv[1]), int(sys.argv[2])
out = {"compiled": not pid_module.__file__.endswith(".py"), "traces": {}}
for name, spec in sorted(BLOCKS.items()):
    for seed in range(seeds):
        run = RandomRun(spec, seed)
        trace = []
        for _ in range(steps):
            run.step()
            b = run.driver.block
            trace.append((b.out, int(b.error_id)))
        out["traces"][f"{name}/{seed}"] = trace
print(json.dumps(out))
"""

TIMING = """
import json, sys, time
import ctrlblocks.blocks.pid as pid_module
from ctrlblocks import ADRC, PID
from simple_pid import PID as SimplePID
from pyadrc import StateSpace
pid = PID(kp=2.0, ti=10.0, td=0.5, ts=0.1, u_min=0.0, u_max=100.0)
peer = SimplePID(2.0, 0.2, 1.0, setpoint=1.0, sample_time=None, output_limits=(0.0, 100.0))
adrc = ADRC(order=2, b0=0.05, omega_c=0.35, omega_o=1.75, ts=0.1, u_min=0.0, u_max=5.0)
peer_adrc = StateSpace(2, 0.1, 0.05, 0.35, 5.0, m_lim=(0.0, 5.0))

def per_call(fn, number):
    best = float("inf")
    for _ in range(5):
        t0 = time.perf_counter_ns()
        for _ in range(number):
            fn()
        best = min(best, (time.perf_counter_ns() - t0) / number)
    return best

for _ in range(3):
    pid(1.0, 0.5); peer(0.5, dt=0.1); adrc(1.0, 0.5); peer_adrc(0.5, 1.0, 1.0)
print(json.dumps({
    "compiled": not pid_module.__file__.endswith(".py"),
    "pid": per_call(lambda: pid(1.0, 0.5), 20000),
    "simple_pid": per_call(lambda: peer(0.5, dt=0.1), 20000),
    "adrc": per_call(lambda: adrc(1.0, 0.5), 20000),
    "pyadrc": per_call(lambda: peer_adrc(0.5, 1.0, 1.0), 5000),
}))
"""


def load() -> str:
    return f"load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"


class RunFailed(RuntimeError):
    """A measuring process failed; the message is the last line of its error output."""


def run_json(script: str, src: Path, *args: str, timeout: float = 1800) -> dict:
    env = dict(os.environ, PYTHONPATH=str(src))
    out = subprocess.run([PY, "-c", script, *args], capture_output=True, text=True, env=env,
                         timeout=timeout, cwd=src)  # fmt: skip
    if out.returncode:
        raise RunFailed((out.stderr.strip().splitlines() or ["(no output)"])[-1])
    return json.loads(out.stdout.strip().splitlines()[-1])


def build(tmp: Path, typing: bool, only: list[str]) -> tuple[Path, list[str], float]:
    """The copy of the package in ``tmp/src`` with blocks/ compiled; (src, modules, seconds).

    ``typing``: Cython's ``annotation_typing`` (its default): a ``float``
    annotation becomes a C double, converted when the function is entered.
    """
    src = tmp / "src"
    shutil.copytree(ROOT / "src" / "ctrlblocks", src / "ctrlblocks",
                    ignore=shutil.ignore_patterns("__pycache__", "*.so"))  # fmt: skip
    # the interpreted reference: the same files, uncompiled (the tree may change meanwhile)
    shutil.copytree(src / "ctrlblocks", tmp / "plain" / "ctrlblocks")
    mods = sorted(
        f"ctrlblocks/blocks/{p.name}"
        for p in (src / "ctrlblocks" / "blocks").glob("*.py")
        if p.name not in SKIP and (not only or p.stem in only)
    )
    t0 = time.perf_counter()
    subprocess.run([PY, "-c", BUILD, str(typing), *mods], cwd=src, check=True,
                   capture_output=True, timeout=7200)  # fmt: skip
    return src, mods, time.perf_counter() - t0


def compare_traces(interp: dict, comp: dict) -> tuple[int, float, list[str]]:
    """(actions compared, largest |difference| of out, names whose error codes differ)."""
    n, worst, codes = 0, 0.0, []
    for key, a in interp["traces"].items():
        b = comp["traces"][key]
        for (ya, ea), (yb, eb) in zip(a, b, strict=True):
            n += 1
            if ea != eb and key not in codes:
                codes.append(key)
            if ya != yb:
                worst = max(worst, abs(ya - yb) if ya == ya and yb == yb else float("inf"))
    return n, worst, codes


def try_mypyc(tmp: Path, mods: list[str]) -> str:
    """What mypyc says about the same modules (its first lines)."""
    src = tmp / "mypyc"
    shutil.copytree(ROOT / "src" / "ctrlblocks", src / "ctrlblocks",
                    ignore=shutil.ignore_patterns("__pycache__", "*.so"))  # fmt: skip
    out = subprocess.run([PY, "-m", "mypyc", *mods], cwd=src, capture_output=True, text=True,
                         timeout=3600)  # fmt: skip
    lines = [ln for ln in (out.stdout + out.stderr).splitlines() if "error" in ln]
    return f"exit {out.returncode}, {len(lines)} errors; first: " + "; ".join(lines[:3])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5, help="timing rounds (fresh processes)")
    ap.add_argument("--steps", type=int, default=3000, help="actions per block and seed")
    ap.add_argument("--seeds", type=int, default=3, help="seeds per block")
    ap.add_argument("--mypyc", action="store_true", help="also try mypyc on the same modules")
    ap.add_argument("--no-annotation-typing", action="store_true",
                    help="Cython keeps float annotations as Python objects")  # fmt: skip
    ap.add_argument("--modules", default="", help="only these modules of blocks/ (a,b,...)")
    ap.add_argument("--keep", type=Path, help="build here and keep it (default: a temp folder)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = args.keep or Path(tmp_name)
        print(f"compiling blocks/ with Cython ({load()}) ...", file=sys.stderr, flush=True)
        only = [m for m in args.modules.split(",") if m]
        src, mods, secs = build(tmp, not args.no_annotation_typing, only)
        plain = tmp / "plain"
        print(f"  {len(mods)} modules in {secs:.0f} s", file=sys.stderr, flush=True)
        print("traces: the fuzz campaign's actions on every block ...", file=sys.stderr,
              flush=True)  # fmt: skip
        a = run_json(TRACES, plain, str(args.steps), str(args.seeds))
        try:
            b = run_json(TRACES, src, str(args.steps), str(args.seeds))
        except RunFailed as exc:  # the compiled blocks broke a promise of the contract
            print(f"compiled: {len(mods)} modules of blocks/ by Cython in {secs:.0f} s")
            print(f"traces: the compiled blocks failed the campaign: {exc}")
            return 1
        assert not a["compiled"] and b["compiled"], "the compiled modules were not imported"
        n, worst, codes = compare_traces(a, b)
        res: dict[str, dict[str, list[float]]] = {"interpreted": {}, "compiled": {}}
        for r in range(args.rounds):
            print(f"timing round {r + 1}/{args.rounds} ({load()})", file=sys.stderr, flush=True)
            for name, where in (("interpreted", plain), ("compiled", src)):
                t = run_json(TIMING, where)
                assert t.pop("compiled") == (name == "compiled")
                for k, v in t.items():
                    res[name].setdefault(k, []).append(v)
        mypyc = try_mypyc(tmp, mods) if args.mypyc else "not tried (--mypyc)"
    med = {name: {k: statistics.median(v) for k, v in d.items()} for name, d in res.items()}
    print(f"compiled: {len(mods)} modules of blocks/ by Cython in {secs:.0f} s")
    print(f"traces: {n:,} actions on {len(a['traces'])} block runs; largest |out difference| "
          f"{worst:.3g}; error codes differ in: {codes or 'none'}")  # fmt: skip
    print(f"timing: medians of {args.rounds} rounds (best of 5 in each process); {load()}")
    print("| blocks | PID call | simple-pid | ratio | ADRC call | pyadrc | ratio |")
    print("|---|---|---|---|---|---|---|")
    for name, m in med.items():
        print(f"| {name} | {m['pid']:.0f} ns | {m['simple_pid']:.0f} ns | "
              f"{m['pid'] / m['simple_pid']:.2f}x | {m['adrc']:.0f} ns | {m['pyadrc']:.0f} ns | "
              f"{m['adrc'] / m['pyadrc']:.3f}x |")  # fmt: skip
    i, c = med["interpreted"], med["compiled"]
    print(f"compiled / interpreted: PID {c['pid'] / i['pid']:.2f}x, "
          f"ADRC {c['adrc'] / i['adrc']:.2f}x")  # fmt: skip
    print(f"mypyc: {mypyc}")
    return 0 if worst <= 1e-12 and not codes else 1


if __name__ == "__main__":
    raise SystemExit(main())
