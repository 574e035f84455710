"""Instructions per call of the PID and ADRC blocks, counted by callgrind (load-independent).

Usage (from the repository root; needs valgrind)::

    python benchmarks/callgrind_blocks.py                 # interpreted blocks
    python benchmarks/callgrind_blocks.py --compiled      # the build of ctrlblocks compile

A wall-clock timing on a shared machine moves with the load; the number of
instructions a call executes does not.  Each case runs in two processes under
``valgrind --tool=callgrind`` with the same set-up, one with ``--calls`` more
calls than the other (``PYTHONHASHSEED=0``, after a first run that writes the
byte-code caches); the difference of their totals divided by the number of
calls is the cost of one call (what varies between two starts of Python, a
few thousand instructions, is below one instruction per call; OpenBLAS's
worker threads, which varied by millions, are not started).  The cases: the
plain PID and ADRC per call (their fast lanes), the PID with an SP filter and
an output ramp (its general cycle) and the two-phase PID and ADRC
(``compute_output`` + ``update_state``, as the loop structures call them).
Results: docs/performance.md, "Instructions per call".
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

SETUP = {
    "pid": "b = PID(kp=2.0, ti=10.0, td=0.5, ts=0.1, u_min=0.0, u_max=100.0)\n"
    "f = lambda k: b(1.0, 0.5 + 1e-4 * (k % 7))",
    "adrc": "b = ADRC(order=2, b0=0.05, omega_c=0.35, omega_o=1.75, ts=0.1, u_min=0.0, "
    "u_max=5.0)\nf = lambda k: b(1.0, 0.5 + 1e-4 * (k % 7))",
    "pid_general": "b = PID(kp=2.0, ti=10.0, td=0.5, ts=0.1, u_min=0.0, u_max=100.0, "
    "sp_filter=1.0, out_rate=50.0)\nf = lambda k: b(1.0, 0.5 + 1e-4 * (k % 7))",
    "pid_two_phase": "b = PID(kp=2.0, ti=10.0, td=0.5, ts=0.1, u_min=0.0, u_max=100.0)\n"
    "def f(k):\n    b.update_state(b.compute_output(1.0, 0.5 + 1e-4 * (k % 7)))",
    "adrc_two_phase": "b = ADRC(order=2, b0=0.05, omega_c=0.35, omega_o=1.75, ts=0.1, "
    "u_min=0.0, u_max=5.0)\n"
    "def f(k):\n    b.update_state(b.compute_output(1.0, 0.5 + 1e-4 * (k % 7)))",
}

SCRIPT = """
import sys
from ctrlblocks import ADRC, PID, compiled
assert compiled.active() == {compiled!r}, compiled.status()
{setup}
for k in range(200):
    f(k)
for k in range(int(sys.argv[1])):
    f(k)
"""


def instructions(case: str, calls: int, compiled: bool) -> int:
    """The total instructions of one process running the case with ``calls`` calls."""
    script = SCRIPT.format(setup=SETUP[case], compiled=compiled)
    # OPENBLAS_NUM_THREADS=1: numpy's OpenBLAS (imported with ctrlblocks) starts no worker
    # threads, whose busy-waiting callgrind counts too -- a few million instructions that
    # differ between two starts (docs/performance.md, "Instructions per call")
    env = dict(os.environ, PYTHONHASHSEED="0", OPENBLAS_NUM_THREADS="1",
               CTRLBLOCKS_COMPILED="require" if compiled else "off")  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "cg.out"
        subprocess.run(
            ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", sys.executable,
             "-c", script, str(calls)],
            check=True, env=env, capture_output=True,
        )  # fmt: skip
        text = out.read_text()
    m = re.search(r"^(?:summary|totals): (\d+)", text, re.M)
    if m is None:
        raise RuntimeError("no totals in the callgrind output")
    return int(m.group(1))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--compiled", action="store_true", help="the compiled build (must exist)")
    ap.add_argument("--calls", type=int, default=20000)
    ap.add_argument("cases", nargs="*", default=list(SETUP))
    args = ap.parse_args()
    for case in args.cases:
        instructions(case, 0, args.compiled)  # writes the byte-code caches
        base = instructions(case, 0, args.compiled)
        more = instructions(case, args.calls, args.compiled)
        per = (more - base) / args.calls
        print(f"{case:16s} {'compiled' if args.compiled else 'interpreted':12s} "
              f"{per:10.0f} instructions per call", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
