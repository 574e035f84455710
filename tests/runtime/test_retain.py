"""Retentive state: a restart restores what the operator set and starts bumpless."""

from __future__ import annotations

import asyncio
import logging
import sqlite3

import pytest

from ctrlblocks.runtime import FakeClock, MemoryAdapter, MemoryBus, Runtime, parse_config
from ctrlblocks.runtime.retain import SCHEMA_VERSION, RetainStore

from .conftest import FirstOrder, bounded, loop_toml, make, wait_for

CONN = '[connections.io]\nprotocol = "memory"\n[historian]\nbackend = "none"\n'


def runtime(bus: MemoryBus, retain_path, kp: float = 1.0, extra: str = ""):
    block = f'{{ type = "PID", kp = {kp}, ti = 1.0, u_min = -10.0, u_max = 10.0 }}'
    loops = loop_toml(ts=0.1, block=block, extra=extra)
    return make(loops, {"io": bus}, retain=RetainStore(retain_path))


def first_life(bus, path):
    rt, clock, samples = runtime(bus, path)

    async def main():
        await rt.start()
        await clock.run_until(0.45)
        rt.command("loop", user="op", sp=2.0)
        rt.command("loop", user="op", tunings={"kp": 1.5})
        rt.command("loop", user="op", u_min=-5.0, u_max=5.0)
        await clock.run_until(1.95)
        await rt.stop()

    bounded(main())
    return samples


def test_a_restart_restores_the_operators_state_and_starts_bumpless_from_the_read_back_mv(
    tmp_path,
):
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    path = tmp_path / "retain.sqlite"
    first_life(bus, path)
    bus.values["mv"] = 3.3  # the device holds its own value after the stop
    rt, clock, samples = runtime(bus, path)

    async def main():
        await rt.start()
        st = rt.state("loop")
        await clock.run_until(0.55)
        await rt.stop()
        return st

    st = bounded(main())
    assert st["sp"] == 2.0 and st["tunings"]["kp"] == 1.5
    assert (st["u_min"], st["u_max"]) == (-5.0, 5.0) and st["mode"] == "auto"
    assert abs(samples[0].mv - 3.3) < 1e-9  # the read-back MV: no bump
    assert samples[0].mode == samples[1].mode == "auto"
    # then the PID continues from there as after a bumpless manual-to-auto transfer
    assert abs(samples[1].mv - samples[0].mv) < 0.5


def test_without_a_read_back_the_retained_mv_is_the_start(tmp_path):
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    path = tmp_path / "retain.sqlite"
    first = first_life(bus, path)
    last_mv = first[-1].mv
    del bus.values["mv"]  # cannot be read back
    rt, clock, samples = runtime(bus, path)

    async def main():
        await rt.start()
        await clock.run_until(0.05)
        await rt.stop()

    bounded(main())
    assert abs(samples[0].mv - last_mv) < 1e-9


def test_a_tuning_changed_in_the_file_wins_over_the_retained_one_with_a_log_line(tmp_path, caplog):
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    path = tmp_path / "retain.sqlite"
    first_life(bus, path)
    rt, _clock, _samples = runtime(bus, path, kp=3.0)

    async def main():
        with caplog.at_level(logging.INFO, logger="ctrlblocks.runtime"):
            await rt.start()
        st = rt.state("loop")
        await rt.stop()
        return st

    st = bounded(main())
    assert st["tunings"]["kp"] == 3.0 and st["sp"] == 2.0
    msgs = [r.getMessage() for r in caplog.records]
    assert (
        "loop loop: kp = 3.0 from the configuration file replaces the retained 1.5 "
        "(the file changed)" in msgs
    )


def saved_names(path) -> list[str]:
    """The loops in the retain file (none while it is not there or not written yet)."""
    try:
        with sqlite3.connect(f"file:{path}?mode=ro", uri=True) as c:
            return [r[0] for r in c.execute("SELECT name FROM loops ORDER BY name")]
    except sqlite3.OperationalError:
        return []


def test_the_state_is_saved_every_interval_atomically_with_a_schema_version(tmp_path):
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    path = tmp_path / "retain.sqlite"
    cfg = parse_config(
        CONN.replace('backend = "none"\n', 'backend = "none"\n[retain]\n')
        + f'path = "{path}"\ninterval = 1.0\n'
        + loop_toml(ts=0.1)
    )
    clock = FakeClock()
    rt = Runtime(cfg, clock=clock, adapters={"io": MemoryAdapter(bus)}, historian=None)
    assert rt.retain is not None and rt.retain.path == str(path)

    async def main():
        await rt.start()
        await clock.run_until(0.5)
        saved_early = saved_names(path)  # the start made it empty (its write check)
        await clock.run_until(1.2)
        await wait_for(lambda: saved_names(path) == ["loop"], timeout=30.0)  # a thread saves
        with sqlite3.connect(path) as c:
            rows = c.execute("SELECT name FROM loops").fetchall()
            version = c.execute("SELECT value FROM meta").fetchall()
        rt.request_stop()
        await rt.stop()
        return saved_early, rows, version

    saved_early, rows, version = bounded(main())
    assert path.exists() and saved_early == []
    assert rows == [("loop",)] and version == [(str(SCHEMA_VERSION),)]


