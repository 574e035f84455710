"""End to end on 127.0.0.1: plant server <-> runtime with real OPC UA / Modbus, and faults.

These tests run in real time (20 ms cycles, a few hundred cycles; marked
``loopback``).  The plant server steps its plant once per MV write
(``sync="write"``), so the runtime's recorded trace must equal the same
scenario run in the simulator: exactly over OPC UA Double variables, within
FLOAT32 rounding over Modbus and OPC UA Float variables.
"""

from __future__ import annotations

import asyncio
import json
import math

import numpy as np
import pytest

from ctrlblocks.runtime import PlantServer, Runtime, SQLiteHistorian, parse_config
from ctrlblocks.sim import PlantProcess, load_scenario, simulate

from .conftest import DATA, block_table, fresh, wait_for

pytestmark = pytest.mark.loopback

SIGNAL_BINDINGS = ("sp", "mode", "manual_value", "u_min", "u_max")

GENEROUS = "timeout = 5.0\ndeadline = 5.0\n"
"""The trace tests' I/O timeout and input deadline: a loaded machine must not turn a slow
answer into a fault or a late input (the fault tests set their own short timeouts)."""


def runtime_config(sc, conn_toml: str, addr, *, tmp_path, extra: str = "", bind=SIGNAL_BINDINGS):
    """A runtime config running the scenario's first controller against the plant server."""
    ctrl = sc.controllers[0].blocks["main"]
    params = dict(ctrl.params)
    params.pop("u_sf", None)
    lines = [f'{s} = "plant:{addr(s)}"' for s in bind]
    text = f"""
{conn_toml}
[[loops]]
name = "loop"
ts = {sc.ts}
block = {block_table(ctrl.type, params)}
pv = "plant:{addr("pv")}"
mv = "plant:{addr("mv")}"
{chr(10).join(lines)}
safe_value = 0.0
warn_limit = {50 * sc.ts}
alarm_limit = {100 * sc.ts}
start = "block"  # the blocks' own initial state, as the simulator's
{extra}
[historian]
path = "{tmp_path / "history.sqlite"}"
flush_interval = 0.2
"""
    return parse_config(text)


def opcua_addr(name: str) -> str:
    return f"ns=2;s={name}"


def modbus_addr(name: str) -> str:
    from ctrlblocks.runtime.plant_server import MODBUS_REGISTERS

    return f"hr:{MODBUS_REGISTERS[name]}"


def history(tmp_path, loop="loop"):
    with SQLiteHistorian(tmp_path / "history.sqlite").reading() as h:
        return h.samples(loop)


async def run_cycles(rt: Runtime, server: PlantServer, n: int) -> None:
    await rt.start()
    # the lock-step plant steps on MV writes: cycles run unconnected would shift the trace
    assert all(c.connected for c in rt.connections.values()), "not connected at the first cycle"
    await wait_for(lambda: server.process.k >= n, timeout=30.0)
    await rt.stop()


def compare_with_simulator(sc, rows, n):
    # the simulator runs every sample with dt = ts: so must the runtime (a stall of
    # 50 ts would be an overrun and the block would integrate over the real period)
    assert not any(r["overrun"] for r in rows[:n])
    ref = simulate(sc, sc.controllers[0].name).signals
    mv = np.array([r["mv"] for r in rows[:n]])
    pv = np.array([r["pv"] if r["pv_ok"] else math.nan for r in rows[:n]])
    sp = np.array([r["sp"] for r in rows[:n]])
    ok = np.array([bool(r["pv_ok"]) for r in rows[:n]])
    return ref, mv, pv, sp, ok


def test_opcua_loop_equals_the_simulator_exactly(tmp_path, opcua_plant):
    sc = load_scenario(DATA / "pid_pt2.toml")
    n = 300
    server = fresh(*opcua_plant, PlantProcess(sc))

    async def main():
        conn = f'[connections.plant]\nprotocol = "opcua"\nurl = "{server.opcua_url}"\n' + GENEROUS
        rt = Runtime(runtime_config(sc, conn, opcua_addr, tmp_path=tmp_path))
        await run_cycles(rt, server, n)

    asyncio.run(main())
    rows = history(tmp_path)
    assert len(rows) >= n
    assert [r["cycle"] for r in rows] == list(range(len(rows)))
    ref, mv, pv, sp, _ = compare_with_simulator(sc, rows, n)
    # OPC UA Double carries the values bit for bit: the traces are identical
    np.testing.assert_array_equal(mv, ref["u"][:n])
    np.testing.assert_array_equal(pv, ref["ym"][:n])
    np.testing.assert_array_equal(sp, ref["sp"][:n])
    modes = [r["mode"] for r in rows[:n]]
    assert modes[175] == "manual" and mv[175] == 0.8  # mode event at t = 3.5 s
    assert modes[210] == "auto"
    assert max(mv[250:]) <= 1.1  # limits event at t = 5 s


