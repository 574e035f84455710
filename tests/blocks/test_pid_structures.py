"""PID in structures: cascade handshake (awin/awout), selector with every variant, robustness."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ctrlblocks import PID, Mode

H = 0.1


def _cascade(wire: bool) -> tuple[float, list[float]]:
    """Level (primary, integrating) over flow (secondary, PT1 0..50 for 0..100 %).

    The primary asks for more flow than the valve can give: the secondary
    saturates.  Returns the level peak and the changes of the primary's
    integral in the cycles where its ``awin`` was set (or, unwired, where the
    secondary was limited in the cycle before).
    """
    prim = PID(kp=2.0, ti=20.0, ts=H, u_min=0.0, u_max=100.0)
    sec = PID(kp=0.5, ti=1.0, ts=H, u_min=0.0, u_max=100.0)
    a = math.exp(-H / 1.0)
    y2, y1 = 20.0, 50.0
    prim.manual, prim.manual_value, sec.manual, sec.manual_value = True, 20.0, True, 40.0
    for _ in range(50):  # steady state in manual: inflow 20 = outflow 20
        u = sec(prim(50.0, y1), y2)
        y2 = a * y2 + (1 - a) * 0.5 * u
        y1 += H * (y2 - 20.0) / 100.0
    prim.manual = sec.manual = False
    peak, frozen = y1, []
    for _ in range(6000):
        limited = sec.awout
        if wire:
            prim.awin = limited
        i_before = prim.i
        u = sec(prim(80.0, y1), y2)
        if limited:
            frozen.append(prim.i - i_before)
        y2 = a * y2 + (1 - a) * 0.5 * u
        y1 += H * (y2 - 20.0) / 100.0
        peak = max(peak, y1)
    assert abs(y1 - 80.0) < 0.5
    return peak, frozen


def test_cascade_primary_frozen_by_the_secondarys_awout_does_not_wind_up() -> None:
    peak_free, i_free = _cascade(wire=False)
    peak_wired, i_wired = _cascade(wire=True)
    assert len(i_wired) > 100  # the secondary really was limited for a while
    assert max(abs(di) for di in i_wired) == 0.0  # integrator held while awin
    assert sum(i_free) > 20.0  # ... and it winds up without the handshake
    assert peak_free - 80.0 > 14.0
    assert peak_wired - 80.0 < 8.0


@pytest.mark.parametrize("algorithm", ["positional", "velocity"])
@pytest.mark.parametrize("aw", ["clamping", "back_calc_model"])
def test_selector_of_fig_3_9_works_with_every_algorithm_and_aw_method(
    algorithm: str, aw: str
) -> None:
    h = 0.01
    kw = dict(ts=h, u_min=-0.4, u_max=0.4, anti_windup=aw, algorithm=algorithm)
    p1 = PID(kp=1.0, b=0.5, ti=2.5, tt=0.5, **kw)
    p2 = PID(kp=9.0, ti=0.36, tt=0.072, **kw)
    x1 = x2 = 0.0
    xs = []
    for k in range(4001):
        u = min(p1.compute_output(1.0, x1), p2.compute_output(0.2, x2))
        p1.update_state(u)
        p2.update_state(u)
        xs.append((x1, x2))
        d = 0.0 if k * h < 25.0 else -0.15
        x1, x2 = x1 + h * (x2 + d), x2 + h * (u - x2)
    arr = np.array(xs)
    assert arr[:, 0].max() == pytest.approx(1.0225, abs=2e-3)  # continuous: 1.0225
    assert arr[:, 1].max() < 0.2 + 1e-3
    assert arr[-1, 0] == pytest.approx(1.0, abs=0.01)


@pytest.mark.parametrize("algorithm", ["positional", "velocity"])
def test_random_inputs_modes_and_nans_never_raise_and_stay_within_limits(algorithm: str) -> None:
    rng = np.random.default_rng(7)
    pid = PID(
        kp=3.0,
        ti=2.0,
        td=0.5,
        ts=H,
        u_min=-20.0,
        u_max=30.0,
        sp_filter=0.3,
        pv_filter=0.2,
        sp_rate=50.0,
        out_rate=200.0,
        deadband=0.5,
        t_stab=0.5,
        ff_k=0.5,
        ff_t_lead=1.0,
        ff_t_lag=0.5,
        algorithm=algorithm,
        anti_windup="back_calc_model",
    )
    seen = set()
    for _ in range(3000):
        r = rng.random()
        if r < 0.02:
            pid.manual = not pid.manual
        elif r < 0.03:
            pid.hold = not pid.hold
        elif r < 0.035:
            pid.track = not pid.track
        elif r < 0.038:
            pid.reset_active = not pid.reset_active
        pid.manual_value = float(rng.normal(0, 40))
        pid.track_value = float(rng.normal(0, 40))
        vals = rng.normal(0, 10, 3)
        vals[rng.random(3) < 0.02] = math.nan
        dt = H if rng.random() > 0.01 else -1.0
        u = pid(float(vals[0]), float(vals[1]), ff=float(vals[2]), dt=dt)
        seen.add(pid.mode)
        assert math.isfinite(u) and -20.0 <= u <= 30.0
        assert all(math.isfinite(x) for x in (pid.p, pid.i, pid.d, pid.ff))
    assert seen == set(Mode)
