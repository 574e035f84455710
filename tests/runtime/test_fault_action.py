"""``on_fault = "hold"``: the last good MV for ``hold_time``, then the safe value; heartbeat."""

from __future__ import annotations

import pytest

from ctrlblocks.runtime import MemoryBus, RuntimeConfigError, parse_config

from .conftest import FirstOrder, bounded, loop_toml, make, run
from .test_runtime_memory import ADRC_BLOCK

HOLD = 'on_fault = "hold"\nhold_time = 0.3'


def bad_pv_run(extra: str, bad_from: float, bad_to: float, block: str = ADRC_BLOCK):
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    rt, clock, samples = make(
        loop_toml(ts=0.1, block=block, safe_value=-1.5, extra=extra), {"io": bus}
    )

    async def main():
        await run(rt, clock, bad_from - 0.05)
        bus.bad.add("pv")
        await clock.run_until(bad_to - 0.05)
        bus.bad.clear()
        await clock.run_until(bad_to + 0.55)
        await rt.stop()

    bounded(main())
    return {s.cycle: s for s in samples}, bus


def test_adrc_holds_the_last_good_mv_for_hold_time_then_goes_to_the_safe_value():
    by, bus = bad_pv_run(HOLD, 1.0, 1.8)  # cycles 10..17 bad
    held = by[9].mv
    assert held != -1.5 and by[9].pv_ok
    assert [by[k].mv for k in (10, 11, 12)] == [held] * 3  # t - t_fault = 0, 0.1, 0.2 < 0.3
    assert [by[k].mv for k in range(13, 18)] == [-1.5] * 5  # then the safe value
    assert [v for a, v in bus.writes if a == "mv"][10:13] == [held] * 3
    # recovery continues from the applied safe value (the block's own bumpless rule)
    assert by[18].pv_ok and by[18].mv == pytest.approx(-1.5, abs=1e-12)


def test_a_pv_back_within_the_hold_time_continues_from_the_held_mv():
    by, _ = bad_pv_run(HOLD, 1.0, 1.2)  # cycles 10, 11 bad
    held = by[9].mv
    assert [by[10].mv, by[11].mv] == [held, held]
    assert by[12].pv_ok and by[12].mv == pytest.approx(held, abs=1e-9)  # no bump


def test_the_default_fault_action_is_the_safe_value_at_once():
    by, _ = bad_pv_run("", 1.0, 1.3)
    assert [by[k].mv for k in (10, 11, 12)] == [-1.5] * 3


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ('on_fault = "hold"', 'hold_time: missing: on_fault = "hold" needs how long'),
        ("hold_time = 1.0", 'hold_time: only with on_fault = "hold"'),
        ('on_fault = "hold"\nhold_time = -1.0', "hold_time: must be a finite number >= 0"),
        ('on_fault = "freeze"', "on_fault: must be one of safe_value, hold"),
    ],
)
def test_fault_action_settings_are_checked(extra, message):
    with pytest.raises(RuntimeConfigError, match=message):
        parse_config('[connections.io]\nprotocol = "memory"\n' + loop_toml(extra=extra))


def test_the_heartbeat_increments_every_cycle_and_wraps():
    bus = MemoryBus({"pv": 0.0})
    rt, clock, _samples = make(
        '[connections.io]\nprotocol = "memory"\nheartbeat = "hb"\nheartbeat_max = 3\n'
        + loop_toml(ts=0.1),
        {},
    )
    from ctrlblocks.runtime import MemoryAdapter

    rt.connections["io"].adapter = MemoryAdapter(bus)

    async def main():
        await run(rt, clock, 0.65)  # cycles 0..6
        await rt.stop()

    bounded(main())
    assert [v for a, v in bus.writes if a == "hb"] == [1.0, 2.0, 3.0, 0.0, 1.0, 2.0, 3.0]
    # written in the same request as the MV: one write per cycle (+ the stop)
    assert rt.connections["io"].adapter.requests["write"] == 7 + 1
