"""The moving average's rounding error against the exact mean of its window (not timed).

Usage (from the repository root)::

    python benchmarks/moving_average_error.py [samples]     # default 200,000

A window of 50 values of ``1e6 + 1e3 N(0, 1)`` (seed 31), without and with a spike of 1e20
every 5,000 samples, run in float64 (the block's precision) and in REAL (float32, the PLC's:
``plc_cycle.run_float32``) by three sums: a plain running sum (add the new value, subtract
the one leaving), the same summed afresh once per window with a plain FOR loop (the PLC's
average before issue 31), and the one cycle ``signals.moving_average_step`` (its threshold
``SUM_LOSS_FLOAT64`` / ``SUM_LOSS_REAL``).  Printed: the largest error of the average over
the run, relative to the mean magnitude of the window, against ``math.fsum`` of the window
as the cycle holds it.  Results: docs/performance.md, "The moving average's rounding".
"""

from __future__ import annotations

import math
import sys
from typing import Any

import numpy as np

from ctrlblocks.blocks import plc_cycle as pc
from ctrlblocks.blocks.signals import SUM_LOSS_FLOAT64

NAMES = ("mean", "buf", "idx", "count", "since", "total", "spread", "mag", "n_prev")


def worst_error(us: np.ndarray, n: int, real: bool, how: str) -> float:
    """The largest relative error of the average of ``us`` over the run (see the module)."""
    num: Any = np.float32 if real else float
    us = us.astype(np.float32) if real else us
    state = {"mean": num(0), "buf": [num(0)] * n, "idx": 0, "count": 0, "since": 0,
             "total": num(0), "spread": num(0), "mag": num(0), "n_prev": n}  # fmt: skip
    loss = num(pc.SUM_LOSS_REAL if real else SUM_LOSS_FLOAT64)
    worst, total = 0.0, num(0)
    for k, u in enumerate(us):
        if how == "one cycle":
            args = {"u": u, "n": n, "loss": loss, **state}
            res = pc.run_float32(pc.moving_average, **args) if real else pc.moving_average(**args)
            state = dict(zip(NAMES, res, strict=True))
            mean = float(state["mean"])
        else:
            leaving = us[k - n] if k >= n else num(0)
            total = num(total + num(u - leaving))
            if how == "once per window" and (k + 1) % n == 0:
                total = num(0)
                for v in us[k + 1 - n : k + 1]:
                    total = num(total + v)
            mean = float(total) / min(k + 1, n)
        window = [float(v) for v in us[max(0, k + 1 - n) : k + 1]]
        exact = math.fsum(window) / len(window)
        worst = max(worst, abs(mean - exact) / (math.fsum(abs(v) for v in window) / len(window)))
    return worst


def main() -> None:
    samples = int(sys.argv[1]) if len(sys.argv) > 1 else 200_000
    base = 1e6 + 1e3 * np.random.default_rng(31).standard_normal(samples)
    spikes = base.copy()
    spikes[2500::5000] = 1e20
    for name, us in (("ordinary", base), ("spikes", spikes)):
        for real in (False, True):
            row = {how: worst_error(us, 50, real, how)
                   for how in ("plain", "once per window", "one cycle")}  # fmt: skip
            cells = "  ".join(f"{how}: {e:.2e}" for how, e in row.items())
            print(f"{name:9s} {'REAL' if real else 'float64':8s} {cells}", flush=True)


if __name__ == "__main__":
    main()