def test_a_retain_file_of_another_schema_version_is_a_cold_start(tmp_path, caplog):
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    path = tmp_path / "retain.sqlite"
    first_life(bus, path)
    with sqlite3.connect(path) as c:
        c.execute("UPDATE meta SET value = '99' WHERE key = 'schema_version'")
    with caplog.at_level(logging.WARNING, logger="ctrlblocks.runtime"):
        assert RetainStore(path).load() == {}
    assert "schema version 99, not 1: cold start" in caplog.text


def test_the_periodic_save_takes_ten_loops_per_step_spread_over_the_interval(tmp_path):
    """25 loops, interval 1 s: 10 loops at 1/3 s, 10 at 2/3 s, 5 at 1 s, then one save of all."""
    bus = MemoryBus()
    path = tmp_path / "retain.sqlite"
    loops = "".join(
        loop_toml(name=f"l{i:02d}", ts=0.1, pv=f"pv{i}", mv=f"mv{i}") for i in range(25)
    )
    rt, clock, _ = make(loops + "[retain]\ninterval = 1.0\n", {"io": bus}, retain=RetainStore(path))
    taken: list[tuple[float, str]] = []
    for lp in rt.loops.values():
        lp.retained = (  # type: ignore[method-assign]
            lambda lp=lp, f=lp.retained: taken.append((clock.now(), lp.name)) or f()
        )

    async def main():
        await rt.start()
        await clock.run_until(1.05)
        await wait_for(lambda: len(saved_names(path)) == 25, timeout=30.0)  # a thread saves
        rt.request_stop()
        await rt.stop()

    bounded(main())
    first_round = [t for t, _ in taken if t < 1.05]
    steps = sorted({round(t, 6) for t in first_round})
    assert steps == pytest.approx([1 / 3, 2 / 3, 1.0], abs=1e-6)
    assert [sum(1 for t in first_round if round(t, 6) == s) for s in steps] == [10, 10, 5]
    assert sorted(n for t, n in taken if t < 1.05) == sorted(rt.loops)  # each loop once


class _FailingStore(RetainStore):
    """A retain file whose saves fail while ``failing`` is set (a full disk)."""

    failing = False
    saves = 0

    def save(self, states):
        type(self).saves += 1
        if type(self).failing:
            raise sqlite3.OperationalError("database or disk is full")
        super().save(states)


def test_a_failing_retain_save_logs_one_line_per_streak_and_its_recovery(tmp_path, caplog):
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    store = _FailingStore(tmp_path / "retain.sqlite")
    rt, _, _ = make(loop_toml(ts=0.1), {"io": bus}, retain=store)

    async def main():
        await rt.start()  # the start's write check still succeeds
        _FailingStore.failing = True
        for _ in range(5):  # five saves that fail
            await rt.save_retained()
        assert rt.retain_failures == 5
        _FailingStore.failing = False
        await rt.save_retained()
        assert rt.retain_failures == 0
        await rt.stop()

    with caplog.at_level(logging.DEBUG, logger="ctrlblocks.runtime"):
        bounded(main())
    errors = [r for r in caplog.records if r.levelno >= logging.ERROR]
    assert len(errors) == 1 and "save failed (database or disk is full)" in errors[0].getMessage()
    assert errors[0].exc_info is None  # one line, no traceback
    assert not any(r.exc_info for r in caplog.records)
    assert sum("saved again after 5 failed saves" in r.getMessage() for r in caplog.records) == 1


def retained_sp(path) -> float:
    import json

    with sqlite3.connect(f"file:{path}?mode=ro", uri=True) as c:
        (state,) = c.execute("SELECT state FROM loops WHERE name = 'loop'").fetchone()
    return json.loads(state)["sp"]


def test_a_command_is_in_the_retain_file_when_execute_returns_and_survives_a_kill(tmp_path):
    """A set point confirmed 0.1 s before a kill: no periodic save came (5 s interval), yet
    the new runtime has it.  (The issue: changes 0.3 s and 1.0 s before kill -9 were lost.)"""
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    path = tmp_path / "retain.sqlite"
    rt, clock, _ = runtime(bus, path)

    async def first():
        await rt.start()
        await clock.run_until(1.0)
        old = await rt.execute("loop", user="op", sp=2.5)
        on_disk = await asyncio.to_thread(retained_sp, path)
        rt.command("loop", user="op", tunings={"kp": 1.7})  # the plain call retains too
        await rt.durable("loop")
        await clock.run_until(1.1)  # 0.1 s later: killed (no stop, no final save)
        for t in rt._tasks:
            t.cancel()
        return old, on_disk

    old, on_disk = bounded(first())
    assert old == {"sp": 1.0} and on_disk == 2.5
    rt2, _clock2, _ = runtime(bus, path)

    async def second():
        await rt2.start()
        st = rt2.state("loop")
        await rt2.stop()
        return st

    st = bounded(second())
    assert st["sp"] == 2.5 and st["tunings"]["kp"] == 1.7


def test_a_retain_file_that_fails_makes_execute_raise_with_the_change_in_force(tmp_path):
    bus = MemoryBus()
    bus.on_write = FirstOrder(bus)
    rt, clock, _ = runtime(bus, tmp_path / "retain.sqlite")

    def full_disk(name, state):
        raise OSError(28, "No space left on device")

    async def main():
        await rt.start()
        await clock.run_until(0.5)
        rt.retain.save_loop = full_disk
        with pytest.raises(OSError, match="No space left"):
            await rt.execute("loop", user="op", sp=2.5)
        st = rt.state("loop")
        await rt.stop()
        return st

    st = bounded(main())
    assert st["sp"] == 2.5  # in force, and the caller was told it is not retained
