"""Make the figures of docs/blocks/small-blocks.md.

Run from the repository root::

    .venv/bin/python docs/figures/make_small_blocks_figures.py

Writes ``docs/figures/fig5_2_jump_and_rate.png``: the experiment of Åström 1987
Fig. 5.2 (Simnon macro ``fig52``) run with :class:`ctrlblocks.JumpAndRate`:
jlow = -0.5, jhigh = 1, rlow = -0.5, rhigh = 1; input 4 until t = 7 s, 1 until
15 s, 3 until 18 s, then 2; 0..20 s.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from ctrlblocks import JumpAndRate

HERE = Path(__file__).resolve().parent


def fig52_input(t: float) -> float:
    """The input of Åström 1987, macro ``fig52``."""
    return 4.0 if t < 7 else 1.0 if t < 15 else 3.0 if t < 18 else 2.0


def make_fig5_2(path: Path, h: float = 0.01) -> Path:
    """Run the Fig. 5.2 experiment and save the plot to ``path``."""
    jar = JumpAndRate(jlow=-0.5, jhigh=1.0, rlow=-0.5, rhigh=1.0, ts=h)
    n = round(20.0 / h)
    t = [k * h for k in range(n + 1)]
    u = [fig52_input(round(tk, 9)) for tk in t]
    y = [jar(uk) for uk in u]

    fig, ax = plt.subplots(figsize=(7.0, 3.6), dpi=110)
    ax.step(t, u, where="post", color="0.55", lw=1.2, label="input u")
    ax.plot(t, y, color="C0", lw=1.8, label="output y")
    ax.set(
        xlim=(0, 20),
        ylim=(0, 5),
        xlabel="time [s]",
        ylabel="signal",
        title="Jump and rate (Åström 1987, Fig. 5.2): jlow = rlow = -0.5, jhigh = rhigh = 1",
    )
    ax.title.set_fontsize(10)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


if __name__ == "__main__":
    out = make_fig5_2(HERE / "fig5_2_jump_and_rate.png")
    print(f"wrote {out}")