def test_modbus_loop_equals_the_simulator_within_float32(tmp_path):
    sc = load_scenario(DATA / "adrc_pt2.toml")
    n = 300

    async def main():
        server = PlantServer(PlantProcess(sc), opcua_port=None, modbus_port=0, word_order="little")
        await server.start()
        conn = (
            '[connections.plant]\nprotocol = "modbus"\nhost = "127.0.0.1"\n'
            f'port = {server.modbus_port}\nword_order = "little"\n' + GENEROUS
        )
        # max_dt 20 ts: the sensor fault of 0.2 s (10 cycles) ends with the ADRC's own
        # recovery, as in the simulator (a longer outage restarts the blocks afresh)
        cfg = runtime_config(sc, conn, modbus_addr, tmp_path=tmp_path, bind=("sp",),
                             extra="max_dt = 0.4")  # fmt: skip
        rt = Runtime(cfg)
        try:
            await run_cycles(rt, server, n)
        finally:
            await server.stop()

    asyncio.run(main())
    rows = history(tmp_path)
    ref, mv, pv, sp, ok = compare_with_simulator(sc, rows, n)
    # the sensor fault (t = 4.0 .. 4.2 s) reaches the runtime as NaN over Modbus
    np.testing.assert_array_equal(~ok, (ref["t"][:n] >= 4.0 - 1e-9) & (ref["t"][:n] < 4.2 - 1e-9))
    assert np.all(mv[~ok] == 0.0)  # the loop's safe value
    # FLOAT32 on the wire: every value is rounded to 24 bits (relative 6e-8)
    np.testing.assert_allclose(pv[ok], ref["ym"][:n][ok], rtol=0, atol=2e-5)
    np.testing.assert_allclose(mv, ref["u"][:n], rtol=0, atol=2e-4)
    np.testing.assert_array_equal(sp, np.float32(ref["sp"][:n]).astype(float))


def test_opcua_float_variables_are_written_as_float32(tmp_path):
    """A Float (FLOAT32) MV node accepts the write (no BadTypeMismatch) and rounds it."""
    sc = load_scenario(DATA / "pid_pt2.toml")
    n = 60

    async def main():
        server = PlantServer(
            PlantProcess(sc), opcua_port=0, modbus_port=None, float_signals=("mv", "pv")
        )
        await server.start()
        conn = f'[connections.plant]\nprotocol = "opcua"\nurl = "{server.opcua_url}"\n' + GENEROUS
        rt = Runtime(runtime_config(sc, conn, opcua_addr, tmp_path=tmp_path))
        try:
            await run_cycles(rt, server, n)
        finally:
            await server.stop()
        return server

    server = asyncio.run(main())
    rows = history(tmp_path)
    assert all(r["write_ok"] for r in rows)
    assert server.mv_writes >= n
    ref, mv, pv, _, _ = compare_with_simulator(sc, rows, n)
    assert float(server.process.mv) == float(np.float32(server.process.mv))  # was a FLOAT32
    np.testing.assert_allclose(mv, ref["u"][:n], rtol=0, atol=1e-5)
    np.testing.assert_allclose(pv, ref["ym"][:n], rtol=0, atol=1e-5)
    assert not np.array_equal(pv, ref["ym"][:n])  # rounding did happen


ADRC_LOOP = {
    "type": "ADRC",
    "order": 1,
    "b0": 5.0,
    "omega_c": 4.0,
    "omega_o": 16.0,
    "u_min": -5.0,
    "u_max": 5.0,
}


def fault_config(conn: str, addr, tmp_path, ts=0.02, extra=""):
    return parse_config(f"""
{conn}
[[loops]]
name = "loop"
ts = {ts}
block = {block_table("ADRC", {k: v for k, v in ADRC_LOOP.items() if k != "type"})}
pv = "plant:{addr("pv")}"
mv = "plant:{addr("mv")}"
sp = 1.0
safe_value = -0.75
warn_limit = {2.5 * ts}
{extra}
[historian]
path = "{tmp_path / "history.sqlite"}"
flush_interval = 0.2
""")


