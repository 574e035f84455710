"""One I/O image per connection per cycle, the MV check before the write, the final stop write.

Virtual time (FakeClock) and in-memory I/O; the adapters count the requests
they send on the wire (``adapter.requests``).
"""

from __future__ import annotations

import asyncio
import logging
import math

import pytest

from ctrlblocks.runtime import (
    Connection,
    ConnectionConfig,
    MemoryAdapter,
    MemoryBus,
    SQLiteHistorian,
    parse_config,
)

from .conftest import FirstOrder, bounded, loop_toml, make, run


def many_loops(
    n: int, conn: str = "io", ts: float = 0.1, prefix: str = "l", extra: str = ""
) -> str:
    return "".join(
        loop_toml(name=f"{prefix}{i}", conn=conn, ts=ts, pv=f"pv{i}", mv=f"mv{i}", extra=extra)
        for i in range(n)
    )


def bus_for(n: int, prefix_pv: str = "pv") -> MemoryBus:
    bus = MemoryBus({f"{prefix_pv}{i}": 0.0 for i in range(n)})
    return bus


def test_one_read_and_one_write_request_per_cycle_per_connection_with_200_loops():
    a, b = bus_for(200), bus_for(3)
    rt, clock, samples = make(
        many_loops(200, "a") + many_loops(3, "b", prefix="m"), {"a": a, "b": b}
    )

    async def main():
        await run(rt, clock, 0.95)  # cycles at 0.0, 0.1, ..., 0.9
        await rt.stop()

    bounded(main())
    cycles = 10
    assert len(samples) == cycles * 203
    assert all(s.pv_ok and s.write_ok for s in samples)
    ra, rb = rt.connections["a"].adapter.requests, rt.connections["b"].adapter.requests
    assert ra["read"] == cycles and rb["read"] == cycles
    assert ra["write"] == cycles + 1 and rb["write"] == cycles + 1  # + the final stop write


def test_an_address_two_loops_read_is_read_once_per_cycle():
    bus = MemoryBus({"pv0": 0.0, "sp": 2.0})
    text = loop_toml(name="x", pv="pv0", mv="mv0", sp='"io:sp"') + loop_toml(
        name="y", pv="pv0", mv="mv1", sp='"io:sp"'
    )
    rt, clock, samples = make(text, {"io": bus})
    seen = []
    read = MemoryAdapter.read

    async def spy(self, addresses):
        seen.append(list(addresses))
        return await read(self, addresses)

    rt.connections["io"].adapter.read = spy.__get__(rt.connections["io"].adapter)

    async def main():
        await run(rt, clock, 0.05)
        await rt.stop()

    bounded(main())
    # the first read also reads the MVs back (the bumpless cold start), in the same request
    assert seen == [["pv0", "sp", "mv0", "mv1"]]
    assert [s.sp for s in samples] == [2.0, 2.0]


def test_loops_with_different_sample_times_share_a_connection_on_their_own_deadlines():
    bus = bus_for(4)
    text = many_loops(2, ts=0.1) + "".join(
        loop_toml(name=f"s{i}", ts=0.25, pv=f"pv{i + 2}", mv=f"mv{i + 2}") for i in range(2)
    )
    rt, clock, samples = make(text, {"io": bus})

    async def main():
        await run(rt, clock, 1.0)
        await rt.stop()

    bounded(main())
    fast = [round(s.t, 9) for s in samples if s.loop == "l0"]
    slow = [round(s.t, 9) for s in samples if s.loop == "s0"]
    assert fast == pytest.approx([0.1 * k for k in range(11)])
    assert slow == pytest.approx([0.0, 0.25, 0.5, 0.75, 1.0])
    assert not any(s.overrun for s in samples)
    assert rt.connections["io"].adapter.requests["read"] == len(fast) + len(slow)


