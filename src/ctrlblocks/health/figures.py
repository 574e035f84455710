"""The figures of a loop's performance assessment, each a function of recorded data.

Every function takes numpy arrays of one loop's record (time ``t`` [s], setpoint
``sp``, process value ``y``, controller output ``u``, ...) and returns a small
result object; none keeps state.  ``docs/health.md`` gives each figure's
definition, source and the test that checks it.

* :func:`service_factors` -- time in each mode, time at each MV limit, bad-PV time;
* :func:`valve_wear` -- MV travel and reversals per hour;
* :func:`oscillation` -- Hägglund (1995): the IAE between successive zero
  crossings of the control error against ``IAE_lim = 2 a / omega_u``, counted
  with the forgetting factor ``gamma = 1 - h / T_sup``, ``T_sup = 50 T_u``, and
  an oscillation when the count exceeds ``n_lim = 10``; period and amplitude
  of what was detected;
* :func:`harris_index` -- Harris (1989): the minimum-variance benchmark from
  routine data and the dead time, ``eta = sigma_mv^2 / sigma_y^2``;
* :func:`horch_stiction` -- Horch (1999): the cross-correlation of controller
  output and process value of an oscillating loop, odd (stiction) or even (no
  stiction);
* :func:`setpoint_steps` -- the set-point changes where a model can be
  re-identified (the model drift of :mod:`.assess`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "HarrisResult",
    "HorchResult",
    "OscillationResult",
    "ServiceFactors",
    "ValveWear",
    "harris_index",
    "hold_times",
    "horch_stiction",
    "oscillation",
    "service_factors",
    "setpoint_steps",
    "valve_wear",
]

Array = NDArray[np.float64]


def hold_times(t: Array) -> Array:
    """How long each sample holds [s]: ``t[i+1] - t[i]``; the last sample the median step.

    A gap longer than 10 median steps (a stopped recorder) counts as one median step.
    """
    t = np.asarray(t, dtype=float)
    if t.size < 2:
        return np.ones_like(t)
    dt = np.diff(t)
    h = float(np.median(dt))
    dt = np.where(dt > 10.0 * h, h, dt)
    return np.append(dt, h)


# ---------------------------------------------------------------------------
# Service factors
# ---------------------------------------------------------------------------


@dataclass
class ServiceFactors:
    """Fractions of the record's time (0..1); ``modes`` by mode name."""

    duration: float
    modes: dict[str, float]
    at_low: float
    at_high: float
    bad_pv: float
    u_min: float
    u_max: float
    limits_from_data: bool


def service_factors(
    t: Array,
    u: Array,
    mode: list[str] | None,
    pv_ok: NDArray[np.bool_],
    u_min: float | None = None,
    u_max: float | None = None,
    tol: float = 0.002,
) -> ServiceFactors:
    """Time in each mode, at each MV limit and with a bad PV, as fractions of the record.

    A sample is *at a limit* when ``u`` lies within ``tol`` (a fraction of
    ``u_max - u_min``) of it.  Without given limits the record's own extremes
    are taken and a sample counts only while ``u`` also stays there (``|du| <=
    tol`` span from a neighbour): a loop pinned at a limit holds the same MV, a
    healthy loop only touches its extremes.  Each sample weighs its hold time
    (:func:`hold_times`).
    """
    w = hold_times(t)
    total = float(np.sum(w))
    ok_u = np.isfinite(u)
    from_data = u_min is None or u_max is None
    lo = float(np.min(u[ok_u])) if u_min is None and ok_u.any() else (u_min or 0.0)
    hi = float(np.max(u[ok_u])) if u_max is None and ok_u.any() else (u_max or 0.0)
    span = hi - lo if hi > lo else 1.0
    at_lo = ok_u & (u <= lo + tol * span)
    at_hi = ok_u & (u >= hi - tol * span)
    if from_data:
        flat = np.abs(np.diff(u)) <= tol * span  # u[i+1] ~ u[i]
        still = np.append(flat, False) | np.append(False, flat)  # in a run of >= 2 samples
        at_lo &= still
        at_hi &= still
    modes: dict[str, float] = {}
    if mode is not None:
        names = np.asarray(mode, dtype=object)
        for m in sorted(set(mode)):
            modes[m] = float(np.sum(w[names == m])) / total
    else:
        modes["AUTO"] = 1.0
    return ServiceFactors(
        duration=total,
        modes=modes,
        at_low=float(np.sum(w[at_lo])) / total,
        at_high=float(np.sum(w[at_hi])) / total,
        bad_pv=float(np.sum(w[~pv_ok])) / total,
        u_min=lo,
        u_max=hi,
        limits_from_data=from_data,
    )


