"""Make the figure of docs/plc.md: Åström 1987's word-length warning in REAL arithmetic.

Run from the repository root::

    .venv/bin/python docs/figures/make_plc_figures.py

Writes ``docs/figures/plc_wordlength.png``: a PI controller (K = 1, Ti = 1000 s,
h = 0.01 s, forward integral (2.8)) held at 50 % with a constant control error
of 0.01 %, so that each sample adds ``K h e / Ti = 1e-7 %`` to the integral
(Åström 1987, section 2: "the term k h e / Ti is not rounded off when added to
I ... most critical when h is small and Ti is large").  Three lines:
``precision="float64"`` (the increments add up: 0.01 % in 1000 s),
``precision="float32"`` (REAL: every increment is below half an ulp of 50 and is
lost), and the incremental (velocity) idea in REAL with only the final sum in
LREAL (Åström: "short wordlength ... only in the final stage where the
increments are added precision is needed").
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from ctrlblocks import PID

HERE = Path(__file__).resolve().parent
H, TI, E = 0.01, 1000.0, 0.01
N = 100_000  # 1000 s


def run(precision: str) -> np.ndarray:
    pid = PID(kp=1.0, ti=TI, ts=H, u_min=0.0, u_max=100.0, integral_method="forward",
              precision=precision)  # fmt: skip
    pid.manual, pid.manual_value = True, 50.0
    pid(50.0, 50.0)
    pid.manual = False
    return np.array([pid(50.0 + E, 50.0) for _ in range(N)])


def main() -> None:
    t = np.arange(N) * H
    u64, u32 = run("float64"), run("float32")
    inc = np.float32(1.0) * np.float32(H) / np.float32(TI) * np.float32(E)  # REAL increment
    vel = 50.0 + np.cumsum(np.full(N, float(inc))) - float(inc)  # LREAL final sum
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    ax.plot(t, (u64 - 50.0) * 1e3, label='positional, precision="float64"', lw=2)
    ax.plot(t, (u32 - 50.0) * 1e3, label='positional, precision="float32" (REAL)', lw=2)
    ax.plot(t, (vel - 50.0) * 1e3, "--", label="increments in REAL, sum in LREAL", lw=1.5)
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("integral action added since t = 0 [10^-3 %]")
    ax.set_title("Åström 1987, section 2: K h e / Ti = 1e-7 % per sample added to I = 50 %")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper left")
    fig.tight_layout()
    fig.savefig(HERE / "plc_wordlength.png", dpi=110)
    print(f"after {N * H:.0f} s: float64 {u64[-1] - 50:.6f} %, float32 {u32[-1] - 50:.6f} %")


if __name__ == "__main__":
    main()
