"""Åström (1987) experiments: windup Figs. 3.1/3.3/3.4 and the selector of Figs. 3.8/3.9.

The Simnon systems of Appendix A are simulated twice: the continuous system
with scipy's ``solve_ivp`` (the independent reference) and the PID block at
h = 0.01 s wired in Åström's computational order (Listing 6.3) with a forward
Euler integrator plant written here.
"""

from __future__ import annotations

import functools
import itertools

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ctrlblocks import PID

H = 0.01
T_END = 40.0


def _sat(u: float, lo: float, hi: float) -> float:
    return min(max(u, lo), hi)


@functools.lru_cache
def _continuous_windup(ulow: float, uhigh: float, tt: float) -> float:
    """Peak of y for Simnon systems ``int``, ``pid`` (N = 0, k = 1, Ti = 1, b = 1), ``conn``."""

    def f(t: float, s: np.ndarray) -> list[float]:
        x, i = s
        u = (1.0 - x) + i
        u1 = _sat(u, ulow, uhigh)  # v[reg] = u1: the saturation the regulator knows
        return [_sat(u1, -0.1, 0.1), (1.0 - x) + (u1 - u) / tt]

    sol = solve_ivp(f, (0.0, T_END), [0.0, 0.0], max_step=0.01, rtol=1e-8, atol=1e-10)
    return float(sol.y[0].max())


def _block_windup(ulow: float, uhigh: float, tt: float, method: str = "tustin") -> np.ndarray:
    pid = PID(
        kp=1.0,
        ti=1.0,
        b=1.0,
        ts=H,
        u_min=ulow,
        u_max=uhigh,
        anti_windup="back_calc_model",
        tt=tt,
        integral_method=method,
    )
    x, ys = 0.0, []
    for _ in range(round(T_END / H) + 1):
        u = pid(1.0, x)
        ys.append(x)
        x += H * _sat(u, -0.1, 0.1)  # process: integrator with input saturation +-0.1
    return np.array(ys)


@pytest.mark.parametrize("method", ["forward", "backward", "tustin"])
def test_fig_3_1_windup_gives_a_large_overshoot(method: str) -> None:
    # the regulator tracks a saturation at +-1 while the process saturates at +-0.1
    y = _block_windup(-1.0, 1.0, 0.05, method)
    assert y.max() == pytest.approx(1.3369, abs=0.002)
    assert y.max() == pytest.approx(_continuous_windup(-1.0, 1.0, 0.05), abs=0.002)
    assert np.argmax(y) * H == pytest.approx(13.5, abs=0.05)


@pytest.mark.parametrize("method", ["forward", "backward", "tustin"])
def test_fig_3_3_tracking_the_true_saturation_removes_the_overshoot(method: str) -> None:
    y = _block_windup(-0.1, 0.1, 0.02, method)
    assert y.max() == pytest.approx(1.0298, abs=0.001)
    assert y.max() == pytest.approx(_continuous_windup(-0.1, 0.1, 0.02), abs=0.001)


def test_fig_3_4_overshoot_grows_with_the_tracking_time_constant() -> None:
    # continuous peaks: Tt = 0.02 -> 1.0298, 1 -> 1.0546, 2 -> 1.1257, 3 -> 1.2020, 4 -> 1.2685
    want = {0.02: 1.0298, 1.0: 1.0546, 2.0: 1.1257, 3.0: 1.2020, 4.0: 1.2685}
    peaks = {tt: _block_windup(-0.1, 0.1, tt).max() for tt in want}
    for tt, peak in peaks.items():
        assert peak == pytest.approx(want[tt], abs=0.0015), tt
    values = [peaks[tt] for tt in sorted(peaks)]
    assert all(a < b for a, b in itertools.pairwise(values))
    # and all stay well below the windup of Fig. 3.1
    assert max(values) < 1.3369 - 0.05


def test_fig_3_4_reference_peaks_are_those_of_the_continuous_system() -> None:
    assert _continuous_windup(-0.1, 0.1, 2.0) == pytest.approx(1.1257, abs=2e-4)
    assert _continuous_windup(-0.1, 0.1, 4.0) == pytest.approx(1.2685, abs=2e-4)


