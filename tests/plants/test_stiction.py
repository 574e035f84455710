"""StictionValve: Choudhury et al. 2005's two-parameter model (S, J), hand-evaluated."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ctrlblocks import ParameterError
from ctrlblocks.plants import PT1, StictionValve


def _valve(s: float, j: float, x0: float = 50.0) -> StictionValve:
    v = StictionValve(PT1(k=1.0, t=10.0, ts=1.0), s=s, j=j)
    v.reset(x0)
    return v


def test_breakaway_after_a_reversal_needs_s_and_jumps_by_j() -> None:
    v = _valve(s=4.0, j=1.0)
    up = [v.valve(x) for x in np.arange(50.5, 60.01, 0.5)]
    assert up[-1] == pytest.approx(60.0 - 1.5)  # (C1): x - (S - J)/2 while moving up
    down = [v.valve(x) for x in np.arange(59.5, 50.0, -0.5)]
    # stuck at x_ss = 60 until x < 60 - S = 56: the first move is at x = 55.5
    held = [p for x, p in zip(np.arange(59.5, 50.0, -0.5), down, strict=False) if x >= 56.0]
    assert held == [58.5] * len(held)
    i = len(held)
    assert down[i] == pytest.approx(55.5 + 1.5)  # moving down: x + (S - J)/2
    # the jump at breakaway: J plus the 0.5 the input went past the threshold
    assert down[i - 1] - down[i] == pytest.approx(1.0 + 0.5)


def test_restart_in_the_same_direction_needs_only_j() -> None:
    v = _valve(s=6.0, j=2.0)
    for x in (52.0, 54.0, 56.0):
        v.valve(x)
    assert v.position == pytest.approx(54.0)  # 56 - (6 - 2)/2
    v.valve(56.0)  # the input stops: the valve sticks at x_ss = 56
    assert v.stuck
    assert v.valve(58.0) == pytest.approx(54.0)  # 2 <= J: still stuck
    assert v.valve(58.5) == pytest.approx(56.5)  # 2.5 > J: moves, 58.5 - 2


def test_zero_slip_jump_is_a_backlash_of_width_s() -> None:
    v = _valve(s=2.0, j=0.0)
    x = 50.0 + 10.0 * np.sin(np.linspace(0.0, 6.0 * math.pi, 3000))
    y = np.array([v.valve(float(xi)) for xi in x])
    # the input-position characteristic: a parallelogram of width S = 2 (deadband only)
    gap = x - y
    assert gap[1000:].max() == pytest.approx(1.0, abs=0.02)
    assert gap[1000:].min() == pytest.approx(-1.0, abs=0.02)
    assert np.max(np.abs(np.diff(y[1:]))) < 0.07  # no jumps (after the first move from rest)


def test_no_stiction_is_a_linear_valve() -> None:
    v = _valve(s=0.0, j=0.0)
    for x in (55.0, 40.0, 40.0, 70.0):
        assert v.valve(x) == x


def test_input_is_limited_to_the_valve_range_and_nan_holds() -> None:
    v = _valve(s=0.0, j=0.0)
    v.step(150.0)
    assert v.position == 100.0
    v.step(math.nan)
    assert v.position == 100.0


def test_bad_parameters_are_refused() -> None:
    with pytest.raises(ParameterError):
        StictionValve(PT1(k=1.0, t=1.0, ts=1.0), s=-1.0, j=0.0)
    with pytest.raises(ParameterError):
        StictionValve(PT1(k=1.0, t=1.0, ts=1.0), s=200.0, j=0.0)


def test_snapshot_restore_reproduces_the_trace() -> None:
    v = _valve(s=5.0, j=2.0)
    xs = 50.0 + 8.0 * np.sin(np.arange(200) * 0.1)
    for x in xs[:50]:
        v.step(float(x))
    snap = v.snapshot()
    a = [v.step(float(x)) for x in xs[50:]]
    v.restore(snap)
    assert [v.step(float(x)) for x in xs[50:]] == a