def test_killed_server_gives_safe_value_then_reconnects_bumplessly_at_the_device(
    tmp_path, opcua_plant
):
    sc = load_scenario(DATA / "pid_pt2.toml")
    th, _ = opcua_plant
    process = PlantProcess(sc)
    server = fresh(*opcua_plant, process)

    async def main():
        conn = (
            f'[connections.plant]\nprotocol = "opcua"\nurl = "{server.opcua_url}"\n'
            "timeout = 0.2\nreconnect_min = 0.05\nreconnect_max = 0.2\n"
        )
        rt = Runtime(fault_config(conn, opcua_addr, tmp_path))
        await rt.start()
        await wait_for(lambda: process.k >= 40)
        await asyncio.to_thread(th.call, server.kill())  # the server dies
        k_dead = rt.loops["loop"].cycle_count
        await wait_for(lambda: rt.loops["loop"].cycle_count >= k_dead + 15)
        await asyncio.to_thread(th.call, server.revive())  # and comes back on the same port
        await wait_for(lambda: rt.loops["loop"].pv_ok, timeout=15.0)
        k_back = process.k
        await wait_for(lambda: process.k >= k_back + 30)
        reconnects = rt.connections["plant"].reconnects
        await rt.stop()
        return reconnects

    reconnects = asyncio.run(main())
    assert reconnects >= 1
    rows = history(tmp_path)
    ok = [bool(r["pv_ok"]) for r in rows]
    first_bad = ok.index(False)
    first_back = ok.index(True, first_bad)
    assert first_bad >= 40
    # the very cycle whose read failed already outputs the safe value
    assert rows[first_bad]["mv"] == -0.75
    assert all(r["mv"] == -0.75 for r in rows[first_bad:first_back])
    # the safe values never reached the dead server: the device still holds the last MV
    # written before, and the reconnected loop starts from it (read back), not from -0.75
    device_mv = rows[first_bad - 1]["mv"]
    assert process.mv == pytest.approx(device_mv, abs=1e-12) or process.k > first_bad
    assert rows[first_back]["mv"] == pytest.approx(device_mv, abs=1e-9)
    assert abs(rows[first_back + 1]["mv"] - device_mv) < 0.1  # then on without a kick
    assert all(ok[first_back:])


def test_nan_from_server_gives_safe_value_and_recovers(tmp_path, opcua_plant):
    sc = load_scenario(DATA / "pid_pt2.toml")
    process = PlantProcess(sc)
    server = fresh(*opcua_plant, process)

    async def main():
        conn = f'[connections.plant]\nprotocol = "opcua"\nurl = "{server.opcua_url}"\n'
        rt = Runtime(fault_config(conn, opcua_addr, tmp_path))
        await rt.start()
        await wait_for(lambda: process.k >= 30)
        server.force_nan = True
        await wait_for(lambda: process.k >= 40)
        server.force_nan = False
        await wait_for(lambda: process.k >= 60)
        await rt.stop()

    asyncio.run(main())
    rows = history(tmp_path)
    bad = [r for r in rows if not r["pv_ok"]]
    assert 5 <= len(bad) <= 20  # about 10 cycles of NaN (the test polls in real time)
    assert all(r["mv"] == -0.75 and r["error_id"] == 0x8102 for r in bad)
    i = next(i for i, r in enumerate(rows) if not r["pv_ok"])
    j = next(j for j in range(i, len(rows)) if rows[j]["pv_ok"])
    assert rows[j]["mv"] == pytest.approx(-0.75, abs=1e-9)
    assert all(r["pv_ok"] for r in rows[j:])


