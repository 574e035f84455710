"""Processes of known models for the compare tests: bump tests with noise, and the truth."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ctrlblocks.plants.linear import FOPDT as PlantFOPDT
from ctrlblocks.plants.linear import PT2
from ctrlblocks.tuning.identify import FOPDT, SOPDT


@dataclass(frozen=True)
class Process:
    """A true process (an FOPDT or SOPDT of :mod:`ctrlblocks.tuning.identify`) and its record."""

    name: str
    truth: FOPDT | SOPDT
    noise: float  # PV noise of the bump test, as a fraction of the PV change
    seed: int = 1

    def bump(self, du: float = 1.0, u0: float = 2.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A bump test: at rest at ``u0``, the MV stepped by ``du`` after 10 % of the record;
        sampled every ``min(T, L)/10``, the record 8 times the lags and dead time long."""
        m = self.truth
        t2 = getattr(m, "time_constant_2", 0.0)
        tau = m.time_constant + t2 + m.dead_time
        h = min(m.time_constant, m.dead_time if m.dead_time > 0 else m.time_constant) / 10.0
        h = float(f"{h:.2g}")
        if isinstance(m, SOPDT):
            plant = PT2(m.gain, m.time_constant, m.time_constant_2, h, m.dead_time)
        else:
            plant = PlantFOPDT(m.gain, m.time_constant, m.dead_time, h)
        plant.reset(u0)
        n = math.ceil(8.0 * tau / h)
        t = np.arange(n) * h
        u = np.where(t >= 0.1 * n * h, u0 + du, u0)
        y = []
        for uk in u:
            y.append(plant.y)
            plant.step(float(uk))
        rng = np.random.default_rng(self.seed)
        sigma = self.noise * abs(m.gain * du)
        return t, u, np.array(y) + rng.normal(0.0, sigma, n)


NAMED = [
    Process("fopdt", FOPDT(1.5, 20.0, 4.0), 0.01, 1),
    Process("sopdt", SOPDT(0.8, 12.0, 1.5, 5.0), 0.01, 2),
    Process("reverse acting", FOPDT(-2.0, 15.0, 3.0), 0.01, 3),
    Process("dead-time dominant", FOPDT(1.0, 4.0, 12.0), 0.01, 4),
    Process("lag dominant", FOPDT(0.5, 60.0, 2.0), 0.01, 5),
    Process("noisy sopdt", SOPDT(2.0, 30.0, 3.0, 8.0), 0.05, 6),
]
"""The named kinds of the issue: FOPDT, SOPDT, reverse acting, dead-time and lag dominant,
noisy."""


def held_out(n: int, seed: int = 2026) -> list[Process]:
    """``n`` processes from a seeded generator that no method was tuned on.

    Gain 0.2..5 in magnitude (a third negative), T 5..100 s, L/T 0.02..2,
    an SOPDT with T2/T 0.1..0.6 in half of them, noise 0.2..5 % of the PV change.
    """
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        k = float(np.exp(rng.uniform(np.log(0.2), np.log(5.0)))) * (-1 if rng.random() < 1 / 3
                                                                      else 1)  # fmt: skip
        T = float(np.exp(rng.uniform(np.log(5.0), np.log(100.0))))
        L = T * float(np.exp(rng.uniform(np.log(0.02), np.log(2.0))))
        noise = float(np.exp(rng.uniform(np.log(0.002), np.log(0.05))))
        if rng.random() < 0.5:
            m = SOPDT(k, T, L, T * float(rng.uniform(0.1, 0.6)))
        else:
            m = FOPDT(k, T, L)
        out.append(Process(f"held-out {i}", m, noise, 100 + i))
    return out
