"""FOPDT or SOPDT for a bump test: the Bayesian information criterion on the residuals.

Both least-squares fits (:func:`~ctrlblocks.tuning.identify.fit_fopdt`,
:func:`~ctrlblocks.tuning.identify.fit_sopdt`) are scored by Schwarz's (1978)
Bayesian information criterion for Gaussian residuals (Burnham & Anderson
2002, section 6.4.1):

    BIC = N ln(RSS/N) + p ln N

with ``N`` the samples of the record, ``RSS`` the sum of the squared
residuals ``y - y_model`` and ``p`` the estimated parameters (FOPDT: gain,
baseline, time constant, dead time: 4; SOPDT: 5).  The model with the smaller
BIC is used.  Unlike a fixed ratio of fit errors (the former rule: the SOPDT
only when its error was below 0.8 times the FOPDT's, which a noisy record
never meets, since both errors are then mostly the noise), the criterion
weighs a better fit by the number of samples that show it: with noise of
standard deviation ``sigma`` the SOPDT is chosen when it lowers the RSS by
more than about ``sigma^2 ln N``, i.e. when the second lag explains more
than one sample's worth of noise per ``ln N``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["ModelChoice", "bic", "select_model"]

PARAMETERS = {"fopdt": 4, "sopdt": 5}
"""Estimated parameters of each least-squares fit (the baseline ``y0`` included)."""


@dataclass(frozen=True)
class ModelChoice:
    """The two fits, the one used and why (:func:`select_model`).

    Attributes
    ----------
    fopdt, sopdt : FOPDT, SOPDT or None
    model : FOPDT or SOPDT
        The one with the smaller BIC.
    why : str
        One sentence with the numbers.
    criterion : dict
        ``{"name": "BIC", "n": N, "fopdt": {"rss", "p", "bic"}, "sopdt": {...} or None}``.
    """

    fopdt: Any
    sopdt: Any
    model: Any
    why: str
    criterion: dict[str, Any]


def bic(rss: float, n: int, p: int) -> float:
    """``N ln(RSS/N) + p ln N`` (module docstring); ``-inf`` for a perfect fit."""
    if rss <= 0.0:
        return -math.inf
    return n * math.log(rss / n) + p * math.log(n)


def select_model(t: Any, u: Any, y: Any, fopdt: Any = None) -> ModelChoice:
    """Fit both models to the bump test ``(t, u, y)`` and keep the one with the smaller BIC."""
    from .identify import fit_fopdt, fit_sopdt

    t, u, y = (np.asarray(v, float) for v in (t, u, y))
    fo = fit_fopdt(t, u, y) if fopdt is None else fopdt
    try:
        so = fit_sopdt(t, u, y)
    except ValueError:
        so = None
    n = len(t)
    scores: dict[str, Any] = {"name": "BIC", "n": n}
    for kind, m in (("fopdt", fo), ("sopdt", so)):
        if m is None:
            scores[kind] = None
            continue
        rss = float(np.sum((y - m.response(t, u)) ** 2))
        scores[kind] = {"rss": rss, "p": PARAMETERS[kind], "bic": bic(rss, n, PARAMETERS[kind])}
    if so is None:
        return ModelChoice(fo, None, fo, "FOPDT: the SOPDT fit failed", scores)
    bf, bs = scores["fopdt"]["bic"], scores["sopdt"]["bic"]
    nums = f"BIC {_num(bs)} for the SOPDT against {_num(bf)} for the FOPDT, N = {n} samples"
    if bs < bf:
        return ModelChoice(fo, so, so, f"SOPDT: the smaller BIC ({nums})", scores)
    return ModelChoice(fo, so, fo, f"FOPDT: the smaller BIC ({nums})", scores)


def _num(x: float) -> str:
    return "-inf" if x == -math.inf else f"{x:.1f}"
