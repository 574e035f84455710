"""CycleMonitor (Bonde et al. 2021, "Valg av samplingstid"): statistics, jitter, warning, alarm."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ctrlblocks import CycleMonitor, ErrorCode, ParameterError

TRACE = [0.010, 0.0105, 0.0098, 0.0131, 0.0102, 0.0250, 0.0099, 0.0101]


def _fed(**params: object) -> CycleMonitor:
    mon = CycleMonitor(ts=0.010, warn_limit=0.012, alarm_limit=0.020, **params)
    for dt in TRACE:
        mon(dt)
    return mon


def test_statistics_equal_numpy() -> None:
    mon = _fed()
    assert mon.count == 8
    assert mon.min == 0.0098 and mon.max == 0.0250 and mon.out == 0.0101
    assert mon.mean == pytest.approx(np.mean(TRACE), abs=1e-15)
    assert mon.jitter_std == pytest.approx(np.std(TRACE), abs=1e-15)  # population std
    assert mon.jitter_max == pytest.approx(0.015, abs=1e-15)  # |0.025 - 0.010|


def test_statistics_by_hand() -> None:
    mon = CycleMonitor(ts=1.0, warn_limit=5.0, alarm_limit=9.0)
    for dt in (1.0, 2.0, 3.0, 6.0):
        mon(dt)
    # mean 3, deviations -2 -1 0 3: variance 14/4
    assert mon.mean == 3.0
    assert mon.jitter_std == pytest.approx(math.sqrt(3.5), abs=1e-15)
    assert mon.jitter_max == 5.0
    assert (mon.overruns, mon.alarms, mon.warning, mon.alarm) == (1, 0, True, False)


def test_warning_and_alarm_flags_are_live_without_latch() -> None:
    mon = CycleMonitor(ts=0.010, warn_limit=0.012, alarm_limit=0.020)
    flags = []
    for dt in TRACE:
        returned = mon(dt)
        assert returned == mon.warning
        flags.append((mon.warning, mon.alarm))
    assert flags == [
        (False, False),
        (False, False),
        (False, False),
        (True, False),  # 13.1 ms > 12 ms
        (False, False),
        (True, True),  # 25 ms > 20 ms
        (False, False),
        (False, False),
    ]
    assert (mon.overruns, mon.alarms) == (2, 1)


def test_limit_itself_is_not_exceeded() -> None:
    mon = CycleMonitor(ts=0.010, warn_limit=0.012, alarm_limit=0.020)
    assert mon(0.012) is False and not mon.alarm
    assert mon(0.020) is True and not mon.alarm


def test_latched_flags_stay_until_acknowledged() -> None:
    mon = _fed(latch=True)
    assert mon.warning and mon.alarm
    mon.acknowledge()
    assert not mon.warning and not mon.alarm
    assert mon.count == 8  # statistics are kept
    mon(0.0101)
    assert not mon.warning


def test_default_limits_are_one_and_a_half_and_two_cycles() -> None:
    mon = CycleMonitor(ts=0.1)
    assert (mon.warn_limit, mon.alarm_limit) == pytest.approx((0.15, 0.2))
    assert mon(0.16) and not mon.alarm
    mon(0.21)
    assert mon.alarm


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, 0.0, -0.01, None, "10ms"])
def test_unusable_measurement_gives_no_cycle_and_is_not_counted(bad: object) -> None:
    mon = _fed()
    before = mon.snapshot()
    mon(bad)  # type: ignore[arg-type]
    assert mon.error_id == ErrorCode.NO_CYCLE
    assert mon.invalid == 1
    after = mon.snapshot()
    for name in ("count", "mean", "min", "max", "jitter_max", "overruns", "warning", "out"):
        assert after[name] == before[name], name
    mon(0.010)
    assert mon.error_id == ErrorCode.NO_ERROR and mon.count == 9


def test_before_any_cycle_statistics_are_zero() -> None:
    mon = CycleMonitor()
    assert (mon.count, mon.min, mon.max, mon.mean, mon.jitter_std) == (0, 0.0, 0.0, 0.0, 0.0)
    mon(math.nan)
    assert mon.count == 0 and mon.jitter_std == 0.0


def test_reset_clears_statistics_and_flags() -> None:
    mon = _fed(latch=True)
    mon.reset()
    assert (mon.count, mon.overruns, mon.alarms, mon.warning, mon.alarm) == (0, 0, 0, False, False)


@pytest.mark.parametrize(
    ("params", "code"),
    [
        ({"ts": 0.0}, ErrorCode.NO_CYCLE),
        ({"warn_limit": 0.0}, ErrorCode.BAD_LIMITS),
        ({"warn_limit": -0.1, "alarm_limit": 0.2}, ErrorCode.BAD_LIMITS),
        ({"alarm_limit": math.inf}, ErrorCode.BAD_LIMITS),
        ({"warn_limit": 0.3, "alarm_limit": 0.2}, ErrorCode.BAD_LIMITS),
        ({"alarm_limit": 0.1}, ErrorCode.BAD_LIMITS),  # below the default warning 1.5 ts
        ({"latch": "yes"}, ErrorCode.BAD_PARAMETER),
    ],
)
def test_bad_configuration_is_refused(params: dict, code: ErrorCode) -> None:
    with pytest.raises(ParameterError) as info:
        CycleMonitor(**{"ts": 0.1, **params})
    assert info.value.code == code
