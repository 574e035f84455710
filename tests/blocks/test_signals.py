"""The signal blocks (controltheplant 2024 sub-blocks; Åström 1987 saturation and selectors).

PT1 is compared with scipy.signal (cont2discrete + dlsim); the others are
checked against values evaluated by hand.
"""

from __future__ import annotations

import doctest
import importlib
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

import ctrlblocks
from ctrlblocks import (
    PT1,
    DeadBand,
    ErrorCode,
    MaxSelector,
    MinSelector,
    MovingAverage,
    ParameterError,
    RateLimiter,
    Saturation,
    Scale,
    SteadyStateDetector,
    deadband,
    scale,
)

# ---------------------------------------------------------------------------
# PT1 against scipy
# ---------------------------------------------------------------------------

PT1_CASES = [
    # seed, K, T, h, y0
    (1, 1.0, 2.0, 0.1, 0.0),
    (2, 2.5, 0.1, 0.1, 0.0),  # T equal to the sample time
    (3, -0.8, 0.12, 0.1, 0.0),  # T near the sample time
    (4, 1.7, 0.07, 0.1, 0.0),  # T below the sample time
    (5, 0.3, 25.0, 0.5, 0.0),  # slow
    (6, 1.2, 1.5, 0.05, 3.0),  # non-zero initial output
]


def _pt1_ss(k: float, t: float) -> tuple[np.ndarray, ...]:
    return (np.array([[-1.0 / t]]), np.array([[k / t]]), np.array([[1.0]]), np.array([[0.0]]))


@pytest.mark.parametrize(("seed", "k", "t", "h", "y0"), PT1_CASES)
def test_pt1_exact_equals_scipy_zoh_advanced_one_sample(
    seed: int, k: float, t: float, h: float, y0: float
) -> None:
    # signals.py: y[k] = a y[k-1] + (1-a) K u[k] is the ZOH pair (A, B) of
    # cont2discrete with the output y[k] = A x[k] + B u[k] (C = A, D = B) and x[0] = y0
    ad, bd, *_ = signal.cont2discrete(_pt1_ss(k, t), h, method="zoh")
    u = np.random.default_rng(seed).normal(size=300)
    _, y_ref, _ = signal.dlsim((ad, bd, ad, bd, h), u, x0=[y0])
    f = PT1(t=t, ts=h, gain=k, y0=y0)
    ours = np.array([f(float(x)) for x in u])
    assert np.max(np.abs(ours - np.ravel(y_ref))) < 1e-12


@pytest.mark.parametrize(("seed", "k", "t", "h", "y0"), PT1_CASES)
def test_pt1_euler_equals_scipy_backward_diff(
    seed: int, k: float, t: float, h: float, y0: float
) -> None:
    dss = signal.cont2discrete(_pt1_ss(k, t), h, method="backward_diff")
    u = np.random.default_rng(seed).normal(size=300)
    # scipy's realisation has y[0] = Cd x0 + Dd u[0]; ours y[0] = a y0 + (1-a) K u[0]
    # with the pole a = Ad, so the state that reproduces the previous output y0 is
    # x0 = a y0 / Cd
    x0 = [dss[0][0, 0] * y0 / dss[2][0, 0]]
    _, y_ref, _ = signal.dlsim((*dss[:4], h), u, x0=x0)
    f = PT1(t=t, ts=h, gain=k, y0=y0, method="euler")
    ours = np.array([f(float(x)) for x in u])
    assert np.max(np.abs(ours - np.ravel(y_ref))) < 1e-12


def test_pt1_first_sample_by_hand() -> None:
    assert PT1(t=2.0, ts=0.1)(1.0) == pytest.approx(1.0 - math.exp(-0.05), abs=1e-15)
    assert PT1(t=2.0, ts=0.1, method="euler")(1.0) == pytest.approx(0.1 / 2.1, abs=1e-15)


