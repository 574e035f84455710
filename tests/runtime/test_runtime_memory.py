"""The runtime on virtual time with in-memory I/O: scheduling, faults, commands, stop."""

from __future__ import annotations

import asyncio
import math

import pytest

from ctrlblocks.blocks import ADRC, PID
from ctrlblocks.blocks.base import ErrorCode
from ctrlblocks.runtime import (
    CommandError,
    MemoryAdapter,
    MemoryBus,
    SQLiteHistorian,
    parse_config,
)

from .conftest import FirstOrder, loop_toml, make, run

ADRC_BLOCK = (
    '{ type = "ADRC", order = 1, b0 = 1.0, omega_c = 2.0, omega_o = 8.0, '
    "u_min = -5.0, u_max = 5.0 }"
)


def test_cycles_run_on_absolute_deadlines():
    bus = MemoryBus()
    FirstOrder(bus)
    bus.on_write = FirstOrder(bus)
    rt, clock, samples = make(loop_toml(ts=0.1), {"io": bus})

    async def main():
        await run(rt, clock, 1.0)
        await rt.stop()

    asyncio.run(main())
    times = [s.t for s in samples]
    assert times == pytest.approx([0.1 * k for k in range(11)], abs=1e-12)
    assert [s.cycle for s in samples] == list(range(11))
    assert all(not s.overrun and s.dt == 0.1 for s in samples)


def handover(block, u0: float) -> None:
    """The bumpless start by hand: the block tracks ``u0`` in manual for its first call."""
    block.manual, block.manual_value = True, u0


@pytest.mark.parametrize("start", ["read_back", "block"])
def test_loop_equals_the_block_called_by_hand(start):
    """The runtime's loop is exactly PID(sp, pv) per cycle on the plant's samples.

    Its first cycle is the MAN->AUTO handover at the MV read back from the
    device (0.3 here); with ``start = "block"`` the block's own first step.
    """
    bus = MemoryBus()
    plant = FirstOrder(bus)
    bus.on_write = plant
    bus.values["mv"] = 0.3
    rt, clock, samples = make(
        loop_toml(ts=0.1, sp="1.0", extra=f'start = "{start}"'), {"io": bus}
    )

    async def main():
        await run(rt, clock, 2.0)
        await rt.stop()

    asyncio.run(main())
    ref = PID(kp=1.0, ti=1.0, u_min=-10.0, u_max=10.0, ts=0.1, safe_value=0.0)
    if start == "read_back":
        handover(ref, 0.3)
    y = 0.0
    for s in samples:
        assert s.pv == y
        u = ref(1.0, y)
        ref.manual = False
        assert s.mv == u
        y = 0.9 * y + (1.0 - 0.9) * u
    assert len(samples) == 21
    assert samples[0].mv == (0.3 if start == "read_back" else 1.0)


def test_bad_pv_gives_adrc_safe_value_in_the_same_cycle_and_recovers_bumplessly():
    bus = MemoryBus()
    plant = FirstOrder(bus)
    bus.on_write = plant
    rt, clock, samples = make(
        loop_toml(ts=0.1, block=ADRC_BLOCK, sp="1.0", safe_value=-1.5), {"io": bus}
    )

    async def main():
        await run(rt, clock, 0.95)  # cycles 0..9
        bus.bad.add("pv")
        await clock.run_until(1.45)  # cycles 10..14 with bad quality
        bus.bad.clear()
        await clock.run_until(2.0)
        await rt.stop()

    asyncio.run(main())
    by = {s.cycle: s for s in samples}
    assert by[9].pv_ok and by[9].mv != -1.5
    for k in range(10, 15):
        assert not by[k].pv_ok
        assert by[k].mv == -1.5
        assert by[k].error_id == ErrorCode.BAD_MEASUREMENT
    # first good cycle continues from the applied safe value (Nowak et al. 2018, eq. 11)
    assert by[15].pv_ok
    assert by[15].mv == pytest.approx(-1.5, abs=1e-12)
    assert by[16].mv != by[15].mv  # and control resumes
    # the stop value (= safe value) is written last
    assert bus.writes[-1] == ("mv", -1.5)


