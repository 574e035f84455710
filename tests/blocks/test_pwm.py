"""PulseWidth: on/off output whose mean equals the controller output; the ripple formula."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from ctrlblocks import PID, ErrorCode, ParameterError, PulseWidth
from ctrlblocks.blocks.pwm import pwm_ripple
from ctrlblocks.plants import PT1


def test_the_duty_is_latched_per_period_as_whole_samples() -> None:
    pwm = PulseWidth(period=1.0, ts=0.1)
    assert [pwm(30.0) for _ in range(10)] == [1.0] * 3 + [0.0] * 7
    assert [pwm(70.0) for _ in range(10)] == [1.0] * 7 + [0.0] * 3
    assert pwm.duty == pytest.approx(0.7)


@pytest.mark.parametrize("duty", [0.0, 3.0, 12.0, 35.0, 50.0, 87.5, 99.0, 100.0])
def test_the_mean_equals_the_duty_despite_minimum_times_and_rounding(duty: float) -> None:
    pwm = PulseWidth(period=1.0, t_min_on=0.3, t_min_off=0.2, ts=0.1)
    n_periods = 400
    out = [pwm(duty) for _ in range(10 * n_periods)]
    # error diffusion: the mean is right to one period's rounding over the whole run
    assert abs(sum(out) * 0.1 - duty / 100.0 * n_periods) <= 1.0 + 1e-9
    on_runs = [len(r) for r in "".join("1" if o else "0" for o in out).split("0") if r]
    off_runs = [len(r) for r in "".join("0" if o else "1" for o in out).split("1") if r]
    if 0.0 < duty < 100.0:  # the minimum times hold inside the run (not at its ends)
        assert min(on_runs) >= 3
        assert min(off_runs[1:-1] or [2]) >= 2


def test_bad_input_completes_the_pulse_then_switches_off() -> None:
    pwm = PulseWidth(period=1.0, ts=0.1)
    out = [pwm(50.0)] + [pwm(math.nan) for _ in range(14)]
    assert out[:5] == [1.0] * 5 and out[5:] == [0.0] * 10
    assert pwm.error_id == ErrorCode.BAD_INPUT
    pwm(50.0)
    assert pwm.error_id == ErrorCode.NO_ERROR


def test_a_period_shorter_than_the_sample_is_refused() -> None:
    with pytest.raises(ParameterError) as info:
        PulseWidth(period=0.05, ts=0.1)
    assert info.value.code == ErrorCode.BAD_TIME_CONSTANT
    pwm = PulseWidth(period=1.0, ts=0.1)
    with pytest.raises(ParameterError):
        pwm.configure(t_min_on=2.0)
    assert pwm.config.t_min_on == 0.0


@pytest.mark.parametrize("duty", [0.2, 0.5, 0.9])
def test_the_ripple_on_a_first_order_process_equals_the_closed_form(duty: float) -> None:
    k, t, period, ts = 2.0, 20.0, 2.0, 0.01
    pwm = PulseWidth(period=period, ts=ts)
    n = round(period / ts)
    u = np.array([pwm(100.0 * duty) for _ in range(300 * n)])
    # the process as its exact ZOH recursion run by scipy, independent of the blocks
    a = math.exp(-ts / t)
    y = signal.lfilter([0.0, k * (1.0 - a)], [1.0, -a], u)
    last = y[-n:]
    assert last.max() - last.min() == pytest.approx(pwm_ripple(k, t, period, duty), rel=2e-3)
    assert last.mean() == pytest.approx(k * duty, rel=1e-2)
    # small-period approximation K d (1 - d) P / T
    assert pwm_ripple(k, t, period, duty) == pytest.approx(
        k * duty * (1 - duty) * period / t, rel=0.06
    )


def test_the_averaged_pwm_loop_equals_the_continuous_loop_within_the_ripple() -> None:
    """A PI on a heater: on/off through PWM against the same PI driving the heater directly."""
    ts, period, k, t = 0.1, 2.0, 1.0, 50.0

    def loop(with_pwm: bool) -> np.ndarray:
        pid = PID(kp=4.0, ti=40.0, ts=ts, u_min=0.0, u_max=100.0)
        plant = PT1(k=k, t=t, ts=ts)
        pwm = PulseWidth(period=period, ts=ts)
        ys = []
        for _ in range(6000):
            u = pid(40.0, plant.y)
            plant.step(100.0 * pwm(u) if with_pwm else u)
            ys.append(plant.y)
        return np.array(ys)

    y_pwm, y_cont = loop(True), loop(False)
    ripple = pwm_ripple(100.0 * k, t, period, 0.4)
    assert np.max(np.abs(y_pwm[2000:] - y_cont[2000:])) < ripple
    assert abs(y_pwm[-1000:].mean() - 40.0) < 0.2 * ripple