# --- Figs. 3.8 / 3.9: selector -----------------------------------------------------

K1, B1, TI1 = 1.0, 0.5, 2.5
K2, TI2 = 9.0, 9.0 / 25.0
X2MAX, R, D0, T10 = 0.2, 1.0, -0.15, 25.0


@functools.lru_cache
def _continuous_select(tt1: float, tt2: float) -> tuple[np.ndarray, np.ndarray]:
    """Simnon system ``select`` of Appendix A; returns x1(t), x2(t) on the grid k*H."""

    def f(t: float, s: np.ndarray) -> list[float]:
        x1, x2, i1, i2 = s
        v1 = K1 * (B1 * R - x1) + i1
        e2 = X2MAX - x2
        v2 = K2 * e2 + i2
        u = _sat(min(v1, v2), -0.4, 0.4)
        d = 0.0 if t < T10 else D0
        return [
            x2 + d,
            u - x2,
            K1 * (R - x1) / TI1 + (u - v1) / tt1,
            K2 * e2 / TI2 + (u - v2) / tt2,
        ]

    t = np.arange(round(T_END / H) + 1) * H
    sol = solve_ivp(
        f, (0.0, T_END), [0.0] * 4, max_step=0.01, rtol=1e-8, atol=1e-10, dense_output=True
    )
    z = sol.sol(t)
    return z[0], z[1]


def _block_select(tt1: float, tt2: float) -> dict[str, np.ndarray]:
    p1 = PID(
        kp=K1, b=B1, ti=TI1, tt=tt1, ts=H, u_min=-0.4, u_max=0.4, anti_windup="back_calc_model"
    )
    p2 = PID(kp=K2, ti=TI2, tt=tt2, ts=H, u_min=-0.4, u_max=0.4, anti_windup="back_calc_model")
    x1 = x2 = 0.0
    rec: dict[str, list[float]] = {k: [] for k in ("x1", "x2", "u", "v1", "v2")}
    for k in range(round(T_END / H) + 1):
        v1 = p1.compute_output(R, x1)  # ComputeOutput
        v2 = p2.compute_output(X2MAX, x2)
        u = min(v1, v2)  # ShapeOutput: min selector (both are limited to +-0.4)
        p1.update_state(u)  # UpdateState with the applied value
        p2.update_state(u)
        for name, val in (("x1", x1), ("x2", x2), ("u", u), ("v1", v1), ("v2", v2)):
            rec[name].append(val)
        d = 0.0 if k * H < T10 else D0
        x1, x2 = x1 + H * (x2 + d), x2 + H * (u - x2)
    return {k: np.array(v) for k, v in rec.items()}


def test_fig_3_9_selector_matches_the_continuous_simnon_system() -> None:
    got = _block_select(TI1 / 5, TI2 / 5)
    x1, x2 = _continuous_select(TI1 / 5, TI2 / 5)
    assert np.max(np.abs(got["x1"] - x1)) < 2e-3
    assert np.max(np.abs(got["x2"] - x2)) < 2e-3
    # the constraint x2 <= 0.2 holds (controller 2 selected at the start and after d)
    assert got["x2"].max() == pytest.approx(0.2, abs=1e-3)
    assert got["x1"].max() == pytest.approx(1.0225, abs=2e-3)


def test_fig_3_9_the_non_selected_controller_tracks_and_takes_over_without_windup() -> None:
    got = _block_select(TI1 / 5, TI2 / 5)
    i2 = int(2.0 / H)  # t = 2: controller 2 holds x2 at its limit ...
    assert got["u"][i2] == pytest.approx(got["v2"][i2], abs=1e-12)
    assert got["v1"][i2] - got["u"][i2] < 0.08  # ... and controller 1 stays close to u
    i5 = int(8.0 / H)  # t = 8: controller 1 has taken over
    assert got["u"][i5] == pytest.approx(got["v1"][i5], abs=1e-12)
    # without tracking (tt -> infinity) controller 1 winds up while not selected
    wound = _block_select(1e9, 1e9)
    assert wound["x1"].max() > got["x1"].max() + 0.15
