"""The block contract, checked over every block (every block has the same shape).

Each entry of CASES makes a block, drives it one sample, and names a
configuration change that must be refused with a given error code.  A test
makes sure that every block exported by ``ctrlblocks`` has an entry.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import pytest

import ctrlblocks
from ctrlblocks import Block, ErrorCode, ParameterError
from ctrlblocks.blocks.transfer import lowpass, notch


@dataclasses.dataclass
class Case:
    make: Callable[[], Block]
    drive: Callable[[Block, int], Any]  # one sample at step k
    bad: dict[str, Any]  # a configuration change that must be refused
    code: ErrorCode  # ... with this code
    # makes the block from configuration fields (default: the class called with them)
    construct: Callable[[dict[str, Any]], Block] | None = None


def _wave(k: int) -> float:
    return math.sin(0.3 * k) + (1.0 if k % 17 < 8 else -0.5)


def _drive_regulator(b: Any, k: int) -> Any:
    b.auto = k % 37 < 25
    b.remote = k % 53 > 30
    return b(20.0 + 5.0 * _wave(k), 25.0 + _wave(k // 7), sp_inc=k % 11 < 3, out_dec=k % 13 < 2)


CASES: dict[str, Case] = {
    "ADRC": Case(
        lambda: ctrlblocks.ADRC(order=2, b0=0.05, omega_c=0.35, omega_o=1.75, ts=0.1, u_max=5.0),
        lambda b, k: b(_wave(k // 10), 0.5 * _wave(k + 3)),
        {"order": 4},
        ErrorCode.BAD_ORDER,
    ),
    "PT1": Case(
        lambda: ctrlblocks.PT1(t=2.0, ts=0.1, y0=0.5),
        lambda b, k: b(_wave(k)),
        {"t": -1.0},
        ErrorCode.BAD_TIME_CONSTANT,
    ),
    "RateLimiter": Case(
        lambda: ctrlblocks.RateLimiter(rate_up=2.0, rate_down=1.0, ts=0.1),
        lambda b, k: b(3 * _wave(k)),
        {"rate_up": -1.0},
        ErrorCode.BAD_RATE,
    ),
    "CycleMonitor": Case(
        lambda: ctrlblocks.CycleMonitor(ts=0.1, warn_limit=0.12, alarm_limit=0.2),
        lambda b, k: b(0.1 + 0.03 * _wave(k) + (0.15 if k % 19 == 3 else 0.0)),
        {"alarm_limit": 0.11},
        ErrorCode.BAD_LIMITS,
    ),
    "Alarm": Case(
        lambda: ctrlblocks.Alarm(limit=0.5, deadband=0.2, on_delay=0.2, off_delay=0.3, ts=0.1),
        lambda b, k: b(_wave(k), suppress=k % 31 < 3),
        {"on_delay": -1.0},
        ErrorCode.BAD_TIME_CONSTANT,
    ),
    "LoopAlarms": Case(
        lambda: ctrlblocks.LoopAlarms(hh=1.5, h=0.8, l=-0.3, ll=-1.0, dev=0.7, roc=5.0,
                                      roc_period=0.3, deadband=0.1, on_delay=0.2, ts=0.1),
        lambda b, k: b(0.5, _wave(k), manual=k % 37 < 5, pv_ok=k % 23 != 4),
        {"h": 2.0},
        ErrorCode.BAD_LIMITS,
    ),
    "DeadBand": Case(
        lambda: ctrlblocks.DeadBand(width=0.1),
        lambda b, k: b(_wave(k)),
        {"width": math.nan},
        ErrorCode.BAD_PARAMETER,
    ),
    "Scale": Case(
        lambda: ctrlblocks.Scale(in_lo=0.0, in_hi=10.0, out_lo=0.0, out_hi=100.0),
        lambda b, k: b(5 + 5 * _wave(k)),
        {"in_hi": 0.0},
        ErrorCode.BAD_LIMITS,
    ),
    "MovingAverage": Case(
        lambda: ctrlblocks.MovingAverage(n=5),
        lambda b, k: b(_wave(k)),
        {"n": 0},
        ErrorCode.BAD_WINDOW,
    ),
    "SteadyStateDetector": Case(
        lambda: ctrlblocks.SteadyStateDetector(tolerance=0.2, t_stab=0.5, ts=0.1),
        lambda b, k: b(round(_wave(k // 9), 1)),
        {"t_stab": 0.0},
        ErrorCode.BAD_STAB_TIME,
    ),
    "Saturation": Case(
        lambda: ctrlblocks.Saturation(lo=-0.5, hi=0.8),
        lambda b, k: b(_wave(k)),
        {"lo": 1.0},
        ErrorCode.BAD_LIMITS,
    ),
    "MinSelector": Case(
        lambda: ctrlblocks.MinSelector(),
        lambda b, k: b(_wave(k), _wave(k + 5), 0.2),
        {},
        ErrorCode.NO_ERROR,
    ),
    "JumpAndRate": Case(
        lambda: ctrlblocks.JumpAndRate(jlow=-0.5, jhigh=1.0, rlow=-0.5, rhigh=1.0, ts=0.1),
        lambda b, k: b(3 * _wave(k)),
        {"rlow": 0.5},
        ErrorCode.BAD_RATE,
    ),
    "LeadLag": Case(
        lambda: ctrlblocks.LeadLag(k=1.5, t_lead=2.0, t_lag=0.5, ts=0.1, out_min=-2.0, out_max=3.0),
        lambda b, k: b(_wave(k), enable=k % 23 != 5),
        {"out_min": 4.0},
        ErrorCode.BAD_LIMITS,
    ),
    "ManualStation": Case(
        lambda: ctrlblocks.ManualStation(tm=5.0, tr=0.3, ts=0.1, y0=50.0),
        lambda b, k: b(inc=k % 13 < 6, dec=k % 29 < 4, track=None if k % 40 < 30 else 20.0),
        {"tr": -1.0},
        ErrorCode.BACK_CALC_T,
    ),
    "PID": Case(
        lambda: ctrlblocks.PID(kp=2.0, ti=1.0, td=0.3, ts=0.1, u_min=-5.0, u_max=5.0),
        lambda b, k: b(1.0, 0.5 * _wave(k)),
        {"ti": -1.0},
        ErrorCode.BAD_PID_COEFFS,
    ),
    "StepController": Case(
        lambda: ctrlblocks.StepController(travel_time=5.0, min_pulse=0.2, min_pause=0.3, ts=0.1),
        lambda b, k: b(50.0 + 20.0 * _wave(k // 7), open_limit=k % 31 == 4),
        {"travel_time": -1.0},
        ErrorCode.BAD_TIME_CONSTANT,
    ),
    "PulseWidth": Case(
        lambda: ctrlblocks.PulseWidth(period=1.0, t_min_on=0.2, ts=0.1),
        lambda b, k: b(50.0 + 40.0 * _wave(k // 10)),
        {"period": 0.01},
        ErrorCode.BAD_TIME_CONSTANT,
    ),
    "GainSchedule": Case(
        lambda: ctrlblocks.GainSchedule(
            ctrlblocks.PID(kp=1.0, ti=5.0, ts=0.1, u_min=-5.0, u_max=5.0),
            breakpoints=(-1.0, 1.0),
            kp=(1.0, 2.0),
            ti=(5.0, 3.0),
        ),
        lambda b, k: b(1.0, 0.5 * _wave(k), w=_wave(k // 5)),
        {"breakpoints": (1.0, -1.0)},
        ErrorCode.BAD_PARAMETER,
        lambda params: ctrlblocks.GainSchedule(
            ctrlblocks.PID(kp=1.0, ti=5.0, ts=0.1), ctrlblocks.GainScheduleConfig(**params)
        ),
    ),
    "TwoPoint": Case(
        lambda: ctrlblocks.TwoPoint(hysteresis=0.4, t_min_on=0.2, t_min_off=0.3, ts=0.1),
        lambda b, k: b(0.2, _wave(k), pv_ok=k % 23 != 4, enable=k % 41 > 2),
        {"hysteresis": -1.0},
        ErrorCode.BAD_LIMITS,
    ),
    "ThreePoint": Case(
        lambda: ctrlblocks.ThreePoint(deadband=0.5, hysteresis=0.2, t_min_off=0.2, ts=0.1),
        lambda b, k: b(0.0, 1.5 * _wave(k), pv_ok=k % 23 != 4),
        {"hysteresis": 1.5},
        ErrorCode.BAD_LIMITS,
    ),
    "TransferFunction": Case(
        lambda: ctrlblocks.TransferFunction(
            sections=(*lowpass(2.0, 0.1, 3), notch(5.0, 2.0, 0.1, 0.1)), ts=0.1, out_max=1.2
        ),
        lambda b, k: b(_wave(k), init=k % 53 == 0),
        {"sections": ((1.0, 0.0, 0.0, 0.0, 1.0),)},
        ErrorCode.BAD_PARAMETER,
    ),
    "SetpointProgram": Case(
        lambda: ctrlblocks.SetpointProgram(
            segments=((2.0, 1.0, 0.5), (-1.0, 0.0, 0.3)), repeat=True, holdback_ramp=1.5, ts=0.1
        ),
        lambda b, k: b(_wave(k), run=k % 31 > 2, reset=k % 97 == 50),
        {"segments": ((1.0, -1.0, 0.0),)},
        ErrorCode.BAD_RATE,
    ),
    "HeatCoolPID": Case(
        lambda: ctrlblocks.HeatCoolPID(kp=20.0, ti=1.0, cool_method="parameters", kp_cool=40.0,
                                       ti_cool=0.5, deadzone=2.0, pwm_period=0.5, ts=0.1),
        lambda b, k: b(0.5, _wave(k), pv_ok=k % 23 != 4),
        {"cool_factor": -1.0},
        ErrorCode.BAD_PARAMETER,
    ),
    "Regulator": Case(
        lambda: ctrlblocks.Regulator(kp=2.0, ti=1.0, sp0=20.0, u0=30.0, ts=0.1),
        _drive_regulator,
        {"tr": -1.0},
        ErrorCode.BACK_CALC_T,
    ),
    "MaxSelector": Case(
        lambda: ctrlblocks.MaxSelector(),
        lambda b, k: b(_wave(k), _wave(k + 5), 0.2),
        {},
        ErrorCode.NO_ERROR,
    ),
}


def _exported_blocks() -> list[str]:
    return sorted(
        name
        for name in ctrlblocks.__all__
        if isinstance(getattr(ctrlblocks, name), type)
        and issubclass(getattr(ctrlblocks, name), Block)
        and getattr(ctrlblocks, name) is not Block
    )


def _trace(block: Block, drive: Callable[[Block, int], Any], start: int, n: int) -> list[Any]:
    out = []
    for k in range(start, start + n):
        drive(block, k)
        out.append(block.snapshot())
    return out


def test_every_exported_block_has_a_contract_case() -> None:
    assert set(_exported_blocks()) <= set(CASES), set(_exported_blocks()) - set(CASES)


@pytest.mark.parametrize("name", sorted(CASES))
def test_reset_restores_the_initial_state(name: str) -> None:
    case = CASES[name]
    block = case.make()
    initial = block.snapshot()
    _trace(block, case.drive, 0, 40)
    assert block.snapshot() != initial, "the drive should change the state"
    block.reset()
    assert block.snapshot() == initial


@pytest.mark.parametrize("name", sorted(CASES))
def test_snapshot_restore_reproduces_the_trace(name: str) -> None:
    case = CASES[name]
    block = case.make()
    _trace(block, case.drive, 0, 25)
    snap = block.snapshot()
    first = _trace(block, case.drive, 25, 30)
    block.restore(snap)
    assert _trace(block, case.drive, 25, 30) == first


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_configuration_is_refused_and_the_old_one_stays(name: str) -> None:
    case = CASES[name]
    if not case.bad:
        pytest.skip("block has no parameters")
    block = case.make()
    _trace(block, case.drive, 0, 10)
    config, state = block.config, block.snapshot()
    with pytest.raises(ParameterError) as info:
        block.configure(**case.bad)
    assert info.value.code == case.code
    assert isinstance(info.value, ValueError)
    assert block.config is config
    assert block.snapshot() == state
    # and the block still runs
    case.drive(block, 10)


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_configuration_is_refused_at_construction(name: str) -> None:
    case = CASES[name]
    if not case.bad:
        pytest.skip("block has no parameters")
    construct = case.construct or (lambda params: type(case.make())(**params))
    params = {**dataclasses.asdict(case.make().config), **case.bad}
    with pytest.raises(ParameterError) as info:
        construct(params)
    assert info.value.code == case.code


@pytest.mark.parametrize("name", sorted(CASES))
def test_unknown_parameter_is_a_type_error(name: str) -> None:
    block = CASES[name].make()
    with pytest.raises(TypeError, match="no parameter"):
        block.configure(no_such_parameter=1.0)


@pytest.mark.parametrize("name", sorted(CASES))
def test_repr_names_the_block_and_its_configuration(name: str) -> None:
    block = CASES[name].make()
    text = repr(block)
    assert text.startswith(type(block).__name__ + "(")
    for field in dataclasses.fields(block.config):
        assert f"{field.name}=" in text
