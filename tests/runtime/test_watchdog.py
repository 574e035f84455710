"""The device watchdog: the runtime's heartbeat, the plant server's own safe MV (loopback).

The pattern of a real PLC (docs/runtime.md, "Device watchdog"): the runtime
writes a counter every cycle; the device applies its own safe MV when the
counter stops for longer than its timeout, and takes the runtime's MVs again
when the counter moves -- the runtime then starts from the MV it reads back.
"""

from __future__ import annotations

import asyncio

import pytest

from ctrlblocks.runtime import PlantServer, Runtime, parse_config
from ctrlblocks.runtime.plant_server import MODBUS_REGISTERS
from ctrlblocks.sim import PlantProcess, load_scenario

from .conftest import DATA, wait_for

pytestmark = pytest.mark.loopback


def config(port: int) -> str:
    return f"""
[connections.plant]
protocol = "modbus"
port = {port}
timeout = 2.0
heartbeat = "hr:{MODBUS_REGISTERS["hb"]}"
[[loops]]
name = "loop"
ts = 0.05
block = {{ type = "PID", kp = 0.5, ti = 1.0, u_min = 0.0, u_max = 5.0 }}
pv = "plant:hr:{MODBUS_REGISTERS["pv"]}"
mv = "plant:hr:{MODBUS_REGISTERS["mv"]}"
sp = 1.0
safe_value = 0.0
warn_limit = 1.0
alarm_limit = 2.0
[historian]
backend = "none"
"""


def test_a_dead_runtime_trips_the_plant_servers_watchdog_and_a_new_one_starts_from_its_mv():
    sc = load_scenario(DATA / "pid_pt2.toml")

    async def main():
        process = PlantProcess(sc)
        server = PlantServer(process, opcua_port=None, modbus_port=0, sync="clock",
                             watchdog=1.0, watchdog_mv=0.2)  # fmt: skip
        await server.start()
        loop = asyncio.get_running_loop()
        try:
            rt = Runtime(parse_config(config(server.modbus_port)), retain=None)
            await rt.start()
            # armed from the start, the watchdog may trip before the first heartbeat (a
            # slow start on a loaded machine): the device then waits in its safe state
            await wait_for(lambda: server.hb > 0 and not server.tripped)
            trips0 = server.trips
            await wait_for(lambda: rt.loops["loop"].cycle_count >= 20)
            alive = (server.tripped, server.hb, server.trips - trips0)
            for t in rt._tasks:  # the runtime dies: no stop values, no more heartbeats
                t.cancel()
            died = loop.time()
            await wait_for(lambda: server.tripped, timeout=10.0)
            assert server.heartbeat_at <= died  # nothing came after the runtime died
            # from the last heartbeat, which may have come up to a cycle before the death
            tripped_after = server.tripped_at - server.heartbeat_at
            await asyncio.sleep(0.3)
            held = process.mv
            await asyncio.gather(*(c.close() for c in rt.connections.values()))
            rt2 = Runtime(parse_config(config(server.modbus_port)), retain=None)
            await rt2.start()
            await wait_for(lambda: not server.tripped and rt2.loops["loop"].cycle_count >= 10)
            st = rt2.state("loop")
            await rt2.stop()
            return alive, tripped_after, held, st
        finally:
            await server.stop()

    alive, tripped_after, held, st = asyncio.run(main())
    assert alive[0] is False and alive[1] >= 20 and alive[2] == 0
    # the timeout, plus the watchdog's poll (generous: a loaded machine is slow)
    assert 1.0 <= tripped_after < 1.0 + 2.0
    assert held == 0.2  # the plant's own safe MV, whatever the runtime wrote last
    assert st["last_start"] == "start: bumpless from the device's MV 0.2"


def test_without_a_heartbeat_the_watchdog_trips_after_its_timeout_and_refuses_mvs():
    sc = load_scenario(DATA / "pid_pt2.toml")

    async def main():
        process = PlantProcess(sc)
        server = PlantServer(process, opcua_port=None, modbus_port=None, sync="clock",
                             watchdog=0.1, watchdog_mv=-1.0)  # fmt: skip
        await server.start()
        try:
            await wait_for(lambda: server.tripped, timeout=5.0)
            server._mv_written(3.0)  # a write while tripped: the safe MV stays
            mv = process.mv
            server._heartbeat(1.0)
            released = not server.tripped
            server._mv_written(3.0)
            return mv, released, process.mv
        finally:
            await server.stop()

    mv, released, after = asyncio.run(main())
    assert mv == -1.0 and released and after == 3.0


@pytest.mark.parametrize("value", [0.0, -1.0, float("nan"), float("inf")])
def test_a_watchdog_timeout_that_is_not_a_positive_number_is_refused(value):
    sc = load_scenario(DATA / "pid_pt2.toml")
    with pytest.raises(ValueError, match="watchdog timeout"):
        PlantServer(PlantProcess(sc), opcua_port=None, modbus_port=None, watchdog=value)