# ---------------------------------------------------------------------------
# Valve wear
# ---------------------------------------------------------------------------


@dataclass
class ValveWear:
    """MV travel and reversals, in total and per hour."""

    travel: float
    """Sum of ``|u[k] - u[k-1]|`` [MV units]."""
    travel_per_hour: float
    reversals: int
    """Direction changes of more than ``deadband`` (turning points)."""
    reversals_per_hour: float
    hours: float


def valve_wear(t: Array, u: Array, deadband: float = 0.0) -> ValveWear:
    """MV travel and reversals per hour (what a valve's packing and actuator wear by).

    Travel: ``sum |u[k] - u[k-1]|``.  A reversal is counted when ``u`` turns
    back from its last extreme by more than ``deadband`` (a turning point of
    the hysteresis-filtered MV), so jitter smaller than the deadband counts
    no reversal.
    """
    ok = np.isfinite(u)
    uu = u[ok]
    hours = float(np.sum(hold_times(t))) / 3600.0
    travel = float(np.sum(np.abs(np.diff(uu)))) if uu.size > 1 else 0.0
    rev = _reversals(uu, deadband)
    per = 1.0 / hours if hours > 0 else 0.0
    return ValveWear(travel, travel * per, rev, rev * per, hours)


def _reversals(u: Array, deadband: float) -> int:
    """Turning points of ``u`` with hysteresis ``deadband``."""
    d = 0  # direction of the current run: +1 up, -1 down, 0 not yet known
    hi = lo = ext = float(u[0]) if u.size else 0.0
    n = 0
    for x in u.tolist():
        if d == 0:
            hi, lo = max(hi, x), min(lo, x)
            if hi - lo > deadband:
                d, ext = (1, hi) if x == hi else (-1, lo)
        elif d > 0:
            if x > ext:
                ext = x
            elif ext - x > deadband:
                n, d, ext = n + 1, -1, x
        elif x < ext:
            ext = x
        elif x - ext > deadband:
            n, d, ext = n + 1, 1, x
    return n


# ---------------------------------------------------------------------------
# Oscillation (Hägglund 1995)
# ---------------------------------------------------------------------------


@dataclass
class OscillationResult:
    """Hägglund's (1995) oscillation detection on the control error."""

    detected: bool
    iae_lim: float
    """``2 a / omega_u`` [error units x s]."""
    loads: int
    """Half-cycles whose IAE exceeded ``iae_lim`` (Hägglund's load disturbances)."""
    peak_count: float
    """Largest value of the forgetting count ``x``; an oscillation when > ``n_lim``."""
    spans: list[tuple[float, float]] = field(default_factory=list)
    """Time spans [s] in which the count exceeded ``n_lim``."""
    period: float = math.nan
    """Period [s] of the detected oscillation: twice the median half-cycle."""
    amplitude: float = math.nan
    """Amplitude [error units]: ``pi IAE_i / (2 tau_i)`` (a sine's), median over its half-cycles."""
    fraction: float = 0.0
    """Fraction of the record's time inside the spans."""


N_LIM = 10.0
"""Hägglund (1995): an oscillation when more than ``n_lim = 10`` loads are counted."""
SUPERVISION = 50.0
"""Hägglund (1995): supervision time ``T_sup = 50 T_u``."""