@pytest.mark.parametrize(
    ("on_bad", "expected"),
    [("hold", "previous"), ("safe", 2.5)],
)
def test_pid_holds_or_goes_to_safe_value_on_nan_pv(on_bad, expected):
    bus = MemoryBus()
    plant = FirstOrder(bus)
    bus.on_write = plant
    rt, clock, samples = make(
        loop_toml(ts=0.1, sp="1.0", safe_value=2.5, extra=f'on_bad_pv = "{on_bad}"'),
        {"io": bus},
    )

    async def main():
        await run(rt, clock, 0.45)  # cycles 0..4
        y = bus.values["pv"]
        bus.values["pv"] = math.nan
        await clock.run_until(0.75)  # cycles 5..7
        bus.values["pv"] = y
        await clock.run_until(1.0)
        await rt.stop()

    asyncio.run(main())
    by = {s.cycle: s for s in samples}
    want = by[4].mv if expected == "previous" else expected
    for k in (5, 6, 7):
        assert not by[k].pv_ok
        assert by[k].mv == want
    # recovery without a bump: the integrator is re-initialised to the applied MV
    assert by[8].pv_ok and by[8].mv == pytest.approx(want, abs=1e-12)
    assert by[9].mv != pytest.approx(want, abs=1e-9)


def test_a_late_read_holds_the_loop_and_the_next_step_gets_the_stretched_period_as_dt():
    """Cycle 5's read takes 0.25 s (its deadline is ts/2 = 0.05 s): the loop holds in
    cycle 5 (nothing written, dt 0 in its sample), the read is cycle 6's input, and
    the block's step in cycle 6 gets the 0.4 s since its last step as dt."""
    bus = MemoryBus()
    plant = FirstOrder(bus)
    bus.on_write = plant
    rt, clock, samples = make(loop_toml(ts=0.1, sp="1.0", extra='start = "block"'), {"io": bus})
    reads = {"n": 0}

    def slow_read():
        reads["n"] += 1
        if reads["n"] == 6:  # cycle 5 takes 0.25 s: deadlines 0.6 and 0.7 are missed
            clock.advance(0.25)

    bus.on_read = slow_read

    async def main():
        await run(rt, clock, 1.2)
        st = rt.state("loop")
        await rt.stop()
        return st

    st = asyncio.run(main())
    by = {s.cycle: s for s in samples}
    assert by[5].dt == 0.0 and by[5].mv == by[4].mv  # held
    assert by[6].t == pytest.approx(0.8)  # phase kept: next deadline after 0.75
    assert by[6].overrun and by[6].dt == pytest.approx(0.4)
    assert not by[7].overrun and by[7].dt == 0.1
    assert rt.loops["loop"].monitor.overruns == 1
    assert st["late_cycles"] == 1 and st["stretched"] == 1
    assert {"late_io", "overrun", "stretched"} <= set(st["status"])  # still (off-delay)
    # replay: the block saw dt = 0.4 in cycle 6, nothing in cycle 5 and ts elsewhere
    ref = PID(kp=1.0, ti=1.0, u_min=-10.0, u_max=10.0, ts=0.1, safe_value=0.0)
    for k in range(len(samples)):
        if k != 5:
            assert ref(1.0, by[k].pv, dt=0.4 if k == 6 else None) == by[k].mv


