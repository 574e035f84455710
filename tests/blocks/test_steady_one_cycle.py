"""The steady-state detector's one cycle (issue 31): the block and the PLC cycle run
``signals.steady_step``; checked sample by sample over random inputs and periods, bad inputs
(a restart) and absurd periods (the time saturates instead of growing to inf)."""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from ctrlblocks.blocks import SteadyStateDetector
from ctrlblocks.blocks.signals import STEADY_TIME_CAP, steady_step

_U = st.one_of(st.floats(-10.0, 10.0), st.sampled_from([math.nan, math.inf, 0.0, 0.05]))
_H = st.one_of(st.floats(1e-3, 5.0), st.just(1e308))


@settings(max_examples=80, deadline=None)
@given(us=st.lists(st.tuples(_U, _H), min_size=1, max_size=60), tol=st.floats(0.0, 2.0),
       t_stab=st.floats(0.01, 10.0))  # fmt: skip
def test_the_block_and_the_plc_cycle_are_one_detector(us, tol, t_stab):
    det = SteadyStateDetector(tolerance=tol, t_stab=t_stab, ts=0.1)
    anchor, elapsed, started = 0.0, 0.0, False
    for u, h in us:
        got = det(u, dt=h)
        bad = not math.isfinite(u)
        steady, anchor, elapsed, started = steady_step(
            0.0 if bad else u, tol, t_stab, h, bad, anchor, elapsed, started
        )
        assert got is steady
        assert elapsed <= STEADY_TIME_CAP and det.snapshot()["_elapsed"] == elapsed
