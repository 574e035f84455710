"""The compiled PID and ADRC per call, against simple-pid and pyadrc (issue 18, goal 6).

Usage (from the repository root; needs the ``bench`` extra -- Cython and the peers --
and a C compiler)::

    python benchmarks/compiled_blocks.py                  # build, check, time: ~3 minutes
    python benchmarks/compiled_blocks.py --rounds 9 --json out.json
    python benchmarks/compiled_blocks.py --reuse          # the build ctrlblocks compile made

What it does:

1. builds the package's compiled blocks (:func:`ctrlblocks.compiled.build`, the
   same as ``ctrlblocks compile``) into a temporary folder, or with ``--reuse``
   takes the build of the current source from the user's cache folder;
2. runs the fuzz campaign's seeded random actions (``ctrlblocks.testing``:
   inputs with NaN/inf, modes, limits, reconfiguration, snapshot/restore,
   reset) on every exported block, with PID and ADRC runs that start in
   ``precision="float32"``, once interpreted (``CTRLBLOCKS_COMPILED=off``) and
   once compiled (``require``), and compares ``out`` and ``error_id`` after
   every action, bit for bit;
3. times one call of ``PID`` and ``ADRC`` against simple-pid and pyadrc in
   fresh processes, interpreted and compiled rounds interleaved, and prints
   the medians and ratios with the load average.

The targets (issue 18): a full ``PID`` call <= 0.5x simple-pid, a full ``ADRC``
call <= 0.1x pyadrc.  Results and history: docs/performance.md, "Compiled
blocks (goal 6)".
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PY = sys.executable
TARGETS = {"pid": 0.5, "adrc": 0.1}

TRACES = """
import json, sys
from ctrlblocks import compiled
from ctrlblocks.testing import traces
out = traces(*(int(a) for a in sys.argv[1:4]))
print(json.dumps({"active": compiled.active(), **out}))
"""

TIMING = """
import json, time
from ctrlblocks import ADRC, PID, compiled
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
    "compiled": compiled.active(),
    "pid": per_call(lambda: pid(1.0, 0.5), 20000),
    "simple_pid": per_call(lambda: peer(0.5, dt=0.1), 20000),
    "adrc": per_call(lambda: adrc(1.0, 0.5), 20000),
    "pyadrc": per_call(lambda: peer_adrc(0.5, 1.0, 1.0), 5000),
}))
"""


def load() -> str:
    return f"load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"


def run_json(script: str, root: Path, how: str, *args: str) -> dict:
    """``script`` in a fresh process with CTRLBLOCKS_COMPILED=``how`` and the builds in ``root``."""
    env = dict(os.environ, CTRLBLOCKS_COMPILED=how, CTRLBLOCKS_COMPILED_DIR=str(root))
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), env.get("PYTHONPATH", "")]).rstrip(":")
    out = subprocess.run([PY, "-c", script, *args], capture_output=True, text=True, env=env,
                         timeout=1800, check=False)  # fmt: skip
    if out.returncode:
        raise SystemExit(f"a measuring process failed: {out.stderr.strip()[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def compare_traces(interp: dict, comp: dict) -> tuple[int, list[str]]:
    """(actions compared, the block runs whose out or error code differ somewhere)."""
    n, differ = 0, []
    for key, a in interp["traces"].items():
        b = comp["traces"][key]
        n += len(a)
        if a != b:
            differ.append(key)
    return n, differ


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5, help="timing rounds (fresh processes)")
    ap.add_argument("--steps", type=int, default=3000, help="actions per block and seed")
    ap.add_argument("--seeds", type=int, default=3, help="seeds per block")
    ap.add_argument("--float32-seeds", type=int, default=3,
                    help="and this many seeds of PID and ADRC that start in float32")  # fmt: skip
    ap.add_argument("--reuse", action="store_true",
                    help="use the build of ctrlblocks compile (user's cache folder)")  # fmt: skip
    ap.add_argument("--json", type=Path, help="also write the results here")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT / "src"))
    from ctrlblocks import compiled

    with tempfile.TemporaryDirectory() as tmp_name:
        if args.reuse:
            root = compiled.build_root()
            if not compiled.build_folder().is_dir():
                raise SystemExit(f"no build for this source in {root}: run ctrlblocks compile")
            secs = None
        else:
            root = Path(tmp_name)
            os.environ["CTRLBLOCKS_COMPILED_DIR"] = str(root)
            print(f"building the compiled blocks ({load()}) ...", file=sys.stderr, flush=True)
            t0 = time.perf_counter()
            compiled.build()
            secs = time.perf_counter() - t0
        print("traces: the fuzz campaign's actions on every block, interpreted and compiled ...",
              file=sys.stderr, flush=True)  # fmt: skip
        targs = (str(args.steps), str(args.seeds), str(args.float32_seeds))
        interp = run_json(TRACES, root, "off", *targs)
        comp = run_json(TRACES, root, "require", *targs)
        assert not interp["active"] and comp["active"], "not the builds asked for"
        res: dict[str, dict[str, list[float]]] = {"interpreted": {}, "compiled": {}}
        for r in range(args.rounds):
            print(f"timing round {r + 1}/{args.rounds} ({load()})", file=sys.stderr, flush=True)
            for name, how in (("interpreted", "off"), ("compiled", "require")):
                t = run_json(TIMING, root, how)
                assert t.pop("compiled") == (name == "compiled")
                for k, v in t.items():
                    res[name].setdefault(k, []).append(v)
    med = {name: {k: statistics.median(v) for k, v in d.items()} for name, d in res.items()}
    n, differ = compare_traces(interp, comp)
    built = f"built in {secs:.0f} s" if secs is not None else "the build in the cache folder"
    print(f"compiled blocks: {', '.join(compiled.MODULES)} ({built})")
    print(f"traces: {n:,} actions on {len(interp['traces'])} block runs ({interp['float32']:,} "
          f"in float32); out or error code differ in: {differ or 'none'}")  # fmt: skip
    print(f"timing: medians of {args.rounds} rounds (best of 5 in each process); {load()}")
    print("| blocks | PID call | simple-pid | ratio | ADRC call | pyadrc | ratio |")
    print("|---|---|---|---|---|---|---|")
    for name, m in med.items():
        print(f"| {name} | {m['pid']:.0f} ns | {m['simple_pid']:.0f} ns | "
              f"{m['pid'] / m['simple_pid']:.2f}x | {m['adrc']:.0f} ns | {m['pyadrc']:.0f} ns | "
              f"{m['adrc'] / m['pyadrc']:.3f}x |")  # fmt: skip
    # the machine is shared: a whole process may run at half speed, so the ratio is taken
    # inside each process (block and peer timed in it) and its median over the rounds
    c = res["compiled"]
    per_round = {
        "pid": [a / b for a, b in zip(c["pid"], c["simple_pid"], strict=True)],
        "adrc": [a / b for a, b in zip(c["adrc"], c["pyadrc"], strict=True)],
    }
    ratios = {k: statistics.median(v) for k, v in per_round.items()}
    print("compiled, the ratio in each process: median (lowest-highest) over the rounds: "
          f"PID {ratios['pid']:.2f}x ({min(per_round['pid']):.2f}-{max(per_round['pid']):.2f}), "
          f"ADRC {ratios['adrc']:.3f}x ({min(per_round['adrc']):.3f}-"
          f"{max(per_round['adrc']):.3f})")  # fmt: skip
    met = {k: ratios[k] <= TARGETS[k] for k in TARGETS}
    print(f"targets: PID <= {TARGETS['pid']}x simple-pid: {'met' if met['pid'] else 'MISSED'}; "
          f"ADRC <= {TARGETS['adrc']}x pyadrc: {'met' if met['adrc'] else 'MISSED'}")  # fmt: skip
    if args.json:
        args.json.write_text(json.dumps({"medians": med, "ratios": ratios, "rounds": res,
                                         "actions": n, "differ": differ, "load": load()},
                                        indent=2))  # fmt: skip
    return 0 if not differ else 1


if __name__ == "__main__":
    raise SystemExit(main())
