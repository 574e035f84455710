"""Helpers of the runtime tests.

Tests marked ``loopback`` run real protocol servers and clients on 127.0.0.1
in real time (a few hundred cycles of 20 ms); they run in the default suite.
"""

from __future__ import annotations

import asyncio
import math
import sqlite3
import threading
import time
from pathlib import Path
from typing import Any

import pytest

from ctrlblocks.runtime import (
    FakeClock,
    MemoryAdapter,
    MemoryBus,
    Runtime,
    SQLiteHistorian,
    parse_config,
)

DATA = Path(__file__).parent / "data"


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers", "loopback: real-time end-to-end test with servers on 127.0.0.1 (a few s)"
    )


def toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, float) and math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return repr(v)


def block_table(block_type: str, params: dict[str, Any]) -> str:
    items = ", ".join(f"{k} = {toml_value(v)}" for k, v in params.items())
    return f'{{ type = "{block_type}"' + (f", {items}" if items else "") + " }"


def loop_toml(
    *,
    name: str = "loop",
    ts: float = 0.1,
    block: str = '{ type = "PID", kp = 1.0, ti = 1.0, u_min = -10.0, u_max = 10.0 }',
    conn: str = "io",
    sp: str = "1.0",
    extra: str = "",
    safe_value: float = 0.0,
    pv: str = "pv",
    mv: str = "mv",
) -> str:
    return f"""
[[loops]]
name = "{name}"
ts = {ts}
block = {block}
pv = "{conn}:{pv}"
mv = "{conn}:{mv}"
sp = {sp}
safe_value = {safe_value}
{extra}
"""


class FirstOrder:
    """A test plant on the bus: y[k+1] = a y[k] + (1 - a) u[k], stepped on each MV write."""

    def __init__(self, bus: MemoryBus, a: float = 0.9, pv: str = "pv", mv: str = "mv") -> None:
        self.bus, self.a, self.pv = bus, a, pv
        bus.values[pv] = 0.0
        bus.values[mv] = 0.0
        self.mv = mv

    def __call__(self, address: str, u: float) -> None:
        if address == self.mv:
            y = self.bus.values[self.pv]
            if math.isfinite(y):
                self.bus.values[self.pv] = self.a * y + (1.0 - self.a) * u


def make(
    loops: str,
    buses: dict[str, MemoryBus],
    tmp_path: Path | None = None,
    historian: Any = False,
    retain: Any = "config",
) -> tuple[Runtime, FakeClock, list[Any]]:
    """A runtime of ``loops`` on in-memory connections (name -> bus) on a fake clock.

    ``historian``: True for an SQLite historian in ``tmp_path``, or an open
    historian; ``retain``: as :class:`Runtime` takes it.  Returns the
    runtime, its clock and the list every sample is appended to.
    """
    conns = "".join(f'[connections.{n}]\nprotocol = "memory"\n' for n in buses)
    cfg = parse_config(conns + loops + '\n[historian]\nbackend = "none"\n')
    clock = FakeClock()
    hist = historian or None
    if historian is True:
        hist = SQLiteHistorian(tmp_path / "h.sqlite")
        hist.open()
    samples = []
    rt = Runtime(
        cfg,
        clock=clock,
        adapters={n: MemoryAdapter(b) for n, b in buses.items()},
        historian=hist,
        on_sample=samples.append,
        retain=retain,
    )
    return rt, clock, samples


async def run(rt: Runtime, clock: FakeClock, t_end: float) -> None:
    """Start ``rt`` and run its fake clock to ``t_end`` [s]."""
    await rt.start()
    await clock.run_until(t_end)


def bounded(coro: Any, timeout: float = 60.0) -> Any:
    """``asyncio.run`` with a per-test timeout (no test hangs the suite)."""
    return asyncio.run(asyncio.wait_for(coro, timeout))


async def wait_for(pred, timeout: float = 10.0, step: float = 0.01) -> None:
    """Wait (real time) until ``pred()`` is true; fail after ``timeout`` s."""
    loop = asyncio.get_running_loop()
    t_end = loop.time() + timeout
    while not pred():
        if loop.time() > t_end:
            raise AssertionError("condition not reached in time")
        await asyncio.sleep(step)


