"""Block.start_at: start again at rest from a given output (the runtime's bumpless restart).

A runtime that finds its device's MV after a restart or an outage, with the
block's own state too old to continue from, starts the block at rest at that
MV: the first cycle outputs it, an ADRC's observer sits at rest on the
present measurement with x4 = -b0 u (Nowak et al. 2018, (4a) at rest), and
the ADRC's first move goes toward the set point (its handover offset).
"""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ctrlblocks import ADRC, PID

BLOCKS = {
    "PID": lambda: PID(kp=1.5, ti=4.0, td=0.5, ts=0.1, u_min=0.0, u_max=5.0),
    "ADRC": lambda: ADRC(order=2, b0=0.5, omega_c=1.0, omega_o=5.0, ts=0.1, u_max=5.0),
}


@settings(max_examples=60, deadline=None)
@given(kind=st.sampled_from(sorted(BLOCKS)), u=st.floats(0.0, 5.0), y=st.floats(-10.0, 10.0),
       sp=st.floats(-10.0, 10.0), stale=st.floats(-50.0, 50.0))  # fmt: skip
def test_the_first_cycle_after_start_at_outputs_that_mv_whatever_the_old_state(
    kind, u, y, sp, stale
):
    b = BLOCKS[kind]()
    for _ in range(30):  # some old state, far from the present
        b(stale, stale / 2.0)
    b.start_at(u)
    assert b(sp, y) == pytest.approx(u, abs=1e-9)


@pytest.mark.parametrize("offset", [0.5, -0.5])
def test_the_adrc_starts_at_rest_on_the_pv_and_moves_toward_the_set_point(offset):
    b = BLOCKS["ADRC"]()
    for _ in range(30):
        b(4.0, 0.0)  # an observer far from the present
    b.start_at(2.19)
    u0 = b(1.5 + offset, 1.5)
    yh, x2, x3, x4 = b.x
    assert u0 == pytest.approx(2.19, abs=1e-12)
    # at rest: Y_hat = y, no derivative, the total disturbance holds the plant at u0
    assert yh == pytest.approx(1.5, abs=1e-12) and x2 == x3 == 0.0
    assert x4 == pytest.approx(-0.5 * 2.19, abs=1e-12)
    u1 = b(1.5 + offset, 1.5)
    assert (u1 - u0) * offset > 0.0


def test_a_non_finite_output_is_a_plain_reset():
    b = BLOCKS["PID"]()
    b(1.0, 0.0)
    b.start_at(math.nan)
    fresh = BLOCKS["PID"]()
    assert b(1.0, 0.5) == fresh(1.0, 0.5)


@pytest.mark.parametrize("kind", sorted(BLOCKS))
def test_an_output_beyond_the_limits_starts_at_the_limit(kind):
    b = BLOCKS[kind]()
    b.start_at(9.0)
    assert b.out == 5.0 and b(1.0, 1.0) == pytest.approx(5.0, abs=1e-12)
