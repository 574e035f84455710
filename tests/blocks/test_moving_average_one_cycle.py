"""The moving average's one cycle (issue 31): the block and the PID's dead band in the PLC
cycle run ``signals.moving_average_step``; checked sample by sample over random inputs, bad
inputs and huge samples, and its rounding error over a long run against ``math.fsum`` of the
window, in float64 (the block) and in REAL (the float32 cycle)."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ctrlblocks.blocks import MovingAverage
from ctrlblocks.blocks import plc_cycle as pc
from ctrlblocks.blocks.signals import SUM_LOSS_FLOAT64

_NAMES = ("mean", "buf", "idx", "count", "since", "total", "spread", "mag", "n_prev")
_HUGE = 1.7976931348623157e308
_U = st.one_of(
    st.floats(-1e3, 1e3),
    st.sampled_from([math.nan, math.inf, 0.0, 1e300, -1e300, 1.5e308, -_HUGE, 1e-300]),
)


def _fresh(n: int) -> dict:
    return {"mean": 0.0, "buf": [0.0] * n, "idx": 0, "count": 0, "since": 0, "total": 0.0,
            "spread": 0.0, "mag": 0.0, "n_prev": n}  # fmt: skip


def _same(a: float, b: float) -> bool:
    return a == b or (a != a and b != b)


@settings(max_examples=80, deadline=None)
@given(us=st.lists(_U, min_size=1, max_size=80), n=st.integers(1, 12))
def test_the_block_and_the_plc_cycle_are_one_average(us, n):
    ma = MovingAverage(n=n)
    state = _fresh(n)
    for u in us:
        got = ma(u)
        if math.isfinite(u):  # a bad input is not stored (the PID's cycle passes none)
            res = pc.moving_average(u, n, SUM_LOSS_FLOAT64, *(state[k] for k in _NAMES))
            state = dict(zip(_NAMES, res, strict=True))
        assert got == state["mean"]
        snap = ma.snapshot()
        assert snap["_buf"] == state["buf"]
        assert (snap["_idx"], snap["_count"], snap["_since"]) == (
            state["idx"], state["count"], state["since"])  # fmt: skip
        for mine, its in (("_sum", "total"), ("_spread", "spread"), ("_mag", "mag")):
            assert _same(snap[mine], state[its]), (mine, snap[mine], state[its])
        _is_the_mean_of_its_window(ma)


def _is_the_mean_of_its_window(ma: MovingAverage) -> None:
    """The fuzz campaign's oracle: the mean of the window the block holds (exact, in
    fractions: ``math.fsum`` of the quotients overflows for three values of 1.8e308), to 1e-9
    of the largest value in it."""
    st_ = ma.snapshot()
    n, count = ma.config.n, st_["_count"]
    if count:
        window = [st_["_buf"][(st_["_idx"] - count + j) % n] for j in range(count)]
        exact = float(sum(Fraction(v) for v in window) / count)
        assert abs(ma.out - exact) <= 1e-9 * max(abs(v) for v in window), (ma.out, exact)


@pytest.mark.parametrize("n", [2, 3, 36])
def test_the_largest_floats_leaving_the_window_leave_the_mean_of_the_rest(n):
    """-1.8e308 and 0.9e308 make the running sum's error bound and magnitudes infinite
    (loss * mag overflows too): the window is summed afresh, and once they have left the
    mean is that of the small values (the fuzz campaign's find, seed 0 step 28551: 0.0
    instead of 11.94)."""
    ma = MovingAverage(n=n)
    rng = np.random.default_rng(n)
    for u in (*rng.uniform(-118.0, 118.0, 2 * n), -_HUGE, _HUGE / 2,
              *rng.uniform(-118.0, 118.0, 3 * n)):  # fmt: skip
        ma(float(u))
        _is_the_mean_of_its_window(ma)


def test_a_window_of_the_largest_floats_has_their_mean_also_after_configure():
    """Three values of -1.8e308: their sum overflows and so does the sum of the rounded
    quotients v / 3; the mean is the value itself, in the cycle and after configure."""
    ma = MovingAverage(n=3)
    for _ in range(3):
        assert ma(-_HUGE) == -_HUGE
    ma.configure(n=4)
    assert ma.out == -_HUGE
    assert ma(-_HUGE) == -_HUGE


def drift(us: np.ndarray, n: int, real: bool) -> float:
    """The largest error of the average against the exact mean of its window (``math.fsum``
    of the values as the cycle holds them), relative to the mean magnitude of the window,
    over the run: ``real`` runs the PLC's cycle in REAL with its threshold, else the block."""
    state = _fresh(n)
    ma = MovingAverage(n=n)
    if real:
        us = us.astype(np.float32)
        state = {k: pc.to_real(v) for k, v in state.items() if k != "buf"} | {
            "buf": [np.float32(0.0)] * n}  # fmt: skip
    worst = 0.0
    for k, u in enumerate(us):
        if real:
            res = pc.run_float32(pc.moving_average, u=u, n=n, loss=pc.SUM_LOSS_REAL,
                                 **{k: state[k] for k in _NAMES})  # fmt: skip
            state = dict(zip(_NAMES, res, strict=True))
            mean = float(state["mean"])
        else:
            mean = ma(float(u))
        window = [float(v) for v in us[max(0, k + 1 - n) : k + 1]]
        exact = math.fsum(window) / len(window)
        scale = math.fsum(abs(v) for v in window) / len(window)
        if scale > 0.0:
            worst = max(worst, abs(mean - exact) / scale)
    return worst


def _process(samples: int, seed: int) -> np.ndarray:
    """A process value on a large offset with noise, and a spike of 1e20 every 5,000 samples
    (a plain running sum loses the window's small values to it)."""
    rng = np.random.default_rng(seed)
    us = 1e6 + 1e3 * rng.standard_normal(samples)
    us[2500::5000] = 1e20
    return us


@pytest.mark.parametrize(("real", "bound"), [(False, 2.0**-30), (True, 2.0**-14)])
def test_no_drift_over_a_long_run_against_the_exact_window_sum(real, bound):
    """Over 20,000 samples (n = 50) the average stays within the threshold's bound of the
    exact mean: the rounding-error bound times the unit roundoff, 2^-30 (float64) and 2^-14
    (REAL) of the window's magnitudes, spikes included."""
    assert drift(_process(20_000, 31), 50, real) <= bound


@pytest.mark.slow
@pytest.mark.parametrize(("real", "samples", "bound"),
                         [(False, 2_000_000, 2.0**-30), (True, 500_000, 2.0**-14)])  # fmt: skip
def test_no_drift_over_months_of_samples(real, samples, bound):
    """The same over 2 million samples (23 days at 1 s) in float64, half a million in REAL."""
    assert drift(_process(samples, 32), 50, real) <= bound


def test_a_snapshot_of_the_earlier_block_restores_to_the_same_average():
    """A snapshot taken before the one cycle (the bound ``_err`` in absolute terms, no
    ``_since``: the window was summed afresh when the index wrapped) continues as the block
    that took it would have."""
    ma = MovingAverage(n=7)
    for k in range(33):
        ma(20.0 + 50.0 * math.sin(0.3 * k))
    snap = ma.snapshot()
    old = {k: v for k, v in snap.items() if k not in ("_spread", "_since")}
    old["_err"] = snap["_spread"] * (2.0**-53)
    twin = MovingAverage(n=7)
    twin.restore(old)
    for k in range(33, 80):
        u = 20.0 + 50.0 * math.sin(0.3 * k)
        assert twin(u) == ma(u)
