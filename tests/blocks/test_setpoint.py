"""Setpoint programmer: ramps, soaks, exact timing across segment ends, holdback, repeat."""

from __future__ import annotations

import math

import pytest

from ctrlblocks import ErrorCode, ParameterError, SetpointProgram


def test_ramp_soak_and_step_take_their_hand_computed_times() -> None:
    # 20 -> 100 at 2/s: 40 s; soak 10 s; step to 20: the program ends at t = 51 s
    prog = SetpointProgram(segments=((100.0, 2.0, 10.0), (20.0, 0.0, 0.0)), start=20.0, ts=1.0)
    sps = [prog() for _ in range(55)]
    assert sps[0] == 22.0 and sps[38] == 98.0 and sps[39] == 100.0
    assert sps[49] == 100.0 and sps[50] == 20.0
    assert prog.done and prog.segment == 1


def test_time_is_carried_across_segment_ends() -> None:
    # ramp 0 -> 1 at 0.4/s ends 0.5 s into the third sample of 1 s; the soak of 0.25 s
    # then ends, and the next ramp (down at 0.5/s) runs for the remaining 0.25 s
    prog = SetpointProgram(segments=((1.0, 0.4, 0.25), (0.0, 0.5, 0.0)), ts=1.0)
    assert [prog() for _ in range(3)] == pytest.approx([0.4, 0.8, 1.0 - 0.5 * 0.25], abs=1e-15)


def test_holdback_holds_the_ramp_while_the_pv_lags_and_the_soak_timer_too() -> None:
    prog = SetpointProgram(segments=((10.0, 1.0, 2.0),), holdback_ramp=1.5, holdback_soak=0.5,
                           ts=1.0)  # fmt: skip
    assert prog(0.0) == 1.0 and prog(0.0) == 2.0  # |PV - SP| = 1, then 2 > 1.5 ...
    assert prog(0.0) == 2.0 and prog.held  # ... held
    assert prog(1.0) == 3.0 and not prog.held  # the PV caught up: the ramp goes on
    for _ in range(7):
        prog(prog.out)  # a PV on the setpoint: the ramp reaches 10
    assert prog.out == 10.0 and prog.phase == "soak"
    prog(9.0)  # 1.0 off the soak target: the soak timer stops
    assert prog.held and not prog.done
    prog(10.0), prog(10.0)
    assert prog.done


def test_run_false_holds_and_reset_starts_again_at_the_pv() -> None:
    prog = SetpointProgram(segments=((10.0, 1.0, 0.0),), start_at_pv=True, ts=1.0)
    assert prog(4.0) == 5.0  # started at the PV
    assert prog(4.0, run=False) == 5.0
    assert prog(7.5, reset=True) == 8.5


def test_repeat_starts_the_first_segment_again_from_the_last_target() -> None:
    prog = SetpointProgram(segments=((2.0, 1.0, 0.0), (0.0, 1.0, 0.0)), repeat=True, ts=1.0)
    assert [prog() for _ in range(6)] == [1.0, 2.0, 1.0, 0.0, 1.0, 2.0]
    assert not prog.done


def test_bad_pv_holds_only_with_a_holdback_band() -> None:
    plain = SetpointProgram(segments=((10.0, 1.0, 0.0),), ts=1.0)
    assert plain(math.nan) == 1.0 and plain.error_id == ErrorCode.NO_ERROR
    guarded = SetpointProgram(segments=((10.0, 1.0, 0.0),), holdback_ramp=5.0, ts=1.0)
    assert guarded(0.0) == 1.0
    assert guarded(math.nan) == 1.0 and guarded.error_id == ErrorCode.BAD_INPUT and guarded.held
    assert guarded(0.0, pv_ok=False) == 1.0 and guarded.error_id == ErrorCode.BAD_MEASUREMENT


def test_zero_length_segments_with_repeat_do_not_loop_forever() -> None:
    prog = SetpointProgram(segments=((1.0, 0.0, 0.0), (2.0, 0.0, 0.0)), repeat=True, ts=1.0)
    outs = [prog() for _ in range(4)]
    assert all(v in (1.0, 2.0) for v in outs)


BAD = [
    ({"segments": ((1.0, -1.0, 0.0),)}, ErrorCode.BAD_RATE),
    ({"segments": ((1.0, 1.0, -2.0),)}, ErrorCode.BAD_TIME_CONSTANT),
    ({"segments": ()}, ErrorCode.BAD_PARAMETER),
    ({"holdback_soak": -1.0}, ErrorCode.BAD_LIMITS),
]


@pytest.mark.parametrize("bad, code", BAD)
def test_bad_programs_are_refused_and_the_old_one_stays(bad: dict, code: ErrorCode) -> None:
    prog = SetpointProgram(segments=((1.0, 1.0, 1.0),))
    with pytest.raises(ParameterError) as e:
        prog.configure(**bad)
    assert e.value.code == code
    assert prog.config.segments == ((1.0, 1.0, 1.0),)


def test_float32_lane_reaches_the_same_targets() -> None:
    a = SetpointProgram(segments=((50.0, 0.7, 3.0), (20.0, 0.0, 1.0)), start=10.0, ts=0.1)
    b = SetpointProgram(segments=((50.0, 0.7, 3.0), (20.0, 0.0, 1.0)), start=10.0, ts=0.1,
                        precision="float32")  # fmt: skip
    ya = [a() for _ in range(700)]
    yb = [b() for _ in range(700)]
    assert max(abs(x - y) for x, y in zip(ya, yb, strict=True)) < 1e-3
    assert ya[-1] == yb[-1] == 20.0 and a.done and b.done
