"""Process models from step-response (bump test) records.

Models (``t`` in s, ``k`` in PV unit per MV unit)::

    FOPDT        k e^{-theta s} / (T s + 1)
    SOPDT        k e^{-theta s} / ((T1 s + 1)(T2 s + 1)),   T1 >= T2
    Integrating  k e^{-theta s} / s                          (k in PV unit per MV unit per s)

Methods
-------
* :func:`two_point` -- the two-point method of Nowak et al.'s (2018) reference [18]
  (T. E. Marlin, *Process Control*, McGraw-Hill 1995, chapter 6): with
  ``t28`` and ``t63`` the times after the step at which the response reaches
  28.3 % and 63.2 % of its final change,
  ``T = 1.5 (t63 - t28)``, ``theta = t63 - T``, ``k = dy/du``.
  (28.3 % and 63.2 % are the FOPDT response at ``theta + T/3`` and
  ``theta + T``.)  Nowak et al. 2018 obtained its FOPDT models (10a)/(10b) this way.
* :func:`sundaresan_krishnaswamy` -- Sundaresan & Krishnaswamy, *Estimation
  of time delay, time constant parameters in time, frequency and Laplace
  domains*, Can. J. Chem. Eng. 56 (1978) 257-262: with ``t1`` at 35.3 % and
  ``t2`` at 85.3 %, ``T = 0.67 (t2 - t1)``, ``theta = 1.3 t1 - 0.29 t2``.
* :func:`fit_fopdt`, :func:`fit_sopdt`, :func:`fit_integrating` -- least
  squares over the whole record (``scipy.optimize.least_squares``).  The model
  output is computed exactly for the recorded MV held constant between samples
  (zero-order hold), by superposition of delayed step responses, so the MV may
  have any shape, size and sign, the step may come at any time, and the dead
  time is not restricted to whole samples.  The linear parameters (gain,
  baseline ``y0``, and the drift of an integrating process) are solved by
  linear least squares inside the nonlinear search (variable projection);
  the nonlinear ones start from a coarse grid search.

The record must start at steady state (for an integrating process: at a
constant slope), before the MV moves.

Every result carries ``fit``, the normalised RMS error
``rms(y - y_model) / (max(y) - min(y))`` (0 is perfect; noise of standard
deviation sigma on a step of size A alone gives about sigma/A), and a list of
``warnings`` (record too short to reach steady state, poor fit, noisy record
for a two-point method).

Reading files is :mod:`ctrlblocks.tuning.records` (historian and spreadsheet
CSV exports: :func:`~ctrlblocks.tuning.records.read_step_csv`); its names
``read_step_csv``, ``StepData``, ``DataFileError``, ``split_unit`` and
``MAX_MAGNITUDE`` are also importable from here.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import interpolate, optimize

from .records import BEYOND as _BEYOND
from .records import (
    MAX_MAGNITUDE,
    MIN_SAMPLES,
    DataFileError,
    StepData,
    read_step_csv,
    split_unit,
)
from .records import constant as _constant

__all__ = [
    "FOPDT",
    "SOPDT",
    "DataFileError",
    "Integrating",
    "StepData",
    "fit_fopdt",
    "fit_integrating",
    "fit_sopdt",
    "read_step_csv",
    "split_unit",
    "sundaresan_krishnaswamy",
    "two_point",
]

_log = logging.getLogger(__name__)

_MAX_CHANGES = 400
"""Above this many MV changes (a noisy measured MV) the MV is simplified, see :func:`_changes`."""


# ---------------------------------------------------------------------------
# Results
# ---------------------------------------------------------------------------


@dataclass(frozen=True)
class FOPDT:
    """First order plus dead time ``k e^{-theta s}/(T s + 1)``.

    Attributes
    ----------
    gain : float
        Static gain k [PV unit / MV unit].
    time_constant : float
        T [s].
    dead_time : float
        theta [s].
    fit : float
        Normalised RMS error against the data (NaN if not from data).
    warnings : list of str
        Problems found with the record or the fit.
    method : str
        How the model was obtained.
    u0, y0 : float
        Operating point: steady-state MV and PV before the first MV change.
    """

    gain: float
    time_constant: float
    dead_time: float
    fit: float = math.nan
    warnings: list[str] = field(default_factory=list)
    method: str = ""
    u0: float = 0.0
    y0: float = 0.0

    def response(self, t: ArrayLike, u: ArrayLike) -> NDArray[np.float64]:
        """Model output for the MV record ``u`` (held between samples) at times ``t``."""
        return _lag_response(self, t, u, _fopdt_step(self.time_constant))

    def as_dict(self) -> dict[str, object]:
        """The keys of ``ctrlblocks identify --json``."""
        return _model_dict(self, "fopdt", ("gain", "time_constant", "dead_time"))


@dataclass(frozen=True)
class SOPDT:
    """Second order plus dead time ``k e^{-theta s}/((T1 s + 1)(T2 s + 1))``, T1 >= T2.

    Attributes are those of :class:`FOPDT` (``time_constant`` is T1 [s]) plus
    ``time_constant_2`` (T2 [s]).
    """

    gain: float
    time_constant: float
    dead_time: float
    time_constant_2: float
    fit: float = math.nan
    warnings: list[str] = field(default_factory=list)
    method: str = ""
    u0: float = 0.0
    y0: float = 0.0

    def response(self, t: ArrayLike, u: ArrayLike) -> NDArray[np.float64]:
        """Model output for the MV record ``u`` (held between samples) at times ``t``."""
        return _lag_response(self, t, u, _sopdt_step(self.time_constant, self.time_constant_2))

    def as_dict(self) -> dict[str, object]:
        """The keys of ``ctrlblocks identify --json``."""
        return _model_dict(self, "sopdt", ("gain", "time_constant", "time_constant_2", "dead_time"))


@dataclass(frozen=True)
class Integrating:
    """Integrating process with dead time ``k e^{-theta s}/s``.

    Attributes
    ----------
    gain : float
        k [PV unit / (MV unit s)]: the PV slope per unit of MV away from ``u0``.
    dead_time : float
        theta [s].
    fit, warnings, method : see :class:`FOPDT`.
    u0 : float
        Balancing MV: the MV at which the PV does not move.
    y0 : float
        PV at the first sample.
    t0 : float
        Time of the first sample [s].
    """

    gain: float
    dead_time: float
    fit: float = math.nan
    warnings: list[str] = field(default_factory=list)
    method: str = ""
    u0: float = 0.0
    y0: float = 0.0
    t0: float = 0.0

    def response(self, t: ArrayLike, u: ArrayLike) -> NDArray[np.float64]:
        """Model output for the MV record ``u`` (held between samples) at times ``t``.

        Before the record the MV is taken to have been ``u[0]`` for ever, so
        the PV drifts at ``gain (u[0] - u0)`` from the first sample on.
        """
        t, u = np.asarray(t, float), np.asarray(u, float)
        drift = self.gain * (u[0] - self.u0) * (t - self.t0)
        return self.y0 + drift + self.gain * _superpose(t, u, self.dead_time, _ramp)

    def as_dict(self) -> dict[str, object]:
        """The keys of ``ctrlblocks identify --json``."""
        return _model_dict(self, "integrating", ("gain", "dead_time"))


Model = FOPDT | SOPDT | Integrating


def _lag_response(m: FOPDT | SOPDT, t: ArrayLike, u: ArrayLike, step) -> NDArray[np.float64]:
    """Output of a self-regulating model ``m`` (unit step response ``step``) for the MV ``u``."""
    t, u = np.asarray(t, float), np.asarray(u, float)
    x = _superpose(t, u, m.dead_time, step)
    return m.y0 + m.gain * (u[0] - m.u0 + x)


def _model_dict(m: Model, kind: str, params: tuple[str, ...]) -> dict[str, object]:
    """``{"model": kind, <params>, "fit", "method", "warnings"}`` of ``m`` (the JSON keys)."""
    return {
        "model": kind,
        **{p: getattr(m, p) for p in params},
        "fit": m.fit,
        "method": m.method,
        "warnings": list(m.warnings),
    }


# ---------------------------------------------------------------------------
# Two-point methods
# ---------------------------------------------------------------------------


def two_point(t: ArrayLike, u: ArrayLike, y: ArrayLike) -> FOPDT:
    """FOPDT by Marlin's two-point method (28.3 % / 63.2 %).

    ``T = 1.5 (t63 - t28)``, ``theta = t63 - T``, ``k = dy/du`` with the times
    measured from the MV step (Nowak et al. 2018, reference [18]: Marlin, *Process
    Control*, 1995).  See :func:`_step_analysis` for how the step, the
    baseline and the final value are found.  Meant for clean records with a
    single MV step; use :func:`fit_fopdt` for noisy ones.

    Parameters
    ----------
    t : array_like
        Time [s], strictly increasing.
    u, y : array_like
        MV and PV samples (MV held from each sample to the next).

    Returns
    -------
    FOPDT
    """
    return _two_point(
        t, u, y, (0.283, 0.632), lambda t1, t2: (1.5 * (t2 - t1), t2 - 1.5 * (t2 - t1)), "two-point"
    )


def sundaresan_krishnaswamy(t: ArrayLike, u: ArrayLike, y: ArrayLike) -> FOPDT:
    """FOPDT by Sundaresan and Krishnaswamy (35.3 % / 85.3 %).

    ``T = 0.67 (t2 - t1)``, ``theta = 1.3 t1 - 0.29 t2`` (Sundaresan &
    Krishnaswamy, Can. J. Chem. Eng. 56 (1978) 257-262), ``t1``/``t2`` the
    times after the step at 35.3 % / 85.3 % of the final change.  Arguments
    and result as :func:`two_point`.
    """
    return _two_point(
        t, u, y, (0.353, 0.853), lambda t1, t2: (0.67 * (t2 - t1), 1.3 * t1 - 0.29 * t2), "sk"
    )


def _two_point(t, u, y, fractions, rule, method) -> FOPDT:
    t, u, y = _check_record(t, u, y)
    s = _step_analysis(t, u, y)
    warnings = list(s["warnings"])
    tc = [
        _crossing_time(t, y, s["y_start"] + f * s["dy"], s["i_step"]) - s["t_step"]
        for f in fractions
    ]
    T, theta = rule(*tc)
    if theta < 0.0:
        warnings.append(f"the rule gave a negative dead time ({theta:.4g} s); set to 0")
        theta = 0.0
    if T <= 0.0:
        raise ValueError(f"{method}: the response gives a non-positive time constant ({T:.4g} s)")
    gain = s["dy"] / s["du"]
    model = FOPDT(gain, T, theta, method=method, u0=s["u_start"], y0=s["y_start"])
    fit = _nrmse(y, model.response(t, u))
    t_end = t[-1] - s["t_step"]
    if t_end < theta + 4.0 * T:
        warnings.append(_short_record(t_end, theta + 4.0 * T))
    return replace(model, fit=fit, warnings=warnings)


def _step_analysis(t: NDArray, u: NDArray, y: NDArray) -> dict:
    """Find the MV step and the PV baseline/final value for the two-point methods.

    The step is at the sample with the largest MV change (``u[i] - u[i-1]``);
    the MV is taken to switch at ``t[i]``.  Baseline: mean PV over the samples
    before the step (``y[0]`` if there is only one).  Final value: mean PV over
    the last 5 % of the record (at least 3 samples).
    """
    du_all = np.diff(u)
    i = int(np.argmax(np.abs(du_all))) + 1
    warnings: list[str] = []
    n_end = max(3, len(t) // 20)
    u_start, u_end = float(np.mean(u[:i])), float(np.mean(u[-n_end:]))
    y_start, y_end = float(np.mean(y[:i])), float(np.mean(y[-n_end:]))
    du, dy = u_end - u_start, y_end - y_start
    if np.sum(np.abs(du_all) > 0.01 * abs(du)) > 1:
        warnings.append("the MV changes more than once; two-point methods assume a single step")
    if dy == 0.0:
        raise ValueError("the PV does not change: no step response to analyse")
    if i >= 3:
        noise = float(np.std(y[:i])) / abs(dy)
        if noise > 0.01:
            warnings.append(
                f"noisy record (PV noise {100 * noise:.1f} % of the step): crossing times are "
                "uncertain; prefer the least-squares fit"
            )
    return {
        "i_step": i,
        "t_step": float(t[i]),
        "u_start": u_start,
        "y_start": y_start,
        "du": du,
        "dy": dy,
        "warnings": warnings,
    }


def _crossing_time(t: NDArray, y: NDArray, level: float, i0: int) -> float:
    """First time after sample ``i0`` at which ``y`` reaches ``level``.

    A cubic spline through the samples around the crossing is solved for the
    crossing (exact to O(h^4) for a smooth record).
    """
    sign = 1.0 if level >= y[max(i0 - 1, 0)] else -1.0
    above = np.nonzero(sign * (y[i0:] - level) >= 0.0)[0]
    if len(above) == 0:
        raise ValueError(f"the PV never reaches {level:.6g}")
    j = i0 + int(above[0])
    if j == 0 or y[j] == level:
        return float(t[j])
    lo, hi = max(j - 4, 0), min(j + 4, len(t))
    spline = interpolate.CubicSpline(t[lo:hi], y[lo:hi]) if hi - lo >= 4 else None
    if spline is None:
        return float(np.interp(level, [y[j - 1], y[j]], [t[j - 1], t[j]]))
    try:
        return float(
            optimize.brentq(lambda x: float(spline(x)) - level, t[j - 1], t[j], xtol=1e-12)
        )
    except ValueError:  # spline wiggles past the bracket: fall back to linear
        return float(t[j - 1] + (level - y[j - 1]) * (t[j] - t[j - 1]) / (y[j] - y[j - 1]))


# ---------------------------------------------------------------------------
# Least squares
# ---------------------------------------------------------------------------


def fit_fopdt(t: ArrayLike, u: ArrayLike, y: ArrayLike) -> FOPDT:
    """Least-squares FOPDT fit to the whole record.

    Minimises ``sum (y - y0 - k x(t; T, theta))^2`` where ``x`` is the exact
    response of ``e^{-theta s}/(T s + 1)`` to the recorded MV changes (ZOH);
    ``k`` and ``y0`` are solved linearly for each ``(T, theta)``.

    Parameters
    ----------
    t : array_like
        Time [s], strictly increasing.
    u, y : array_like
        MV and PV samples.

    Returns
    -------
    FOPDT
    """
    t, u, y = _check_record(t, u, y)
    dt_min, span = _time_scales(t)
    grid = [
        (T, th) for T in np.geomspace(dt_min, span, 14) for th in np.linspace(0.0, 0.6 * span, 13)
    ]
    p = _fit(t, u, y, lambda q: _fopdt_step(q[0]), grid, [(dt_min / 10, 10 * span), (0.0, span)])
    T, theta = p["q"]
    model = FOPDT(p["k"], T, theta, method="lsq", u0=float(u[0]), y0=p["y0"])
    return _finish(model, t, u, y, theta + 4.0 * T, p)


def fit_sopdt(t: ArrayLike, u: ArrayLike, y: ArrayLike) -> SOPDT:
    """Least-squares SOPDT fit (``T1 >= T2``) to the whole record.

    As :func:`fit_fopdt` with the step response of
    ``1/((T1 s + 1)(T2 s + 1))``: ``1 - e^{-t/T1}(1 + (t/T1) phi(x))``,
    ``x = -t (T1 - T2)/(T1 T2)``, ``phi(x) = (e^x - 1)/x`` (equal to the
    textbook ``1 - (T1 e^{-t/T1} - T2 e^{-t/T2})/(T1 - T2)`` and exact also
    for ``T1 = T2``).  Starts from the FOPDT fit, split by the inverse half
    rule at several ratios.
    """
    t, u, y = _check_record(t, u, y)
    dt_min, span = _time_scales(t)
    f = fit_fopdt(t, u, y)
    T, th = f.time_constant, f.dead_time
    grid = []
    for share in (0.1, 0.3, 0.6, 0.9):
        t2 = max(2.0 * th * share, 0.05 * T)
        grid.append((max(T - t2 / 2.0, t2), t2, max(th - t2 / 2.0, 0.0)))
    grid.append((0.7 * T, 0.7 * T, 0.5 * th))

    def step(q):
        return _sopdt_step(max(q[0], q[1]), min(q[0], q[1]))

    bounds = [(dt_min / 10, 10 * span), (dt_min / 100, 10 * span), (0.0, span)]
    p = _fit(t, u, y, step, grid, bounds, polish_all=True)
    T1, T2, theta = p["q"]
    T1, T2 = max(T1, T2), min(T1, T2)
    model = SOPDT(p["k"], T1, theta, T2, method="lsq-sopdt", u0=float(u[0]), y0=p["y0"])
    return _finish(model, t, u, y, theta + 4.0 * T1 + 2.0 * T2, p)


def fit_integrating(t: ArrayLike, u: ArrayLike, y: ArrayLike) -> Integrating:
    """Least-squares fit of ``k e^{-theta s}/s`` (level-like processes).

    ``y = y0 + d (t - t[0]) + k x(t; theta)`` with ``x`` the delayed ramp
    response to the MV changes; ``k``, ``y0`` and the initial drift ``d`` are
    linear.  The balancing MV is ``u0 = u[0] - d/k``.
    """
    t, u, y = _check_record(t, u, y)
    _, span = _time_scales(t)
    grid = [(th,) for th in np.linspace(0.0, 0.6 * span, 25)]
    p = _fit(t, u, y, lambda q: _ramp, grid, [(0.0, span)], drift=True)
    (theta,) = p["q"]
    k = p["k"]
    u0 = float(u[0] - p["drift"] / k) if k != 0.0 else float(u[0])
    model = Integrating(k, theta, method="integrating", u0=u0, y0=p["y0"], t0=float(t[0]))
    return _finish(model, t, u, y, None, p)


_FIT_SAMPLES = 1500
"""Grid search and the search from several starts use at most about this many samples."""


def _fit(t, u, y, make_step, grid, bounds, drift=False, polish_all=False) -> dict:
    """Variable-projection least squares: grid search, then ``least_squares``.

    On a long record the grid search and the searches from the best starts
    run on every k-th sample (at most ``_FIT_SAMPLES``); the best result is
    then polished on the whole record.
    """
    changes = _changes(t, u)
    lo = np.array([b[0] for b in bounds])
    hi = np.array([b[1] for b in bounds])

    def make_solver(idx):
        tt, yy = t[idx], y[idx]
        cols0 = [np.ones_like(tt)] + ([tt - t[0]] if drift else [])

        def solve(q):
            x = _superpose_changes(tt, changes, q[-1], make_step(q))
            a = np.column_stack([x, *cols0])
            coef, *_ = np.linalg.lstsq(a, yy, rcond=None)
            return coef, yy - a @ coef

        return solve

    def search(solve, q0):
        q0 = np.clip(np.asarray(q0, float), lo, hi)
        return optimize.least_squares(
            lambda q: solve(q)[1], q0, bounds=(lo, hi), x_scale="jac", method="trf"
        )

    step = -(-len(t) // _FIT_SAMPLES)  # ceil
    coarse = make_solver(slice(None, None, step))
    scored = sorted(grid, key=lambda q: float(np.sum(coarse(np.asarray(q, float))[1] ** 2)))
    best = min(
        (search(coarse, q0) for q0 in scored[: 3 if not polish_all else len(scored)]),
        key=lambda sol: sol.cost,
    )
    solve = coarse
    if step > 1:
        solve = make_solver(slice(None))
        best = search(solve, best.x)
    coef, res = solve(best.x)
    out = {
        "q": [float(v) for v in best.x],
        "k": float(coef[0]),
        "y0": float(coef[1]),
        "res": res,
        "at_bound": [
            bool(np.isclose(v, b[1], rtol=1e-6)) for v, b in zip(best.x, bounds, strict=True)
        ],
    }
    if drift:
        out["drift"] = float(coef[2])
    return out


def _finish(model, t, u, y, settle, p):
    warnings = []
    fit = _nrmse(y, model.response(t, u))
    if settle is not None:
        tk, duk = _changes(t, u)
        t_last = tk[np.abs(duk) >= 0.1 * np.max(np.abs(duk))][-1]  # last real move
        if t[-1] - t_last < settle:
            warnings.append(_short_record(t[-1] - t_last, settle))
    if any(p["at_bound"]):
        warnings.append(
            "a parameter hit the upper end of its search range: the record may be too short"
        )
    if fit > 0.05:
        warnings.append(
            f"poor fit (normalised RMS error {fit:.3f}); check the model type and the record"
        )
    for w in warnings:
        _log.info("%s: %s", model.method, w)
    return replace(model, fit=fit, warnings=warnings)


# ---------------------------------------------------------------------------
# Helpers: step responses and superposition
# ---------------------------------------------------------------------------


def _fopdt_step(T: float):
    T = float(T)
    return lambda s: -np.expm1(-s / T)


def _sopdt_step(T1: float, T2: float):
    T1, T2 = float(T1), float(T2)

    def step(s):
        x = -s * (T1 - T2) / (T1 * T2)
        with np.errstate(invalid="ignore", divide="ignore"):
            phi = np.where(
                np.abs(x) < 1e-8, 1.0 + x / 2.0, np.expm1(x) / np.where(x == 0.0, 1.0, x)
            )
        return 1.0 - np.exp(-s / T1) * (1.0 + (s / T1) * phi)

    return step


def _ramp(s):
    return s


def _changes(t: NDArray, u: NDArray) -> tuple[NDArray, NDArray]:
    """Times and sizes of the MV changes (the MV switches at the sample time).

    The cost of the exact superposition grows with the number of changes.  A
    measured MV with noise changes at every sample; above ``_MAX_CHANGES``
    changes (fewer for long records: at most 2e6/N, at least 50) it is
    replaced by a hysteresis-quantised copy (a new level only when the MV
    leaves a band of +-delta around the held one; delta starts at
    0.5 % of the MV range and doubles until few enough changes remain).  This
    filters MV measurement noise and keeps every real move larger than 2 delta.
    """
    du = np.diff(u)
    rng = float(np.ptp(u))
    keep = np.abs(du) > 1e-12 * max(rng, 1e-300)
    delta = 0.005 * rng
    limit = min(_MAX_CHANGES, max(50, 2_000_000 // len(t)))  # bounds the cost N x changes
    while np.count_nonzero(keep) > limit:
        uq = _hysteresis_quantise(u, delta)
        du = np.diff(uq)
        keep = du != 0.0
        delta *= 2.0
    return t[1:][keep], du[keep]


def _hysteresis_quantise(u: NDArray, delta: float) -> NDArray:
    out = np.empty_like(u)
    level = float(u[0])
    for i, x in enumerate(u.tolist()):
        if abs(x - level) > delta:
            level = x
        out[i] = level
    return out


def _superpose_changes(t: NDArray, changes: tuple[NDArray, NDArray], theta: float, step) -> NDArray:
    tk, duk = changes
    s = t[:, None] - tk[None, :] - theta
    return np.where(s > 0.0, step(np.maximum(s, 0.0)), 0.0) @ duk


def _superpose(t: NDArray, u: NDArray, theta: float, step) -> NDArray:
    """Response of ``e^{-theta s} G(s)`` (unit step response ``step``) to the MV changes."""
    return _superpose_changes(t, _changes(t, u), theta, step)


def _check_record(t, u, y) -> tuple[NDArray, NDArray, NDArray]:
    t, u, y = (np.asarray(a, dtype=float).ravel() for a in (t, u, y))
    if not (len(t) == len(u) == len(y)):
        raise ValueError(f"t, u and y must have the same length (got {len(t)}, {len(u)}, {len(y)})")
    if len(t) < MIN_SAMPLES:
        raise ValueError(f"at least {MIN_SAMPLES} samples are needed, got {len(t)}")
    for name, a in (("t", t), ("u", u), ("y", y)):
        if not np.all(np.isfinite(a)):
            raise ValueError(
                f"{name} contains NaN or inf (first at index {int(np.argmin(np.isfinite(a)))})"
            )
        if np.any(np.abs(a) > MAX_MAGNITUDE):
            first = int(np.argmax(np.abs(a) > MAX_MAGNITUDE))
            raise ValueError(f"{name}[{first}] = {float(a[first])!r} is beyond {_BEYOND}")
    if np.any(np.diff(t) <= 0.0):
        raise ValueError(
            "time must increase strictly (first violation at index "
            f"{int(np.argmax(np.diff(t) <= 0)) + 1})"
        )
    if _constant(u):
        raise ValueError("the MV never changes: there is no step to identify from")
    return t, u, y


def _time_scales(t: NDArray) -> tuple[float, float]:
    return float(np.min(np.diff(t))), float(t[-1] - t[0])


def _nrmse(y: NDArray, y_model: NDArray) -> float:
    rng = float(np.ptp(y))
    return float(np.sqrt(np.mean((y - y_model) ** 2)) / rng) if rng > 0 else math.inf


def _short_record(have: float, need: float) -> str:
    return (
        f"the record ends {have:.4g} s after the last MV change, but the model needs about "
        f"{need:.4g} s to settle (98 %): the gain and time constants are uncertain"
    )
