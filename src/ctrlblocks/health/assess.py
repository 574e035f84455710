"""The performance assessment of one loop: its figures and its findings.

:func:`assess` takes a loop's record (:class:`LoopData`) and what is known about the
loop (:class:`AssessOptions`: MV limits, PV range, the tuning's model) and
returns an :class:`Assessment`: every figure of :mod:`.figures`, and the
*findings* -- what an engineer should look at, each with its kind, the loop,
the time span and the figures behind it:

=================  =========================================================================
kind               when
=================  =========================================================================
``manual``         time in MAN (any mode but AUTO) above ``max_manual`` (default 10 %)
``saturation``     time at an MV limit above ``max_saturated`` (default 5 %), per limit
``bad_pv``         time with a bad PV above ``max_bad_pv`` (default 1 %)
``valve_wear``     reversals per hour above ``max_reversals_per_hour`` (default 720)
``oscillation``    Hägglund (1995) detects an oscillation in AUTO
``stiction``       an oscillation, and Horch's (1999) test says stiction
``performance``    Harris (1989) index below ``min_harris`` (default 0.05)
``model_drift``    the models re-identified at set-point steps differ from the tuning's
                   (their median, and two of them or more, the same way): gain by more than
                   ``max_gain_change`` (20 %), time constant or dead time by more than
                   ``max_time_change`` (60 %)
=================  =========================================================================

The thresholds were set on the fault campaign of ``docs/health.md`` (no finding on
the healthy loops); each is a field of :class:`AssessOptions`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .figures import (
    HarrisResult,
    HorchResult,
    OscillationResult,
    ServiceFactors,
    ValveWear,
    harris_index,
    horch_stiction,
    oscillation,
    service_factors,
    setpoint_steps,
    valve_wear,
)

__all__ = ["AssessOptions", "Assessment", "Finding", "LoopData", "Model", "assess", "normal_mode"]

Array = NDArray[np.float64]

_MODE_NAMES = {
    "0": "AUTO",
    "1": "MANUAL",
    "2": "TRACK",
    "3": "HOLD",
    "4": "RESET",
    "MAN": "MANUAL",
    "A": "AUTO",
    "M": "MANUAL",
    "CAS": "AUTO",
}


def normal_mode(value: Any) -> str:
    """A mode as recorded (``"auto"``, ``"manual"``, 0/1, ``"MAN"``) -> ``"AUTO"``, ``"MANUAL"``.

    Numbers follow :class:`ctrlblocks.Mode` (0 AUTO, 1 MANUAL, 2 TRACK, 3 HOLD,
    4 RESET); a cascade (``CAS``) counts as AUTO.
    """
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    s = str(value).strip().upper()
    return _MODE_NAMES.get(s, s or "UNKNOWN")


@dataclass
class Model:
    """A first-order-plus-dead-time model ``k e^{-L s} / (T s + 1)`` (the tuning's)."""

    gain: float
    time_constant: float
    dead_time: float


@dataclass
class LoopData:
    """One loop's record: time [s], setpoint, PV, MV, mode and PV quality per sample."""

    t: Array
    sp: Array
    y: Array
    u: Array
    mode: list[str] | None = None
    pv_ok: NDArray[np.bool_] | None = None
    name: str = "loop"
    start: str = ""
    """The first time stamp (ISO 8601) when the time came as timestamps."""

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, dtype=float)
        self.sp = np.asarray(self.sp, dtype=float)
        self.y = np.asarray(self.y, dtype=float)
        self.u = np.asarray(self.u, dtype=float)
        n = self.t.size
        if not (self.sp.size == self.y.size == self.u.size == n):
            raise ValueError("t, sp, y and u must have the same length")
        if self.mode is not None:
            names = {m: normal_mode(m) for m in set(self.mode)}
            self.mode = [names[m] for m in self.mode]
            if len(self.mode) != n:
                raise ValueError("mode must have one value per sample")
        ok = np.isfinite(self.y)
        self.pv_ok = ok if self.pv_ok is None else (np.asarray(self.pv_ok, dtype=bool) & ok)

    @property
    def auto(self) -> NDArray[np.bool_]:
        """The samples in AUTO (every sample without a mode record)."""
        if self.mode is None:
            return np.ones(self.t.size, dtype=bool)
        return np.array([m == "AUTO" for m in self.mode], dtype=bool)

    def window(self, start: float | None, end: float | None) -> LoopData:
        """The samples with ``start <= t <= end``."""
        k = np.ones(self.t.size, dtype=bool)
        if start is not None:
            k &= self.t >= start
        if end is not None:
            k &= self.t <= end
        mode = (
            None if self.mode is None else [m for m, keep in zip(self.mode, k, strict=True) if keep]
        )
        assert self.pv_ok is not None
        return LoopData(
            self.t[k], self.sp[k], self.y[k], self.u[k], mode, self.pv_ok[k], self.name, self.start
        )


