"""Bumpless on every transition: cold start, reconnection, restart -- with the plant moving.

The device holds its MV (2.19 at the start, as the issue's rig); the plants
move on the clock whatever the runtime does (:class:`ClockedPlant`), so a
runtime that starts late, loses its connection or dies finds the PV
elsewhere than it left it.  "At the device" means the MVs the device took,
in order, starting from the one it held: their largest step is the bump.
"""

from __future__ import annotations

import asyncio
import contextlib
import re

import numpy as np
import pytest

from ctrlblocks.runtime import MemoryBus
from ctrlblocks.runtime.retain import RetainStore

from .conftest import ClockedPlant, bounded, loop_toml, make

PID = '{ type = "PID", kp = 1.0, ti = 2.0, u_min = 0.0, u_max = 5.0 }'
ADRC = (
    '{ type = "ADRC", order = 1, b0 = 0.5, omega_c = 1.0, omega_o = 5.0, '
    "u_min = 0.0, u_max = 5.0 }"
)
BLOCKS = {"PID": PID, "ADRC": ADRC}
U_DEVICE = 2.19
STEP = {"PID": 0.1, "ADRC": 0.4}
"""The largest MV step allowed after a transition (MV range 0..5).  The transition itself
adds no step (the first write is the device's MV); what follows is the block leaving MAN
for AUTO with SP != PV: the PID's integrator takes the error over; the ADRC, its observer
at rest on the present PV with the device's MV, moves its reference from the PV toward
the set point at the loop's speed (its first move kp (1 - exp(-omega_c ts)) (SP - PV) / b0
= -0.13 at the cold start below: docs/blocks/adrc.md, "Modes and bumpless transfer")."""


def largest_step(plant: ClockedPlant, before: float, n: int) -> float:
    """The largest |dMV| of the device over its first ``n`` writes, from ``before``."""
    w = [before, *plant.device_writes()[:n]]
    return float(np.max(np.abs(np.diff(w))))


def cold_start(block: str, start: str, sp: float = 1.5):
    bus = MemoryBus()
    rt, clock, samples = make(
        loop_toml(sp=str(sp), block=block, extra=f'start = "{start}"'), {"io": bus}
    )
    plant = ClockedPlant(bus, clock, 0.1, u0=U_DEVICE)  # at rest: PV 2.19

    async def main():
        plant.start()
        await clock.run_until(3.0)  # the plant runs before the runtime starts
        await rt.start()
        await clock.run_until(13.0)
        await rt.stop()

    bounded(main())
    return plant, samples


@pytest.mark.parametrize("kind", ["PID", "ADRC"])
def test_a_cold_start_reads_the_mv_back_and_starts_from_it(kind):
    plant, samples = cold_start(BLOCKS[kind], "read_back")
    w = plant.device_writes()
    assert w[0] == U_DEVICE  # the first write is what the device had
    # then the loop moves the MV toward the set point (PV 2.19 above SP 1.5: down)
    assert largest_step(plant, U_DEVICE, 20) < STEP[kind]
    assert max(w[:20]) <= U_DEVICE and w[19] < U_DEVICE - 0.2
    assert samples[0].mode == "auto" and abs(samples[-1].pv - 1.5) < 0.05


def test_a_cold_start_of_the_blocks_own_state_is_the_bump_the_read_back_avoids():
    plant, _ = cold_start(PID, "block")
    assert largest_step(plant, U_DEVICE, 20) > 1.0  # 2.19 -> the PID's first output


def test_a_cold_start_without_a_read_back_uses_initial_mv():
    bus = MemoryBus()
    rt, clock, _ = make(loop_toml(sp="1.5", block=PID, extra="initial_mv = 2.0"), {"io": bus})
    plant = ClockedPlant(bus, clock, 0.1, u0=U_DEVICE)
    del bus.values["mv"]  # the device cannot give its MV back

    async def main():
        plant.step = lambda: None  # (no MV to move the plant with)
        await rt.start()
        await clock.run_until(0.05)
        st = rt.state("loop")
        await rt.stop()
        return st

    st = bounded(main())
    assert plant.device_writes()[0] == 2.0
    assert st["last_start"] == "start: bumpless from initial_mv 2"


