"""Split range and ratio loops in the runtime against the plant server (127.0.0.1, real time).

The plant server serves a split range's second actuator ``mv2`` (writable when
the process has one; the lock-step plant steps once both MVs of the cycle are
written) and a ratio loop's wild flow ``wild``.  The runtime's trace must equal
:func:`ctrlblocks.sim.simulate`: bit for bit over OPC UA Double variables,
within FLOAT32 rounding over Modbus.  The scenarios are the in-memory tests'
(test_split_ratio_runtime.py) on a 20 ms sample, so that a few hundred cycles
run in a few seconds.
"""

from __future__ import annotations

import asyncio
import math

import numpy as np
import pytest

from ctrlblocks.runtime import PlantServer, Runtime, SQLiteHistorian, parse_config
from ctrlblocks.runtime.plant_server import MODBUS_REGISTERS
from ctrlblocks.sim import PlantProcess, parse_scenario, simulate

from .conftest import fresh, wait_for
from .test_structures import HEAD, _pi, loop_tables

# both protocols end to end against the plant server: run with the long campaigns (-m slow);
# tests/runtime/test_split_ratio_runtime.py checks the same structures in memory by default
pytestmark = [pytest.mark.loopback, pytest.mark.slow]

TS = 0.02

SPLIT = (
    HEAD.format(name="split", structure="split_range", ts=TS, duration=6.0)
    + f"""
[plant]
type = "HeatCool"
k_heat = 0.6
k_cool = 0.4
t = {30 * TS}
dead_time = {2 * TS}

[initial]
u = 50.0

[[controllers]]
name = "split"
[controllers.main]
{_pi(4.0, 30 * TS, 0.0, 100.0)}
[controllers.split]
gap = 6.0

[[events]]
t = {5 * TS}
do = "setpoint"
value = 30.0

[[events]]
t = {120 * TS}
do = "setpoint"
value = 12.0
"""
)

RATIO = (
    HEAD.format(name="ratio", structure="ratio", ts=TS, duration=6.0)
    + f"""
[plant]
type = "FOPDT"
k = 0.5
t = {6 * TS}
dead_time = {TS}

[initial]
sp = 2.0
wild = 10.0
y = 20.0

[[controllers]]
name = "ratio"
[controllers.main]
{_pi(2.0, 6 * TS, 0.0, 100.0)}
[controllers.ratio]
r_min = 1.0
r_max = 3.0
rate = {0.1 / (2 * TS)}

[[events]]
t = {20 * TS}
do = "wild"
value = 14.0

[[events]]
t = {60 * TS}
do = "setpoint"
value = 2.5

[[events]]
t = {100 * TS}
do = "wild"
ok = false
value = 12.0

[[events]]
t = {120 * TS}
do = "wild"
ok = true
"""
)

GENEROUS = "timeout = 5.0\ndeadline = 5.0\n"


def _opcua(name: str) -> str:
    return f"ns=2;s={name}"


def _modbus(name: str) -> str:
    return f"hr:{MODBUS_REGISTERS[name]}"


def _config(sc, conn: str, addr, tmp_path) -> object:
    text = loop_tables(sc, conn="plant", pv=addr("pv"), sp=f'"plant:{addr("sp")}"')
    for name in ("mv", "mv2", "wild"):
        text = text.replace(f'"plant:{name}"', f'"plant:{addr(name)}"')
    text += f"warn_limit = {50 * TS}\nalarm_limit = {100 * TS}\n"
    hist = f'[historian]\npath = "{tmp_path / "history.sqlite"}"\nflush_interval = 0.2\n'
    return parse_config(conn + text + hist)


def _record_steps(process: PlantProcess) -> list[tuple[float, float]]:
    """The actuator values the plant received, one pair per sample."""
    received: list[tuple[float, float]] = []
    step = process.step

    def recording(u: float, u2: float | None = None) -> None:
        received.append((u, process.mv2 if u2 is None else u2))
        step(u, u2)

    process.step = recording  # type: ignore[method-assign]
    return received


async def _run(rt: Runtime, server: PlantServer, n: int) -> None:
    await rt.start()
    assert all(c.connected for c in rt.connections.values()), "not connected at the first cycle"
    await wait_for(lambda: server.process.k >= n, timeout=60.0)
    await rt.stop()


def _rows(tmp_path, n: int) -> list[dict]:
    with SQLiteHistorian(tmp_path / "history.sqlite").reading() as h:
        rows = h.samples("loop")
    assert len(rows) >= n
    assert not any(r["overrun"] for r in rows[:n])  # every cycle ran with dt = ts
    return rows[:n]