def test_pt1_with_zero_time_constant_is_a_gain() -> None:
    f = PT1(t=0.0, gain=3.0)
    assert [f(x) for x in (1.0, -2.0, 0.5)] == [3.0, -6.0, 1.5]


def test_pt1_nan_input_holds_and_recovers() -> None:
    f = PT1(t=1.0, ts=0.1)
    y = f(1.0)
    assert f(math.nan) == y and f.error_id == ErrorCode.BAD_INPUT and f.error
    assert f(1.0) > y and f.error_id == ErrorCode.NO_ERROR


def test_pt1_per_call_dt_uses_that_sample_time() -> None:
    f = PT1(t=1.0, ts=0.1)
    assert f(1.0, dt=0.5) == pytest.approx(1.0 - math.exp(-0.5), abs=1e-15)
    # back to ts
    y = f.out
    assert f(1.0) == pytest.approx(1.0 - (1.0 - y) * math.exp(-0.1), abs=1e-15)


# ---------------------------------------------------------------------------
# dt handling, for every block that takes a dt
# ---------------------------------------------------------------------------

DT_BLOCKS = {
    "PT1": lambda: PT1(t=1.0, ts=0.1),
    "RateLimiter": lambda: RateLimiter(rate_up=1.0, rate_down=1.0, ts=0.1),
    "SteadyStateDetector": lambda: SteadyStateDetector(tolerance=0.1, t_stab=0.3, ts=0.1),
}


@pytest.mark.parametrize("name", sorted(DT_BLOCKS))
@pytest.mark.parametrize("dt", [0.0, -0.1, math.nan, math.inf, -math.inf])
def test_bad_dt_gives_no_cycle_and_the_previous_output(name: str, dt: float) -> None:
    block = DT_BLOCKS[name]()
    for _ in range(5):
        block(2.0)
    state = block.snapshot()
    y = block(7.0, dt=dt)
    assert block.error_id == ErrorCode.NO_CYCLE and block.error
    assert y == state["out"] or y == bool(state["out"])
    after = block.snapshot()
    after.pop("error_id"), state.pop("error_id")
    assert after == state
    block(2.0)
    assert block.error_id == ErrorCode.NO_ERROR


# ---------------------------------------------------------------------------
# Rate limiter
# ---------------------------------------------------------------------------


def test_rate_limiter_ramps_at_its_rates_and_flags_limiting() -> None:
    r = RateLimiter(rate_up=2.0, rate_down=0.5, ts=0.1)
    ys, flags = [], []
    for u in [1.0] * 7 + [0.0] * 3:
        ys.append(r(u))
        flags.append(r.limiting)
    # up at 2/s = 0.2 per sample until 1.0 is reached after 5 samples
    assert ys[:7] == pytest.approx([0.2, 0.4, 0.6, 0.8, 1.0, 1.0, 1.0], abs=1e-12)
    assert flags[:7] == [True, True, True, True, False, False, False]
    # down at 0.5/s = 0.05 per sample
    assert ys[7:] == pytest.approx([0.95, 0.90, 0.85], abs=1e-12)
    assert flags[7:] == [True, True, True]


def test_rate_limiter_zero_rate_means_no_limit_in_that_direction() -> None:
    r = RateLimiter(rate_up=0.0, rate_down=1.0, ts=0.1)
    assert r(100.0) == 100.0 and not r.limiting
    assert r(0.0) == pytest.approx(99.9, abs=1e-12) and r.limiting


def test_rate_limiter_per_call_dt_scales_the_step() -> None:
    r = RateLimiter(rate_up=2.0, rate_down=2.0, ts=0.1)
    assert r(10.0, dt=1.5) == pytest.approx(3.0, abs=1e-12)


def test_rate_limiter_nan_holds() -> None:
    r = RateLimiter(rate_up=1.0, rate_down=1.0, ts=0.1)
    r(1.0)
    assert r(math.nan) == pytest.approx(0.1) and r.error_id == ErrorCode.BAD_INPUT


