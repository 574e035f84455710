"""ADRC MAN -> AUTO with SP != PV: no bump at the switch, and the first move goes toward SP.

The handover solves the reference offset ``q`` of (4b) instead of x4 by (11)
(``ctrlblocks.blocks.adrc.handover_offset``; docs/blocks/adrc.md, "Modes and
bumpless transfer"), in the one cycle every executor runs (``adrc_law``): the
block, its float32 cycle (what the PLC export translates, bit-equal to it:
tests/plc) and the compiled lanes (``ctrlblocks.fast``).  Also: the Euler
observer is sub-stepped for any period (issue 36), and the outputs of Fig. 2.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ctrlblocks import ADRC
from ctrlblocks.fast import closed_loop
from ctrlblocks.plants import PTn


def _at_rest_in_manual(order, wc, ratio, k, u_man, precision="float64", reverse=False):
    plant = PTn(k, [2.0, 1.0], 0.1)
    adrc = ADRC(order=order, b0=0.5, omega_c=wc, omega_o=ratio * wc, ts=0.1,
                precision=precision, reverse=reverse)  # fmt: skip
    adrc.manual, adrc.u_man = True, u_man
    for _ in range(600):
        plant.step(adrc(plant.y, plant.y))
    return plant, adrc


def _switch(plant, adrc, sp, n=6):
    adrc.manual = False
    us = []
    for _ in range(n):
        us.append(adrc(sp, plant.y))
        plant.step(us[-1])
    return us


CASES = dict(
    order=st.sampled_from((1, 2, 3)),
    wc=st.floats(0.2, 1.5),
    ratio=st.floats(3.0, 10.0),
    offset=st.floats(0.5, 5.0) | st.floats(-5.0, -0.5),
    reverse=st.booleans(),
)


@settings(max_examples=60, deadline=None)
@given(**CASES)
def test_first_move_is_toward_the_setpoint_without_a_bump(order, wc, ratio, offset, reverse):
    k = -1.0 if reverse else 1.0  # a reverse-acting process with reverse=True
    plant, adrc = _at_rest_in_manual(order, wc, ratio, k, 1.0, reverse=reverse)
    y0 = plant.y
    us = _switch(plant, adrc, y0 + offset)
    assert us[0] == pytest.approx(1.0, abs=1e-9)  # bumpless: the switch holds the MV
    toward = math.copysign(1.0, offset * k)  # more MV raises PV when k > 0
    assert (us[1] - us[0]) * toward > 0.0


@settings(max_examples=25, deadline=None)
@given(**CASES)
def test_the_float32_cycle_hands_over_the_same_way(order, wc, ratio, offset, reverse):
    k = -1.0 if reverse else 1.0
    plant, adrc = _at_rest_in_manual(order, wc, ratio, k, 1.0, "float32", reverse)
    us = _switch(plant, adrc, plant.y + offset)
    assert us[0] == pytest.approx(1.0, abs=1e-6)  # REAL rounding
    assert (us[1] - us[0]) * math.copysign(1.0, offset * k) > 0.0


@pytest.mark.parametrize("order", [1, 2, 3])
@pytest.mark.parametrize("offset", [2.0, -2.0])
def test_the_compiled_lane_hands_over_as_the_block(order, offset):
    n, sw = 700, 600
    sp = np.where(np.arange(n) < sw, 0.0, offset)
    manual = np.arange(n) < sw
    runs = []
    for engine in ("auto", "blocks"):  # auto: the numba kernel
        adrc = ADRC(order=order, b0=0.5, omega_c=1.0, omega_o=4.0, ts=0.1)
        res = closed_loop(adrc, PTn(1.0, [2.0, 1.0], 0.1), sp, manual=manual,
                          u_man=np.zeros(n), engine=engine)  # fmt: skip
        runs.append(res.u)
    np.testing.assert_array_equal(runs[0], runs[1])  # bit for bit
    u = runs[0]
    assert u[sw] == pytest.approx(u[sw - 1], abs=1e-12)
    assert (u[sw + 1] - u[sw]) * offset > 0.0


def test_the_setpoint_step_at_the_switch_no_longer_drives_the_pv_away() -> None:
    # issue 30: SP stepped in the cycle MAN is released; the paper's (11) moved the MV
    # the wrong way first (n = 2: 1.0 -> 0.598, the PV dipped 0.017 below its start)
    for order in (1, 2, 3):
        plant, adrc = _at_rest_in_manual(order, 1.0, 3.0, 1.0, 1.0)
        y0 = plant.y
        us, ys = [], []
        adrc.manual = False
        for _ in range(40):
            us.append(adrc(3.0, plant.y))
            ys.append(plant.y)
            plant.step(us[-1])
        assert us[0] == pytest.approx(1.0, abs=1e-12)
        assert us[1] > us[0] and min(ys) >= y0 - 1e-9


def test_at_rest_the_handover_starts_the_reference_at_the_measurement() -> None:
    plant, adrc = _at_rest_in_manual(2, 1.0, 4.0, 1.0, 1.0)
    adrc.manual = False
    adrc(3.0, plant.y)
    assert adrc.y_ref + adrc._q == pytest.approx(plant.y, abs=1e-9)  # ref + q = y: no kick
    assert adrc.x[3] == pytest.approx(-0.5 * 1.0, abs=1e-9)  # x4 = -b0 u: unbent


# --- issue 36: the observer stable for any measured period --------------------------


@settings(max_examples=40, deadline=None)
@given(order=st.sampled_from((1, 2, 3)), wo_ts=st.floats(0.05, 0.35),
       seed=st.integers(0, 2**16))  # fmt: skip
def test_the_euler_observer_converges_for_periods_from_ts_over_10_to_20_ts(order, wo_ts, seed):
    ts = 0.1
    adrc = ADRC(order=order, b0=1.0, omega_c=wo_ts / ts / 4.0, omega_o=wo_ts / ts, ts=ts)
    adrc.manual, adrc.u_man = True, 2.0
    rng = np.random.default_rng(seed)
    for _ in range(400):  # y held at 1 with u = 2: the ESO must settle on h = -b0 u
        adrc(1.0, 1.0, dt=ts * float(rng.uniform(0.1, 20.0)))
        assert all(abs(v) < 1e6 for v in adrc.x)
    yh, x2, x3, x4 = adrc.x
    assert abs(x2) < 1e-5 and abs(x3) < 1e-5
    assert yh == pytest.approx(1.0, abs=1e-6) and x4 == pytest.approx(-2.0, abs=1e-5)


def test_a_period_inside_the_trusted_step_runs_the_papers_single_step() -> None:
    a, b = ADRC(order=2, omega_o=4.0, ts=0.1), ADRC(order=2, omega_o=4.0, ts=0.1)
    for k in range(200):
        y = math.sin(0.05 * k)
        assert a(1.0, y) == b(1.0, y, dt=0.1)


# --- issue 34: the outputs of Fig. 2 -------------------------------------------------


@pytest.mark.parametrize("precision", ["float64", "float32"])
def test_the_outputs_of_fig2_are_the_cycles(precision) -> None:
    adrc = ADRC(order=2, b0=0.5, omega_c=1.0, omega_o=4.0, ts=0.1, t_ref=1.0,
                precision=precision)  # fmt: skip
    for k in range(50):
        adrc(2.0, 0.02 * k)
    assert adrc.e == pytest.approx(2.0 - 0.02 * 49, rel=1e-6)
    assert adrc.y == pytest.approx(0.02 * 49, rel=1e-6)
    assert 0.0 < adrc.y_ref < 2.0
    assert all(math.isfinite(v) for v in adrc.x) and adrc.x != (0.0, 0.0, 0.0, 0.0)
