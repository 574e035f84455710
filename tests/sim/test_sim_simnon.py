"""The shipped Åström scenarios against the continuous Simnon systems of Åström 1987, Appendix A.

The Simnon programs are continuous; the scenarios sample them at ts = 0.01 s.
Here the Simnon equations are integrated by scipy's ``solve_ivp`` (tight
tolerances) and compared with the simulator's traces at the sample instants.
The difference is the discretisation error of a 0.01 s sample time (ZOH input,
backward-Euler integral, implicit tracking, ZOH coupling of series plants):
below 2e-3 on signals of size 1.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ctrlblocks.sim import simulate
from ctrlblocks.sim.report import load_shipped


def _sat(x: float, lo: float, hi: float) -> float:
    return min(max(x, lo), hi)


def _pid_int(tt: float, lo: float, hi: float):
    """Systems ``int``, ``pid``, ``conn`` of macros fig31, fig33, fig34 (N = 0, b = k = Ti = 1)."""

    def f(t, s):
        x, i = s
        e = 1.0 - x
        u = e + i  # u[reg] = P + I
        v = _sat(u, lo, hi)  # the regulator's actuator model (ulow, uhigh of conn)
        return [_sat(u, -0.1, 0.1), e + (v - u) / tt]  # process input saturates at ±0.1

    return f


def _select(t, s):
    """System ``select`` of macro fig39."""
    x1, x2, i1, i2 = s
    k1, b1, ti1 = 1.0, 0.5, 2.5
    k2, ti2 = 9.0, 9.0 / 25.0
    v1 = k1 * (b1 * 1.0 - x1) + i1
    v2 = k2 * (0.2 - x2) + i2
    u = _sat(min(v1, v2), -0.4, 0.4)
    d = 0.0 if t < 25.0 else -0.15
    return [
        x2 + d,
        u - x2,
        k1 * (1.0 - x1) / ti1 + (u - v1) / (ti1 / 5),
        k2 * (0.2 - x2) / ti2 + (u - v2) / (ti2 / 5),
    ]


def _solve(f, n_states: int, t: np.ndarray) -> np.ndarray:
    sol = solve_ivp(
        f, (0.0, t[-1]), [0.0] * n_states, t_eval=t, max_step=0.005, rtol=1e-9, atol=1e-11
    )
    assert sol.success
    return sol.y


@pytest.mark.parametrize(
    ("controller", "tt", "lo", "hi"),
    [
        ("no anti-windup (Fig. 3.1)", 0.05, -1.0, 1.0),
        ("tracking Tt = 0.02 (Fig. 3.3)", 0.02, -0.1, 0.1),
    ],
)
def test_windup_scenarios_match_the_continuous_simnon_system(controller, tt, lo, hi):
    (sc,) = load_shipped(["astrom_fig31_33"])
    s = simulate(sc, controller).signals
    ref = _solve(_pid_int(tt, lo, hi), 2, s["t"])
    assert np.max(np.abs(s["y"] - ref[0])) < 2e-3
    assert s["y"].max() == pytest.approx(ref[0].max(), abs=1e-3)


@pytest.mark.parametrize("tt", [1.0, 4.0])
def test_fig34_matches_the_continuous_simnon_system(tt):
    (sc,) = load_shipped(["astrom_fig34"])
    s = simulate(sc, f"Tt = {tt:g}").signals
    ref = _solve(_pid_int(tt, -0.1, 0.1), 2, s["t"])
    assert np.max(np.abs(s["y"] - ref[0])) < 2e-3


def test_selector_scenario_matches_the_continuous_simnon_system():
    (sc,) = load_shipped(["astrom_fig39"])
    s = simulate(sc, "min selector").signals
    ref = _solve(_select, 4, s["t"])
    assert np.max(np.abs(s["y"] - ref[0])) < 2e-3  # x1
    assert np.max(np.abs(s["y2"] - ref[1])) < 2e-3  # x2
