"""A runtime a plant can trust, measured on loopback (issue 36).

Usage (from the repository root, with the ``runtime`` and ``web`` extras)::

    python benchmarks/runtime_trust.py slow-device    # one slow device, the others' deadlines
    python benchmarks/runtime_trust.py bumpless       # max |dMV| at the device per transition
    python benchmarks/runtime_trust.py kill           # commands confirmed 0.1 s before kill -9
    python benchmarks/runtime_trust.py browsers       # 200 loops, 0 / 1 / 2 browsers watching
    python benchmarks/runtime_trust.py all --json out.json --plot-dir figures/

Every case runs real processes or real protocol servers on 127.0.0.1 in real
time; the machine is whatever it is (say so next to the figures, which are
medians or worst cases of one run).

* ``slow-device``: three devices, each a process of its own: the three-tank
  rig (noise 1 mbar) under the ADRC of Nowak et al. 2018, Table 2, over OPC
  UA; twenty first-order plants under PI loops over OPC UA
  (:class:`~ctrlblocks.runtime.PairServer`); a second three-tank under a PID
  over Modbus TCP, whose answers are delayed by 0, 300 and 600 ms (the
  connection's timeout 0.5 s) and then 0 again.  Per phase: the share of the
  healthy loops' deadlines kept (a sample at every ``t0 + k ts``), their
  overruns and late cycles, whether the ADRC oscillates (the runtime's swing
  check, MV reversals, PV range), and what the slow loop did.
* ``bumpless``: the rig's device holds 2.19 bar (PV 1.5 bar); the runtime
  (ADRC and PID, one at a time) starts cold, loses the device for 3 s while
  the plant moves (the device's watchdog takes it to 1.0 bar), and is killed
  during a set-point transient and started again 3 s later from its retain
  file; for each transition the largest step of the MV at the device over
  the next 20 writes, from the MV the device held -- with the blocks' own
  start (``start = "block"``) for comparison.
* ``kill``: ``ctrlblocks serve`` with its faceplate and a plant server as
  processes; a set point and a tuning are changed through the faceplate's
  API and the process is killed (SIGKILL) 0.1 s after the confirmation, 20
  times; after each restart the state is read back, and the samples the
  historian's writer reported lost by each kill (its audit rows) are listed.
* ``browsers``: 200 PID loops (in-memory I/O, ts 100 ms) with the
  faceplate on the runtime's event loop, as ``ctrlblocks serve`` runs them;
  60 s each with no browser, one and two headless Chromium pages watching
  (one with a loop's faceplate open, one scrolled through the table); the
  share of cycles on time (period <= 1.5 ts) and the period p99.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import gc
import json
import math
import multiprocessing as mp
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path
from typing import Any

import numpy as np

from ctrlblocks.runtime import (
    MemoryAdapter,
    MemoryBus,
    PairServer,
    PlantServer,
    Runtime,
    parse_config,
)
from ctrlblocks.runtime.plant_server import MODBUS_REGISTERS

TS = 0.1
ADRC = ('{ type = "ADRC", order = 2, b0 = 0.05, omega_c = 0.35, omega_o = 1.75, '
        "u_min = 0.0, u_max = 5.0 }")  # fmt: skip
PID = '{ type = "PID", kp = 2.0, ti = 8.0, u_min = 0.0, u_max = 5.0 }'
U_RIG = 2.19  # the supply pressure that holds p3 at 1.5 bar
LIFETIME = 1800.0  # s: a device or browser process ends by then whatever happens to its parent


def serving(stop: Any, parent: int, until: float) -> bool:
    """A child process's loop goes on: not told to stop, its parent alive, before ``until``."""
    return not stop.is_set() and os.getppid() == parent and time.monotonic() < until


async def lag_monitor(stalls: list[tuple[float, float, float, float]]) -> None:
    """The event loop's own lateness: a 20 ms sleep that wakes more than 50 ms late.

    Appends (time, how late, the CPU the process used meanwhile, the time the
    event loop's thread waited for a CPU: Linux schedstat).  A stall whose
    run-queue wait is as long as it is late is the machine's (the thread was
    ready to run and got no CPU), not the runtime's work.
    """
    loop = asyncio.get_running_loop()
    while True:
        t, cpu, rq = loop.time(), time.process_time(), run_queue_wait()
        await asyncio.sleep(0.02)
        late = loop.time() - t - 0.02
        if late > 0.05:
            stalls.append((loop.time(), late, time.process_time() - cpu, run_queue_wait() - rq))