def test_a_cold_start_in_manual_takes_the_devices_mv_as_the_manual_value():
    bus = MemoryBus()
    rt, clock, _ = make(loop_toml(sp="1.5", block=PID, extra='mode = "manual"'), {"io": bus})
    plant = ClockedPlant(bus, clock, 0.1, u0=U_DEVICE)

    async def main():
        plant.start()
        await rt.start()
        await clock.run_until(2.0)
        st = rt.state("loop")
        await rt.stop()
        return st

    st = bounded(main())
    assert st["mode"] == "manual" and st["manual_value"] == U_DEVICE
    assert set(plant.device_writes()[:-1]) == {U_DEVICE}  # (the last: the stop value)


@pytest.mark.parametrize("kind", ["PID", "ADRC"])
def test_a_reconnection_starts_from_the_devices_mv_not_from_the_unwritten_safe_value(kind):
    """The connection is down 3 s; meanwhile the device's own watchdog puts its MV to 1.0
    and the plant follows it; the loop wrote nothing (its safe value 0.0 never got
    there).  At the reconnection it reads 1.0 back and goes on from it."""
    bus = MemoryBus()
    rt, clock, _samples = make(
        '[connections.io]\nprotocol = "memory"\nreconnect_min = 0.2\nreconnect_max = 0.4\n'
        + loop_toml(sp="1.5", block=BLOCKS[kind]),
        {},
    )
    from ctrlblocks.runtime import MemoryAdapter

    rt.connections["io"].adapter = MemoryAdapter(bus)
    plant = ClockedPlant(bus, clock, 0.1, u0=U_DEVICE)

    async def main():
        plant.start()
        await rt.start()
        await clock.run_until(10.0)
        n_before = len(plant.device_writes())
        last = plant.device_writes()[-1]
        bus.down = True
        plant.hold = 1.0  # the device's watchdog
        await clock.run_until(13.0)
        assert rt.state("loop")["pv_ok"] is False and rt.state("loop")["mv"] == 0.0
        plant.hold = None
        bus.down = False
        await clock.run_until(20.0)
        st = rt.state("loop")
        await rt.stop()
        return n_before, last, st

    n_before, last, st = bounded(main())
    after = plant.device_writes()[n_before:]
    assert after[0] == 1.0  # the device's MV, read back: not 0.0
    # then toward the set point (the PV followed the MV 1.0 down: up again), no kick
    assert float(np.max(np.abs(np.diff([1.0, *after[:20]])))) < STEP[kind]
    assert min(after[:20]) >= 1.0 and after[19] > 1.1
    assert st["last_start"].startswith("reconnect: bumpless from the device's MV 1")
    assert rt.connections["io"].reconnects == 1 and abs(st["pv"] - 1.5) < 0.1
    assert abs(last - 1.5) < 0.05  # it was regulating before


def age_the_retained_state(path, seconds: float) -> None:
    """Make every loop's retained state ``seconds`` older (its wall-clock time stamp)."""
    import json
    import sqlite3

    with contextlib.closing(sqlite3.connect(path)) as conn, conn:
        for name, text in conn.execute("SELECT name, state FROM loops").fetchall():
            st = json.loads(text)
            st["t_wall"] -= seconds
            conn.execute("UPDATE loops SET state = ? WHERE name = ?", (json.dumps(st), name))