@dataclass
class AssessOptions:
    """What is known about the loop, and the thresholds of the findings.

    Attributes
    ----------
    u_min, u_max : float, optional
        MV limits; default: the record's extremes (see :func:`.figures.service_factors`).
    pv_span : float, optional
        PV range [PV units]; Hägglund's acceptable amplitude is ``osc_amplitude``
        of it.  Default: the larger of the setpoints' mean magnitude and range.
    model : Model, optional
        The tuning's process model: its dead time is Harris' delay, ``T_u`` is
        estimated from it, and model drift is judged against it.
    ti : float, optional
        The controller's integral time [s]: Hägglund's ``T_u`` when no model is given.
    tu : float, optional
        The ultimate period [s], when known (relay test).
    dead_time : float, optional
        Dead time [s] for Harris' benchmark when no model is given.
    """

    u_min: float | None = None
    u_max: float | None = None
    pv_span: float | None = None
    model: Model | None = None
    ti: float | None = None
    tu: float | None = None
    dead_time: float | None = None
    osc_amplitude: float = 0.01
    max_manual: float = 0.10
    max_saturated: float = 0.05
    max_bad_pv: float = 0.01
    max_reversals_per_hour: float = 720.0
    reversal_deadband: float = 0.01
    """Hysteresis of the reversal count, a fraction of the MV range."""
    min_harris: float = 0.05
    harris_order: int = 20
    max_gain_change: float = 0.20
    max_time_change: float = 0.60
    drift_segments: int = 4
    """Set-point steps re-identified at most (the largest)."""


@dataclass
class Finding:
    """One thing to look at: kind, loop, time span [s] and the figures behind it."""

    kind: str
    loop: str
    start: float
    end: float
    message: str
    figures: dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready (no NaN: null)."""
        return {
            "kind": self.kind,
            "loop": self.loop,
            "start": self.start,
            "end": self.end,
            "message": self.message,
            "figures": _clean(self.figures),
        }


@dataclass
class Assessment:
    """Every figure of one loop and the findings."""

    loop: str
    start: float
    end: float
    service: ServiceFactors
    wear: ValveWear
    osc: OscillationResult
    harris: HarrisResult
    horch: HorchResult | None
    drift: dict[str, Any]
    findings: list[Finding]
    notes: list[str]
    tu: float
    a: float

    def figures(self) -> dict[str, Any]:
        """The figures as a flat JSON-ready dict."""
        s, w, o, h = self.service, self.wear, self.osc, self.harris
        out: dict[str, Any] = {
            "duration_s": s.duration,
            "time_in_mode": s.modes,
            "time_at_u_min": s.at_low,
            "time_at_u_max": s.at_high,
            "u_min": s.u_min,
            "u_max": s.u_max,
            "limits_from_data": s.limits_from_data,
            "time_bad_pv": s.bad_pv,
            "mv_travel": w.travel,
            "mv_travel_per_hour": w.travel_per_hour,
            "reversals": w.reversals,
            "reversals_per_hour": w.reversals_per_hour,
            "oscillation": o.detected,
            "oscillation_loads": o.loads,
            "oscillation_iae_lim": o.iae_lim,
            "oscillation_period_s": o.period,
            "oscillation_amplitude": o.amplitude,
            "oscillation_time_fraction": o.fraction,
            "ultimate_period_s": self.tu,
            "acceptable_amplitude": self.a,
            "harris_index": h.index,
            "harris_delay_samples": h.delay,
        }
        if self.horch is not None:
            out["stiction_test"] = self.horch.verdict
            out["ccf_asymmetry"] = self.horch.asymmetry
        out.update({f"drift_{k}": v for k, v in self.drift.items() if k != "segments"})
        return _clean(out)

    def as_dict(self) -> dict[str, Any]:
        """The loop's summary: figures, findings, notes."""
        return {
            "loop": self.loop,
            "start": self.start,
            "end": self.end,
            "figures": self.figures(),
            "findings": [f.as_dict() for f in self.findings],
            "notes": list(self.notes),
        }