def stall_summary(stalls: list[tuple[float, float, float, float]], t0: float, t1: float) -> dict:
    """The stalls between ``t0`` and ``t1``: how many, the worst, how much was run-queue wait."""
    ph = [x for x in stalls if t0 <= x[0] < t1]
    return {
        "event_loop_stalls": len(ph),
        "stalls_late_ms_total": round(1e3 * sum(x[1] for x in ph)),
        "stalls_run_queue_wait_ms_total": round(1e3 * sum(x[3] for x in ph)),
        "stalls_cpu_ms_total": round(1e3 * sum(x[2] for x in ph)),
        "event_loop_stalls_worst": [
            {"t": round(t - t0, 1), "late_ms": round(1e3 * late), "cpu_ms": round(1e3 * cpu),
             "run_queue_wait_ms": round(1e3 * rq)}
            for t, late, cpu, rq in sorted(ph, key=lambda x: -x[1])[:8]
        ],
    }  # fmt: skip


def run_queue_wait() -> float:
    """The time [s] this thread has waited for a CPU so far (Linux schedstat; else 0)."""
    try:
        with open("/proc/thread-self/schedstat") as f:
            return int(f.read().split()[1]) * 1e-9
    except (OSError, ValueError, IndexError):
        return 0.0


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


# ---------------------------------------------------------------------------
# the rig: the three-tank process of Nowak et al. 2018 (section 6), noise 1 mbar
# ---------------------------------------------------------------------------


class Rig:
    """The three-tank rig as a plant server's process (ts 0.1 s, p3 in bar)."""

    def __init__(self, u0: float = U_RIG, noise: float = 0.001, seed: int = 1) -> None:
        from ctrlblocks.plants import Noise, ThreeTank, process

        self.ts = TS
        n = Noise(noise, kind="gaussian", seed=seed) if noise else None
        self.plant = process(ThreeTank(ts=TS), u_min=0.0, u_max=5.0, noise=n)
        self.plant.reset(u0)
        self.mv = u0
        self.k = 0
        self.sensor_ok = self.sensor2_ok = True

    def step(self, u: float) -> None:
        self.mv = u
        self.plant.step(u)
        self.k += 1

    def values(self) -> dict[str, float]:
        nan = math.nan
        return {"pv": float(self.plant.y), "mv": self.mv, "sp": nan, "mode": nan,
                "manual_value": nan, "u_min": nan, "u_max": nan, "k": float(self.k)}  # fmt: skip


def serve_rig(protocol: str, port: int, delay: Any, stop: Any, ready: Any = None) -> None:
    """A rig process: serves until ``stop``; its Modbus answers follow ``delay`` (s)."""
    import logging

    logging.getLogger("pymodbus").setLevel(logging.WARNING)

    async def main():
        server = PlantServer(
            Rig(), opcua_port=port if protocol == "opcua" else None,
            modbus_port=port if protocol == "modbus" else None, sync="clock",
        )  # fmt: skip
        await server.start()
        if ready is not None:
            ready.put(protocol)
        parent, until = os.getppid(), time.monotonic() + LIFETIME
        while serving(stop, parent, until):
            server.delay = delay.value
            await asyncio.sleep(0.02)
        await server.stop()

    asyncio.run(main())


def serve_pairs(n: int, port: int, stop: Any, ready: Any = None) -> None:
    async def main():
        server = PairServer(n, opcua_port=port)
        await server.start()
        if ready is not None:
            ready.put("pairs")
        parent, until = os.getppid(), time.monotonic() + LIFETIME
        while serving(stop, parent, until):
            await asyncio.sleep(0.05)
        await server.stop()

    asyncio.run(main())


# ---------------------------------------------------------------------------
# slow-device
# ---------------------------------------------------------------------------