def wait_for_samples(
    db: Path, n: int, *, timeout: float = 60.0, keep: Any = None
) -> list[dict[str, Any]]:
    """Poll (real time) the historian ``db`` another process writes until it holds ``n`` samples.

    ``keep``: count only the samples it is true for.  Returns them (fewer
    after ``timeout`` s: the caller's assertion says so).
    """
    from ctrlblocks.runtime import SQLiteHistorian
    from ctrlblocks.runtime.historian import HistoryError

    t_end = time.monotonic() + timeout
    rows: list[dict[str, Any]] = []
    while time.monotonic() < t_end:
        time.sleep(0.1)
        try:
            with SQLiteHistorian(db).reading() as h:
                rows = [r for r in h.samples() if keep is None or keep(r)]
        except (sqlite3.OperationalError, HistoryError):
            continue  # no file or no tables yet
        if len(rows) >= n:
            break
    return rows


class ServerThread:
    """An event loop in a background thread that hosts servers (as another process would)."""

    def __init__(self) -> None:
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()

    def call(self, coro, timeout: float = 60.0):
        return asyncio.run_coroutine_threadsafe(coro, self.loop).result(timeout)

    def close(self) -> None:
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(10.0)
        self.loop.close()


@pytest.fixture(scope="session")
def opcua_plant():
    """One OPC UA plant server (127.0.0.1, any free port) for the tests that need a plain one.

    Starting an asyncua server costs about 3 s (its standard address space),
    so the tests share it: each sets ``server.process`` to a fresh
    :class:`PlantProcess` and resets the fault switches.  Stopped at the end.
    """
    from ctrlblocks.runtime import PlantServer
    from ctrlblocks.sim import PlantProcess, load_scenario

    th = ServerThread()
    server = PlantServer(
        PlantProcess(load_scenario(DATA / "pid_pt2.toml")), opcua_port=0, modbus_port=None
    )
    th.call(server.start())
    try:
        yield th, server
    finally:
        th.call(server.stop())
        th.close()


def fresh(th: ServerThread, server, process):
    """Give the shared server a new process and clear its fault switches.

    A server a failed test left killed serves again, so one failure does not cascade.
    """

    async def reset():
        await server.revive()
        server.process = process
        server.force_nan = server.reject_mv = server.stale = False
        server.delay = 0.0
        await server.set_mv_writable(True)

    th.call(reset())
    return server


class ClockedPlant:
    """A first-order plant on a bus that moves on the clock, whatever the runtime does.

    ``y[k+1] = a y[k] + (1 - a) k u[k]`` every ``ts`` of the (fake) clock, ``u``
    the MV the device holds (``bus.values[mv]``): the plant moves meanwhile --
    while the runtime is stopped, its connection down or its inputs late.
    ``hold`` pins the device's MV (a device watchdog's safe value).
    """

    def __init__(
        self,
        bus: MemoryBus,
        clock: Any,
        ts: float,
        *,
        a: float = 0.9,
        gain: float = 1.0,
        pv: str = "pv",
        mv: str = "mv",
        u0: float = 0.0,
    ) -> None:
        self.bus, self.clock, self.ts, self.a, self.gain = bus, clock, ts, a, gain
        self.pv, self.mv = pv, mv
        bus.values[mv] = u0
        bus.values[pv] = gain * u0  # at rest
        self.hold: float | None = None
        self.task: asyncio.Task[None] | None = None

    def step(self) -> None:
        if self.hold is not None:
            self.bus.values[self.mv] = self.hold
        u = self.bus.values[self.mv]
        y = self.bus.values[self.pv]
        self.bus.values[self.pv] = self.a * y + (1.0 - self.a) * self.gain * u

    async def _run(self) -> None:
        t = self.clock.now()
        while True:
            t += self.ts
            await self.clock.sleep_until(t)
            self.step()

    def start(self) -> None:
        """Run on the clock (call inside the event loop)."""
        self.task = asyncio.ensure_future(self._run())

    def device_writes(self) -> list[float]:
        """The MVs the device took, in order."""
        return [v for a, v in self.bus.writes if a == self.mv]
