"""Alarms and the live assessment in the runtime: configured per loop, journaled, acknowledged."""

from __future__ import annotations

import asyncio

import pytest

from ctrlblocks.runtime import MemoryBus, RuntimeConfigError, parse_config
from ctrlblocks.runtime.health import alarm_events

from .conftest import FirstOrder, loop_toml, make, run

ALARMS = 'alarms = { h = 0.5, hh = 2.0, deadband = 0.05, on_delay = 0.2 }'


def _conf(extra: str) -> str:
    return '[connections.io]\nprotocol = "memory"\n' + loop_toml(extra=extra) + (
        '\n[historian]\nbackend = "none"\n'
    )


@pytest.mark.parametrize(
    ("extra", "where", "what"),
    [
        ("alarms = { h = 1.0, hh = 0.5 }", "loops[0].alarms.h", "above hh"),
        ("alarms = { hi = 1.0 }", "loops[0].alarms.hi", "unknown key"),
        ("alarms = { h = 1.0, on_delay = -1.0 }", "loops[0].alarms.on_delay", ">= 0"),
        ("assess = { window = 0.5 }", "loops[0].assess.window", "at least 10 samples"),
        ("assess = { every = -1 }", "loops[0].assess.every", "> 0"),
        ("assess = { nope = 1 }", "loops[0].assess.nope", "unknown key"),
    ],
)
def test_a_bad_alarm_or_assess_table_names_its_key(extra: str, where: str, what: str) -> None:
    with pytest.raises(RuntimeConfigError) as e:
        parse_config(_conf(extra))
    assert where in str(e.value) and what in str(e.value)


def test_alarms_of_a_running_loop_are_journaled_acknowledged_and_read_back(tmp_path) -> None:
    bus = MemoryBus()
    plant = FirstOrder(bus)
    bus.on_write = plant
    rt, clock, samples = make(loop_toml(sp="1.0", extra=ALARMS), {"io": bus}, tmp_path,
                              historian=True)

    async def main():
        await run(rt, clock, 3.0)
        st = rt.health.status("loop")
        assert {a["name"]: a["state"] for a in st["alarms"]}["H"] == "UNACK"
        assert st["unacknowledged"] >= 1 and st["worst"] == 2
        assert rt.health.acknowledge("loop", "H", user="anna") == ["H"]
        await rt.stop()

    asyncio.run(main())
    # the PV passed 0.5 on the way to SP 1.0: H became active after the 0.2 s on-delay
    first = next(s for s in samples if s.pv >= 0.5)
    ev = alarm_events(_reopen(tmp_path), "loop")
    assert ev[0]["alarm"] == "H" and (ev[0]["old"], ev[0]["new"]) == ("NORMAL", "UNACK")
    assert ev[0]["who"] == "alarm" and ev[0]["message"].startswith("value ")
    assert float(ev[0]["message"].split()[1]) >= 0.5
    assert ev[-1]["who"] == "anna" and (ev[-1]["old"], ev[-1]["new"]) == ("UNACK", "ACKED")
    assert first.t <= 3.0


def _reopen(tmp_path):
    from ctrlblocks.runtime import SQLiteHistorian

    h = SQLiteHistorian(tmp_path / "h.sqlite")
    h.open_reading()
    return h


def test_live_assessment_in_the_runtime_finds_a_loop_in_manual(tmp_path) -> None:
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    extra = 'mode = "manual"\nmanual_value = 0.0\nassess = { window = 20.0, every = 5.0 }'
    rt, clock, _ = make(loop_toml(sp="1.0", extra=extra), {"io": bus})

    async def main():
        await run(rt, clock, 12.0)
        st = rt.health.status("loop")
        await rt.stop()
        return st

    st = asyncio.run(main())
    assert [f["kind"] for f in st["findings"]][:1] == ["manual"]
    assert st["alarms"] == []
