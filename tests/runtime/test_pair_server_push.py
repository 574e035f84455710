"""PairServer(push=True): a subscription sees every PV the plant computes (the
read-vs-subscription benchmark relies on it; docs/performance.md)."""

from __future__ import annotations

import asyncio

import pytest

from ctrlblocks.runtime import PairServer

pytestmark = pytest.mark.loopback


async def _subscribe_and_step() -> tuple[list[float], list[float]]:
    from asyncua import Client, ua

    server = PairServer(2, opcua_port=0, push=True)
    await server.start()
    seen: list[float] = []

    class Handler:
        def datachange_notification(self, node, val, data) -> None:
            seen.append(float(val))

    try:
        async with Client(server.opcua_url, timeout=10.0) as client:
            sub = await client.create_subscription(20, Handler())
            await sub.subscribe_data_change([client.get_node("ns=2;s=pv0")])
            mv = client.get_node("ns=2;s=mv0")
            for u in (10.0, 10.0):
                await mv.write_value(ua.Variant(u, ua.VariantType.Double))
                for _ in range(500):  # bounded: 5 s at most per change
                    if seen and seen[-1] == server.pv[0]:
                        break
                    await asyncio.sleep(0.01)
            await sub.delete()
    finally:
        await server.stop()
    return seen, list(server.pv)


def test_pushed_pvs_reach_a_subscription_after_each_mv_write():
    seen, pv = asyncio.run(asyncio.wait_for(_subscribe_and_step(), 60))
    # y[k+1] = 0.9 y[k] + 0.1 u: 0 -> 1.0 -> 1.9 after two writes of 10
    assert pv[0] == pytest.approx(1.9, abs=1e-12)
    assert seen[0] == 0.0  # the initial value
    assert seen[-2:] == pytest.approx([1.0, 1.9], abs=1e-12)