def test_the_io_timeout_measures_the_request_on_the_wire_not_the_wait_behind_others():
    """Four requests of 0.3 s queue on one connection with a 1 s timeout: all succeed.

    Before, the wait for the lock counted against the timeout: the fourth
    request (1.2 s after the first) timed out."""
    bus = MemoryBus({"pv": 1.0})

    async def slow():
        await asyncio.sleep(0.3)

    bus.on_read = slow
    conn = Connection(ConnectionConfig("io", "memory", timeout=1.0), MemoryAdapter(bus))

    async def main():
        await conn.start()
        return await asyncio.gather(*(conn.read(["pv"]) for _ in range(4)))

    results = bounded(main())
    assert [r[0].ok for r in results] == [True] * 4
    assert [r[0].value for r in results] == [1.0] * 4


def test_a_nan_mv_from_a_block_never_reaches_the_device(tmp_path, caplog):
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    rt, clock, samples = make(
        loop_toml(ts=0.1, safe_value=0.25), {"io": bus}, tmp_path=tmp_path, historian=True
    )
    side = rt.loops["loop"].side
    step = side.step
    calls = []

    def defective(*args, **kw):  # a block defect: NaN in cycles 3 and 4
        calls.append(1)
        u = step(*args, **kw)
        return math.nan if len(calls) in (4, 5) else u

    side.step = defective

    async def main():
        await run(rt, clock, 0.35)
        st = rt.state("loop")
        await clock.run_until(0.75)
        st2 = rt.state("loop")
        await rt.stop()
        return st, st2

    with caplog.at_level(logging.ERROR, logger="ctrlblocks.runtime"):
        st, st2 = bounded(main())
    assert all(math.isfinite(v) for _, v in bus.writes)
    assert [s.mv for s in samples[3:5]] == [0.25, 0.25]  # the safe value went out instead
    assert all(s.write_ok for s in samples)
    assert "non-finite MV" in st["mv_alarm"] and st2["mv_alarm"] == ""
    msgs = [r.getMessage() for r in caplog.records if "non-finite MV" in r.getMessage()]
    assert len(msgs) == 1  # one log line per episode, not one per cycle
    with SQLiteHistorian(tmp_path / "h.sqlite").reading() as h:
        alarms = [r for r in h.audit_rows("loop") if r["action"] == "alarm"]
    assert len(alarms) == 1 and "non-finite MV" in alarms[0]["message"]


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_a_connection_never_sends_a_non_finite_value(value):
    bus = MemoryBus()
    conn = Connection(ConnectionConfig("io", "memory"), MemoryAdapter(bus))

    async def main():
        await conn.start()
        return await conn.write([("mv", value), ("hb", 3.0)])

    res = bounded(main())
    assert res[0] is not None and "not finite" in res[0] and res[1] is None
    assert bus.writes == [("hb", 3.0)]


def test_stop_writes_all_200_stop_values_in_one_batched_write():
    bus = bus_for(200)
    rt, clock, _samples = make(many_loops(200, extra="stop_value = 0.5"), {"io": bus})

    async def main():
        await run(rt, clock, 0.25)
        before = rt.connections["io"].adapter.requests["write"]
        await rt.stop()
        return rt.connections["io"].adapter.requests["write"] - before

    stop_writes = bounded(main())
    assert stop_writes == 1
    assert [v for a, v in bus.writes[-200:]] == [0.5] * 200
    assert sorted(a for a, _ in bus.writes[-200:]) == sorted(f"mv{i}" for i in range(200))
    assert rt.stop_failures == {}


def test_stop_retries_a_struggling_connection_once_with_its_own_timeout():
    """The first stop write hangs past ``stop_timeout``; the retry writes every stop value."""
    bus = bus_for(5)
    rt, clock, _samples = make(
        '[connections.io]\nprotocol = "memory"\ntimeout = 0.05\nstop_timeout = 0.3\n'
        + many_loops(5),
        {},
    )
    adapter = MemoryAdapter(bus)
    rt.connections["io"].adapter = adapter
    write = MemoryAdapter.write
    calls = []

    async def hangs_once(self, items):
        calls.append(len(items))
        if len(calls) == 4:  # cycles 0..2 wrote; the first stop write hangs
            await asyncio.sleep(30.0)
        return await write(self, items)

    adapter.write = hangs_once.__get__(adapter)

    async def main():
        await run(rt, clock, 0.25)
        await rt.stop()

    bounded(main())
    assert calls == [5, 5, 5, 5, 5]
    assert [v for _, v in bus.writes[-5:]] == [0.0] * 5
    assert rt.stop_failures == {}