def test_slow_server_makes_late_inputs_held_cycles_and_stretched_periods(tmp_path):
    """Each Modbus request answered 40 ms late (ts = 20 ms, input deadline 10 ms).

    The cycles whose read is not back hold (dt 0 in the historian: the block did
    not run); the read is the input of the next cycle, whose step gets the time
    since the last step as dt (a stretched period, above the warning limit);
    no read fails, and late I/O and stretched periods are alarms in the audit.
    """
    sc = load_scenario(DATA / "pid_pt2.toml")

    async def main():
        process = PlantProcess(sc)
        server = PlantServer(process, opcua_port=None, modbus_port=0)
        await server.start()
        conn = (
            f'[connections.plant]\nprotocol = "modbus"\nport = {server.modbus_port}\n'
            "timeout = 1.0\n"
        )
        rt = Runtime(fault_config(conn, modbus_addr, tmp_path))
        try:
            await rt.start()
            await wait_for(lambda: process.k >= 20)
            server.delay = 0.04  # each request answered 40 ms late: two per cycle
            await wait_for(lambda: process.k >= 26)
            server.delay = 0.0
            await wait_for(lambda: process.k >= 50)
            return rt.state("loop")
        finally:  # stopped also when a wait times out
            await rt.stop()
            await server.stop()

    st = asyncio.run(main())
    rows = history(tmp_path)
    held = [r for r in rows if r["dt"] == 0.0]
    stretched = [r for r in rows if r["dt"] > 2.5 * 0.02]
    assert len(held) == st["late_cycles"] >= 3
    assert st["stretched"] == len(stretched) >= 3
    assert all(r["dt"] in (0.0, 0.02) or r["dt"] > 2.5 * 0.02 for r in rows)
    assert all(r["pv_ok"] for r in rows)  # slow, but no read failed
    assert rows[-1]["cycle"] == len(rows) - 1
    with SQLiteHistorian(tmp_path / "history.sqlite").reading() as h:
        rows = [r for r in h.audit_rows("loop") if r["action"] == "alarm"]
    raised = {json.loads(r["new"])["code"] for r in rows}
    assert {"late_io", "stretched"} <= raised


@pytest.mark.parametrize("protocol", ["modbus", "opcua"])
def test_rejected_write_is_reported_and_the_loop_keeps_running(tmp_path, protocol, opcua_plant):
    sc = load_scenario(DATA / "pid_pt2.toml")
    th, _ = opcua_plant
    process = PlantProcess(sc)

    async def main():
        if protocol == "modbus":
            server = PlantServer(process, opcua_port=None, modbus_port=0)
            await server.start()
            conn = f'[connections.plant]\nprotocol = "modbus"\nport = {server.modbus_port}\n'
            addr = modbus_addr
        else:
            server = fresh(th, opcua_plant[1], process)
            conn = f'[connections.plant]\nprotocol = "opcua"\nurl = "{server.opcua_url}"\n'
            addr = opcua_addr
        rt = Runtime(fault_config(conn, addr, tmp_path))
        try:
            await rt.start()
            lp = rt.loops["loop"]
            await wait_for(lambda: lp.cycle_count >= 10)
            if protocol == "modbus":
                server.reject_mv = True
            else:
                await asyncio.to_thread(th.call, server.set_mv_writable(False))
            await wait_for(lambda: lp.write_failures >= 5)
            st = rt.state("loop")
            if protocol == "modbus":
                server.reject_mv = False
            else:
                await asyncio.to_thread(th.call, server.set_mv_writable(True))
            n = lp.cycle_count
            await wait_for(lambda: lp.cycle_count >= n + 5 and lp.write_ok)
            return st
        finally:  # stopped also when a wait times out
            await rt.stop()
            if protocol == "modbus":
                await server.stop()

    st = asyncio.run(main())
    assert st["write_ok"] is False
    expected = "exception 3" if protocol == "modbus" else "Bad"
    assert expected in st["write_error"]
    assert st["pv_ok"] is True  # reads go on
    rows = history(tmp_path)
    failed = [r for r in rows if not r["write_ok"]]
    assert len(failed) >= 5
    assert rows[-1]["write_ok"]


def test_stale_opcua_value_is_a_bad_measurement(tmp_path, opcua_plant):
    """A PV whose source timestamp is older than ``stale_after`` gives the safe value."""
    sc = load_scenario(DATA / "pid_pt2.toml")
    process = PlantProcess(sc)
    server = fresh(*opcua_plant, process)

    async def main():
        conn = (
            f'[connections.plant]\nprotocol = "opcua"\nurl = "{server.opcua_url}"\n'
            "stale_after = 5.0\n"
        )
        rt = Runtime(fault_config(conn, opcua_addr, tmp_path))
        await rt.start()
        await wait_for(lambda: process.k >= 10)
        server.stale = True  # timestamps an hour old
        await wait_for(lambda: process.k >= 20)
        st = rt.state("loop")
        server.stale = False
        await wait_for(lambda: process.k >= 30 and rt.loops["loop"].pv_ok)
        await rt.stop()
        return st

    st = asyncio.run(main())
    assert (st["pv_ok"], st["pv_reason"], st["mv"]) == (False, "stale", -0.75)
    rows = history(tmp_path)
    assert rows[0]["pv_ok"] and rows[-1]["pv_ok"]