def test_rejected_write_is_retried_reported_and_other_loops_keep_running():
    a, b = MemoryBus(), MemoryBus()
    a.on_write, b.on_write = FirstOrder(a), FirstOrder(b)
    attempts = []
    a_write = MemoryAdapter.write

    loops = loop_toml(name="a", conn="a", extra="write_retries = 2") + loop_toml(name="b", conn="b")
    rt, clock, samples = make(loops, {"a": a, "b": b})

    async def counting_write(self, items):
        attempts.append(items)
        return await a_write(self, items)

    rt.connections["a"].adapter.write = counting_write.__get__(rt.connections["a"].adapter)

    async def main():
        await run(rt, clock, 0.25)  # cycles 0..2 fine
        a.reject.add("mv")
        attempts.clear()
        await clock.run_until(0.55)  # cycles 3..5 rejected
        st = rt.state("a")
        st["attempts"] = len(attempts)
        a.reject.clear()
        await clock.run_until(0.65)
        await rt.stop()
        return st

    st = asyncio.run(main())
    assert st["attempts"] == 3 * 3  # 1 + 2 retries per cycle
    assert st["write_ok"] is False and st["write_error"] == "write rejected"
    assert st["write_failures"] == 3
    a_s = [s for s in samples if s.loop == "a"]
    b_s = [s for s in samples if s.loop == "b"]
    assert [s.write_ok for s in a_s[:7]] == [True] * 3 + [False] * 3 + [True]
    assert all(s.write_ok and s.pv_ok for s in b_s)
    assert len(b_s) == len(a_s) == 7


def test_lost_connection_reconnects_with_exponential_backoff():
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    bus.down = True
    rt, clock, samples = make(
        '[connections.io]\nprotocol = "memory"\nreconnect_min = 0.1\nreconnect_max = 0.4\n'
        + loop_toml(ts=0.05, safe_value=0.7),
        {},
    )
    adapter = MemoryAdapter(bus)
    connects = []
    orig = adapter.connect

    async def connect():
        connects.append(round(clock.now(), 9))
        await orig()

    adapter.connect = connect
    rt.connections["io"].adapter = adapter

    async def main():
        await run(rt, clock, 1.6)
        bus.down = False
        await clock.run_until(2.5)
        await rt.stop()

    asyncio.run(main())
    # t = 0 first try, then back-off 0.1, 0.2, 0.4, 0.4, ... after each failure
    assert connects[:6] == pytest.approx([0.0, 0.1, 0.3, 0.7, 1.1, 1.5])
    assert connects[6] == pytest.approx(1.9)  # the bus is up again: connected
    assert len(connects) == 7
    before = [s for s in samples if s.t < 1.9 - 1e-9]
    after = [s for s in samples if s.t > 1.9 + 1e-9]
    assert all(not s.pv_ok and s.mv == 0.7 for s in before)
    assert all(s.pv_ok for s in after)
    assert rt.connections["io"].reconnects == 1


def test_commands_are_validated_applied_bumplessly_and_audited(tmp_path):
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    rt, clock, samples = make(loop_toml(ts=0.1, sp="1.0"), {"io": bus}, tmp_path, historian=True)

    async def main():
        await run(rt, clock, 0.95)
        out_before = rt.state("loop")["mv"]
        rt.command("loop", user="alice", mode="manual")
        st = rt.state("loop")
        assert st["mode"] == "manual" and st["manual_value"] == out_before
        await clock.run_until(1.05)  # one manual cycle: the output does not jump
        assert samples[-1].mv == out_before
        rt.command("loop", user="alice", manual_value=3.0)
        with pytest.raises(CommandError) as e1:
            rt.command("loop", user="bob", u_min=5.0, u_max=1.0)
        assert e1.value.code == ErrorCode.BAD_LIMITS
        with pytest.raises(CommandError) as e2:
            rt.command("loop", user="bob", tunings={"kp": -1.0})
        assert e2.value.code == ErrorCode.BAD_PID_COEFFS
        assert rt.loops["loop"].block.config.kp == 1.0  # old tuning in force
        with pytest.raises(CommandError):
            rt.command("loop", user="bob", mode="cascade")
        rt.command("loop", user="carol", tunings={"kp": 2.0, "ti": 0.5}, u_min=-1.0, u_max=4.0)
        rt.command("loop", user="carol", mode="auto", sp=2.0)
        await clock.run_until(1.5)
        await rt.stop()

    asyncio.run(main())
    blk = rt.loops["loop"].block
    assert (blk.config.kp, blk.config.ti, blk.u_min, blk.u_max) == (2.0, 0.5, -1.0, 4.0)
    assert rt.loops["loop"].sp == 2.0
    with SQLiteHistorian(tmp_path / "h.sqlite").reading() as h:
        audit = h.audit_rows()
    who_ok = [(r["who"], r["action"], r["ok"]) for r in audit]
    assert who_ok[:6] == [
        ("alice", "mode", 1),
        ("alice", "manual_value", 1),
        ("bob", "u_max,u_min", 0),
        ("bob", "tunings", 0),
        ("bob", "mode", 0),
        ("carol", "tunings,u_max,u_min", 1),
    ]
    assert '"kp": 1.0' in audit[5]["old"]  # the old tuning is recorded
    assert who_ok[-1] == ("runtime", "stop", 1)


