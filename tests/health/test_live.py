"""The live assessor: ring buffer in order, one sample kept a second, assessment when due."""

from __future__ import annotations

import numpy as np
import pytest

from ctrlblocks.health.faults import simulate
from ctrlblocks.health.live import LiveAssessor


def test_the_window_is_the_last_samples_in_order_one_a_second() -> None:
    a = LiveAssessor("x", 0.1, window=2.0, every=1.0)
    for k in range(55):
        a.append(0.1 * k, 0.0, float(k), 0.0, True, True)
    w = a.window()
    # one sample in ten kept (k = 0, 10, ..., 50); the window holds 2 s = 2 of them
    assert w.y.tolist() == [40.0, 50.0]


def test_an_assessment_is_due_every_period_after_the_first_delay() -> None:
    a = LiveAssessor("x", 1.0, window=100.0, every=30.0)
    a.delay_first(5.0)
    due = []
    for k in range(100):
        a.append(float(k), 0.0, np.sin(k), 0.0, True, True)
        if a.due(float(k)):
            a.assess(float(k))
            due.append(k)
    # 5 s after the first sample, but only once 10 samples are in (k = 9); then every 30 s
    assert due == [9, 39, 69, 99]


def test_the_live_assessment_equals_the_offline_one_on_the_same_window() -> None:
    c = simulate("stiction", 2, hours=1.0)
    d = c.data
    live = LiveAssessor("x", 1.0, window=3600.0, every=3600.0, sample=1.0,
                        options=c.options, drift=True)  # fmt: skip
    for i in range(d.t.size):
        live.append(d.t[i], d.sp[i], d.y[i], d.u[i], d.mode[i] == "AUTO", True)
    got = live.assess()
    from ctrlblocks.health import assess

    want = assess(d, c.options)
    assert got is not None
    assert [f.kind for f in got.findings] == [f.kind for f in want.findings]
    assert got.osc.period == pytest.approx(want.osc.period)


def test_a_window_shorter_than_ten_samples_is_refused() -> None:
    with pytest.raises(ValueError):
        LiveAssessor("x", 1.0, window=5.0)