def test_a_restart_after_a_kill_during_a_transient_starts_from_the_mv_and_the_present_pv(
    tmp_path,
):
    """The ADRC of the issue: killed 1.9 s after its last retained snapshot, during a
    set-point transient; the plant moves for 3 s on the MV the device holds.  The new
    runtime restores the operator's state, resets the stale observer, reads the MV
    back and goes on from it: no drop to 0 (the issue saw 2.208 -> 0.740 -> 0.0)."""
    path = tmp_path / "retain.sqlite"
    bus = MemoryBus()
    text = loop_toml(sp="1.5", block=ADRC, extra="")

    def life():
        rt, clock, samples = make(text, {"io": bus}, retain=RetainStore(path))
        return rt, clock, samples

    rt1, clock1, _ = life()
    plant = ClockedPlant(bus, clock1, 0.1, u0=U_DEVICE)

    async def first():
        plant.start()
        await rt1.start()
        await clock1.run_until(4.0)
        rt1.command("loop", user="op", sp=3.0)  # the transient
        await clock1.run_until(6.9)  # retained at 5.0 (interval 5 s); killed here
        for t in rt1._tasks:
            t.cancel()  # kill -9: no stop, no final save
        await asyncio.sleep(0)

    bounded(first())
    mv_at_kill = bus.values["mv"]
    for _ in range(30):  # the plant moves 3 s on the MV the device holds
        plant.step()
    # the file as a real kill leaves it: its snapshot taken 4.9 s before the restart
    # (1.9 s to the kill, 3 s dead; the test's virtual time does not move the wall clock)
    age_the_retained_state(path, 4.9)
    rt2, clock2, _samples = life()
    plant.clock = clock2

    async def second():
        plant.start()
        await rt2.start()
        await clock2.run_until(3.0)
        st = rt2.state("loop")
        await rt2.stop()
        return st

    n0 = len(plant.device_writes())
    st = bounded(second())
    after = plant.device_writes()[n0:]
    assert st["sp"] == 3.0  # the operator's set point survived (it was retained at 5.0)
    assert after[0] == pytest.approx(mv_at_kill)
    assert st["last_start"].startswith("restart: bumpless from the device's MV")
    age = re.search(r"block state ([0-9.]+) s old$", st["last_start"])
    assert age is not None and float(age.group(1)) >= 4.9  # beyond max_dt 1 s: reset
    # at rest on the present PV with the held MV: the reference moves from PV 2.92 to
    # SP 3.0 at the loop's speed (the stale observer: 2.208 -> 0.740 -> 0.0)
    assert float(np.max(np.abs(np.diff([mv_at_kill, *after[:15]])))) < 0.05
    assert after[2] > after[1]  # the first move: up, toward the set point
    assert min(after[:15]) > 0.8 * mv_at_kill  # toward SP 3 (above the PV): never down to 0


@pytest.mark.parametrize("kind", ["PID", "ADRC"])
def test_a_device_that_comes_back_during_a_cycles_read_holds_that_cycle_then_starts_from_it(
    kind,
):
    """The loopback race CI met once: the connection came back while a cycle's read was on
    its way (after the cycle had looked for reconnections), so the read carried the PV but no
    MV read-back; the loop cycled from its safe value and recorded it (nothing was written).
    Now that cycle holds, and the next one resyncs and starts from the device's MV."""
    bus = MemoryBus()
    rt, clock, _samples = make(loop_toml(sp="1.5", block=BLOCKS[kind]), {"io": bus})
    plant = ClockedPlant(bus, clock, 0.1, u0=U_DEVICE)
    conn = rt.connections["io"]
    adapter = conn.adapter
    real_read = adapter.read
    raced = []

    async def read(addresses):
        if not raced and clock.now() >= 5.0:  # the reconnection lands inside this read
            raced.append(clock.now())
            conn.reconnects += 1
        return await real_read(addresses)

    adapter.read = read

    async def main():
        plant.start()
        await rt.start()
        await clock.run_until(4.95)
        writes0 = len(plant.device_writes())
        await clock.run_until(5.05)  # the cycle of the race
        writes1 = len(plant.device_writes())
        await clock.run_until(5.15)  # the next one
        st = rt.state("loop")
        await rt.stop()
        return writes0, writes1, st

    writes0, writes1, st = bounded(main())
    rows = {round(x.t, 6): x for x in _samples}
    assert raced == [5.0] and writes1 == writes0  # nothing written in the cycle of the race
    assert rows[5.0].mv == rows[4.9].mv and rows[4.9].mv != rows[4.8].mv  # held, not cycled
    assert st["last_start"].startswith("reconnect: bumpless from the device's MV")
