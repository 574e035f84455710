"""Batched I/O against the loopback servers: one read request per cycle per connection.

Twenty PID loops on one OPC UA connection and twenty on one Modbus
connection, against :class:`~ctrlblocks.runtime.PairServer` (twenty
first-order plants stepped on each MV write) on 127.0.0.1.  The adapters
count the requests they send; the heartbeat reaches the server; the stop
values all reach it in the final batched write.
"""

from __future__ import annotations

import asyncio

import pytest

from ctrlblocks.runtime import PairServer, Runtime, parse_config

from .conftest import ServerThread, wait_for

pytestmark = pytest.mark.loopback

N = 20


def pair_config(conn: str, pv, mv, n: int = N, ts: float = 0.05) -> str:
    # a generous input deadline: a loaded machine must not make a read late (a late
    # read holds its cycle, which sends no new read: the counts below would differ)
    conn += "deadline = 5.0\n"
    loops = "".join(
        f"""
[[loops]]
name = "l{i}"
ts = {ts}
block = {{ type = "PID", kp = 1.0, ti = 1.0, u_min = -10.0, u_max = 10.0 }}
pv = "plant:{pv(i)}"
mv = "plant:{mv(i)}"
sp = 1.0
safe_value = 0.0
stop_value = -1.0
warn_limit = {40 * ts}
alarm_limit = {80 * ts}
"""
        for i in range(n)
    )
    return conn + loops + '\n[historian]\nbackend = "none"\n[retain]\nenabled = false\n'


async def run_and_count(rt: Runtime, server: PairServer, cycles: int) -> tuple[int, dict]:
    await rt.start()
    await wait_for(lambda: server.writes >= cycles * N, timeout=60.0)
    await rt.stop()
    counted = dict(rt.connections["plant"].adapter.requests)
    return rt.loops["l0"].cycle_count, counted


def test_opcua_reads_every_loop_in_one_read_service_call_per_cycle():
    th = ServerThread()
    server = PairServer(N, opcua_port=0)
    th.call(server.start())
    try:
        conn = (
            f'[connections.plant]\nprotocol = "opcua"\nurl = "{server.opcua_url}"\n'
            'heartbeat = "ns=2;s=hb"\n'
        )
        cfg = parse_config(pair_config(conn, lambda i: f"ns=2;s=pv{i}", lambda i: f"ns=2;s=mv{i}"))
        cycles, req = asyncio.run(asyncio.wait_for(run_and_count(Runtime(cfg), server, 40), 90))
    finally:
        th.call(server.stop())
        th.close()
    # one Read per cycle, plus the one read of the nodes' data types before the first write
    assert req["read"] == cycles + 1
    assert req["write"] == cycles + 1  # one Write per cycle (MVs and heartbeat), + the stop
    assert server.mv == [-1.0] * N  # every stop value reached the server, in one request
    hb = server.heartbeats
    assert len(hb) == cycles and hb[:3] == [1.0, 2.0, 3.0]
    assert hb == [float(k + 1) for k in range(len(hb))]


def test_modbus_reads_coalesced_register_ranges_once_per_cycle():
    th = ServerThread()
    server = PairServer(N, opcua_port=None, modbus_port=0)
    th.call(server.start())
    try:
        conn = (
            f'[connections.plant]\nprotocol = "modbus"\nhost = "127.0.0.1"\n'
            f'port = {server.modbus_port}\nunit = 0\nheartbeat = "hr:{4 * N}"\n'
        )
        cfg = parse_config(
            pair_config(conn, lambda i: f"hr:{2 * i}", lambda i: f"hr:{2 * N + 2 * i}")
        )
        cycles, req = asyncio.run(asyncio.wait_for(run_and_count(Runtime(cfg), server, 40), 90))
    finally:
        th.call(server.stop())
        th.close()
    assert req["read"] == cycles  # 20 PVs = 40 contiguous registers: one request
    # the 20 MVs and the heartbeat are contiguous (registers 40..81): one request per cycle
    assert req["write"] == cycles + 1
    assert server.mv == [-1.0] * N
    assert server.heartbeats[:3] == [1.0, 2.0, 3.0]