def oscillation(
    t: Array,
    e: Array,
    a: float,
    tu: float,
    *,
    active: NDArray[np.bool_] | None = None,
    filter_time: float | None = None,
) -> OscillationResult:
    """Hägglund's (1995) oscillation detection on the control error ``e = sp - y``.

    Between successive zero crossings of ``e`` (a half-cycle of duration
    ``tau_i``) the integral ``IAE_i = integral |e| dt`` is compared with
    ``IAE_lim = 2 a / omega_u = a T_u / pi`` (the IAE of a half period of a
    sine of amplitude ``a`` at the ultimate frequency ``omega_u = 2 pi / T_u``).
    Each larger one is a *load*; the count ``x`` forgets with ``gamma = 1 -
    h / T_sup`` per sample (``T_sup = 50 T_u``) and an oscillation is detected
    while ``x > n_lim = 10``.

    Parameters
    ----------
    a : float
        Acceptable amplitude [error units] (Hägglund suggests 1 % of the signal range).
    tu : float
        Ultimate period [s] (Hägglund: the integral time ``T_i`` when ``T_u`` is unknown).
    active : bool array, optional
        Samples where the loop controls (AUTO); others break the half-cycles.
    filter_time : float, optional
        Time constant [s] of a first-order filter on ``e`` against crossings
        made by measurement noise; default ``tu / 20`` (ctrlblocks' addition).
    """
    t = np.asarray(t, dtype=float)
    e = np.asarray(e, dtype=float)
    iae_lim = a * tu / math.pi
    ok = np.isfinite(e) if active is None else (np.isfinite(e) & active)
    w = hold_times(t)
    tf = tu / 20.0 if filter_time is None else filter_time
    ef = _lowpass(np.where(ok, e, 0.0), w, tf)
    sign = np.sign(ef)
    # a half-cycle ends where the sign changes (or where the loop stops controlling)
    cross = np.flatnonzero((sign[1:] * sign[:-1] < 0) | ~ok[1:] | ~ok[:-1]) + 1
    bounds = np.concatenate(([0], cross, [e.size]))
    absw = np.abs(np.where(ok, e, 0.0)) * w
    csum = np.concatenate(([0.0], np.cumsum(absw)))
    tsum = np.concatenate(([0.0], np.cumsum(w)))
    iae = csum[bounds[1:]] - csum[bounds[:-1]]
    dur = tsum[bounds[1:]] - tsum[bounds[:-1]]
    ends = bounds[1:] - 1
    valid = ok[bounds[:-1]] & (bounds[1:] > bounds[:-1])
    # the first and the last half-cycle are cut by the record: not judged
    valid[0] = False
    valid[-1] = False
    load = valid & (iae > iae_lim)
    h = float(np.median(w))
    gamma = max(0.0, 1.0 - h / (SUPERVISION * tu))  # a T_u below h/50: no memory
    x = 0.0
    last = 0
    peak = 0.0
    spans: list[tuple[float, float]] = []
    osc_half: list[int] = []
    start: float | None = None
    for i in np.flatnonzero(load).tolist():
        k = int(ends[i])
        x = x * gamma ** (k - last) + 1.0
        last = k
        peak = max(peak, x)
        if x > N_LIM:
            if start is None:
                start = float(t[int(bounds[i])])
            osc_half.append(i)
        elif start is not None:
            spans.append((start, float(t[k])))
            start = None
    if start is not None:
        spans.append((start, float(t[-1])))
    res = OscillationResult(bool(spans), iae_lim, int(np.sum(load)), peak, spans)
    if osc_half:
        idx = np.array(osc_half)
        res.period = 2.0 * float(np.median(dur[idx]))
        res.amplitude = float(np.median(math.pi * iae[idx] / (2.0 * dur[idx])))
        total = float(np.sum(w))
        res.fraction = sum(b - a0 for a0, b in spans) / total if total > 0 else 0.0
    return res


def _lowpass(x: Array, w: Array, tf: float) -> Array:
    """First-order filter ``y[k] = a y[k-1] + (1 - a) x[k]``, ``a = exp(-h/tf)``, from x[0]."""
    if tf <= 0.0:
        return x
    from scipy.signal import lfilter

    a = math.exp(-float(np.median(w)) / tf)
    y, _ = lfilter([1.0 - a], [1.0, -a], x, zi=[a * x[0]])
    return np.asarray(y)


