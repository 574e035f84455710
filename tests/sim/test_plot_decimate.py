"""Long traces are drawn decimated: the minimum and maximum of every bin, in time order."""

from __future__ import annotations

import numpy as np

from ctrlblocks.sim.plot import PLOT_POINTS, decimate


def test_a_short_trace_is_drawn_as_it_is():
    t = np.arange(PLOT_POINTS) * 0.1
    x = np.sin(t)
    td, xd = decimate(t, x)
    assert td is t and xd is x


def test_a_long_trace_keeps_every_bins_extremes_and_both_ends_in_time_order():
    rng = np.random.default_rng(4)
    n = 10_007
    t = np.arange(n) * 0.01
    x = rng.normal(size=n).cumsum()
    td, xd = decimate(t, x, points=1000)
    assert len(td) <= 1000 + 3 and np.all(np.diff(td) > 0)
    assert (td[0], td[-1]) == (t[0], t[-1])
    assert xd.min() == x.min() and xd.max() == x.max()
    b = -(-n // 500)  # bins of 21 samples: 476 of them, and 11 samples kept as they are
    assert n // b == 476
    for k in (0, 17, 475):
        seg = x[k * b : (k + 1) * b]
        assert seg.min() in xd and seg.max() in xd
    # every drawn point is a sample of the trace at its own time
    np.testing.assert_array_equal(xd, x[np.searchsorted(t, td)])


def test_a_nan_in_a_long_trace_stays_a_gap():
    x = np.ones(5000)
    x[2500] = np.nan
    _, xd = decimate(np.arange(5000.0), x)
    assert np.isnan(xd).sum() == 1
