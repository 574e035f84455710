"""Every error code of the PID block (controltheplant 2024, 2.2, and our own), block running."""

from __future__ import annotations

import math

import pytest

from ctrlblocks import PID, ErrorCode, ParameterError

# (configuration change, expected code); each is refused and the old configuration stays
REFUSED = [
    ({"ts": 0.0}, ErrorCode.NO_CYCLE),  # controltheplant 2024 ERR_NO_CYCLE
    ({"u_min": 80.0, "u_max": 20.0}, ErrorCode.BAD_LIMITS),  # ERR_BAD_LIMITS
    ({"u_min": math.nan}, ErrorCode.BAD_LIMITS),
    ({"pv_range": (5.0, 5.0)}, ErrorCode.BAD_LIMITS),
    ({"pv_range": (10.0, 0.0)}, ErrorCode.BAD_LIMITS),
    ({"bumpless": "track_setpoint", "sp_rate": 0.0}, ErrorCode.CANT_TRACK_SETP),
    ({"sp_rate": -1.0}, ErrorCode.BAD_RATE),  # ERR_BAD_RATE
    ({"out_rate": -0.5}, ErrorCode.BAD_RATE),
    ({"tt": 0.0}, ErrorCode.BACK_CALC_T),  # ERR_BACK_CALC_T
    ({"tt": -1.0}, ErrorCode.BACK_CALC_T),
    ({"anti_windup": "none"}, ErrorCode.BAD_ANTIWINDUP),  # ERR_BAD_ANTIWINDUP
    ({"t_stab": 0.0}, ErrorCode.BAD_STAB_TIME),  # ERR_BAD_STAB_TIME
    ({"dev_tol": 60.0}, ErrorCode.BAD_DEV_TOL),  # ERR_BAD_DEV_TOL
    ({"bumpless": "suppress_p_action", "dev_tol": 0.0}, ErrorCode.BAD_DEV_TOL),
    ({"kp": 0.0}, ErrorCode.BAD_PID_COEFFS),  # ERR_BAD_PID_COEFFS
    ({"kp": -1.0}, ErrorCode.BAD_PID_COEFFS),
    ({"ti": -1.0}, ErrorCode.BAD_PID_COEFFS),
    ({"td": -0.1}, ErrorCode.BAD_PID_COEFFS),
    ({"n": 0.0}, ErrorCode.BAD_PID_COEFFS),
    ({"kp": math.inf}, ErrorCode.BAD_PID_COEFFS),
    ({"derivative_method": "forward", "td": 0.04, "n": 10.0}, ErrorCode.BAD_PID_COEFFS),
    ({"integral_method": "simpson"}, ErrorCode.BAD_PARAMETER),
    ({"form": "cascade"}, ErrorCode.BAD_PARAMETER),
    ({"sp_filter": -1.0}, ErrorCode.BAD_TIME_CONSTANT),
    ({"ff_k": 1.0, "ff_t_lag": 0.0}, ErrorCode.BAD_TIME_CONSTANT),
]


@pytest.mark.parametrize(("change", "code"), REFUSED, ids=[str(c) for c, _ in REFUSED])
def test_bad_configuration_is_refused_with_its_code_and_the_block_keeps_running(
    change: dict[str, object], code: ErrorCode
) -> None:
    pid = PID(kp=1.0, ti=2.0, td=0.5, ts=0.1, u_min=0.0, u_max=100.0, sp_rate=1.0)
    for k in range(10):
        pid(50.0, 40.0 + k)
    config, before = pid.config, pid.out
    with pytest.raises(ParameterError) as info:
        pid.configure(**change)
    assert info.value.code == code
    assert pid.config is config
    with pytest.raises(ParameterError) as info:
        PID(**{**{"kp": 1.0, "ti": 2.0, "td": 0.5, "sp_rate": 1.0}, **change})
    assert info.value.code == code
    u = pid(50.0, 49.0)
    assert pid.error_id == 0 and u != before


def test_forward_derivative_stability_limit_is_td_over_n_above_h_over_2() -> None:
    # Åström 1987, (2.10): a = 1 - h N/Td; |a| < 1 needs Td/N > h/2
    PID(td=0.051, n=1.0, ts=0.1, derivative_method="forward")
    with pytest.raises(ParameterError):
        PID(td=0.05, n=1.0, ts=0.1, derivative_method="forward")


RUNTIME = ["no_cycle", "bad_input", "bad_measurement", "bad_limits"]