# ---------------------------------------------------------------------------
# Minimum-variance benchmark (Harris 1989)
# ---------------------------------------------------------------------------


@dataclass
class HarrisResult:
    """Harris' (1989) minimum-variance benchmark."""

    index: float
    """``eta = sigma_mv^2 / sigma_y^2`` in [0, 1]; 1: the loop has minimum variance."""
    var_y: float
    """Mean square of the control error (its offset counts too)."""
    var_mv: float
    """``sigma_eps^2 sum_{j<d} psi_j^2``: the variance no feedback can remove."""
    delay: int
    """Dead time ``d`` in samples (with the sample of the hold)."""
    order: int


def harris_index(e: Array, delay: int, order: int = 20) -> HarrisResult:
    """Harris' (1989) index from routine closed-loop data and the loop's dead time.

    The error ``e = y - sp`` (sampled at the controller's period) is fitted by
    an autoregressive model of ``order``, ``e_t = sum a_i e_{t-i} + eps_t``
    (the Yule-Walker equations of its autocovariances: for the long records of
    routine data the same as least squares, at a fraction of the cost); its
    impulse response ``psi_0 = 1, psi_j = sum_i a_i psi_{j-i}`` gives the first
    ``d`` terms of the closed loop's moving-average form, which no feedback
    can change, so ``sigma_mv^2 = sigma_eps^2 sum_{j=0}^{d-1} psi_j^2``;
    ``eta = sigma_mv^2 / mean(e^2)``.

    ``delay`` is the dead time in samples including the hold: ``d = 1 +
    floor(L / h)`` for a dead time ``L`` at sample time ``h``.
    """
    e = np.asarray(e, dtype=float)
    e = e[np.isfinite(e)]
    p = int(order)
    # a dead time longer than the record leaves nothing to judge: at most a quarter of it
    delay = min(max(int(delay), 1), max(e.size // 4, 1))
    ms = float(np.mean(e * e)) if e.size else math.nan
    if e.size < 5 * p + 10 or not ms > 0.0:
        return HarrisResult(math.nan, ms, math.nan, delay, p)
    from scipy.linalg import solve_toeplitz

    x = e - np.mean(e)
    n = x.size
    # the Yule-Walker equations R a = r of the autocovariances r_k = sum x_t x_{t+k} / n
    r = np.array([float(np.dot(x[: n - k], x[k:])) / n for k in range(p + 1)])
    coef = solve_toeplitz(r[:p], r[1:])
    var_eps = float(r[0] - np.dot(coef, r[1:]))
    psi = np.zeros(delay)
    psi[0] = 1.0
    for j in range(1, delay):
        psi[j] = sum(coef[i - 1] * psi[j - i] for i in range(1, min(j, p) + 1))
    var_mv = var_eps * float(np.sum(psi * psi))
    return HarrisResult(min(var_mv / ms, 1.0), ms, var_mv, delay, p)


# ---------------------------------------------------------------------------
# Stiction (Horch 1999)
# ---------------------------------------------------------------------------


@dataclass
class HorchResult:
    """Horch's (1999) cross-correlation test of an oscillating loop."""

    verdict: str
    """``"stiction"`` (odd CCF), ``"no stiction"`` (even) or ``"undecided"``."""
    asymmetry: float
    """``(tau_r + tau_l)/(tau_r - tau_l)`` in [-1, 1]: 0 even, +-1 odd."""
    tau_l: float
    tau_r: float
    """The zero crossings [s] of the CCF nearest lag 0, left (<= 0) and right (>= 0)."""
    lags: Array = field(repr=False, default_factory=lambda: np.zeros(0))
    ccf: Array = field(repr=False, default_factory=lambda: np.zeros(0))


ODD = 0.3
"""Asymmetry above which the CCF counts as odd (stiction): the crossings 27 deg or more off
lag +-T/4 (set on the fault campaign of docs/health.md)."""
EVEN = 0.15
"""Asymmetry below which it counts as even (no stiction): within 13.5 deg."""


def horch_stiction(u: Array, y: Array, h: float, period: float) -> HorchResult:
    """Horch's (1999) test: is the cross-correlation of ``u`` and ``y`` odd or even?

    For a self-regulating process in a loop that oscillates, Horch (1999)
    observed that valve stiction makes the cross-correlation function
    ``r_uy(tau)`` of controller output and process value odd (zero at lag 0:
    the PV, square-like, and the controller output, a ramp integrating it, are
    a quarter period apart), while an oscillation from tuning or an external
    disturbance makes it even (extreme at lag 0: output and PV in opposition).
    Both signals first lose their moving average over one ``period`` (the
    slower load and set-point changes; ctrlblocks' addition).
    ctrlblocks quantifies it by the zero crossings of ``r_uy`` nearest lag 0,
    ``tau_l <= 0 <= tau_r``: the asymmetry ``(tau_r + tau_l)/(tau_r - tau_l)``
    is 0 for an even and +-1 for an odd function; above :data:`ODD` it says
    stiction, below :data:`EVEN` no stiction, between undecided.  Not for
    integrating processes (Horch 1999's condition).
    """
    ok = np.isfinite(u) & np.isfinite(y)
    m = max(round(period / h), 1)
    uu = _detrend(u[ok], m)
    yy = _detrend(y[ok], m)
    n = uu.size
    su, sy = float(np.std(uu)), float(np.std(yy))
    if n < 10 or su == 0.0 or sy == 0.0 or not period > 0.0:
        return HorchResult("undecided", math.nan, math.nan, math.nan)
    m = min(m, n // 2)
    # r[k] = sum_i u[i] y[i + k] / (n s_u s_y) for |k| <= m only: O(n m), not O(n^2)
    lags = np.arange(-m, m + 1)
    r = np.array([float(np.dot(uu[max(0, -k) : n - max(0, k)], yy[max(0, k) : n - max(0, -k)]))
                  for k in lags.tolist()]) / (n * su * sy)  # fmt: skip
    tau_r = _first_zero(r[m:], 1.0)
    tau_l = -_first_zero(r[m::-1], 1.0)
    if not (math.isfinite(tau_r) and math.isfinite(tau_l)) or tau_r - tau_l <= 0.0:
        return HorchResult("undecided", math.nan, tau_l * h, tau_r * h, lags * h, r)
    asym = (tau_r + tau_l) / (tau_r - tau_l)
    verdict = "stiction" if abs(asym) > ODD else "no stiction" if abs(asym) < EVEN else "undecided"
    return HorchResult(verdict, asym, tau_l * h, tau_r * h, lags * h, r)


def _detrend(x: Array, m: int) -> Array:
    """``x`` less its centred moving average over ``m`` samples (one period).

    The mean over a whole period of the oscillation is its offset, so this keeps
    the oscillation and removes the slower load and set-point changes; the
    ``m // 2`` samples at each end are dropped.
    """
    if x.size <= m + 2 or m < 2:
        return x - np.mean(x)
    c = np.concatenate(([0.0], np.cumsum(x)))
    avg = (c[m:] - c[:-m]) / m  # avg[i] = mean(x[i : i + m])
    half = m // 2
    return x[half : half + avg.size] - avg


def _first_zero(r: Array, step: float) -> float:
    """The first zero crossing of ``r`` (in samples, interpolated); 0 if ``r[0] == 0``."""
    if r[0] == 0.0:
        return 0.0
    s = np.sign(r)
    idx = np.flatnonzero(s[1:] != s[0])
    if idx.size == 0:
        return math.nan
    k = int(idx[0])
    r0, r1 = float(r[k]), float(r[k + 1])
    return step * (k + r0 / (r0 - r1)) if r1 != r0 else step * k


# ---------------------------------------------------------------------------
# Set-point steps (excitation for re-identification)
# ---------------------------------------------------------------------------


def setpoint_steps(t: Array, sp: Array, min_step: float) -> list[int]:
    """Indices where the setpoint changes by more than ``min_step`` from one sample to the next."""
    d = np.abs(np.diff(sp))
    return (np.flatnonzero(np.isfinite(d) & (d > min_step)) + 1).tolist()
