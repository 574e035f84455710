"""LeadLag (Bonde et al. 2021): as scipy's discretisations; the run-time rules of Fig. 10."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from ctrlblocks import ErrorCode, LeadLag, ParameterError

SCIPY_METHOD = {"tustin": "bilinear", "euler": "backward_diff"}


def _scipy_leadlag(
    u: np.ndarray, k: float, t_lead: float, t_lag: float, h: float, method: str
) -> np.ndarray:
    num_c = [k * t_lead, k] if t_lead else [k]
    num, den, _ = signal.cont2discrete((num_c, [t_lag, 1.0]), h, SCIPY_METHOD[method])
    _, y = signal.dlsim((np.ravel(num), np.ravel(den), h), u)
    return np.ravel(y)


@pytest.mark.parametrize("method", ["tustin", "euler"])
@pytest.mark.parametrize(
    ("seed", "k", "t_lead", "t_lag", "h"),
    [
        (1, 1.0, 2.0, 1.0, 0.1),  # lead
        (2, 0.7, 0.3, 4.0, 0.1),  # lag
        (3, -2.5, 0.1, 0.1, 0.1),  # both time constants equal to the sample time
        (4, 1.3, 0.12, 0.09, 0.1),  # both near the sample time
        (5, 3.0, 0.0, 0.5, 0.02),  # pure lag
        (6, 0.5, 10.0, 0.05, 0.1),  # strong lead, lag below the sample time
    ],
)
def test_leadlag_equals_scipy_cont2discrete(
    method: str, seed: int, k: float, t_lead: float, t_lag: float, h: float
) -> None:
    u = np.random.default_rng(seed).normal(size=300)
    ll = LeadLag(k=k, t_lead=t_lead, t_lag=t_lag, ts=h, method=method)
    ours = np.array([ll(float(x)) for x in u])
    ref = _scipy_leadlag(u, k, t_lead, t_lag, h, method)
    assert np.max(np.abs(ours - ref)) < 1e-12


def test_euler_with_zero_lag_equals_scipy_backward_difference() -> None:
    u = np.random.default_rng(7).normal(size=200)
    ll = LeadLag(k=2.0, t_lead=0.3, t_lag=0.0, ts=0.1, method="euler")
    ours = np.array([ll(float(x)) for x in u])
    # K (1 + Tt s) with s = (1 - z^-1)/h, evaluated by hand
    ref = 2.0 * (u + 0.3 * np.diff(u, prepend=0.0) / 0.1)
    assert np.max(np.abs(ours - ref)) < 1e-12


def test_tustin_first_sample_matches_seed_003_figure_10_by_hand() -> None:
    # diff2 = Setpoint*K_LL*(T + 2 Tt)/(T + 2 Tn), previous values zero
    ll = LeadLag(k=2.0, t_lead=3.0, t_lag=1.5, ts=0.2)
    assert ll(1.0) == pytest.approx(2.0 * 6.2 / 3.2, abs=1e-15)
    # second sample: diff1 + diff2 - diff3
    y1 = 2.0 * 6.2 / 3.2
    expected = 1.0 * 2.0 * (0.2 - 6.0) / 3.2 + 1.0 * 2.0 * 6.2 / 3.2 - y1 * (0.2 - 3.0) / 3.2
    assert ll(1.0) == pytest.approx(expected, abs=1e-15)


@pytest.mark.parametrize("method", ["tustin", "euler"])
def test_step_settles_at_the_static_gain(method: str) -> None:
    ll = LeadLag(k=2.5, t_lead=1.0, t_lag=0.5, ts=0.1, method=method)
    for _ in range(400):
        y = ll(4.0)
    assert y == pytest.approx(10.0, abs=1e-12)


@pytest.mark.parametrize("method", ["tustin", "euler"])
def test_preset_starts_at_the_steady_state(method: str) -> None:
    ll = LeadLag(k=-1.5, t_lead=2.0, t_lag=0.7, ts=0.1, method=method)
    ll.preset(3.0)
    assert ll.out == -4.5
    for _ in range(5):
        assert ll(3.0) == pytest.approx(-4.5, abs=1e-14)


def test_tustin_with_zero_lag_is_refused() -> None:
    with pytest.raises(ParameterError, match="euler") as info:
        LeadLag(t_lead=1.0, t_lag=0.0)
    assert info.value.code == ErrorCode.BAD_TIME_CONSTANT
    ll = LeadLag(t_lag=0.0, method="euler")
    with pytest.raises(ParameterError):
        ll.configure(method="tustin")
    assert ll.config.method == "euler"


@pytest.mark.parametrize(
    ("change", "code"),
    [
        ({"out_min": 2.0, "out_max": 1.0}, ErrorCode.BAD_LIMITS),
        ({"t_lead": -1.0}, ErrorCode.BAD_TIME_CONSTANT),
        ({"t_lag": math.inf}, ErrorCode.BAD_TIME_CONSTANT),
        ({"ts": 0.0}, ErrorCode.NO_CYCLE),
        ({"k": math.nan}, ErrorCode.BAD_PARAMETER),
        ({"method": "zoh"}, ErrorCode.BAD_PARAMETER),
    ],
)
def test_bad_configuration_has_its_code(change: dict, code: ErrorCode) -> None:
    with pytest.raises(ParameterError) as info:
        LeadLag(**change)
    assert info.value.code == code


def test_disabled_outputs_zero_and_input_memory_follows() -> None:
    ll = LeadLag(k=1.0, t_lead=2.0, t_lag=1.0, ts=0.1)
    ll.preset(5.0)
    assert ll(7.0, enable=False) == 0.0
    assert ll.out == 0.0 and not ll.enabled
    # enabled again with the same input: no kick from the old input 5,
    # the lag starts from the stored output 0: y = b0*7 + b1*7 - a1*0 = K*7*2h/(h+2Tn)
    assert ll(7.0) == pytest.approx(7.0 * 0.2 / 2.1, abs=1e-14)


def test_limited_output_is_stored_as_previous_output() -> None:
    # Bonde et al. 2021, Fig. 10 stores U_prev := LL_Output after saturation
    ll = LeadLag(k=1.0, t_lead=0.0, t_lag=1.0, ts=0.1, out_max=0.5)
    b0 = b1 = 0.1 / 2.1
    a1 = (0.1 - 2.0) / 2.1
    y = 0.0
    x_prev = 0.0
    for _ in range(60):
        y = min(b0 * 10.0 + b1 * x_prev - a1 * y, 0.5)
        x_prev = 10.0
        assert ll(10.0) == pytest.approx(y, abs=1e-15)
    assert ll.out == 0.5
    # input reversed: the recursion starts from the limit 0.5, not from the linear
    # filter's 9.5 (no wind-up): y = b0 (-10) + b1 10 - a1 0.5 = -a1 0.5
    assert ll(-10.0) == pytest.approx(-a1 * 0.5, abs=1e-15)


def test_limits_hold_the_output_inside() -> None:
    ll = LeadLag(k=1.0, t_lead=5.0, t_lag=0.2, ts=0.1, out_min=-1.0, out_max=1.0)
    ys = [ll(x) for x in [0.0, 3.0, 3.0, -3.0, -3.0, 0.0]]
    assert max(ys) == 1.0 and min(ys) == -1.0


def test_nan_input_holds_output_and_recovers() -> None:
    ll = LeadLag(k=1.0, t_lead=1.0, t_lag=1.0, ts=0.1)  # K(1+s)/(1+s) = K: y = x
    assert ll(2.0) == pytest.approx(2.0, abs=1e-15)
    assert ll(math.nan) == pytest.approx(2.0, abs=1e-15)
    assert ll.error and ll.error_id == ErrorCode.BAD_INPUT
    assert ll(math.inf) == pytest.approx(2.0, abs=1e-15)
    assert ll(3.0) == pytest.approx(3.0, abs=1e-15)
    assert ll.error_id == ErrorCode.NO_ERROR


@pytest.mark.parametrize("dt", [0.0, -0.1, math.nan, math.inf])
def test_bad_dt_gives_no_cycle_and_the_previous_output(dt: float) -> None:
    ll = LeadLag(k=1.0, t_lead=0.0, t_lag=1.0, ts=0.1)
    y = ll(1.0)
    assert ll(5.0, dt=dt) == y
    assert ll.error_id == ErrorCode.NO_CYCLE
    assert ll(1.0) != y and ll.error_id == ErrorCode.NO_ERROR


def test_per_call_dt_uses_that_sample_time() -> None:
    a = LeadLag(k=1.0, t_lead=0.5, t_lag=1.0, ts=0.1)
    b = LeadLag(k=1.0, t_lead=0.5, t_lag=1.0, ts=0.25)
    xs = [1.0, 2.0, -1.0, 0.5]
    assert [a(x, dt=0.25) for x in xs] == [b(x) for x in xs]
    # and back to the configured ts
    c = LeadLag(k=1.0, t_lead=0.5, t_lag=1.0, ts=0.1)
    c.restore(a.snapshot())
    assert a(1.0) == c(1.0)
