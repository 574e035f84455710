"""Performance metrics of a closed-loop run, per run and per event window.

Every metric is computed from the sampled trace (time ``t``, setpoint ``r``,
controlled variable ``y``, manipulated variable ``u``) of one window
``t0 <= t_k < t1``.  Samples are equidistant with period ``h``; the control
error is ``e_k = r_k - y_k``.  Integrals use the rectangle (left Riemann) sum
that belongs to sampled data held over each period, so a hand calculation
over a few samples gives the same number.

Definitions (``k`` runs over the samples of the window, ``n`` of them):

``iae``
    integral of the absolute error, ``h * sum |e_k|``  [PV units * s].
``ise``
    integral of the squared error, ``h * sum e_k**2``  [PV units^2 * s].
``itae``
    time-weighted IAE, ``h * sum (t_k - t0) |e_k|``, time measured from the
    start of the window  [PV units * s^2].
``step``
    the size of the step the window asks for, ``Δ = r_end - y_0``: final
    setpoint minus the first value of ``y`` in the window [PV units].  A
    window is a *step window* when the setpoint changes at its start
    (``r_end`` differs from the setpoint of the sample before the window), or
    when the window opens with the loop taking control -- the start of the
    data, or a switch to AUTO (``Window.switch``) -- while it is far from the
    setpoint, ``|Δ| > step_tol · max(|r_end|, |y_0|)`` (default 1 %).
    Otherwise it is a regulation window (a load, a plant change, a sensor
    fault, ripple at steady state: the loop was not asked to move, however
    far it happens to be from the setpoint) and the step-response metrics
    below (overshoot, rise time) are NaN: a percentage of a step that was not
    asked for has no meaning.  The whole run of several windows is no step
    either.
``overshoot``
    step windows only: ``max(0, max_k s (y_k - r_end)) / |Δ|`` with
    ``s = sign(Δ)``, a fraction of the step (0.25 = 25 %).
``rise_time``
    step windows only: time from the first sample at which ``y`` has covered
    10 % of the step to the first sample at which it has covered 90 % [s];
    NaN if 90 % is never reached.
``settling_time``
    time from ``t0`` to the first sample after which ``|y_k - r_end|`` stays
    within the band until the end of the window [s].  The band is
    ``band * |Δ|`` for a step window and ``band * max(|r_end|, peak_error)``
    for a regulation window (default ``band = 0.02``: 2 %).  0 if ``y`` never
    leaves the band; NaN if it is outside the band at the end of the window.
``peak_error``
    ``max |e_k|`` [PV units] (for a load window: the largest deviation).
``final_error``
    mean of ``|e_k|`` over the last 5 % of the window (at least one sample)
    [PV units]: the offset that remains.
``tv_u``
    total variation of the MV, ``sum |u_k - u_{k-1}|`` over consecutive
    samples inside the window [MV units]: how much the actuator moves.
``max_rate_u``
    largest ``|u_k - u_{k-1}| / h`` inside the window [MV units / s].
``jump_u``
    ``|u_first - u_before|``: the change of the MV at the first sample of the
    window against the sample just before it (0 for the first window) [MV
    units]: the bump of a mode switch.

NaN values are written as ``null`` in ``metrics.json``, and so are infinite
ones (a run whose signals reach beyond the float range, an unstable loop).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "METRIC_NAMES",
    "Window",
    "compute_metrics",
    "final_error",
    "iae",
    "ise",
    "itae",
    "max_rate",
    "overshoot",
    "rise_time",
    "run_metrics",
    "settling_time",
    "total_variation",
    "window_index",
    "windows_from_events",
]

METRIC_NAMES: tuple[str, ...] = (
    "iae",
    "ise",
    "itae",
    "overshoot",
    "settling_time",
    "rise_time",
    "peak_error",
    "final_error",
    "tv_u",
    "max_rate_u",
    "jump_u",
)
"""Keys of the dictionary returned by :func:`compute_metrics`, in table order."""


# ---------------------------------------------------------------------------
# Single metrics over arrays (all inputs are 1-D numpy arrays of one window)
# ---------------------------------------------------------------------------


def iae(e: np.ndarray, h: float) -> float:
    """Integral of the absolute error, ``h * sum |e_k|`` [PV units * s]."""
    return float(h * np.sum(np.abs(e)))


def ise(e: np.ndarray, h: float) -> float:
    """Integral of the squared error, ``h * sum e_k**2`` [PV units^2 * s]."""
    return float(h * np.sum(e * e))


def itae(e: np.ndarray, t: np.ndarray, h: float) -> float:
    """Time-weighted IAE, ``h * sum (t_k - t_0) |e_k|`` [PV units * s^2]."""
    if len(t) == 0:
        return 0.0
    return float(h * np.sum((t - t[0]) * np.abs(e)))


def overshoot(y: np.ndarray, r_end: float, step: float) -> float:
    """Overshoot as a fraction of the step: ``max(0, max s (y - r_end)) / |step|``.

    ``s = sign(step)``; NaN when ``step`` is 0.
    """
    if step == 0.0 or len(y) == 0:
        return math.nan
    s = 1.0 if step > 0 else -1.0
    return float(max(0.0, float(_max(s * (y - r_end)))) / abs(step))


def rise_time(t: np.ndarray, y: np.ndarray, y0: float, step: float) -> float:
    """Time from 10 % to 90 % of the step (first crossings) [s]; NaN if not reached."""
    if step == 0.0 or len(y) == 0:
        return math.nan
    covered = (y - y0) / step
    # the first sample of each (argmax of a boolean array: its first True, or 0 if none)
    c10, c90 = covered >= 0.1, covered >= 0.9
    i10, i90 = int(c10.argmax()), int(c90.argmax())
    if not (c10[i10] and c90[i90]):
        return math.nan
    return float(t[i90] - t[i10])


def settling_time(t: np.ndarray, y: np.ndarray, r_end: float, band: float) -> float:
    """Time from ``t[0]`` until ``|y - r_end| <= band`` holds to the end [s].

    0 when ``y`` never leaves the band, NaN when it is outside at the end.
    """
    if len(y) == 0 or not math.isfinite(band):
        return math.nan
    outside = (~(np.abs(y - r_end) <= band)).nonzero()[0]
    if len(outside) == 0:
        return 0.0
    last = outside[-1]
    if last == len(y) - 1:
        return math.nan
    return float(t[last + 1] - t[0])


def final_error(e: np.ndarray) -> float:
    """Mean ``|e|`` over the last 5 % of the window (at least one sample)."""
    if len(e) == 0:
        return math.nan
    m = max(1, round(0.05 * len(e)))
    return float(np.mean(np.abs(e[-m:])))


def total_variation(u: np.ndarray) -> float:
    """Total variation ``sum |u_k - u_{k-1}|`` [MV units]."""
    if len(u) < 2:
        return 0.0
    return float(np.sum(np.abs(np.diff(u))))


def max_rate(u: np.ndarray, h: float) -> float:
    """Largest ``|u_k - u_{k-1}| / h`` [MV units / s]; 0 for fewer than two samples."""
    if len(u) < 2:
        return 0.0
    return float(np.max(np.abs(np.diff(u))) / h)


# ---------------------------------------------------------------------------
# All metrics of one window
# ---------------------------------------------------------------------------


@dataclass(frozen=True)
class Window:
    """A time window ``t0 <= t < t1`` with a label (the event that opens it).

    ``switch``: the window opens with the loop taking control (the start of
    the run, a switch to AUTO), so a distance to the setpoint is a step it is
    asked to make (module docstring, ``step``).
    """

    label: str
    t0: float
    t1: float
    switch: bool = False


def compute_metrics(
    t: np.ndarray,
    r: np.ndarray,
    y: np.ndarray,
    u: np.ndarray,
    h: float,
    *,
    t0: float | None = None,
    t1: float | None = None,
    band: float = 0.02,
    step_tol: float = 0.01,
    switch: bool | None = None,
) -> dict[str, float]:
    """All metrics of the module docstring over the window ``t0 <= t < t1``.

    Parameters
    ----------
    t, r, y, u : numpy.ndarray
        Time [s], setpoint, controlled variable and MV of the whole run.
    h : float
        Sample time [s].
    t0, t1 : float, optional
        Window bounds (default: the whole run).  A sample belongs to the
        window when ``t0 - h/2 <= t_k < t1 - h/2`` (robust to rounding of
        event times).
    band : float
        Settling band as a fraction (default 2 %).
    step_tol : float
        Relative size below which ``|r_end - y_0|`` counts as no step when the
        loop takes control at the window start (default 1 %).
    switch : bool, optional
        The window opens with the loop taking control (:attr:`Window.switch`);
        default: when it starts at the first sample.

    Returns
    -------
    dict
        ``{name: value}`` for every name in :data:`METRIC_NAMES`.
    """
    run = _Run(t, r, y, u)
    idx = window_index(run.t, h, t0, t1)
    if len(idx) == 0:
        return dict.fromkeys(METRIC_NAMES, math.nan)
    i0 = int(idx[0])
    start = i0 == 0 if switch is None else switch
    return run.metrics(i0, int(idx[-1]) + 1, h, band, step_tol, switch=start)


def run_metrics(
    t: np.ndarray,
    r: np.ndarray,
    y: np.ndarray,
    u: np.ndarray,
    h: float,
    windows: Sequence[Window] = (),
    *,
    band: float = 0.02,
    step_tol: float = 0.01,
) -> tuple[dict[str, float], list[dict[str, float]]]:
    """:func:`compute_metrics` of a whole run and of each of its ``windows``, at once.

    The same numbers as one :func:`compute_metrics` call per window (the
    same operations on the same values), with what every window uses
    computed once for the run: ``e``, ``|e|``, ``e**2``, ``|du|``.  ``t``
    must increase (a run's time): a window's samples are then found by
    bisection.  A run with more than one step window has no overshoot or rise
    time of its own (NaN).  Returns ``(whole run, [window, ...])``.
    """
    run = _Run(t, r, y, u)
    n = len(run.t)
    nan = dict.fromkeys(METRIC_NAMES, math.nan)
    out = []
    steps = 0
    for w in windows:
        i0 = int(np.searchsorted(run.t, w.t0 - 0.5 * h, "left"))
        i1 = int(np.searchsorted(run.t, w.t1 - 0.5 * h, "left"))
        out.append(run.metrics(i0, i1, h, band, step_tol, w.switch) if i1 > i0 else dict(nan))
        steps += i1 > i0 and run.step(i0, i1, step_tol, w.switch) != 0.0
    whole = run.metrics(0, n, h, band, step_tol, switch=True) if n else dict(nan)
    if steps > 1:  # the run asks for several steps: one overshoot of them all means nothing
        whole["overshoot"] = whole["rise_time"] = math.nan
    return whole, out


class _Run:
    """The arrays of one run and what every window's metrics use, computed once."""

    __slots__ = ("ae", "du", "e", "e2", "r", "t", "u", "y")

    def __init__(self, t: np.ndarray, r: np.ndarray, y: np.ndarray, u: np.ndarray) -> None:
        self.t, self.r, self.y, self.u = (np.asarray(a, dtype=float) for a in (t, r, y, u))
        with _beyond_range():
            self.e = self.r - self.y
            self.ae = np.abs(self.e)
            self.e2 = self.e * self.e
            self.du = np.abs(np.diff(self.u))

    def metrics(
        self, i0: int, i1: int, h: float, band: float, step_tol: float, switch: bool = False
    ) -> dict:
        """Every metric of the samples ``i0 <= k < i1`` (not empty; module docstring).

        ``switch``: the window opens with the loop taking control (``Window.switch``).
        """
        with _beyond_range():
            return self._metrics(i0, i1, h, band, step_tol, switch)

    def step(self, i0: int, i1: int, step_tol: float, switch: bool) -> float:
        """The step ``Δ`` the window ``i0 <= k < i1`` asks for; 0 for a regulation window."""
        r_end = float(self.r[i1 - 1])
        y0 = float(self.y[i0])
        step = r_end - y0
        sp_changed = i0 > 0 and abs(r_end - float(self.r[i0 - 1])) > 0.0
        far = abs(step) > step_tol * max(abs(r_end), abs(y0))
        return step if sp_changed or (switch and far) else 0.0

    def _metrics(
        self, i0: int, i1: int, h: float, band: float, step_tol: float, switch: bool
    ) -> dict:
        tw, yw, ae = self.t[i0:i1], self.y[i0:i1], self.ae[i0:i1]
        r_end = float(self.r[i1 - 1])
        y0 = float(yw[0])
        step = self.step(i0, i1, step_tol, switch)
        peak = float(_max(ae))
        if step != 0.0:
            band_abs = band * abs(step)
        else:
            scale_ = max(abs(r_end), peak)
            band_abs = band * scale_ if scale_ > 0 else math.nan
        jump = abs(float(self.u[i0] - self.u[i0 - 1])) if i0 > 0 else 0.0
        m = max(1, round(0.05 * (i1 - i0)))
        du = self.du[i0 : i1 - 1] if i1 - i0 >= 2 else None  # |u_k - u_{k-1}| in the window
        return {
            "iae": float(h * _sum(ae)),
            "ise": float(h * _sum(self.e2[i0:i1])),  # ise(e, h)
            "itae": float(h * _sum((tw - tw[0]) * ae)),
            "overshoot": overshoot(yw, r_end, step),
            "settling_time": settling_time(tw, yw, r_end, band_abs),
            "rise_time": rise_time(tw, yw, y0, step),
            "peak_error": peak,
            "final_error": float(_sum(ae[-m:]) / m),  # np.mean
            "tv_u": 0.0 if du is None else float(_sum(du)),
            "max_rate_u": 0.0 if du is None else float(_max(du) / h),
            "jump_u": jump,
        }


def _beyond_range() -> np.errstate:
    """A run whose signals reach beyond the float range (an unstable loop: |e| near
    1e308) has infinite (or NaN) metrics, written as ``null``, without a RuntimeWarning."""
    return np.errstate(over="ignore", invalid="ignore")


_sum = np.add.reduce  # np.sum of a 1-D float array, without the wrapper
_max = np.maximum.reduce  # np.max likewise


def window_index(
    t: np.ndarray, h: float, t0: float | None = None, t1: float | None = None
) -> np.ndarray:
    """Indices of the samples in the window ``t0 <= t < t1`` (bounds default: open).

    A sample belongs to the window when ``t0 - h/2 <= t_k < t1 - h/2``
    (robust to rounding of event times; ``h`` is the sample time [s]).
    """
    lo = -math.inf if t0 is None else t0 - 0.5 * h
    hi = math.inf if t1 is None else t1 - 0.5 * h
    return np.flatnonzero((t >= lo) & (t < hi))


def windows_from_events(
    events: Sequence[tuple[float, str] | tuple[float, str, bool]],
    t_end: float,
    *,
    first_label: str = "start",
    start_switch: bool = True,
) -> list[Window]:
    """Split ``[0, t_end)`` at the event times.

    ``events`` are ``(time, label)`` pairs, or ``(time, label, switch)`` with
    ``switch`` True for an event that puts the loop in control (a switch to
    AUTO: :attr:`Window.switch`); events at the same time share one window
    (labels joined with ``"; "``); an event at t = 0 labels the first window,
    which opens with the start of the run (``switch`` unless ``start_switch``
    is False: a run that starts in MAN).
    """
    times: dict[float, list[str]] = {}
    switches: set[float] = set()
    for ev in sorted(events, key=lambda p: p[0]):
        te, label = ev[0], ev[1]
        if 0.0 <= te < t_end:
            times.setdefault(round(te, 9), []).append(label)
            if len(ev) > 2 and ev[2]:
                switches.add(round(te, 9))
    starts = sorted(times)
    if not starts or starts[0] > 0.0:
        starts = [0.0, *starts]
        times.setdefault(0.0, [first_label])
    out = []
    for i, ts in enumerate(starts):
        te = starts[i + 1] if i + 1 < len(starts) else t_end
        first = ts == 0.0 and start_switch
        out.append(Window("; ".join(times[ts]), ts, te, switch=first or ts in switches))
    return out
