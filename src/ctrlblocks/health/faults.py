"""Simulated loops with known faults: the campaign that measures the assessment.

:func:`simulate` runs one PI loop on a first-order-plus-dead-time process (the
project's :class:`~ctrlblocks.PID` block and :class:`~ctrlblocks.plants.FOPDT`,
:class:`~ctrlblocks.plants.Actuator` for the input loads), tuned by SIMC on its
model, with measurement noise, load disturbances and set-point steps, and
injects one fault:

==============  ===========================================================================
``healthy``     no fault: noise, load disturbances and set-point steps only
``stiction``    a sticky valve (:class:`~ctrlblocks.plants.StictionValve`, Choudhury et
                al. 2005) with ``S`` 3..8 % and ``J`` 1..3 %
``oscillating`` over-tuned: ``kp`` raised to 0.8..1.1 times the ultimate gain (SIMC's ``Ti``)
``drift``       the process gain is 30 % above or below the model the loop was tuned on
``manual``      the loop is left in MAN for the last 30..90 % of the record
``saturated``   an input load drives the MV to its upper limit for 20..60 % of the record
==============  ===========================================================================

Every random draw comes from ``numpy.random.default_rng(seed)``; a case is
reproducible from ``(kind, seed)``.  :func:`campaign` runs many and counts the
findings (``docs/health.md`` states the rates measured).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..blocks.pid import PID
from ..plants import FOPDT, Actuator, StictionValve
from ..tuning.pid_rules import simc
from .assess import Assessment, AssessOptions, LoopData, Model, assess, ultimate_period

__all__ = ["EXPECTED", "KINDS", "CampaignResult", "FaultCase", "campaign", "simulate"]

KINDS = ("healthy", "stiction", "oscillating", "drift", "manual", "saturated")
EXPECTED = {
    "healthy": None,
    "stiction": "stiction",
    "oscillating": "oscillation",
    "drift": "model_drift",
    "manual": "manual",
    "saturated": "saturation",
}
"""The finding each fault must raise (a healthy loop: none)."""


@dataclass
class FaultCase:
    """One simulated loop: its record, what the assessment is told, what was injected."""

    kind: str
    seed: int
    data: LoopData
    options: AssessOptions
    truth: dict[str, float] = field(default_factory=dict)


def simulate(kind: str, seed: int, *, hours: float = 2.0, ts: float = 1.0) -> FaultCase:
    """Simulate one loop of ``kind`` (see the module docstring) for ``hours``."""
    if kind not in KINDS:
        raise ValueError(f"unknown fault {kind!r}; kinds: {', '.join(KINDS)}")
    rng = np.random.default_rng([KINDS.index(kind), seed])
    n = round(hours * 3600.0 / ts)
    k_model = float(rng.uniform(0.6, 1.6))
    tc = float(rng.uniform(20.0, 80.0))
    lt = float(rng.uniform(2.0, 10.0))
    model = Model(k_model, tc, lt)
    k_true = k_model
    truth: dict[str, float] = {"gain": k_model, "time_constant": tc, "dead_time": lt}
    if kind == "drift":
        k_true = k_model * (1.3 if rng.random() < 0.5 else 0.7)
        truth["true_gain"] = k_true
    tun = simc(k_model, tc, lt, tau_c=max(lt, tc / 4.0))
    kp, ti = tun.kp, tun.ti
    if kind == "oscillating":
        ku = _ultimate_gain(model)
        kp = float(rng.uniform(0.8, 1.1)) * ku
        truth["kp_over_ku"] = kp / ku
    u_lo, u_hi = 0.0, 100.0
    sp0 = 50.0
    bias = sp0 - k_true * 50.0  # PV = plant output + bias: u = 50 % holds SP = 50 at rest
    inner = Actuator(FOPDT(k=k_true, t=tc, dead_time=lt, ts=ts))
    plant: Any = inner
    if kind == "stiction":
        s = float(rng.uniform(3.0, 8.0))
        j = float(rng.uniform(1.0, 3.0))
        plant = StictionValve(inner, s=s, j=j, u_min=u_lo, u_max=u_hi)
        truth.update(s=s, j=j)
    plant.reset(50.0)
    pid = PID(kp=kp, ti=ti, ts=ts, u_min=u_lo, u_max=u_hi, reset_value=50.0)
    # set-point steps: 3 or 4, of 3..8 % of the range, at random times past the first 10 %
    sp = np.full(n, sp0)
    for at in sorted(rng.uniform(0.1, 0.9, int(rng.integers(3, 5)))):
        sp[int(at * n) :] += float(rng.choice((-1.0, 1.0)) * rng.uniform(3.0, 8.0))
    # load disturbances at the process input: steps of 2..6 % every 20 min on average,
    # and a slow random walk
    load = np.zeros(n)
    t_next = float(rng.exponential(1200.0))
    while t_next < n * ts:
        load[int(t_next / ts) :] += float(rng.normal(0.0, 4.0))
        t_next += float(rng.exponential(1200.0))
    load += np.cumsum(rng.normal(0.0, 0.02, n))
    manual = np.zeros(n, dtype=bool)
    if kind == "manual":
        manual[int(n * float(rng.uniform(0.1, 0.7))) :] = True
    if kind == "saturated":
        a = int(n * float(rng.uniform(0.1, 0.3)))
        b = min(n, a + int(n * float(rng.uniform(0.25, 0.6))))
        load[a:b] -= float(rng.uniform(70.0, 90.0))
    noise = rng.normal(0.0, float(rng.uniform(0.02, 0.1)), n)
    y = np.empty(n)
    u = np.empty(n)
    for i in range(n):
        yi = plant.y + bias + noise[i]
        pid.manual = bool(manual[i])
        ui = pid(sp[i], yi)
        inner.load = load[i]
        plant.step(ui)
        y[i], u[i] = yi, ui
    mode = np.where(manual, "MANUAL", "AUTO").tolist()
    t = np.arange(n) * ts
    data = LoopData(t, sp, y, u, mode, None, f"{kind}-{seed}")
    opts = AssessOptions(u_min=u_lo, u_max=u_hi, pv_span=100.0, model=model, ti=tun.ti)
    return FaultCase(kind, seed, data, opts, truth)


def _ultimate_gain(m: Model) -> float:
    """``K_u = 1 / |G(j omega_u)|`` of the FOPDT model (P control)."""
    w = 2.0 * math.pi / ultimate_period(m)
    return math.sqrt(1.0 + (w * m.time_constant) ** 2) / m.gain


@dataclass
class CampaignResult:
    """Counts per fault kind: loops, loops with the expected finding, loops with any finding."""

    loops: dict[str, int]
    detected: dict[str, int]
    any_finding: dict[str, int]
    findings: dict[str, dict[str, int]]

    def rate(self, kind: str) -> float:
        """Detection rate of ``kind``; for ``healthy`` the false-alarm rate (any finding)."""
        n = self.loops[kind]
        hits = self.any_finding[kind] if kind == "healthy" else self.detected[kind]
        return hits / n if n else math.nan


def campaign(
    seeds: Iterable[int],
    kinds: Iterable[str] = KINDS,
    *,
    hours: float = 2.0,
    progress: Callable[[int, int], None] | None = None,
) -> CampaignResult:
    """Simulate and assess every ``(kind, seed)``; count the findings."""
    jobs = [(k, s) for k in kinds for s in seeds]
    res = CampaignResult({}, {}, {}, {})
    for i, (kind, seed) in enumerate(jobs):
        a = assess_case(simulate(kind, seed, hours=hours))
        kinds_found = {f.kind for f in a.findings}
        res.loops[kind] = res.loops.get(kind, 0) + 1
        exp = EXPECTED[kind]
        res.detected[kind] = res.detected.get(kind, 0) + int(exp is not None and exp in kinds_found)
        res.any_finding[kind] = res.any_finding.get(kind, 0) + int(bool(kinds_found))
        per = res.findings.setdefault(kind, {})
        for f in kinds_found:
            per[f] = per.get(f, 0) + 1
        if progress is not None:
            progress(i + 1, len(jobs))
    return res


def assess_case(case: FaultCase) -> Assessment:
    """The assessment of a simulated case with what it is told about the loop."""
    return assess(case.data, case.options)
