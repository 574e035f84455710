"""GainSchedule: parameters interpolated over a scheduling variable, bumpless retuning."""

from __future__ import annotations

import math

import pytest

from ctrlblocks import ADRC, PID, ErrorCode, GainSchedule, ParameterError
from ctrlblocks.blocks.schedule import interpolate


def test_interpolation_is_linear_between_breakpoints_and_holds_the_ends() -> None:
    bps, vals = (0.0, 10.0, 30.0), (1.0, 3.0, 2.0)
    assert interpolate(bps, vals, -5.0) == 1.0
    assert interpolate(bps, vals, 5.0) == 2.0
    assert interpolate(bps, vals, 10.0) == 3.0
    assert interpolate(bps, vals, 25.0) == pytest.approx(2.25)
    assert interpolate(bps, vals, 99.0) == 2.0


def test_the_controller_is_retuned_to_the_interpolated_parameters() -> None:
    gs = GainSchedule(
        PID(kp=1.0, ti=10.0, ts=0.1), breakpoints=(0.0, 100.0), kp=(1.0, 3.0), ti=(10.0, 20.0)
    )
    gs(50.0, 45.0, w=25.0)
    assert (gs.controller.config.kp, gs.controller.config.ti) == (1.5, 12.5)
    assert gs.parameters == {"kp": 1.5, "ti": 12.5}


def test_every_retune_is_bumpless() -> None:
    pid = PID(kp=1.0, ti=10.0, ts=0.1, u_min=0.0, u_max=100.0)
    gs = GainSchedule(pid, breakpoints=(0.0, 100.0), kp=(1.0, 4.0), ti=(5.0, 20.0))
    for _ in range(50):
        gs(50.0, 45.0, w=0.0)
    before = gs.out
    # a big jump of the scheduling variable: kp 1 -> 4 with an error of 5 would jump
    # the output by 15; the PID's bumpless retune moves the integrator instead, and the
    # new law acts in the same sample: one integral increment K h/Ti e = 4*0.1/20*5 = 0.1
    assert gs(50.0, 45.0, w=100.0) == pytest.approx(before + 0.1, abs=1e-9)
    assert gs.controller.config.kp == 4.0
    assert gs(50.0, 45.0, w=100.0) == pytest.approx(before + 0.2, abs=1e-9)


def test_adrc_parameters_can_be_scheduled() -> None:
    adrc = ADRC(order=1, b0=0.1, omega_c=0.5, omega_o=2.5, ts=0.1, u_min=0.0, u_max=10.0)
    gs = GainSchedule(adrc, breakpoints=(0.0, 1.0), b0=(0.1, 0.2))
    gs(1.0, 0.5, w=0.5)
    assert adrc.config.b0 == pytest.approx(0.15)


def test_a_table_the_controller_refuses_names_the_breakpoint() -> None:
    with pytest.raises(ParameterError) as info:
        GainSchedule(PID(kp=1.0, ti=10.0, ts=0.1), breakpoints=(0.0, 1.0), ti=(10.0, -1.0))
    assert info.value.code == ErrorCode.BAD_PID_COEFFS
    assert "breakpoint 1.0" in str(info.value)
    with pytest.raises(ParameterError):
        GainSchedule(PID(kp=1.0, ts=0.1), breakpoints=(1.0, 0.0), kp=(1.0, 2.0))
    with pytest.raises(ParameterError):
        GainSchedule(PID(kp=1.0, ts=0.1), breakpoints=(0.0, 1.0), kp=(1.0,))


def test_a_bad_scheduling_variable_keeps_the_parameters_in_force() -> None:
    gs = GainSchedule(PID(kp=1.0, ti=10.0, ts=0.1), breakpoints=(0.0, 1.0), kp=(1.0, 2.0))
    gs(1.0, 0.0, w=1.0)
    u = gs(1.0, 0.0, w=math.nan)
    assert math.isfinite(u) and gs.error_id == ErrorCode.BAD_INPUT
    assert gs.controller.config.kp == 2.0
    gs(1.0, 0.0, w=0.0)
    assert gs.error_id == ErrorCode.NO_ERROR and gs.controller.config.kp == 1.0


def test_two_phase_form_and_snapshot_include_the_controller() -> None:
    gs = GainSchedule(
        PID(kp=1.0, ti=10.0, ts=0.1, u_min=0.0, u_max=2.0), breakpoints=(0.0, 1.0), kp=(1.0, 2.0)
    )
    v = gs.compute_output(5.0, 0.0, w=0.5)
    gs.update_state(min(v, 1.0))
    snap = gs.snapshot()
    a = [gs(5.0, 0.0, w=0.7) for _ in range(5)]
    gs.restore(snap)
    assert [gs(5.0, 0.0, w=0.7) for _ in range(5)] == a


def test_an_adrc_scheduled_on_a_ramping_variable_keeps_controlling() -> None:
    adrc = ADRC(order=1, b0=1.0, omega_c=1.0, omega_o=5.0, ts=0.1, u_min=-10.0, u_max=10.0)
    gs = GainSchedule(adrc, breakpoints=[0.0, 100.0], omega_c=[0.5, 2.0])
    y, outs = 0.0, []
    for k in range(60):
        u = gs(1.0, y, w=float(k))  # w ramps: the tuning changes every sample
        outs.append(u)
        y += 0.1 * (u - y)  # 1/(s + 1), Euler at 0.1 s
    assert max(outs) - min(outs) > 0.1  # before the fix: 0.5 at every sample
    assert abs(y - 1.0) < 0.2