def test_signals_bound_to_io_cannot_be_commanded():
    bus = MemoryBus({"sp": 1.0})
    bus.on_write = FirstOrder(bus)
    rt, _, _ = make(loop_toml(sp='"io:sp"'), {"io": bus})
    with pytest.raises(CommandError, match="bound to I/O"):
        rt.command("loop", user="x", sp=3.0)


def test_stop_writes_stop_values_and_flushes_every_sample(tmp_path):
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    rt, clock, samples = make(
        loop_toml(ts=0.1, block=ADRC_BLOCK, safe_value=0.5, extra="stop_value = -0.25"),
        {"io": bus},
        tmp_path,
        historian=True,
    )

    async def main():
        await run(rt, clock, 0.9)
        await rt.stop()

    asyncio.run(main())
    assert bus.writes[-1] == ("mv", -0.25)
    with SQLiteHistorian(tmp_path / "h.sqlite").reading() as h:
        assert len(h.samples()) == len(samples) == 10


def test_adrc_block_call_matches_a_replay():
    """ADRC through the runtime equals the block called by hand with the same data."""
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    rt, clock, samples = make(loop_toml(ts=0.1, block=ADRC_BLOCK, sp="1.0"), {"io": bus})

    async def main():
        await run(rt, clock, 1.0)
        await rt.stop()

    asyncio.run(main())
    ref = ADRC(order=1, b0=1.0, omega_c=2.0, omega_o=8.0, u_min=-5.0, u_max=5.0, ts=0.1)
    handover(ref, 0.0)  # the MV read back at the cold start (the plant's 0.0)
    for s in samples:
        assert ref(1.0, s.pv) == s.mv
        ref.manual = False


def test_read_timeout_gives_safe_value_in_that_cycle_and_three_drop_the_connection():
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    rt, clock, samples = make(
        '[connections.io]\nprotocol = "memory"\ntimeout = 0.02\nreconnect_min = 0.3\n'
        + loop_toml(ts=0.1, block=ADRC_BLOCK, safe_value=0.4),
        {},
    )
    rt.connections["io"].adapter = MemoryAdapter(bus)
    hang = {"on": False}

    async def maybe_hang():
        if hang["on"]:
            await asyncio.sleep(1.0)  # real time: longer than the 20 ms timeout

    bus.on_read = maybe_hang

    async def step_to(t):  # a timeout takes real time: let it come before the deadline
        while clock.now() < t - 1e-9:
            await clock.run_until(min(t, clock.now() + 0.01))
            await asyncio.sleep(0.03)  # the 20 ms timeout within 10 ms of virtual time
            await clock.settle()

    async def main():
        await run(rt, clock, 0.45)  # cycles 0..4
        hang["on"] = True
        await step_to(0.65)  # cycles 5, 6: timeouts
        st = rt.state("loop")
        await step_to(0.75)  # cycle 7: third timeout -> connection dropped
        connected = rt.connections["io"].connected
        hang["on"] = False
        await step_to(1.5)
        await rt.stop()
        return st, connected

    st, connected = asyncio.run(main())
    by = {s.cycle: s for s in samples}
    assert st["pv_reason"] == "read timeout"
    assert [by[k].mv for k in (5, 6, 7)] == [0.4, 0.4, 0.4]
    assert not any(by[k].pv_ok for k in (5, 6, 7))
    assert connected is False
    assert rt.connections["io"].reconnects == 1 and by[14].pv_ok


