"""Make the figure of docs/blocks/process-blocks.md.

Run from the repository root::

    .venv/bin/python docs/figures/make_process_blocks_figures.py

Writes ``docs/figures/transfer_designs.png``: the magnitude responses of the
designs of ``ctrlblocks.blocks.transfer`` at ts = 0.01 s -- Butterworth low-pass
filters of order 1, 2 and 4 at 10 rad/s, and notches at 50 rad/s with Q = 2
(depth 0 and 0.1, the gain left at the notch: -20 dB) -- computed from the
block's coefficients, with scipy's ``sosfreqz`` of ``scipy.signal.butter`` drawn
over them as dots (they coincide).
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from scipy import signal

from ctrlblocks.blocks.transfer import frequency_response, lowpass, notch

HERE = Path(__file__).resolve().parent
TS = 0.01


def make_transfer_designs(path: Path) -> Path:
    """Plot the designs' magnitude responses [dB] over frequency [rad/s]."""
    w = np.sort(np.append(np.logspace(-1, math.log10(0.999 * math.pi / TS), 600), 50.0))
    fig, ax = plt.subplots(figsize=(7.0, 3.8), dpi=110)
    for order, color in ((1, "C0"), (2, "C1"), (4, "C2")):
        h = [abs(frequency_response(lowpass(10.0, TS, order), x, TS)) for x in w]
        ax.semilogx(w, 20 * np.log10(h), color=color, lw=1.6,
                    label=f"low-pass, Butterworth order {order}, 10 rad/s")  # fmt: skip
        ref = signal.butter(order, 10.0 / (2 * math.pi), fs=1 / TS, output="sos")
        _, hr = signal.sosfreqz(ref, worN=w[::25], fs=2 * math.pi / TS)
        ax.semilogx(w[::25], 20 * np.log10(np.abs(hr)), ".", color=color, ms=4)
    for depth, style, color in ((0.0, "-", "C3"), (0.1, "--", "C4")):
        h = np.array([abs(frequency_response([notch(50.0, 2.0, TS, depth)], x, TS)) for x in w])
        ax.semilogx(w, 20 * np.log10(np.maximum(h, 1e-6)), style, color=color, lw=1.4,
                    label=f"notch 50 rad/s, Q = 2, depth {depth:g}")  # fmt: skip
    ax.axhline(-3.0103, color="0.6", lw=0.8, ls=":")
    ax.set(xlim=(w[0], w[-1]), ylim=(-60, 5), xlabel="frequency [rad/s]",
           ylabel="magnitude [dB]",
           title="TransferFunction designs at ts = 0.01 s (dots: scipy.signal.butter)")  # fmt: skip
    ax.title.set_fontsize(10)
    ax.grid(alpha=0.3, which="both")
    ax.legend(loc="lower left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


if __name__ == "__main__":
    print(make_transfer_designs(HERE / "transfer_designs.png"))