def test_stop_names_the_stop_values_it_could_not_write(tmp_path, caplog):
    bus = bus_for(3)
    rt, clock, _samples = make(many_loops(3), {"io": bus}, tmp_path=tmp_path, historian=True)

    async def main():
        await run(rt, clock, 0.15)
        bus.reject.add("mv1")
        await rt.stop()

    with caplog.at_level(logging.ERROR, logger="ctrlblocks.runtime"):
        bounded(main())
    assert rt.stop_failures == {"l1": "write rejected"}
    lines = [r.getMessage() for r in caplog.records if "NOT written" in r.getMessage()]
    assert lines == ["runtime ctrlblocks: 1 stop value(s) NOT written: l1 (write rejected)"]
    with SQLiteHistorian(tmp_path / "h.sqlite").reading() as h:
        stops = {r["loop"]: r["ok"] for r in h.audit_rows() if r["action"] == "stop"}
    assert stops == {"l0": 1, "l1": 0, "l2": 1}


def test_stop_connects_a_dropped_connection_before_the_final_write():
    bus = bus_for(2)
    rt, clock, _samples = make(
        '[connections.io]\nprotocol = "memory"\nreconnect_min = 100.0\nreconnect_max = 100.0\n'
        + many_loops(2, extra="stop_value = 0.75"),
        {},
    )
    rt.connections["io"].adapter = MemoryAdapter(bus)

    async def main():
        await run(rt, clock, 0.15)
        bus.down = True
        await clock.run_until(0.35)  # the connection is lost; no reconnect for 100 s
        assert not rt.connections["io"].connected
        bus.down = False
        await rt.stop()

    bounded(main())
    assert sorted(bus.writes[-2:]) == [("mv0", 0.75), ("mv1", 0.75)]
    assert rt.stop_failures == {}


def test_gc_is_frozen_while_running_and_restored_after_stop():
    import gc

    before = gc.get_threshold()
    bus = bus_for(1)
    rt, clock, _samples = make(many_loops(1), {"io": bus})

    async def main():
        await run(rt, clock, 0.05)
        during = gc.get_threshold(), gc.get_freeze_count()
        await rt.stop()
        return during

    (thresholds, frozen) = bounded(main())
    assert thresholds[0] == 50_000 and frozen > 1000
    assert gc.get_threshold() == before and gc.get_freeze_count() == 0


def test_parse_config_refuses_a_heartbeat_on_an_input_register():
    from ctrlblocks.runtime import RuntimeConfigError

    text = '[connections.m]\nprotocol = "modbus"\nheartbeat = "ir:4"\n' + loop_toml(
        conn="m", pv="hr:0", mv="hr:2"
    )
    with pytest.raises(RuntimeConfigError, match=r"connections\.m\.heartbeat: must be a holding"):
        parse_config(text)


def test_a_slow_session_set_up_is_not_held_to_the_request_timeout():
    """The cause of the flaky OPC UA trace test: under load a session set-up took > 2 s.

    The connect was bounded by max(4 timeout, 2 s) = 2 s: it timed out, the
    first cycles ran unconnected (MV not written, the lock-step plant not
    stepped) and the recorded trace was shifted by those cycles.  Connecting
    now has its own ``connect_timeout`` (default 10 s); the runtime starts its
    cycles connected.
    """
    bus = bus_for(1)
    adapter = MemoryAdapter(bus)
    connect = adapter.connect

    async def slow_connect():
        await asyncio.sleep(2.5)  # real time: a loaded machine
        await connect()

    adapter.connect = slow_connect
    rt, clock, samples = make('[connections.io]\nprotocol = "memory"\n' + many_loops(1), {})
    rt.connections["io"].adapter = adapter

    async def main():
        await rt.start()
        connected = rt.connections["io"].connected
        await clock.run_until(0.05)
        await rt.stop()
        return connected

    assert bounded(main()) is True
    assert samples[0].pv_ok and samples[0].write_ok
