"""OPC UA inputs: one batched Read per cycle against a subscription ("measure before choosing").

Usage (from the repository root, with the ``runtime`` extra)::

    python benchmarks/opcua_read_vs_subscription.py                # 200 and 1,000 nodes
    python benchmarks/opcua_read_vs_subscription.py --nodes 200 --rounds 300 --json out.json

A :class:`~ctrlblocks.runtime.PairServer` (``n`` first-order plants) runs in a
separate process on 127.0.0.1.  In the same client process, for each node count:

* **read**: the runtime's own :class:`~ctrlblocks.runtime.opcua.OpcUaAdapter`
  makes the cycle's one batched Read of all ``n`` PV nodes, ``rounds`` times
  at the cycle time ``ts``; reported: the request time on the wire (p50, p99,
  max) and the client process's CPU time per cycle.
* **subscription**: one asyncua subscription with a monitored item per PV node
  at publishing interval ``ts``; the server's values change every cycle (the
  benchmark writes every MV, as the runtime does), so every notification carries
  all ``n`` values.  Reported: the age of the value a cycle would use (the time
  since its notification arrived, p50/p99: the input's extra dead time) and the
  client's CPU time per cycle (notifications decoded in the background).

The choice the runtime makes from these figures is in docs/performance.md
("OPC UA inputs: Read or subscription").  Loopback only; bounded in rounds.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import multiprocessing as mp
import time

import numpy as np

from ctrlblocks.runtime import PairServer
from ctrlblocks.runtime.config import ConnectionConfig
from ctrlblocks.runtime.opcua import OpcUaAdapter


def serve(n: int, queue, stop) -> None:
    async def main() -> None:
        server = PairServer(n, opcua_port=0, push=True)
        await server.start()
        queue.put(server.opcua_url)
        while not stop.is_set():
            await asyncio.sleep(0.05)
        await server.stop()

    asyncio.run(main())


def pct(xs: list[float], q: float) -> float:
    return float(np.percentile(np.asarray(xs), q)) if xs else float("nan")


async def measure(url: str, n: int, rounds: int, ts: float) -> dict[str, object]:
    from asyncua import Client

    pvs = [f"ns=2;s=pv{i}" for i in range(n)]
    mvs = [f"ns=2;s=mv{i}" for i in range(n)]
    adapter = OpcUaAdapter(ConnectionConfig(name="io", protocol="opcua", url=url, timeout=2.0))
    await adapter.connect()
    out: dict[str, object] = {"nodes": n, "rounds": rounds, "ts": ts}
    try:
        # -- one batched Read per cycle (what the runtime does today) --
        wire = []
        nxt = time.monotonic()
        for k in range(rounds):
            t0 = time.perf_counter()
            readings = await adapter.read(pvs)
            wire.append(time.perf_counter() - t0)
            await adapter.write([(a, float(k % 7)) for a in mvs])
            assert len(readings) == n and all(r.ok for r in readings)
            nxt += ts
            await asyncio.sleep(max(0.0, nxt - time.monotonic()))
        out["read_ms"] = {
            "p50": 1e3 * pct(wire, 50), "p99": 1e3 * pct(wire, 99), "max": 1e3 * max(wire),
        }  # fmt: skip

        # -- a subscription at publishing interval ts --
        client = Client(url, timeout=2.0)
        await client.connect()
        arrived: dict[str, float] = {}

        class Handler:
            def datachange_notification(self, node, val, data) -> None:
                arrived[node.nodeid.to_string()] = time.monotonic()

        sub = await client.create_subscription(1e3 * ts, Handler())
        await sub.subscribe_data_change([client.get_node(a) for a in pvs])
        ages = []
        nxt = time.monotonic()
        for k in range(rounds):
            now = time.monotonic()
            if len(arrived) == n:
                ages.extend(now - t for t in arrived.values())
            await adapter.write([(a, float(k % 7)) for a in mvs])
            nxt += ts
            await asyncio.sleep(max(0.0, nxt - time.monotonic()))
        await sub.delete()
        await client.disconnect()
        out["subscription_age_ms"] = {"p50": 1e3 * pct(ages, 50), "p99": 1e3 * pct(ages, 99)}
    finally:
        await adapter.close()
    return out


async def cpu_per_cycle(url: str, n: int, rounds: int, ts: float) -> dict[str, float]:
    """Whole-process CPU per cycle of each mode (background decoding included)."""
    from asyncua import Client

    pvs = [f"ns=2;s=pv{i}" for i in range(n)]
    adapter = OpcUaAdapter(ConnectionConfig(name="io", protocol="opcua", url=url, timeout=2.0))
    await adapter.connect()
    res = {}
    try:
        c0 = time.process_time()
        nxt = time.monotonic()
        for _ in range(rounds):
            await adapter.read(pvs)
            nxt += ts
            await asyncio.sleep(max(0.0, nxt - time.monotonic()))
        res["read"] = 1e3 * (time.process_time() - c0) / rounds
        client = Client(url, timeout=2.0)
        await client.connect()

        class Handler:
            def datachange_notification(self, node, val, data) -> None:
                pass

        sub = await client.create_subscription(1e3 * ts, Handler())
        await sub.subscribe_data_change([client.get_node(a) for a in pvs])
        await asyncio.sleep(3 * ts)
        mvs = [f"ns=2;s=mv{i}" for i in range(n)]
        c0 = time.process_time()
        nxt = time.monotonic()
        for k in range(rounds):
            await adapter.write([(a, float(k % 7)) for a in mvs])  # values change every cycle
            nxt += ts
            await asyncio.sleep(max(0.0, nxt - time.monotonic()))
        c_sub = time.process_time() - c0
        c0 = time.process_time()
        nxt = time.monotonic()
        await sub.delete()
        await client.disconnect()
        for k in range(rounds):  # the writes alone, to subtract
            await adapter.write([(a, float(k % 7)) for a in mvs])
            nxt += ts
            await asyncio.sleep(max(0.0, nxt - time.monotonic()))
        res["subscription"] = 1e3 * (c_sub - (time.process_time() - c0)) / rounds
    finally:
        await adapter.close()
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nodes", type=int, nargs="*", default=[200, 1000])
    ap.add_argument("--rounds", type=int, default=200, help="cycles per mode (bounded)")
    ap.add_argument("--ts", type=float, default=0.1, help="cycle time [s]")
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args()
    rounds = max(10, min(args.rounds, 5000))
    results = []
    for n in args.nodes:
        q, stop = mp.Queue(), mp.Event()
        proc = mp.Process(target=serve, args=(n, q, stop), daemon=True)
        proc.start()
        try:
            url = q.get(timeout=60)
            r = asyncio.run(measure(url, n, rounds, args.ts))
            r["cpu_ms_per_cycle"] = asyncio.run(cpu_per_cycle(url, n, rounds, args.ts))
        finally:
            stop.set()
            proc.join(10)
        results.append(r)
        rd, sa, cp = r["read_ms"], r["subscription_age_ms"], r["cpu_ms_per_cycle"]
        print(
            f"{n:5d} nodes: Read p50 {rd['p50']:.2f} ms p99 {rd['p99']:.2f} ms"
            f" max {rd['max']:.2f} ms"
            f" (CPU {cp['read']:.2f} ms/cycle); subscription: value age p50 {sa['p50']:.1f} ms"
            f" p99 {sa['p99']:.1f} ms (CPU {cp['subscription']:.2f} ms/cycle)",
            flush=True,
        )
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(results, f, indent=2)


if __name__ == "__main__":
    main()
