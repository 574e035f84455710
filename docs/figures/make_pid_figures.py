"""Make the figures of docs/blocks/pid.md.

Run from the repository root::

    .venv/bin/python docs/figures/make_pid_figures.py

Writes

* ``docs/figures/pid_antiwindup.png``: Åström 1987, Figs. 3.1, 3.3 and 3.4 (Simnon
  macros ``fig31``, ``fig33``, ``fig34``) run with :class:`ctrlblocks.PID`:
  process = integrator with input saturation +-0.1; PI with k = 1, Ti = 1,
  b = 1, no D (N = 0); r = 1; h = 0.01 s.  Fig. 3.1: the regulator tracks a
  saturation at +-1 (it does not know the real one), Tt = 0.05 -> windup.
  Fig. 3.3: it tracks the real saturation, Tt = 0.02.  Fig. 3.4: Tt = 1, 2,
  3, 4.
* ``docs/figures/pid_selector.png``: Åström 1987, Fig. 3.9 (system ``select``):
  two PI controllers, a min selector, saturation +-0.4, both track the applied
  u (Listing 6.3 order); disturbance -0.15 at t = 25 s.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from ctrlblocks import PID

HERE = Path(__file__).resolve().parent
H = 0.01
T_END = 40.0


def _sat(u: float, lo: float, hi: float) -> float:
    return min(max(u, lo), hi)


def windup_run(
    ulow: float, uhigh: float, tt: float
) -> tuple[list[float], list[float], list[float]]:
    """Simnon systems ``int`` + ``pid`` + ``conn``: returns t, y, applied process input."""
    pid = PID(
        kp=1.0, ti=1.0, b=1.0, ts=H, u_min=ulow, u_max=uhigh, anti_windup="back_calc_model", tt=tt
    )
    x, t, y, up = 0.0, [], [], []
    for k in range(round(T_END / H) + 1):
        u = _sat(pid(1.0, x), -0.1, 0.1)
        t.append(k * H)
        y.append(x)
        up.append(u)
        x += H * u
    return t, y, up


def make_antiwindup(path: Path) -> Path:
    """Figs. 3.1 / 3.3 / 3.4 in one plot."""
    runs = [
        ("Fig. 3.1: tracks +-1 (windup), Tt = 0.05", -1.0, 1.0, 0.05, "tab:red"),
        ("Fig. 3.3: tracks +-0.1, Tt = 0.02", -0.1, 0.1, 0.02, "black"),
    ] + [
        (f"Fig. 3.4: Tt = {tt:g}", -0.1, 0.1, tt, color)
        for tt, color in zip(
            (1.0, 2.0, 3.0, 4.0), ("tab:blue", "tab:cyan", "tab:olive", "tab:purple"), strict=True
        )
    ]
    fig, (ax1, ax2) = plt.subplots(
        2, 1, figsize=(8.0, 6.0), dpi=110, sharex=True, gridspec_kw={"height_ratios": [2, 1]}
    )
    for label, lo, hi, tt, color in runs:
        t, y, up = windup_run(lo, hi, tt)
        peak = max(y)
        ax1.plot(t, y, color=color, lw=1.3, label=f"{label}  (peak {peak:.3f})")
        ax2.plot(t, up, color=color, lw=1.0)
    ax1.axhline(1.0, color="gray", lw=0.8, ls="--")
    ax1.set_ylabel("y")
    ax1.set_title("ctrlblocks.PID: windup and anti-windup by tracking (Åström 1987, Figs. 3.1-3.4)")
    ax1.legend(fontsize=8, loc="lower right")
    ax1.grid(alpha=0.3)
    ax2.set_ylabel("process input (sat +-0.1)")
    ax2.set_xlabel("t [s]")
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def make_selector(path: Path) -> Path:
    """Fig. 3.9: selector with tracking (system ``select`` of Appendix A)."""
    k1, b1, ti1, k2, ti2 = 1.0, 0.5, 2.5, 9.0, 9.0 / 25.0
    p1 = PID(
        kp=k1, b=b1, ti=ti1, tt=ti1 / 5, ts=H, u_min=-0.4, u_max=0.4, anti_windup="back_calc_model"
    )
    p2 = PID(kp=k2, ti=ti2, tt=ti2 / 5, ts=H, u_min=-0.4, u_max=0.4, anti_windup="back_calc_model")
    x1 = x2 = 0.0
    rows = []
    for k in range(round(T_END / H) + 1):
        v1 = p1.compute_output(1.0, x1)
        v2 = p2.compute_output(0.2, x2)
        u = min(v1, v2)
        p1.update_state(u)
        p2.update_state(u)
        rows.append((k * H, x1, x2, u, v1, v2))
        d = 0.0 if k * H < 25.0 else -0.15
        x1, x2 = x1 + H * (x2 + d), x2 + H * (u - x2)
    t, x1s, x2s, us, v1s, v2s = (list(c) for c in zip(*rows, strict=True))
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8.0, 5.5), dpi=110, sharex=True)
    ax1.plot(t, x1s, label="x1 (controlled, r = 1)")
    ax1.plot(t, x2s, label="x2 (constraint x2 <= 0.2)")
    ax1.axhline(0.2, color="gray", lw=0.8, ls="--")
    ax1.set_title("ctrlblocks.PID: min selector with tracking (Åström 1987, Fig. 3.9)")
    ax1.legend(fontsize=8)
    ax1.grid(alpha=0.3)
    ax2.plot(t, us, color="black", lw=1.6, label="u = min(v1, v2)")
    ax2.plot(t, v1s, lw=1.0, ls="--", label="v1 (PID 1)")
    ax2.plot(t, v2s, lw=1.0, ls=":", label="v2 (PID 2)")
    ax2.set_xlabel("t [s]")
    ax2.legend(fontsize=8)
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


if __name__ == "__main__":
    print(make_antiwindup(HERE / "pid_antiwindup.png"))
    print(make_selector(HERE / "pid_selector.png"))