def slow_device(a: argparse.Namespace) -> dict[str, Any]:
    ctx = mp.get_context("spawn")
    stop, delay, no_delay = ctx.Event(), ctx.Value("d", 0.0), ctx.Value("d", 0.0)
    ready = ctx.Queue()
    ports = {"rig": free_port(), "pairs": free_port(), "slow": free_port()}
    procs = [
        ctx.Process(target=serve_rig, args=("opcua", ports["rig"], no_delay, stop, ready)),
        ctx.Process(target=serve_pairs, args=(a.pairs, ports["pairs"], stop, ready)),
        ctx.Process(target=serve_rig, args=("modbus", ports["slow"], delay, stop, ready)),
    ]
    for p in procs:
        p.start()
    started = {ready.get(timeout=120) for _ in procs}  # asyncua's servers take seconds
    print(f"devices up: {sorted(started)}", flush=True)
    reg = MODBUS_REGISTERS
    text = f"""
[connections.rig]
protocol = "opcua"
url = "opc.tcp://127.0.0.1:{ports["rig"]}/ctrlblocks/plant"
[connections.pairs]
protocol = "opcua"
url = "opc.tcp://127.0.0.1:{ports["pairs"]}/ctrlblocks/pairs"
[connections.slow]
protocol = "modbus"
port = {ports["slow"]}
[[loops]]
name = "adrc"
ts = {TS}
block = {ADRC}
pv = "rig:ns=2;s=pv"
mv = "rig:ns=2;s=mv"
sp = 1.5
safe_value = 0.0
[[loops]]
name = "slow_pid"
ts = {TS}
block = {PID}
pv = "slow:hr:{reg["pv"]}"
mv = "slow:hr:{reg["mv"]}"
sp = 1.5
safe_value = 0.0
""" + "".join(
        f'[[loops]]\nname = "p{i}"\nts = {TS}\nblock = {{ type = "PID", kp = 1.0, ti = 1.0, '
        f'u_min = -10.0, u_max = 10.0 }}\npv = "pairs:ns=2;s=pv{i}"\nmv = "pairs:ns=2;s=mv{i}"\n'
        f"sp = 1.0\nsafe_value = 0.0\n"
        for i in range(a.pairs)
    ) + '[historian]\nbackend = "none"\n[retain]\nenabled = false\n'
    phases = [("0 ms", 0.0, a.warm), ("300 ms", 0.3, a.phase), ("600 ms", 0.6, a.phase),
              ("recovery", 0.0, a.phase)]  # fmt: skip
    samples: list[Any] = []
    statuses: dict[str, set[str]] = {}
    loads: dict[str, float] = {}

    stalls: list[tuple[float, float, float, float]] = []  # (time, late, CPU, run-queue wait)

    collections: list[tuple[float, int, float]] = []  # (time, generation, seconds)
    gc_start: list[float] = []

    def on_gc(phase: str, info: dict[str, int]) -> None:
        if phase == "start":
            gc_start[:] = [time.perf_counter()]
        elif gc_start:
            took = time.perf_counter() - gc_start[0]
            if took > 0.005:
                collections.append((time.monotonic(), info["generation"], took))

    async def main():
        rt = Runtime(parse_config(text), on_sample=samples.append)
        await rt.start()
        gc.callbacks.append(on_gc)
        monitor = asyncio.ensure_future(lag_monitor(stalls))
        marks = []
        try:
            for name, d, secs in phases:
                delay.value = d
                t0 = rt.clock.now()
                end = t0 + secs
                seen: set[str] = set()
                while rt.clock.now() < end:
                    await asyncio.sleep(0.5)
                    seen |= set(rt.state("adrc").get("status", ()))  # (older runtimes: none)
                statuses[name] = seen
                loads[name] = round(os.getloadavg()[0], 1)
                marks.append((name, t0, rt.clock.now()))
            st = {n: rt.state(n) for n in ("adrc", "slow_pid")}
        finally:
            monitor.cancel()
            gc.callbacks.remove(on_gc)
            await rt.stop()
        return marks, st

    try:
        marks, st = asyncio.run(main())
    finally:
        stop.set()
        for p in procs:
            p.join(20)
    out: dict[str, Any] = {"pairs": a.pairs, "phases": []}
    healthy = {"adrc", *(f"p{i}" for i in range(a.pairs))}
    for name, t0, t1 in marks:
        ph = [s for s in samples if t0 <= s.t < t1]
        row: dict[str, Any] = {"phase": name, "seconds": round(t1 - t0, 1)}
        kept, due, over, late = 0, 0, 0, 0
        for lp in sorted(healthy):
            ts_ = [s.t for s in ph if s.loop == lp]
            if not ts_:
                continue
            n_due = round((ts_[-1] - ts_[0]) / TS) + 1
            due += n_due
            kept += len(ts_)
            over += sum(1 for s in ph if s.loop == lp and s.overrun)
            late += sum(1 for s in ph if s.loop == lp and s.dt == 0.0)
        row["healthy_deadlines_kept_pct"] = round(100.0 * kept / max(due, 1), 3)
        row["healthy_overrun_times_s"] = sorted({round(s.t - t0, 1) for s in ph
                                                 if s.loop in healthy and s.overrun})[:20]
        row["load_average"] = loads.get(name)
        # the runtime's event loop woke late (its process busy: CPU used, or not given a core)
        row.update(stall_summary(stalls, t0, t1))
        row["healthy_overruns"] = over
        row["healthy_held_cycles"] = late
        row["healthy_held_times_s"] = sorted({round(s.t - t0, 1) for s in ph
                                              if s.loop in healthy and s.dt == 0.0})[:20]
        row["collections_over_5ms"] = [  # the garbage collector's (time, generation, ms)
            (round(t - t0, 1), g, round(1e3 * d)) for t, g, d in collections if t0 <= t < t1
        ][:10]
        ad = [s for s in ph if s.loop == "adrc"]
        pv, mv = np.array([s.pv for s in ad]), np.array([s.mv for s in ad])
        row["adrc_pv_range_bar"] = [round(float(pv.min()), 4), round(float(pv.max()), 4)]
        row["adrc_mv_range_bar"] = [round(float(mv.min()), 4), round(float(mv.max()), 4)]
        row["adrc_oscillating"] = "oscillating" in statuses.get(name, set())
        sl = [s for s in ph if s.loop == "slow_pid"]
        m = max(len(sl), 1)
        row["slow_samples"] = len(sl)
        row["slow_held_pct"] = round(100.0 * sum(1 for s in sl if s.dt == 0.0) / m, 1)
        row["slow_stretched"] = sum(1 for s in sl if s.dt > 1.5 * TS)
        row["slow_bad_pv_pct"] = round(100.0 * sum(1 for s in sl if not s.pv_ok) / m, 1)
        spv = [s.pv for s in sl if s.pv_ok]
        row["slow_pv_range_bar"] = [round(min(spv), 4), round(max(spv), 4)] if spv else None
        out["phases"].append(row)
    out["final_status"] = {n: s.get("status") for n, s in st.items()}
    if a.plot_dir:
        plot_slow(samples, marks, Path(a.plot_dir) / "runtime-slow-device.png")
    return out


