"""One slow device cannot upset the loops on another connection; late inputs and the dt.

Virtual time (FakeClock) and in-memory devices: a device is made slow by a
read that takes fake time (``bus.on_read`` sleeps on the clock), the plants
move on the clock whatever the runtime does (:class:`ClockedPlant`).
"""

from __future__ import annotations

import dataclasses
import itertools
import math

import pytest

from ctrlblocks.runtime import MemoryBus

from .conftest import ClockedPlant, bounded, loop_toml, make

PI = '{ type = "PID", kp = 1.0, ti = 1.0, u_min = 0.0, u_max = 5.0 }'
ADRC1 = (
    '{ type = "ADRC", order = 1, b0 = 1.0, omega_c = 1.0, omega_o = 4.0, '
    "u_min = 0.0, u_max = 5.0 }"
)


def slow(bus: MemoryBus, clock, delay: float) -> None:
    """Every read of ``bus`` takes ``delay`` seconds of the clock (a slow device)."""

    async def read():
        await clock.sleep_until(clock.now() + delay)

    bus.on_read = read


def two_devices(delay: float, *, b_extra: str = "", b_block: str = PI, t_end: float = 20.0):
    """Loops a1, a2 on a healthy device, b1 on one whose reads take ``delay`` s."""
    a, b = MemoryBus(), MemoryBus()
    text = (
        loop_toml(name="a1", conn="a", pv="pv1", mv="mv1", sp="1.5", block=PI)
        + loop_toml(name="a2", conn="a", pv="pv2", mv="mv2", sp="1.5", block=PI)
        + loop_toml(name="b1", conn="b", sp="1.5", block=b_block, extra=b_extra)
    )
    rt, clock, samples = make(text, {"a": a, "b": b})
    # the wire timeout runs on the real clock: the virtual delays must not reach it
    rt.connections["b"].config = dataclasses.replace(rt.connections["b"].config, timeout=600.0)
    plants = [ClockedPlant(a, clock, 0.1, pv="pv1", mv="mv1", u0=1.0),
              ClockedPlant(a, clock, 0.1, pv="pv2", mv="mv2", u0=1.0),
              ClockedPlant(b, clock, 0.1, u0=1.0)]  # fmt: skip
    slow(b, clock, delay)

    async def main():
        for p in plants:
            p.start()
        await rt.start()
        await clock.run_until(t_end)
        states = {n: rt.state(n) for n in rt.loop_names()}
        await rt.stop()
        return states

    states = bounded(main())
    by = {n: [s for s in samples if s.loop == n] for n in ("a1", "a2", "b1")}
    return by, states, plants


@pytest.mark.parametrize("delay", [0.3, 0.6])
def test_a_slow_device_delays_only_its_own_loops(delay):
    by, states, _ = two_devices(delay)
    for n in ("a1", "a2"):  # the healthy device's loops: every deadline, ts as dt
        s = by[n]
        assert [round(x.t, 9) for x in s] == pytest.approx([0.1 * k for k in range(len(s))])
        assert len(s) == 201 and all(x.dt == 0.1 and not x.overrun for x in s)
        assert states[n]["late_cycles"] == 0 and states[n]["status"] == []
        assert abs(states[n]["pv"] - 1.5) < 1e-3  # and they regulate
    b = states["b1"]
    assert b["late_cycles"] > 50 and "late_io" in b["status"]
    assert abs(b["pv"] - 1.5) < 0.02  # the slow loop still regulates, on its own pace
    assert "oscillating" not in b["status"]


def test_the_slow_loop_steps_with_the_time_since_its_last_step_as_dt_within_max_dt():
    by, states, _ = two_devices(0.3)
    stepped = [s for s in by["b1"] if s.dt > 0.0]
    held = [s for s in by["b1"] if s.dt == 0.0]
    assert held and stepped
    assert [s.dt for s in stepped[:2]] == [0.1, 0.1]  # the start, and the step after it
    for prev, s in itertools.pairwise(stepped[1:]):
        gap = s.t - prev.t
        # the jitter band (warn_limit 1.5 ts) gives ts, beyond it the measured period
        assert s.dt == pytest.approx(0.1 if gap <= 0.15 + 1e-9 else gap), (prev, s)
        assert s.dt <= states["b1"]["max_dt"]
    assert states["b1"]["stretched"] == sum(1 for s in stepped if s.dt > 0.1 + 1e-9)


def test_on_late_last_good_runs_every_cycle_on_the_last_inputs_flagged_late():
    """Never held: every cycle steps, on the last inputs when the new ones are late (its
    cycles run at the device's pace: the MV write waits behind the late read)."""
    by, states, _ = two_devices(0.3, b_extra='on_late = "last_good"')
    b = by["b1"]
    assert all(s.dt > 0.0 for s in b) and len(b) > 20
    assert states["b1"]["late_cycles"] > 20 and "holding" not in states["b1"]["status"]
    assert abs(states["b1"]["pv"] - 1.5) < 0.02


def test_inputs_late_beyond_max_dt_hold_the_loop_and_restart_its_blocks_from_the_mv():
    """The device answers after 1.5 s, max_dt is 1 s: the ADRC is never stepped over 1.5 s
    (its Euler observer is unstable from omega_o dt = 2): at each return it starts
    again from the MV last written and the present PV, as after a restart -- so the
    loop holds its MV -- with the warning ``held_long``, audited once."""
    by, states, _ = two_devices(1.5, b_extra="max_dt = 1.0", b_block=ADRC1, t_end=30.0)
    b = by["b1"]
    stepped = [s for s in b if s.dt > 0.0]
    assert all(s.dt == 0.1 for s in stepped)
    assert states["b1"]["initialisations"] >= 10  # the cold start, then every return
    assert states["b1"]["last_start"].startswith("held: bumpless from the MV last written")
    assert {s.mv for s in b} == {1.0}  # the device's MV, held: no kick, no swing
    assert {"held_long", "late_io"} <= set(states["b1"]["status"])
    assert "oscillating" not in states["b1"]["status"]


def test_the_first_steps_after_a_slow_start_use_ts_not_the_start_up_period():
    """The first read takes 0.35 s: the bumpless start and the step after it get ts."""
    bus = MemoryBus()
    rt, clock, samples = make(loop_toml(ts=0.1, block=ADRC1, sp="1.5"), {"io": bus})
    plant = ClockedPlant(bus, clock, 0.1, u0=1.0)
    reads = {"n": 0}

    async def first_slow():
        reads["n"] += 1
        if reads["n"] == 1:
            await clock.sleep_until(clock.now() + 0.35)

    bus.on_read = first_slow

    async def main():
        plant.start()
        await rt.start()
        await clock.run_until(2.0)
        await rt.stop()

    bounded(main())
    stepped = [s for s in samples if s.dt > 0.0]
    assert stepped[0].mv == 1.0  # the MV read back
    assert [s.dt for s in stepped[:3]] == [0.1, 0.1, 0.1]
    assert math.isclose(stepped[0].t, 0.3)  # the read is back within cycle 0.3's deadline
