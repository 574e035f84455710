"""Properties of the blocks, checked with hypothesis (issue 2, "Tests that must exist").

* a rate limiter never exceeds its rates;
* the dead band is continuous (1-Lipschitz) and odd;
* selectors return one of their inputs;
* saturation output is always within its limits;
* no exported block returns NaN/inf for finite inputs, and none raises on NaN
  input (it flags an error and recovers).
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import ctrlblocks
from ctrlblocks import (
    Block,
    DeadBand,
    JumpAndRate,
    LeadLag,
    MaxSelector,
    MinSelector,
    RateLimiter,
    Saturation,
    compiled,
    deadband,
)

from .test_contract import CASES

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])

finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False)
signals = st.lists(finite, min_size=1, max_size=40)
positive_rate = st.floats(min_value=1e-3, max_value=1e3)
sample_time = st.floats(min_value=1e-3, max_value=2.0)


def _tol(*values: float) -> float:
    """Rounding allowance for one addition of numbers of these sizes."""
    return 4e-16 * max(1.0, *(abs(v) for v in values))


# ---------------------------------------------------------------------------
# Rate limiter
# ---------------------------------------------------------------------------


@SETTINGS
@given(
    up=positive_rate,
    down=positive_rate,
    ts=sample_time,
    u=signals,
    dts=st.lists(st.one_of(st.none(), sample_time), min_size=40, max_size=40),
)
def test_rate_limiter_never_exceeds_its_rates(
    up: float, down: float, ts: float, u: list[float], dts: list[float | None]
) -> None:
    r = RateLimiter(rate_up=up, rate_down=down, ts=ts)
    y_prev = r.out
    for x, dt in zip(u, dts, strict=False):
        h = ts if dt is None else dt
        y = r(x, dt=dt)
        step = y - y_prev
        assert step <= up * h + _tol(y, y_prev, up * h)
        assert step >= -down * h - _tol(y, y_prev, down * h)
        if not r.limiting:
            assert y == x
        y_prev = y


# ---------------------------------------------------------------------------
# Dead band
# ---------------------------------------------------------------------------


@SETTINGS
@given(u=finite, width=finite)
def test_deadband_is_odd(u: float, width: float) -> None:
    assert deadband(-u, width) == -deadband(u, width)
    assert DeadBand(width=width)(-u) == -DeadBand(width=width)(u)


@SETTINGS
@given(u1=finite, u2=finite, width=finite)
def test_deadband_is_continuous_with_slope_at_most_one(u1: float, u2: float, width: float) -> None:
    # 1-Lipschitz: |db(u1) - db(u2)| <= |u1 - u2|, so no jump anywhere, also at +-width
    d = abs(deadband(u1, width) - deadband(u2, width))
    assert d <= abs(u1 - u2) + _tol(u1, u2, width)
    # zero exactly inside the zone, never larger than the input
    assert (deadband(u1, width) == 0.0) == (abs(u1) <= abs(width))
    assert abs(deadband(u1, width)) <= abs(u1)


@SETTINGS
@given(width=st.floats(min_value=0.0, max_value=1e3), eps=st.floats(min_value=0.0, max_value=1.0))
def test_deadband_is_continuous_at_the_edge(width: float, eps: float) -> None:
    # just outside the zone the output is just above zero
    assert deadband(width + eps, width) <= eps + _tol(width, eps)
    assert deadband(-width - eps, width) >= -eps - _tol(width, eps)


# ---------------------------------------------------------------------------
# Selectors and saturation
# ---------------------------------------------------------------------------


@SETTINGS
@given(inputs=st.lists(finite, min_size=1, max_size=8))
def test_selectors_return_one_of_their_inputs(inputs: list[float]) -> None:
    lo, hi = MinSelector(), MaxSelector()
    assert lo(*inputs) in inputs and inputs[lo.selected] == lo.out == min(inputs)
    assert hi(*inputs) in inputs and inputs[hi.selected] == hi.out == max(inputs)


@SETTINGS
@given(
    inputs=st.lists(
        st.one_of(finite, st.just(math.nan), st.just(math.inf), st.just(-math.inf)),
        min_size=1,
        max_size=8,
    )
)
def test_selectors_with_bad_inputs_return_a_finite_input_or_hold(inputs: list[float]) -> None:
    sel = MinSelector()
    sel(1.5, 2.5)
    y = sel(*inputs)
    good = [x for x in inputs if math.isfinite(x)]
    assert y == (min(good) if good else 1.5)


@SETTINGS
@given(
    a=finite,
    b=finite,
    u=st.lists(st.one_of(finite, st.just(math.nan), st.just(math.inf)), min_size=1, max_size=30),
)
def test_saturation_output_is_always_within_its_limits(a: float, b: float, u: list[float]) -> None:
    lo, hi = min(a, b), max(a, b)
    s = Saturation(lo=lo, hi=hi)
    assert lo <= s.out <= hi
    for x in u:
        assert lo <= s(x) <= hi


@SETTINGS
@given(
    lim=st.tuples(finite, finite).map(sorted),
    k=st.floats(min_value=-100.0, max_value=100.0),
    u=signals,
)
def test_leadlag_output_is_always_within_its_limits(
    lim: list[float], k: float, u: list[float]
) -> None:
    ll = LeadLag(k=k, t_lead=3.0, t_lag=0.2, ts=0.1, out_min=lim[0], out_max=lim[1])
    for x in u:
        assert lim[0] <= ll(x) <= lim[1]


@SETTINGS
@given(u=signals, h=sample_time)
def test_jump_and_rate_output_lies_between_state_and_input(u: list[float], h: float) -> None:
    # y = x + sat(u - x, jlow, jhigh) with jlow <= 0 <= jhigh never overshoots the input
    jar = JumpAndRate(jlow=-0.5, jhigh=2.0, rlow=-3.0, rhigh=1.0, ts=h)
    for x in u:
        state = jar.x
        y = jar(x)
        tol = _tol(state, x, 2.0)
        assert min(state, x) - tol <= y <= max(state, x) + tol
        if jar.jump_limited:
            assert min(abs(y - state - 2.0), abs(y - state + 0.5)) <= tol
        else:
            assert y == x


# ---------------------------------------------------------------------------
# Every exported block: finite in -> finite out; NaN in -> no exception, flag, recover
# ---------------------------------------------------------------------------

# Configurations with non-trivial dynamics for the blocks known here; any other
# exported block is made as in test_contract.CASES (or with its defaults).
MAKERS: dict[str, Callable[[], Block]] = {
    "PT1": lambda: ctrlblocks.PT1(t=0.3, ts=0.1, gain=2.0),
    "RateLimiter": lambda: ctrlblocks.RateLimiter(rate_up=3.0, rate_down=1.0, ts=0.1),
    "DeadBand": lambda: ctrlblocks.DeadBand(width=0.5),
    "MovingAverage": lambda: ctrlblocks.MovingAverage(n=4),
    "SteadyStateDetector": lambda: ctrlblocks.SteadyStateDetector(tolerance=1.0, t_stab=0.3),
    "LeadLag": lambda: ctrlblocks.LeadLag(k=1.5, t_lead=2.0, t_lag=0.15, ts=0.1),
    "JumpAndRate": lambda: ctrlblocks.JumpAndRate(jlow=-0.5, rlow=-0.5, ts=0.1),
    "ManualStation": lambda: ctrlblocks.ManualStation(tr=0.3, out_min=-1e9, out_max=1e9),
    "CycleMonitor": lambda: ctrlblocks.CycleMonitor(ts=0.1),
}

# How to feed one input value x; any other block gets x on every required argument.
FEEDERS: dict[str, Callable[[Block, float], Any]] = {
    "MinSelector": lambda b, x: b(x, 0.25 * x, 1.0),
    "MaxSelector": lambda b, x: b(x, 0.25 * x, 1.0),
    "LeadLag": lambda b, x: b(x, enable=abs(x) != 7.0),
    "ManualStation": lambda b, x: b(inc=x > 0, dec=x < -1, track=x),
}


def _exported_blocks() -> list[str]:
    return sorted(
        name
        for name in ctrlblocks.__all__
        if isinstance(getattr(ctrlblocks, name), type)
        and issubclass(getattr(ctrlblocks, name), Block)
        and getattr(ctrlblocks, name) is not Block
    )


def _make(name: str) -> Block:
    """The block from MAKERS, else from the contract test's CASES, else with its defaults."""
    maker = MAKERS.get(name)
    if maker is None:
        case = CASES.get(name)
        maker = case.make if case is not None else getattr(ctrlblocks, name)
    return maker()


