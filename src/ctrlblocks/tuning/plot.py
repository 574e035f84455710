"""Plot of a bump-test record against an identified model (matplotlib, imported lazily)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from numpy.typing import ArrayLike

from .identify import FOPDT, SOPDT, Integrating

__all__ = ["plot_identification", "plot_loop"]


def plot_identification(
    t: ArrayLike,
    u: ArrayLike,
    y: ArrayLike,
    model: FOPDT | SOPDT | Integrating,
    path: str | Path,
    *,
    title: str = "",
    y_label: str = "PV",
    u_label: str = "MV",
    gain_unit: str | None = None,
) -> Path:
    """Write a PNG: measured PV and model output (top), MV (bottom).

    Parameters
    ----------
    t, u, y : array_like
        The record (time [s], MV, PV).
    model : FOPDT, SOPDT or Integrating
        The identified model (its ``response`` is drawn).
    path : str or Path
        Output file (PNG).
    title : str
        Figure title; default: the model and its fit.
    y_label, u_label : str
        Axis labels with names and units, e.g. ``"PV: p3 [bar]"``.
    gain_unit : str, optional
        Unit of the gain in the default title (``"bar/bar"``).

    Returns
    -------
    Path
        ``path``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    d = model.as_dict()
    if not title:
        parts = [f"k = {d['gain']:.4g}" + (f" {gain_unit}" if gain_unit else "")]
        if "time_constant" in d:
            parts.append(f"T = {d['time_constant']:.4g} s")
        if "time_constant_2" in d:
            parts.append(f"T2 = {d['time_constant_2']:.4g} s")
        parts.append(f"L = {d['dead_time']:.4g} s")
        title = f"{d['model'].upper()} ({model.method}): " + ", ".join(parts)
        title += f"; fit {100 * d['fit']:.2f} %"
    fig, (ax_y, ax_u) = plt.subplots(2, 1, sharex=True, figsize=(7.5, 5.0), height_ratios=(3, 1.3))
    ax_y.plot(t, y, ".", ms=2.5, color="0.45", label="measured PV")
    ax_y.plot(t, model.response(t, u), "-", color="C3", lw=1.6, label="model")
    ax_y.set_ylabel(y_label)
    ax_y.legend(loc="best")
    ax_y.grid(alpha=0.3)
    ax_y.set_title(title, fontsize=10)
    ax_u.step(t, u, where="post", color="C0")
    ax_u.set_ylabel(u_label)
    ax_u.set_xlabel("time [s]")
    ax_u.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_loop(loop: Any, margins: Any, path: str | Path, *, title: str = "") -> Path:
    """Write a PNG of a tuned loop on its model (:class:`~ctrlblocks.tuning.margins.Loop`).

    Four panels: the Nyquist curve of ``L`` with the circle of radius
    ``1/Ms`` around -1 (the curve touches it at the sensitivity peak); the
    Bode magnitudes of ``S`` and ``T`` [dB] up to the Nyquist frequency; the
    set-point step response (unit step) and, in the second half, an input load
    (the size of the step's steady-state MV, negative) on the model, PV and MV.

    Returns ``path``.
    """
    import math

    import matplotlib
    import numpy as np

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    w = loop.grid()
    L = loop.loop_gain(w)
    S, T = loop.sensitivity(w)
    fig, axes = plt.subplots(2, 2, figsize=(10.0, 7.5))
    ax_n, ax_b, ax_y, ax_u = axes[0, 0], axes[0, 1], axes[1, 0], axes[1, 1]
    # no legend: on the Nyquist plane any corner can hold the curve; the title names the lines
    ax_n.plot(L.real, L.imag, color="C0", lw=1.4)
    ax_n.plot(L.real, -L.imag, color="C0", lw=0.8, ls=":")
    ax_n.plot([-1], [0], "x", color="C3", ms=8)
    circle = ""
    if margins.stable and math.isfinite(margins.ms):
        r = 1.0 / margins.ms
        th = np.linspace(0, 2 * np.pi, 200)
        ax_n.plot(-1 + r * np.cos(th), r * np.sin(th), color="C3", lw=1.0)
        circle = f"\nred: the Ms circle around -1, radius 1/Ms = {r:.3f}"
    ax_n.set_xlim(-2.5, 1.0)
    ax_n.set_ylim(-2.0, 1.5)
    ax_n.set_aspect("equal")
    ax_n.set_xlabel("Re L")
    ax_n.set_ylabel("Im L")
    ax_n.grid(alpha=0.3)
    ax_n.set_title(
        r"Nyquist curve of $L(e^{j\omega h})$ (dotted: $\omega < 0$)" + circle, fontsize=9
    )
    ax_b.semilogx(w, 20 * np.log10(np.abs(S)), color="C3", label="|S|")
    ax_b.semilogx(w, 20 * np.log10(np.abs(T)), color="C0", label="|T|")
    if math.isfinite(margins.ms):
        ax_b.axhline(20 * math.log10(margins.ms), color="C3", lw=0.8, ls="--",
                     label=f"Ms = {margins.ms:.3f}")  # fmt: skip
    ax_b.set_ylim(-40, 20)
    ax_b.set_xlabel("frequency [rad/s]")
    ax_b.set_ylabel("magnitude [dB]")
    ax_b.grid(alpha=0.3, which="both")
    ax_b.legend(fontsize=8)
    ax_b.set_title(margins.summary(), fontsize=9)
    # step, then an input load of the size of the steady-state MV
    horizon = loop.response_time() if margins.stable else 200 * loop.ts
    _t1, _y1, u1 = loop.simulate(horizon)
    load = (
        -float(u1[-1])
        if margins.stable and abs(u1[-1]) > 1e-12
        else -0.5 * float(np.max(np.abs(u1)))
    )
    t, y, u = loop.simulate(2 * horizon, load=load, t_load=horizon)
    ax_y.plot(t, np.ones_like(t), color="0.4", lw=0.8, ls="--", label="set point")
    ax_y.plot(t, y, color="C0", lw=1.4, label="PV")
    ax_y.axvline(horizon, color="0.6", lw=0.8, ls=":")
    ax_y.set_xlabel("time [s]")
    ax_y.set_ylabel("PV [per unit set-point step]")
    ax_y.grid(alpha=0.3)
    ax_y.legend(fontsize=8)
    ax_y.set_title(f"step at 0, input load {load:+.3g} at {horizon:.4g} s (model)", fontsize=9)
    ax_u.plot(t, u, color="C2", lw=1.2)
    ax_u.axvline(horizon, color="0.6", lw=0.8, ls=":")
    ax_u.set_xlabel("time [s]")
    ax_u.set_ylabel("MV (controller output)")
    ax_u.grid(alpha=0.3)
    ax_u.set_title("controller output (no limits)", fontsize=9)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