@pytest.mark.parametrize("case", RUNTIME)
def test_run_time_errors_are_status_codes_that_clear_when_the_cause_goes(case: str) -> None:
    pid = PID(kp=1.0, ti=2.0, ts=0.1)
    pid(50.0, 40.0)
    if case == "no_cycle":
        pid(50.0, 40.0, dt=-1.0)
        want = ErrorCode.NO_CYCLE
    elif case == "bad_input":
        pid(math.nan, 40.0)
        want = ErrorCode.BAD_INPUT
    elif case == "bad_measurement":
        pid(50.0, 40.0, pv_ok=False)
        want = ErrorCode.BAD_MEASUREMENT
    else:
        pid.set_limits(100.0, 0.0)
        pid(50.0, 40.0)
        want = ErrorCode.BAD_LIMITS
    assert pid.error_id == want and pid.error
    if case == "bad_limits":
        pid.set_limits(0.0, 90.0)
    pid(50.0, 40.0)
    assert pid.error_id == ErrorCode.NO_ERROR and not pid.error


@pytest.mark.parametrize("bad", [[1.0, 2.0], None, "50"])
def test_a_non_number_input_holds_the_output_in_the_fast_lane_too(bad: object) -> None:
    # plain auto operation runs pid_step (the fast lane); a bad input must take
    # the same documented fallback as in the two-phase path, never raise
    import numpy as np

    pid = PID(kp=1.0, ti=2.0, ts=0.1)
    pid(50.0, 40.0)
    u = pid(50.0, 40.0)
    sp = np.array(bad) if isinstance(bad, list) else bad
    assert pid(sp, 40.0) == u and pid.error_id == ErrorCode.BAD_INPUT  # type: ignore[arg-type]
    assert pid(50.0, 40.0) == pytest.approx(u, abs=1e-12)  # recovers without a bump
    assert pid.error_id == ErrorCode.NO_ERROR


def test_manual_mode_with_a_bad_pv_keeps_the_manual_output_and_flags_it() -> None:
    pid = PID(kp=1.0, ti=2.0, ts=0.1)
    pid.manual, pid.manual_value = True, 25.0
    assert pid(50.0, math.nan) == 25.0
    assert pid.error_id == ErrorCode.BAD_INPUT
    pid.manual_value = math.nan
    assert pid(50.0, 40.0) == 25.0 and pid.error_id == ErrorCode.BAD_INPUT


@pytest.mark.parametrize("manual", [False, True])
def test_a_pv_whose_scaling_overflows_holds_the_output_as_a_failed_cycle(manual: bool) -> None:
    """A finite PV that the PV range scales beyond the doubles (1e307 over a range of 1) is no
    measurement to control on: the cycle fails (``BAD_RESULT``), the output holds (MANUAL: the
    manual value stands) and the next good cycle continues from it without a bump -- as the
    exported FB does with a REAL that overflows (``pid.pid_compute``, one input stage).  The
    PV filter, a sub-block of its own before, held its last output with its own ``BAD_INPUT``
    and the PID integrated on that stale PV with no status."""
    pid = PID(kp=1.0, ti=1.0, ts=0.1, u_min=-100.0, u_max=100.0, pv_range=(0.0, 1.0))
    for _ in range(3):
        pid(0.5, 0.4)
    held = pid.out
    if manual:
        pid.manual, pid.manual_value = True, 7.0
        held = 7.0
    assert pid(0.5, 1e307) == held
    assert pid.error_id == ErrorCode.BAD_RESULT
    assert pid(0.5, 0.4) == held  # the recovery continues from the held output
    assert pid.error_id == ErrorCode.NO_ERROR


def test_a_failed_law_after_a_first_compute_output_holds_the_committed_output() -> None:
    """``compute_output`` again in the same cycle starts from the committed state: a law that
    overflows in the second call holds the committed output (or the safe value), not the
    output the first call computed and nobody applied (the fallback of ``pid_compute``)."""
    pid = PID(kp=10.0, ti=1.0, ts=0.1, u_min=-100.0, u_max=100.0)
    pid(1.0, 0.0)
    committed = pid.out
    assert pid.compute_output(5.0, 0.0) != committed
    assert pid.compute_output(1e308, -1e308) == committed
    assert pid.error_id == ErrorCode.BAD_RESULT
    alone = PID(kp=10.0, ti=1.0, ts=0.1, u_min=-100.0, u_max=100.0)
    alone(1.0, 0.0)
    assert alone.compute_output(1e308, -1e308) == committed  # the same result as called alone