def plot_slow(samples: list[Any], marks: list[Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t0 = marks[0][1]
    fig, ax = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
    for lp, c in (("adrc", "tab:blue"), ("slow_pid", "tab:red")):
        s = [x for x in samples if x.loop == lp]
        t = np.array([x.t - t0 for x in s])
        ax[0].plot(t, [x.pv for x in s], color=c, lw=1, label=f"{lp} PV")
        ax[1].plot(t, [x.mv for x in s], color=c, lw=1, label=f"{lp} MV")
        st = [x for x in s if x.dt > 0.0]
        ax[2].plot([x.t - t0 for x in st[1:]], np.diff([x.t for x in st]), ".", ms=2, color=c,
                   label=f"{lp}: time between steps")  # fmt: skip
    ax[0].set_ylabel("p3 [bar]")
    ax[1].set_ylabel("supply pressure [bar]")
    ax[2].set_ylabel("period [s]")
    ax[2].set_xlabel("time [s]")
    for name, a_, b_ in marks:
        for x in ax:
            x.axvspan(a_ - t0, b_ - t0, alpha=0.08 if name in ("300 ms", "600 ms") else 0.0,
                      color="k")
        ax[0].text((a_ + b_) / 2 - t0, ax[0].get_ylim()[1], name, ha="center", va="top")
    for x in ax:
        x.legend(loc="upper right", fontsize=8)
        x.grid(alpha=0.3)
    fig.suptitle("One slow Modbus device (0 / 300 / 600 ms): the OPC UA ADRC loop is not affected")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


# ---------------------------------------------------------------------------
# bumpless
# ---------------------------------------------------------------------------


def bumpless(a: argparse.Namespace) -> dict[str, Any]:
    out: dict[str, Any] = {}
    traces: dict[str, Any] = {}
    for kind, block in (("ADRC", ADRC), ("PID", PID)):
        for start in ("read_back", "block"):
            res, tr = _transitions(kind, block, start)
            out[f"{kind} start={start}"] = res
            traces[f"{kind} start={start}"] = tr
    if a.plot_dir:
        plot_bumpless(traces, Path(a.plot_dir) / "runtime-bumpless.png")
    return out


def _transitions(kind: str, block: str, start: str) -> tuple[dict[str, float], dict[str, Any]]:
    """Cold start, reconnection, restart after a kill; the device's MV writes around each."""
    from tests.runtime.conftest import ServerThread  # the tests' server thread

    th = ServerThread()
    server = PlantServer(Rig(noise=0.0), opcua_port=0, modbus_port=None, sync="clock",
                         watchdog=3600.0, watchdog_mv=1.0)  # fmt: skip
    writes: list[tuple[float, float]] = []
    orig = server._mv_written

    def spy(u: float, name: str = "mv") -> None:
        orig(u, name)
        writes.append((time.monotonic(), server.process.mv))

    server._mv_written = spy  # type: ignore[method-assign]
    th.call(server.start())
    tmp = tempfile.mkdtemp(prefix="ctrlblocks-bumpless-")
    text = f"""
[connections.rig]
protocol = "opcua"
url = "{server.opcua_url}"
reconnect_min = 0.2
reconnect_max = 0.5
heartbeat = "ns=2;s=hb"
[[loops]]
name = "loop"
ts = {TS}
block = {block}
pv = "rig:ns=2;s=pv"
mv = "rig:ns=2;s=mv"
sp = 1.5
safe_value = 0.0
start = "{start}"
[historian]
backend = "none"
[retain]
path = "{tmp}/retain.sqlite"
interval = 5.0
"""
    res: dict[str, float] = {}
    tr: dict[str, Any] = {}

    def after(name: str, t: float, before: float, pv: float, sp: float) -> None:
        """The largest step over the next 20 writes; whether the first move went toward SP."""
        w = [u for tw, u in writes if tw >= t][:20]
        res[name] = float(np.max(np.abs(np.diff([before, *w])))) if w else math.nan
        moved = next((u - before for u in w if abs(u - before) > 1e-6), 0.0)
        res[f"{name}: PV - SP then"] = pv - sp
        res[f"{name}: first move"] = moved
        tr[name] = [before, *w]

    async def main():
        # cold start: the device holds 2.19 bar
        before, pv = server.process.mv, server.process.values()["pv"]
        t = time.monotonic()
        rt = Runtime(parse_config(text))
        await rt.start()
        await asyncio.sleep(8.0)
        after("cold start", t, before, pv, 1.5)
        # reconnection: the device goes away 3 s; its watchdog takes the MV to 1.0 bar
        server.watchdog = 0.5
        await asyncio.to_thread(th.call, server.kill())
        await asyncio.sleep(3.0)
        before, pv = server.process.mv, server.process.values()["pv"]
        t = time.monotonic()
        await asyncio.to_thread(th.call, server.revive())
        await asyncio.sleep(8.0)
        after("reconnection", t, before, pv, 1.5)
        # restart: a set-point transient, killed 1.9 s after the last retained snapshot;
        # the device holds the MV of the transient (its watchdog off for this part)
        server.watchdog = 3600.0
        await asyncio.sleep(max(0.0, 5.2 - (time.monotonic() - t) % 5.0))
        rt.command("loop", user="bench", sp=1.8)
        await asyncio.sleep(1.0)
        for task in rt._tasks:
            task.cancel()
        await asyncio.gather(*(c.close() for c in rt.connections.values()))
        await asyncio.sleep(3.0)  # the plant moves on the MV the device holds (its watchdog)
        before, pv = server.process.mv, server.process.values()["pv"]
        t = time.monotonic()
        rt2 = Runtime(parse_config(text))
        await rt2.start()
        await asyncio.sleep(8.0)
        after("restart after kill", t, before, pv, 1.8)
        await rt2.stop()

    try:
        asyncio.run(main())
    finally:
        th.call(server.stop())
        th.close()
    return {k: round(v, 4) for k, v in sorted(res.items())}, tr


def plot_bumpless(traces: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    keys = ["cold start", "reconnection", "restart after kill"]
    fig, ax = plt.subplots(1, len(keys), figsize=(12, 3.8), sharey=True)
    for j, k in enumerate(keys):
        for name, tr in traces.items():
            w = tr[k]
            ax[j].step(range(len(w)), w, where="post", label=name, lw=1.2,
                       ls="-" if "read_back" in name else "--")  # fmt: skip
        ax[j].set_title(k)
        ax[j].set_xlabel("MV writes after the transition (0: the device's MV)")
        ax[j].grid(alpha=0.3)
    ax[0].set_ylabel("MV at the device [bar]")
    ax[-1].legend(fontsize=7)
    fig.suptitle("MV at the device through each transition (three-tank rig, ts 0.1 s)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


# ---------------------------------------------------------------------------
# kill
# ---------------------------------------------------------------------------


def kill(a: argparse.Namespace) -> dict[str, Any]:
    from ctrlblocks.web import UserStore

    tmp = Path(tempfile.mkdtemp(prefix="ctrlblocks-kill-"))
    users = UserStore(tmp / "users.json")
    users.add("eng", "bench password", role="engineer", n=2**10)
    mb_port, web_port = free_port(), free_port()
    cfg = tmp / "loops.toml"
    cfg.write_text(f"""
[connections.rig]
protocol = "modbus"
port = {mb_port}
[[loops]]
name = "loop"
ts = {TS}
block = {PID}
pv = "rig:hr:{MODBUS_REGISTERS["pv"]}"
mv = "rig:hr:{MODBUS_REGISTERS["mv"]}"
sp = 1.5
safe_value = 0.0
sp_range = [0.0, 3.0]
[historian]
path = "{tmp}/history.sqlite"
[retain]
interval = 5.0
""")
    ctx = mp.get_context("spawn")
    stop, no_delay, ready = ctx.Event(), ctx.Value("d", 0.0), ctx.Queue()
    plant = ctx.Process(target=serve_rig, args=("modbus", mb_port, no_delay, stop, ready))
    plant.start()
    ready.get(timeout=120)
    base = f"http://127.0.0.1:{web_port}/"
    cmd = [sys.executable, "-c", "from ctrlblocks.cli import main; main()", "serve", str(cfg),
           "--port", str(web_port), "--users", str(tmp / "users.json")]  # fmt: skip
    log = open(tmp / "serve.log", "a")  # noqa: SIM115 - closed below
    results = []

    def start_serve() -> subprocess.Popen:
        p = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT)
        for _ in range(300):
            with contextlib.suppress(OSError):
                urllib.request.urlopen(base + "api/info", timeout=1).read()
                return p
            time.sleep(0.1)
        raise RuntimeError("serve did not start")

    def request(opener, path: str, body: dict | None = None) -> Any:
        data = None if body is None else json.dumps(body).encode()
        req = urllib.request.Request(base + path, data=data,
                                     headers={"Content-Type": "application/json"})  # fmt: skip
        with opener.open(req, timeout=10) as r:
            return json.loads(r.read())

    try:
        for k in range(a.kills):
            p = start_serve()
            import http.cookiejar

            opener = urllib.request.build_opener(
                urllib.request.HTTPCookieProcessor(http.cookiejar.CookieJar())
            )
            request(opener, "api/login", {"user": "eng", "password": "bench password"})
            time.sleep(0.5 + 0.37 * k % 4.5)  # anywhere in the 5 s retain interval
            sp, kp = round(1.2 + 0.01 * k, 2), round(1.5 + 0.05 * k, 2)
            request(opener, "api/loops/loop/command", {"sp": sp})
            request(opener, "api/loops/loop/command", {"tunings": {"kp": kp}})
            t_ok = time.monotonic()
            time.sleep(0.1)
            os.kill(p.pid, signal.SIGKILL)
            p.wait()
            gap = time.monotonic() - t_ok
            p = start_serve()
            request(opener, "api/login", {"user": "eng", "password": "bench password"})
            st = request(opener, "api/loops/loop")
            results.append({"sp": sp, "kp": kp, "after": [st["sp"], st["tunings"]["kp"]],
                            "killed_after_s": round(gap, 3)})  # fmt: skip
            p.send_signal(signal.SIGTERM)
            p.wait(30)
    finally:
        stop.set()
        plant.join(20)
        log.close()
    kept = sum(1 for r in results if r["after"] == [r["sp"], r["kp"]])
    # what the historian's writer said after each kill (the samples never handed over)
    import sqlite3

    with contextlib.closing(sqlite3.connect(tmp / "history.sqlite")) as db:
        lost = [json.loads(n)["lost"] for (n,) in db.execute(
            "SELECT new FROM audit WHERE who = 'historian' AND action = 'lost' ORDER BY t_wall")]
    return {"kills": len(results), "both_changes_present": kept,
            "killed_after_confirmation_s": [r["killed_after_s"] for r in results],
            "historian_lost_rows_reported": lost}  # fmt: skip


# ---------------------------------------------------------------------------
# browsers
# ---------------------------------------------------------------------------


def browsers(a: argparse.Namespace) -> dict[str, Any]:
    from ctrlblocks.web import UserStore
    from ctrlblocks.web.server import bind_socket, make_server

    n = a.loops
    text = '[runtime]\nname = "bench"\n[connections.io]\nprotocol = "memory"\n' + "".join(
        f'[[loops]]\nname = "l{i:03d}"\nts = {TS}\nblock = {{ type = "PID", kp = 1.0, ti = 1.0, '
        f'u_min = -10.0, u_max = 10.0 }}\npv = "io:pv{i}"\nmv = "io:mv{i}"\nsp = 1.0\n'
        f"safe_value = 0.0\n"
        for i in range(n)
    ) + '[historian]\nbackend = "none"\n[retain]\nenabled = false\n[web]\npublic_view = true\n'
    bus = MemoryBus({f"pv{i}": 0.0 for i in range(n)})

    def step(address: str, u: float) -> None:
        i = address[2:]
        bus.values[f"pv{i}"] = 0.9 * bus.values[f"pv{i}"] + 0.1 * u

    bus.on_write = step
    periods: list[tuple[float, str, float]] = []  # (wall time, loop, period)
    last: dict[str, float] = {}

    def on_sample(s) -> None:
        if s.loop in last:
            periods.append((time.monotonic(), s.loop, s.t - last[s.loop]))
        last[s.loop] = s.t

    rt = Runtime(parse_config(text), adapters={"io": MemoryAdapter(bus)}, on_sample=on_sample)
    # the event loop's time in making the pushes (the views, the diffs, the JSON)
    from ctrlblocks.web.routes import push

    push_cost: list[float] = []
    update = push._Client.update

    def timed_update(self, hub):
        t = time.perf_counter()
        msg = update(self, hub)
        json.dumps(msg)  # what the route does with it next (its own dumps, the same cost)
        push_cost.append(time.perf_counter() - t)
        return msg

    push._Client.update = timed_update  # type: ignore[method-assign]
    sock = bind_socket("127.0.0.1", 0)
    port = sock.getsockname()[1]
    server = make_server(rt, port=port, users=UserStore(None))
    stalls: list[tuple[float, float, float, float]] = []

    async def serve() -> None:  # the runtime, its faceplate and the stall monitor: one loop
        monitor = asyncio.ensure_future(lag_monitor(stalls))
        try:
            await server.serve(sockets=[sock])
        finally:
            monitor.cancel()

    th = threading.Thread(target=lambda: asyncio.run(serve()), daemon=True)
    th.start()
    url = f"http://127.0.0.1:{port}/"
    for _ in range(100):
        with contextlib.suppress(OSError):
            urllib.request.urlopen(url + "api/info", timeout=1).read()
            break
        time.sleep(0.1)
    out: dict[str, Any] = {"loops": n}
    # the browsers in a process of their own (in a plant they run on other computers):
    # no share of this process's GIL, the normal scheduling policy under chrt
    ctx = mp.get_context("spawn")
    commands, replies = ctx.Queue(), ctx.Queue()
    driver = ctx.Process(target=drive_browsers, args=(url, commands, replies))
    driver.start()
    try:
        replies.get(timeout=120)  # Chromium is up (its start is no part of a case)
        for watching in range(3):
            if watching:
                commands.put("open")
                replies.get(timeout=120)
            time.sleep(3.0)
            push_cost.clear()
            made0 = server.config.app.state.hub.made
            t0 = time.monotonic()
            commands.put(("watch", a.duration))
            pushes = replies.get(timeout=a.duration + 120)
            end = time.monotonic()
            ps = np.array([p for t, _, p in periods if t0 <= t < end])
            out[f"{watching} browser(s)"] = {
                "cycles": len(ps),
                "on_time_pct": round(100.0 * float(np.mean(ps <= 1.5 * TS)), 3),
                "p99_ms": round(1e3 * float(np.percentile(ps, 99)), 1),
                "max_ms": round(1e3 * float(ps.max()), 1),
                "pushes_received": int(pushes),
                "views_made": int(server.config.app.state.hub.made - made0),
                "push_ms_median": round(1e3 * float(np.median(push_cost)), 3)
                if push_cost else 0.0,
                "push_ms_p99": round(1e3 * float(np.percentile(push_cost, 99)), 3)
                if push_cost else 0.0,
                "load_average": round(os.getloadavg()[0], 1),
                **stall_summary(stalls, t0, end),
            }
        commands.put("stop")
        driver.join(60)
    finally:
        if driver.is_alive():
            driver.kill()
        server.should_exit = True
        th.join(20)
    return out


def drive_browsers(url: str, commands: Any, replies: Any) -> None:
    """The browsers' side: headless Chromium pages on the faceplate, as told.

    ``"open"``: one more page (the first with a loop's faceplate open, the
    second at the table's top); ``("watch", seconds)``: let them watch, the
    second scrolling through the table, and answer the pushes they received;
    ``"stop"``.  Runs at the normal scheduling policy whatever the parent's.
    """
    if os.sched_getscheduler(0) != os.SCHED_OTHER:
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    from playwright.sync_api import sync_playwright

    def updates() -> int:
        return sum(int(pg.evaluate("() => window.faceplate.updates")) for pg in pages)

    pages: list[Any] = []
    with sync_playwright() as pw:
        br = pw.chromium.launch(executable_path="/usr/bin/chromium", headless=True,
                                args=["--no-sandbox", "--disable-gpu"])  # fmt: skip
        replies.put("up")
        # told what to do within the lifetime; a parent gone quiet ends it (queue.Empty)
        while (cmd := commands.get(timeout=LIFETIME)) != "stop":
            if cmd == "open":
                pg = br.new_page(viewport={"width": 1400, "height": 1000})
                pg.goto(url + ("#l100" if not pages else "#l000"))
                pg.wait_for_function("() => window.faceplate && window.faceplate.updates > 5")
                pages.append(pg)
                replies.put("ready")
            else:
                n0, end = updates(), time.monotonic() + cmd[1]
                while time.monotonic() < end:
                    if len(pages) > 1:
                        pages[1].mouse.wheel(0, 400)
                    time.sleep(1.0)
                replies.put(updates() - n0)
        br.close()


CASES = {"slow-device": slow_device, "bumpless": bumpless, "kill": kill, "browsers": browsers}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    ap.add_argument("case", choices=[*CASES, "all"])
    ap.add_argument("--pairs", type=int, default=20, help="slow-device: PI loops on OPC UA")
    ap.add_argument("--warm", type=float, default=20.0, help="slow-device: s before the delay")
    ap.add_argument("--phase", type=float, default=40.0, help="slow-device: s per delay phase")
    ap.add_argument("--kills", type=int, default=20, help="kill: how many kill -9")
    ap.add_argument("--loops", type=int, default=200, help="browsers: loops")
    ap.add_argument("--duration", type=float, default=60.0, help="browsers: s per case")
    ap.add_argument("--json", default=None, help="write the results here")
    ap.add_argument("--plot-dir", default=None, help="folder for the PNGs")
    a = ap.parse_args()
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # tests.runtime.conftest
    policy = {os.SCHED_OTHER: "normal"}.get(os.sched_getscheduler(0), "real-time (chrt)")
    conditions = {"scheduling": policy, "cpus": os.cpu_count(), "load_average": os.getloadavg()}
    results: dict[str, Any] = {"conditions": conditions}
    print(f"scheduling {policy}, load average {os.getloadavg()}", flush=True)
    for name in CASES if a.case == "all" else [a.case]:
        print(f"-- {name}", flush=True)
        results[name] = CASES[name](a)
        print(json.dumps(results[name], indent=1), flush=True)
    if a.json:
        Path(a.json).write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