def _clean(d: Any) -> Any:
    if isinstance(d, dict):
        return {k: _clean(v) for k, v in d.items()}
    if isinstance(d, (list, tuple)):
        return [_clean(v) for v in d]
    if isinstance(d, (np.floating, float)):
        return float(d) if math.isfinite(d) else None
    if isinstance(d, (np.integer,)):
        return int(d)
    if isinstance(d, np.bool_):
        return bool(d)
    return d


# ---------------------------------------------------------------------------
# the assessment
# ---------------------------------------------------------------------------


def assess(data: LoopData, options: AssessOptions | None = None) -> Assessment:
    """Assess one loop's record (see the module docstring)."""
    o = options or AssessOptions()
    if data.t.size < 10:
        raise ValueError(f"loop {data.name!r}: {data.t.size} samples; an assessment needs >= 10")
    if not np.all(np.diff(data.t) > 0):
        raise ValueError(f"loop {data.name!r}: the time must increase from sample to sample")
    notes: list[str] = []
    t, sp, y, u = data.t, data.sp, data.y, data.u
    assert data.pv_ok is not None
    h = float(np.median(np.diff(t)))
    t0, t1 = float(t[0]), float(t[-1])
    findings: list[Finding] = []

    def find(
        kind: str, message: str, figs: dict[str, Any], span: tuple[float, float] | None = None
    ) -> None:
        a, b = span or (t0, t1)
        findings.append(Finding(kind, data.name, a, b, message, figs))

    # -- service factors --------------------------------------------------------------
    sf = service_factors(t, u, data.mode, data.pv_ok, o.u_min, o.u_max)
    if sf.limits_from_data:
        notes.append(
            "MV limits not given: the record's extremes were taken "
            f"({sf.u_min:.4g} .. {sf.u_max:.4g}); give --u-min/--u-max"
        )
    not_auto = 1.0 - sf.modes.get("AUTO", 0.0)
    if not_auto > o.max_manual:
        find(
            "manual",
            f"{100 * not_auto:.1f} % of the time not in AUTO",
            {"time_not_auto": not_auto, "time_in_mode": sf.modes},
        )
    for side, frac, lim in (("low", sf.at_low, sf.u_min), ("high", sf.at_high, sf.u_max)):
        if frac > o.max_saturated:
            find(
                "saturation",
                f"MV at its {side} limit {lim:.4g} for {100 * frac:.1f} % of the time",
                {"limit": side, "u_limit": lim, "time_at_limit": frac},
            )
    if sf.bad_pv > o.max_bad_pv:
        find(
            "bad_pv", f"PV bad for {100 * sf.bad_pv:.1f} % of the time", {"time_bad_pv": sf.bad_pv}
        )

    # -- valve wear ---------------------------------------------------------------------
    span_u = sf.u_max - sf.u_min if sf.u_max > sf.u_min else 1.0
    wear = valve_wear(t, u, o.reversal_deadband * span_u)
    if wear.reversals_per_hour > o.max_reversals_per_hour:
        find(
            "valve_wear",
            f"{wear.reversals_per_hour:.0f} MV reversals per hour "
            f"(travel {wear.travel_per_hour:.4g} per hour)",
            {
                "reversals_per_hour": wear.reversals_per_hour,
                "travel_per_hour": wear.travel_per_hour,
            },
        )

    # -- oscillation (Hägglund 1995) -----------------------------------------------------
    auto = data.auto & data.pv_ok
    tu = _ultimate_period(o, h, notes)
    a = o.osc_amplitude * _pv_span(o, sp, y, notes)
    e = sp - y
    osc = oscillation(t, e, a, tu, active=auto)
    horch = None
    if osc.detected:
        sp0, sp1 = osc.spans[0][0], osc.spans[-1][1]
        find(
            "oscillation",
            f"oscillation of period {osc.period:.3g} s and amplitude "
            f"{osc.amplitude:.3g} (Hägglund 1995) during {100 * osc.fraction:.0f} % of the time",
            {
                "period_s": osc.period,
                "amplitude": osc.amplitude,
                "loads": osc.loads,
                "time_fraction": osc.fraction,
            },
            (sp0, sp1),
        )
        k = (t >= sp0) & (t <= sp1) & auto
        horch = horch_stiction(u[k], y[k], h, osc.period)
        if horch.verdict == "stiction":
            find(
                "stiction",
                "the oscillation looks like valve stiction (Horch 1999: odd "
                f"cross-correlation of MV and PV, asymmetry {horch.asymmetry:+.2f})",
                {"ccf_asymmetry": horch.asymmetry, "tau_l_s": horch.tau_l, "tau_r_s": horch.tau_r},
                (sp0, sp1),
            )

    # -- minimum-variance benchmark (Harris 1989) ----------------------------------------
    delay = _delay_samples(o, h, notes)
    e_auto = np.where(auto, y - sp, np.nan)
    harris = harris_index(_longest_run(e_auto), delay, o.harris_order)
    if math.isfinite(harris.index) and harris.index < o.min_harris and not osc.detected:
        find(
            "performance",
            f"Harris index {harris.index:.3f}: the error variance is "
            f"{1 / harris.index:.0f} times the minimum variance (Harris 1989)",
            {"harris_index": harris.index, "delay_samples": delay},
        )

    # -- model drift -----------------------------------------------------------------------
    drift = _model_drift(data, o, h, auto, notes)
    if drift.get("drifted"):
        m = o.model
        assert m is not None
        find(
            "model_drift",
            drift["message"],
            {
                k: drift[k]
                for k in (
                    "gain",
                    "time_constant",
                    "dead_time",
                    "gain_change",
                    "time_constant_change",
                    "dead_time_change",
                    "segments",
                )
            },
            (drift["start"], drift["end"]),
        )
    return Assessment(
        data.name, t0, t1, sf, wear, osc, harris, horch, drift, findings, notes, tu, a
    )


