"""Plot of a bump-test record against an identified model (matplotlib, imported lazily)."""

from __future__ import annotations

from pathlib import Path

from numpy.typing import ArrayLike

from .identify import FOPDT, SOPDT, Integrating

__all__ = ["plot_identification"]


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