def test_the_examples_of_docs_runtime_md_load(monkeypatch):
    import re
    from pathlib import Path

    doc = (Path(__file__).parents[2] / "docs" / "runtime.md").read_text()
    blocks = re.findall(r"```toml\n(.*?)```", doc, re.S)
    loops = [b for b in blocks if "[[loops]]" in b]
    conns = [b for b in blocks if "[[loops]]" not in b]
    assert len(loops) == 3 and len(conns) == 1
    for b in loops:
        cfg = parse_config(b)
        assert len(cfg.loops) == 1 and cfg.build_blocks()
    assert [parse_config(b).loops[0].structure for b in loops] == ["single", "single", "cascade"]
    monkeypatch.setenv("PLC_PASSWORD", "x")
    loop = loops[0][loops[0].index("[[loops]]") :]
    cfg = parse_config(conns[0] + "\n" + loop)
    c = cfg.connections["plc"]
    assert (c.security, c.user, c.password) == ("Basic256Sha256_SignAndEncrypt", "runtime", "x")


def test_event_loop_is_the_loop_the_runtime_started_on_and_audit_writes_a_row(tmp_path):
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    rt, clock, _ = make(loop_toml(ts=0.1, sp="1.0"), {"io": bus}, tmp_path, historian=True)
    assert rt.event_loop is None  # not started

    async def main():
        await run(rt, clock, 0.25)
        assert rt.event_loop is asyncio.get_running_loop()
        rt.audit("alice", "login")
        rt.audit("mallory", "sp", loop="loop", new={"sp": 9.0}, ok=False, message="refused")
        await rt.stop()

    asyncio.run(main())
    with SQLiteHistorian(tmp_path / "h.sqlite").reading() as h:
        rows = h.audit_rows()
    got = [(r["who"], r["loop"], r["action"], r["new"], r["ok"], r["message"]) for r in rows[:2]]
    assert got == [
        ("alice", "", "login", "null", 1, ""),
        ("mallory", "loop", "sp", '{"sp": 9.0}', 0, "refused"),
    ]


def test_audit_without_a_historian_does_nothing():
    bus = MemoryBus()
    rt, _, _ = make(loop_toml(ts=0.1, sp="1.0"), {"io": bus})
    rt.audit("alice", "login")  # no historian: no error
    assert rt.historian is None


def test_a_failing_audit_write_does_not_break_the_stop(tmp_path):
    """The stop's audit rows go through the same guard as every other audit: a database
    error is logged, and the stop still flushes the samples and closes the connections."""
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    rt, clock, samples = make(loop_toml(ts=0.1, sp="1.0"), {"io": bus}, tmp_path, historian=True)

    def broken_audit(*args, **kw):
        raise OSError("disk full")

    async def main():
        await run(rt, clock, 0.45)
        rt.historian.audit = broken_audit
        await rt.stop()

    asyncio.run(main())
    assert bus.writes[-1] == ("mv", 0.0)  # the stop value (safe_value 0) was written
    assert not rt.connections["io"].adapter.open  # the connection was closed
    with SQLiteHistorian(tmp_path / "h.sqlite").reading() as h:
        assert len(h.samples()) == len(samples) == 5  # flushed on stop
        assert h.query("SELECT stopped IS NOT NULL FROM runs") == [(1,)]


def test_an_exception_in_a_cycle_is_in_the_state_and_the_loop_goes_on():
    """docs/runtime.md: any exception in a cycle is caught, logged, ``last_exception`` in the
    state; the next cycle runs."""
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    rt, clock, samples = make(loop_toml(ts=0.1, sp="1.0"), {"io": bus})
    side = rt.loops["loop"].side
    step = side.step
    calls = []

    def flaky(*args, **kw):
        calls.append(1)
        if len(calls) == 3:
            raise RuntimeError("boom")
        return step(*args, **kw)

    side.step = flaky

    async def main():
        await run(rt, clock, 0.45)
        st = rt.state("loop")
        await rt.stop()
        return st

    st = asyncio.run(main())
    assert st["last_exception"] == "RuntimeError: boom"
    assert len(samples) == 5 and st["cycle"] == 5