# ---------------------------------------------------------------------------
# Dead band and scale
# ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("u", "width", "y"),
    [
        (2.0, 0.5, 1.5),
        (-2.0, 0.5, -1.5),
        (0.3, 0.5, 0.0),
        (-0.5, 0.5, 0.0),  # the edge is inside the zone
        (2.0, -0.5, 1.5),  # negative width: its absolute value (controltheplant 2024, 2.3.10)
        (0.7, 0.0, 0.7),  # zero width: inactive
    ],
)
def test_deadband_by_hand(u: float, width: float, y: float) -> None:
    assert deadband(u, width) == pytest.approx(y, abs=1e-15)
    assert DeadBand(width=width)(u) == pytest.approx(y, abs=1e-15)


@pytest.mark.parametrize(
    ("u", "y"),
    [(12.0, 50.0), (4.0, 0.0), (20.0, 100.0), (8.0, 25.0), (24.0, 125.0), (0.0, -25.0)],
)
def test_scale_4_20_ma_to_percent(u: float, y: float) -> None:
    assert scale(u, 4.0, 20.0, 0.0, 100.0) == pytest.approx(y, abs=1e-12)
    assert Scale(in_lo=4.0, in_hi=20.0, out_lo=0.0, out_hi=100.0)(u) == pytest.approx(y)


def test_scale_clamp_and_inverted_ranges() -> None:
    s = Scale(in_lo=4.0, in_hi=20.0, out_lo=0.0, out_hi=100.0, clamp=True)
    assert s(24.0) == 100.0 and s(0.0) == 0.0
    inv = Scale(in_lo=0.0, in_hi=10.0, out_lo=100.0, out_hi=0.0, clamp=True)
    assert inv(2.5) == 75.0 and inv(-1.0) == 100.0 and inv(11.0) == 0.0


def test_scale_nan_holds() -> None:
    s = Scale()
    s(30.0)
    assert s(math.nan) == 30.0 and s.error_id == ErrorCode.BAD_INPUT


# ---------------------------------------------------------------------------
# Moving average
# ---------------------------------------------------------------------------


def test_moving_average_window_by_hand() -> None:
    m = MovingAverage(n=3)
    ys = [m(u) for u in (1.0, 2.0, 3.0, 4.0, 5.0, 9.0)]
    # until the window is full, the mean of what arrived
    assert ys == pytest.approx([1.0, 1.5, 2.0, 3.0, 4.0, 6.0], abs=1e-15)


def test_moving_average_nan_is_not_stored() -> None:
    m = MovingAverage(n=2)
    m(1.0), m(3.0)
    assert m(math.nan) == 2.0 and m.error_id == ErrorCode.BAD_INPUT
    assert m(5.0) == 4.0 and m.error_id == ErrorCode.NO_ERROR


def test_moving_average_preset_fills_the_window() -> None:
    m = MovingAverage(n=4)
    m.preset(10.0)
    assert m(2.0) == pytest.approx((3 * 10.0 + 2.0) / 4, abs=1e-15)


def test_moving_average_does_not_drift_over_a_long_run() -> None:
    m = MovingAverage(n=7)
    u = np.random.default_rng(3).normal(scale=1e3, size=5000) + 1e6
    for x in u:
        m(float(x))
    assert m.out == pytest.approx(math.fsum(u[-7:]) / 7, abs=1e-9)


# ---------------------------------------------------------------------------
# Steady-state detector
# ---------------------------------------------------------------------------


def test_steady_state_detector_timing() -> None:
    d = SteadyStateDetector(tolerance=0.2, t_stab=0.5, ts=0.1)
    flags = [d(1.0 + 0.05 * (-1) ** k) for k in range(8)]
    # anchor at the first sample; steady once 0.5 s = 5 samples have passed
    assert flags == [False] * 5 + [True] * 3
    assert d.out == 1.0


def test_steady_state_detector_restarts_on_a_large_change() -> None:
    d = SteadyStateDetector(tolerance=0.2, t_stab=0.3, ts=0.1)
    for _ in range(10):
        d(5.0)
    assert d.steady
    assert not d(5.5)  # variation 0.5 > tolerance: anchor moves, time restarts
    assert [d(5.5) for _ in range(3)] == [False, False, True]


