"""Margins of a PID configured as a plant runs it: PV/SP filters, scaling, the velocity form.

The controller read off the block (``controller_ss``) is checked against an
independent composition: the plain PID's frequency response times the PT1
filter ``(1 - a) z/(z - a)``, ``a = exp(-h/T)`` (the block's exact filter), times
the scaling ``100/(hi - lo)``; the velocity form against the positional one
(the same linear law, Åström 1987, the incremental form).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ctrlblocks import PID
from ctrlblocks.tuning.identify import FOPDT
from ctrlblocks.tuning.margins import controller_ss, derivative_rings, margins

H = 0.1
BASE = {"kp": 2.0, "ti": 5.0, "td": 0.8, "n": 8.0, "b": 0.7, "ts": H, "u_min": -1e9,
        "u_max": 1e9}  # fmt: skip
W = np.linspace(0.05, 0.98 * math.pi / H, 60)
Z = np.exp(1j * W * H)


def _pt1(t: float) -> np.ndarray:
    a = math.exp(-H / t)
    return (1 - a) * Z / (Z - a)


PLAIN = controller_ss(PID(**BASE)).response(W)


@pytest.mark.parametrize("extra, c_r, c_y", [
    ({"pv_filter": 0.7}, 1.0, _pt1(0.7)),
    ({"sp_filter": 0.4}, _pt1(0.4), 1.0),
    ({"pv_range": (-50.0, 150.0)}, 0.5, 0.5),
    ({"algorithm": "velocity"}, 1.0, 1.0),
    ({"algorithm": "velocity", "pv_filter": 0.7, "sp_filter": 0.4, "pv_range": (0.0, 400.0)},
     0.25 * _pt1(0.4), 0.25 * _pt1(0.7)),
])  # fmt: skip
def test_the_controller_read_off_the_block_is_the_composition(extra, c_r, c_y) -> None:
    g = controller_ss(PID(**BASE, **extra)).response(W)
    np.testing.assert_allclose(g[:, 0, 0], PLAIN[:, 0, 0] * c_r, rtol=0, atol=1e-12)
    np.testing.assert_allclose(g[:, 0, 1], PLAIN[:, 0, 1] * c_y, rtol=0, atol=1e-12)


def test_the_velocity_form_has_the_margins_and_poles_of_the_positional_one() -> None:
    model = FOPDT(gain=1.5, time_constant=10.0, dead_time=2.0)
    for ti in (8.0, 0.0):  # without integral action too (its bias is no state of the loop)
        pos = margins(model, PID(**{**BASE, "ti": ti}))
        vel = margins(model, PID(**{**BASE, "ti": ti}, algorithm="velocity"))
        assert vel.stable and pos.stable
        assert vel.ms == pytest.approx(pos.ms, rel=1e-9)
        assert vel.radius == pytest.approx(pos.radius, rel=1e-9)


def test_a_pv_filter_costs_phase_margin() -> None:
    model = FOPDT(gain=1.5, time_constant=10.0, dead_time=2.0)
    bare = margins(model, PID(**BASE))
    filtered = margins(model, PID(**BASE, pv_filter=0.5))
    assert filtered.pm < bare.pm and filtered.ms > bare.ms


@pytest.mark.parametrize("td, n, rings", [(0.1, 10.0, True), (1.0, 10.0, False),
                                          (0.5, 10.0, False), (0.49, 10.0, True)])  # fmt: skip
def test_a_ringing_tustin_derivative_is_warned_about(td, n, rings) -> None:
    # Td/N < ts/2 = 0.05 s: the pole (2 Td/N - h)/(2 Td/N + h) is negative
    pid = PID(kp=1.0, ti=5.0, td=td, n=n, ts=H, derivative_method="tustin", u_min=-1e9)
    msg = derivative_rings(pid)
    assert (msg is not None) == rings
    mg = margins(FOPDT(1.0, 10.0, 1.0), pid)
    assert bool(mg.warnings) == rings
    if rings:
        tf = td / n
        assert f"z = {(2 * tf - H) / (2 * tf + H):.3f}" in msg
    backward = PID(kp=1.0, ti=5.0, td=td, n=n, ts=H, u_min=-1e9)
    assert derivative_rings(backward) is None  # the backward derivative never rings