def _col(rows: list[dict], name: str) -> np.ndarray:
    return np.array([r[name] if r["pv_ok"] or name != "pv" else math.nan for r in rows])


@pytest.mark.parametrize("protocol", ["opcua", "modbus"])
def test_split_range_loop_drives_both_actuators_of_the_plant_server(tmp_path, protocol):
    sc = parse_scenario(SPLIT)
    n = 250
    process = PlantProcess(sc)
    assert process.second_actuator
    received = _record_steps(process)

    async def main():
        opcua = protocol == "opcua"
        server = PlantServer(process, opcua_port=0 if opcua else None,
                             modbus_port=None if opcua else 0)  # fmt: skip
        await server.start()
        if opcua:
            conn = f'[connections.plant]\nprotocol = "opcua"\nurl = "{server.opcua_url}"\n'
        else:
            conn = ('[connections.plant]\nprotocol = "modbus"\nhost = "127.0.0.1"\n'
                    f"port = {server.modbus_port}\n")  # fmt: skip
        rt = Runtime(_config(sc, conn + GENEROUS, _opcua if opcua else _modbus, tmp_path))
        try:
            await _run(rt, server, n)
        finally:
            await server.stop()

    asyncio.run(main())
    rows = _rows(tmp_path, n)
    ref = simulate(sc, "split").signals
    mv, pv = _col(rows, "mv"), _col(rows, "pv")
    a, b = (np.array(x[:n]) for x in zip(*received, strict=True))
    assert ref["u_a"][:n].max() > 10.0 and ref["u_b"][:n].max() > 10.0  # both worked
    if protocol == "opcua":  # Double on the wire: the simulator's numbers, bit for bit
        np.testing.assert_array_equal(mv, ref["u"][:n])
        np.testing.assert_array_equal(pv, ref["ym"][:n])
        np.testing.assert_array_equal(a, ref["u_a"][:n])
        np.testing.assert_array_equal(b, ref["u_b"][:n])
    else:  # FLOAT32 registers: 24-bit rounding of every value on the wire
        np.testing.assert_allclose(pv, ref["ym"][:n], rtol=0, atol=1e-4)
        np.testing.assert_allclose(mv, ref["u"][:n], rtol=0, atol=1e-2)
        np.testing.assert_allclose(a, ref["u_a"][:n], rtol=0, atol=1e-2)
        np.testing.assert_allclose(b, ref["u_b"][:n], rtol=0, atol=1e-2)


def test_ratio_loop_reads_the_wild_flow_of_the_plant_server(tmp_path, opcua_plant):
    sc = parse_scenario(RATIO)
    n = 200
    server = fresh(*opcua_plant, PlantProcess(sc))

    async def main():
        conn = f'[connections.plant]\nprotocol = "opcua"\nurl = "{server.opcua_url}"\n'
        rt = Runtime(_config(sc, conn + GENEROUS, _opcua, tmp_path))
        await _run(rt, server, n)

    asyncio.run(main())
    rows = _rows(tmp_path, n)
    ref = simulate(sc, "ratio").signals
    np.testing.assert_array_equal(_col(rows, "mv"), ref["u"][:n])
    np.testing.assert_array_equal(_col(rows, "pv"), ref["ym"][:n])
    np.testing.assert_array_equal(_col(rows, "sp"), ref["sp_in"][:n])  # the SP is the ratio
    t = ref["t"][:n]
    bad = (t >= 100 * TS - 1e-9) & (t < 120 * TS - 1e-9)
    assert np.all(np.diff(ref["sp"][:n][bad]) == 0.0)  # the flow setpoint held meanwhile
    assert np.all([r["pv_ok"] for r in rows])  # the flow PV stays good


def test_mv2_is_served_read_only_without_a_second_actuator():
    from ctrlblocks.runtime.modbus import float32_to_registers

    sc = parse_scenario(RATIO)
    server = PlantServer(PlantProcess(sc), opcua_port=None, modbus_port=0)

    async def main():
        from pymodbus.client import AsyncModbusTcpClient

        await server.start()
        client = AsyncModbusTcpClient("127.0.0.1", port=server.modbus_port)
        try:
            await client.connect()
            words = list(float32_to_registers(1.0))
            rr = await client.write_registers(MODBUS_REGISTERS["mv2"], words)
            assert rr.isError()  # ILLEGAL_ADDRESS: only the MV is writable here
            rr = await client.read_holding_registers(MODBUS_REGISTERS["wild"], count=2)
            return rr.registers
        finally:
            client.close()
            await server.stop()

    regs = asyncio.run(main())
    from ctrlblocks.runtime.modbus import registers_to_float32

    assert registers_to_float32(regs) == 10.0  # the wild flow of the scenario's start
    assert server.mv_writes == 0