def test_steady_state_detector_nan_is_not_steady() -> None:
    d = SteadyStateDetector(tolerance=0.2, t_stab=0.2, ts=0.1)
    for _ in range(5):
        d(1.0)
    assert d(math.nan) is False and d.error_id == ErrorCode.BAD_INPUT
    assert [d(1.0) for _ in range(3)] == [False, False, True]


def test_steady_state_detector_per_call_dt() -> None:
    d = SteadyStateDetector(tolerance=0.2, t_stab=1.0, ts=0.1)
    d(1.0)
    assert d(1.0, dt=1.0)


# ---------------------------------------------------------------------------
# Saturation and selectors (Åström 1987, section 5)
# ---------------------------------------------------------------------------


def test_saturation_by_hand_and_flags() -> None:
    s = Saturation(lo=-1.0, hi=2.0)
    assert (s(3.0), s.high, s.low, s.active) == (2.0, True, False, True)
    assert (s(-4.0), s.high, s.low) == (-1.0, False, True)
    assert (s(0.5), s.active) == (0.5, False)
    assert s(math.inf) == 0.5 and s.error_id == ErrorCode.BAD_INPUT


@pytest.mark.parametrize("bad", [{"hi": True}, {"lo": False}, {"hi": "high"}, {"lo": math.nan}])
def test_saturation_refuses_a_limit_that_is_not_a_number(bad: dict) -> None:
    # a bool is not a limit (as require_finite refuses it for every other parameter)
    with pytest.raises(ParameterError) as info:
        Saturation(**bad)
    assert info.value.code == ErrorCode.BAD_LIMITS and info.value.field == "lo/hi"


def test_selectors_pick_min_and_max_and_tell_which() -> None:
    lo, hi = MinSelector(), MaxSelector()
    assert lo(0.3, -0.2, 0.8) == -0.2 and lo.selected == 1
    assert hi(0.3, -0.2, 0.8) == 0.8 and hi.selected == 2
    assert lo(1.0, 1.0) == 1.0 and lo.selected == 0  # ties pick the first


def test_selectors_leave_out_bad_inputs() -> None:
    lo = MinSelector()
    assert lo(math.nan, 2.0, 3.0) == 2.0 and lo.selected == 1
    assert lo.error_id == ErrorCode.BAD_INPUT
    assert lo(math.nan, math.inf) == 2.0  # none finite: hold
    assert lo(4.0, 5.0) == 4.0 and lo.error_id == ErrorCode.NO_ERROR


# ---------------------------------------------------------------------------
# The examples in the docstrings and in docs/blocks/small-blocks.md run
# ---------------------------------------------------------------------------

DOCS = Path(__file__).resolve().parents[2] / "docs" / "blocks" / "small-blocks.md"


@pytest.mark.parametrize("module", ["signals", "leadlag", "jumprate", "manual", "monitor"])
def test_docstring_examples_run(module: str) -> None:
    mod = importlib.import_module(f"ctrlblocks.blocks.{module}")
    result = doctest.testmod(mod)
    assert result.attempted > 0 and result.failed == 0


def test_docs_page_examples_run() -> None:
    result = doctest.testfile(str(DOCS), module_relative=False, globs=dict(vars(ctrlblocks)))
    assert result.attempted >= 5 and result.failed == 0


def test_docs_page_usage_example_prints_its_numbers(capsys: pytest.CaptureFixture[str]) -> None:
    text = DOCS.read_text()
    start = text.index("```python\nimport math")
    code = text[start + len("```python\n") : text.index("```\n", start + 10)]
    exec(compile(code, str(DOCS), "exec"), {})
    lines = capsys.readouterr().out.splitlines()
    assert lines == ["30 PV bad: BAD_INPUT", "49.987 40.0 20.027 20.027", "100 0.25 1 1"]