def _feed(name: str, block: Block, x: float) -> Any:
    feeder = FEEDERS.get(name)
    if feeder:
        return feeder(block, x)
    params = list(compiled.signature(type(block)).parameters.values())[1:]
    required = [
        p
        for p in params
        if p.default is inspect.Parameter.empty
        and p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)
    ]
    return block(*([x] * max(1, len(required))))


def _finite_values(value: Any) -> list[float]:
    """Every float inside a (nested) state value."""
    if isinstance(value, bool):
        return []
    if isinstance(value, (int, float)):
        return [float(value)]
    if isinstance(value, (list, tuple)):
        return [v for item in value for v in _finite_values(item)]
    if isinstance(value, dict):
        return [v for item in value.values() for v in _finite_values(item)]
    return []


def test_every_exported_block_is_covered() -> None:
    names = _exported_blocks()
    assert {"LeadLag", "JumpAndRate", "ManualStation", "CycleMonitor", "PT1"} <= set(names)
    for name in names:
        _feed(name, _make(name), 1.0)  # each can be made and fed


@pytest.mark.parametrize("name", _exported_blocks())
@SETTINGS
@given(u=signals)
def test_finite_inputs_give_finite_outputs_and_states(name: str, u: list[float]) -> None:
    block = _make(name)
    for x in u:
        y = _feed(name, block, x)
        assert all(math.isfinite(v) for v in _finite_values(y)), (name, x, y)
        assert all(math.isfinite(v) for v in _finite_values(block.snapshot())), (name, x)


@pytest.mark.parametrize("name", _exported_blocks())
@SETTINGS
@given(
    u=st.lists(
        st.one_of(finite, st.just(math.nan), st.just(math.inf), st.just(-math.inf)),
        min_size=1,
        max_size=30,
    )
)
def test_nan_input_never_raises_is_flagged_and_recovers(name: str, u: list[float]) -> None:
    block = _make(name)
    for x in u:
        y = _feed(name, block, x)
        assert all(math.isfinite(v) for v in _finite_values(y)), (name, x, y)
        if not math.isfinite(x):
            assert block.error, (name, x)
    _feed(name, block, 0.5)
    assert not block.error, name