def _ultimate_period(o: AssessOptions, h: float, notes: list[str]) -> float:
    """Hägglund's T_u: given; else the integral time (Hägglund 1995's choice); else the model's."""
    if o.tu:
        return float(o.tu)
    if o.ti:
        return float(o.ti)
    if o.model is not None:
        notes.append("no integral time: the ultimate period is the model's (phase crossover)")
        return ultimate_period(o.model)
    notes.append(
        "no Ti, Tu or model: the ultimate period is taken as 60 samples; give --ti or --tu"
    )
    return 60.0 * h


def ultimate_period(m: Model) -> float:
    """The ultimate period ``T_u = 2 pi / omega_u`` of an FOPDT model under P control.

    ``omega_u`` solves ``atan(omega T) + omega L = pi`` (phase crossover);
    without dead time (no crossover) ``T_u = T``.
    """
    from scipy.optimize import brentq

    T, L = m.time_constant, m.dead_time
    if L <= 0.0:
        return T
    w = brentq(lambda w: math.atan(w * T) + w * L - math.pi, 1e-12, math.pi / L)
    return 2.0 * math.pi / w


def _pv_span(o: AssessOptions, sp: Array, y: Array, notes: list[str]) -> float:
    if o.pv_span:
        return float(o.pv_span)
    s = sp[np.isfinite(sp)]
    span = max(float(np.mean(np.abs(s))), float(np.ptp(s))) if s.size else 0.0
    if span <= 0.0:
        yy = y[np.isfinite(y)]
        span = float(np.ptp(yy)) if yy.size else 1.0
    notes.append(f"PV range not given: {span:.4g} taken (the setpoints' size); give --pv-span")
    return span or 1.0