def test_every_command_path_refuses_a_value_outside_the_engineering_ranges(tmp_path):
    # the loop checks sp_range, mv_range and tuning_ranges itself (runtime.bounds): a
    # Python caller, the faceplate and the live tuner all get the same refusal
    extra = "sp_range = [0.0, 5.0]\nmv_range = [-2.0, 8.0]\ntuning_ranges = { kp = [0.1, 3.0] }"
    block = '{ type = "PID", kp = 1.0, ti = 1.0, u_min = -1.0, u_max = 6.0 }'
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    rt, clock, _ = make(loop_toml(block=block, extra=extra), {"io": bus}, tmp_path, historian=True)
    lp = rt.loops["loop"]

    async def main():
        await run(rt, clock, 0.55)
        rt.command("loop", user="alice", mode="manual", manual_value=2.0)
        before = rt.state("loop")
        for changes, field, code in (
            ({"sp": 5.5}, "sp", ErrorCode.BAD_PARAMETER),
            ({"sp": -0.1}, "sp", ErrorCode.BAD_PARAMETER),
            ({"manual_value": 8.01}, "manual_value", ErrorCode.BAD_PARAMETER),
            ({"u_min": -3.0, "u_max": 4.0}, "u_min", ErrorCode.BAD_LIMITS),
            ({"u_min": 0.0, "u_max": 9.0}, "u_max", ErrorCode.BAD_LIMITS),
            ({"tunings": {"kp": 3.5}}, "tunings.kp", ErrorCode.BAD_PARAMETER),
            ({"tunings": {"ti": 2e6}}, "tunings.ti", ErrorCode.BAD_PARAMETER),  # derived cap
            ({"sp": 2.0, "manual_value": 9.0}, "manual_value", ErrorCode.BAD_PARAMETER),
        ):
            with pytest.raises(CommandError) as exc:
                rt.command("loop", user="bob", **changes)
            assert (exc.value.field, exc.value.code) == (field, code), changes
            assert "outside the engineering range" in exc.value.message or "magnitude" in (
                exc.value.message
            )
        after = rt.state("loop")
        assert {k: after[k] for k in ("sp", "manual_value", "mode")} == {
            k: before[k] for k in ("sp", "manual_value", "mode")
        }
        assert (lp.block.u_min, lp.block.u_max, lp.block.config.kp) == (-1.0, 6.0, 1.0)
        assert lp.sp == 1.0  # all-or-nothing: the good sp of the last command did not land
        rt.command("loop", user="carol", sp=5.0, manual_value=8.0, u_min=-2.0, u_max=8.0)
        assert (lp.sp, lp.block.u_min, lp.block.u_max) == (5.0, -2.0, 8.0)  # the edges are in
        await rt.stop()

    asyncio.run(main())
    with SQLiteHistorian(tmp_path / "h.sqlite").reading() as h:
        refused = [r for r in h.audit_rows() if r["who"] == "bob"]
    assert len(refused) == 8 and not any(r["ok"] for r in refused)
    assert refused[0]["message"].startswith("sp: outside the engineering range [0, 5]")


def test_with_flush_after_cycle_every_sample_is_written_and_stop_does_not_wait(tmp_path):
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    rt, clock, samples = make(loop_toml(ts=5.0), {"io": bus}, tmp_path, historian=True)
    rt.flush_after_cycle = True  # the benchmark's switch (docs/performance.md)

    async def main():
        await rt.start()
        await clock.run_until(12.0)  # three cycles on the fake clock
        await asyncio.sleep(1.5)  # the flush interval (1 s): the flusher waits for a cycle end
        t = asyncio.get_running_loop().time()
        await rt.stop()  # releases that wait (no next cycle for 5 s) and flushes
        return asyncio.get_running_loop().time() - t

    took = asyncio.run(main())
    assert took < 4.0
    with SQLiteHistorian(tmp_path / "h.sqlite").reading() as hr:
        assert hr.query("SELECT COUNT(*) FROM samples")[0][0] == len(samples) == 3