def _delay_samples(o: AssessOptions, h: float, notes: list[str]) -> int:
    L = o.dead_time if o.dead_time is not None else (o.model.dead_time if o.model else None)
    if L is None:
        notes.append("no dead time: Harris' benchmark uses 1 sample; give --dead-time or a model")
        return 1
    return 1 + math.floor(min(L / h, 1e9) + 1e-9)


def _longest_run(x: Array) -> Array:
    """The longest run of finite values of ``x``."""
    ok = np.isfinite(x)
    if ok.all():
        return x
    edges = np.flatnonzero(np.diff(np.concatenate(([0], ok.astype(int), [0]))))
    starts, ends = edges[::2], edges[1::2]
    if starts.size == 0:
        return x[:0]
    i = int(np.argmax(ends - starts))
    return x[starts[i] : ends[i]]


def _model_drift(
    data: LoopData, o: AssessOptions, h: float, auto: NDArray[np.bool_], notes: list[str]
) -> dict[str, Any]:
    """Re-identify an FOPDT at the set-point steps in AUTO; compare with the tuning's model."""
    from ..tuning.identify import fit_fopdt

    t, sp, y, u = data.t, data.sp, data.y, data.u
    m = o.model
    noise = _noise_level(y[auto])
    span = _pv_span(dataclasses.replace(o), sp, y, [])
    steps = setpoint_steps(t, sp, max(5.0 * noise, 0.002 * span))
    lo, hi = (
        (o.u_min, o.u_max)
        if o.u_min is not None and o.u_max is not None
        else (np.nanmin(u), np.nanmax(u))
    )
    tol = 0.002 * (hi - lo)
    at_limit = (u <= lo + tol) | (u >= hi - tol)
    settle = 8.0 * (m.time_constant + m.dead_time) if m else 600.0
    pre = max(int(0.1 * settle / h), 5)
    segs = []
    for i, k in enumerate(steps):
        nxt = steps[i + 1] if i + 1 < len(steps) else t.size
        a = max(k - pre, steps[i - 1] if i else 0)
        b = min(nxt, k + int(settle / h))
        if b - k < int(0.5 * settle / h) or not auto[a:b].all() or k - a < 3:
            continue
        if np.any(at_limit[a:b]):
            continue  # a saturated MV says nothing of the process
        segs.append((abs(float(sp[k] - sp[k - 1])), a, b))
    out: dict[str, Any] = {"steps": len(steps), "segments": 0, "drifted": False}
    if o.drift_segments <= 0:
        return out
    if m is None:  # nothing to compare with: the fits (most of the cost) are not made
        notes.append("no model (--gain, --time-constant, --dead-time): model drift not assessed")
        return out
    if not segs:
        if m is not None:
            notes.append(
                "no set-point step with a settled response in AUTO: model drift "
                "not assessed (needs excitation)"
            )
        return out
    segs.sort(reverse=True)
    fits = []
    for _, a, b in segs[: o.drift_segments]:
        m_dec = max(1, (b - a) // 200)  # the fit's cost grows with the MV changes: decimate
        tt, uu, yy = _decimate(t[a:b] - t[a], u[a:b], y[a:b], m_dec)
        try:
            f = fit_fopdt(tt, uu, yy)
        except (ValueError, ArithmeticError):
            continue
        if math.isfinite(f.fit) and f.fit < 0.1:
            fits.append((f, float(t[a]), float(t[b - 1])))
    out["segments"] = len(fits)
    if not fits:
        notes.append("the set-point steps gave no usable model (poor fit): drift not assessed")
        return out
    k = float(np.median([f.gain for f, _, _ in fits]))
    tc = float(np.median([f.time_constant for f, _, _ in fits]))
    lt = float(np.median([f.dead_time for f, _, _ in fits]))
    out.update(gain=k, time_constant=tc, dead_time=lt, start=fits[0][1], end=fits[-1][2])
    out["start"] = min(a for _, a, _ in fits)
    out["end"] = max(b for _, _, b in fits)
    dk = k / m.gain - 1.0
    dT = tc / m.time_constant - 1.0
    dL = (lt - m.dead_time) / max(m.dead_time, h)
    out.update(gain_change=dk, time_constant_change=dT, dead_time_change=dL)
    # a drift is reported only where two or more re-identifications say so, the same way:
    # one step disturbed by an unmeasured load gives a wrong model, not a drifted process
    gk = [f.gain / m.gain - 1.0 for f, _, _ in fits]
    gt = [f.time_constant / m.time_constant - 1.0 for f, _, _ in fits]
    gl = [(f.dead_time - m.dead_time) / max(m.dead_time, h) for f, _, _ in fits]
    gl_abs = [abs(f.dead_time - m.dead_time) for f, _, _ in fits]
    bad = []
    if len(fits) >= 2 and _agree(gk, o.max_gain_change):
        bad.append(f"gain {m.gain:.4g} -> {k:.4g} ({100 * dk:+.0f} %)")
    if len(fits) >= 2 and _agree(gt, o.max_time_change):
        bad.append(f"time constant {m.time_constant:.4g} -> {tc:.4g} s ({100 * dT:+.0f} %)")
    if len(fits) >= 2 and _agree(gl, o.max_time_change) and min(gl_abs) > 2.0 * h:
        bad.append(f"dead time {m.dead_time:.4g} -> {lt:.4g} s")
    if bad:
        out["drifted"] = True
        out["message"] = (
            "the process has drifted from the tuning's model: "
            + ", ".join(bad)
            + f" (closed-loop re-identification at {len(fits)} set-point step(s)); check the "
            f"tuning on it: ctrlblocks tune pid --gain {k:.4g} --time-constant {tc:.4g} "
            f"--dead-time {lt:.4g}, or ctrlblocks compare on the step's record"
        )
    return out


def _agree(changes: list[float], limit: float) -> bool:
    """The median change beyond ``limit``, and at least two of the changes beyond it that way."""
    med = float(np.median(changes))
    if abs(med) <= limit:
        return False
    return sum((c > limit) if med > 0 else (c < -limit) for c in changes) >= 2


def _decimate(t: Array, u: Array, y: Array, m: int) -> tuple[Array, Array, Array]:
    """Every ``m``-th sample of ``t`` and ``y``; ``u`` as its mean over each block of ``m``.

    The mean is the value a zero-order hold over the block should hold to apply
    the same amount of MV.
    """
    if m <= 1:
        return t, u, y
    n = (t.size // m) * m
    return t[:n:m], u[:n].reshape(-1, m).mean(axis=1), y[:n:m]


def _noise_level(y: Array) -> float:
    """Standard deviation of the sample-to-sample noise: ``median(|dy|) / (0.6745 sqrt 2)``."""
    d = np.diff(y[np.isfinite(y)])
    return float(np.median(np.abs(d))) / (0.6745 * math.sqrt(2.0)) if d.size else 0.0
