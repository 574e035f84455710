"""The fuzz campaign of the block contract, short CI profile (docs/reliability.md).

A hypothesis ``RuleBasedStateMachine`` over every exported block: a random valid
configuration of all options, then random process steps with hostile values
and sample times, mode switches, limit changes, valid and invalid
reconfigurations, snapshot/restore and reset.  The actions and the checks are
those of :mod:`ctrlblocks.testing` (one implementation; the long campaign
``python -m ctrlblocks.testing`` draws the same actions from a seeded
random generator), which fuzzes any block with a ``FuzzSpec``: the shipped
ones (``ctrlblocks.testing.generators``) and blocks of one's own, driven
through the Controller interface or their call.
"""

from __future__ import annotations

import dataclasses
import inspect
import io
import math
import random

import pytest
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import (
    RuleBasedStateMachine,
    initialize,
    precondition,
    rule,
    run_state_machine_as_test,
)

import ctrlblocks
from ctrlblocks import compiled
from ctrlblocks.testing import (
    BAD_PARAMS,
    HOSTILE,
    HOSTILE_DT,
    Driver,
    FuzzSpec,
    fuzz,
    register_fuzz,
)
from ctrlblocks.testing import FUZZ_SPECS as BLOCKS

VALUES = st.one_of(
    st.floats(-200.0, 200.0),
    st.sampled_from(HOSTILE),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(10**20), 10**20),
)
DTS = st.one_of(st.none(), st.none(), st.sampled_from(HOSTILE_DT), st.floats(1e-6, 10.0))
FLAGS = st.one_of(st.booleans(), st.sampled_from((None, 1, 0, "x")))


def _machine(name: str) -> type[RuleBasedStateMachine]:
    spec = BLOCKS[name]

    class Campaign(RuleBasedStateMachine):
        driver: Driver | None = None

        @initialize(seed=st.integers(0, 2**32 - 1))
        def make(self, seed: int) -> None:
            r = random.Random(seed)
            for _ in range(50):
                try:
                    self.driver = Driver(spec, spec.config(r))
                    return
                except ctrlblocks.ParameterError:
                    continue

        def _ok(self) -> bool:
            return self.driver is not None

        @precondition(_ok)
        @rule(
            vals=st.lists(VALUES, min_size=5, max_size=5),
            plant=st.booleans(),
            dt=DTS,
            flags=st.lists(FLAGS, min_size=3, max_size=3),
        )
        def step(self, vals, plant, dt, flags) -> None:
            if plant and spec.controller:
                vals[1] = None  # the loop's own plant output
            self.driver.act_step(vals, dt, flags)
            self.driver.step_done()

        @precondition(lambda self: self._ok() and spec.controller)
        @rule(name=st.sampled_from(spec.modes), value=FLAGS, value2=VALUES)
        def mode(self, name, value, value2) -> None:
            self.driver.act_mode(name, value)
            if name in spec.mode_values:
                self.driver.act_mode(spec.mode_values[name], value2)

        @precondition(_ok)
        @rule(lo=VALUES, hi=VALUES)
        def limits(self, lo, hi) -> None:
            self.driver.act_limits(lo, hi)

        @precondition(_ok)
        @rule(data=st.data())
        def configure(self, data) -> None:
            fields = [f.name for f in dataclasses.fields(self.driver.block.config)]
            if not spec.configurable or not fields:
                return
            names = data.draw(st.lists(st.sampled_from(fields), min_size=1, max_size=3))
            if data.draw(st.booleans()):  # values from another valid configuration
                new = spec.config(random.Random(data.draw(st.integers(0, 2**32 - 1))))
                changes = {n: new[n] for n in names if n in new}
            else:
                changes = {n: data.draw(st.sampled_from(BAD_PARAMS) | VALUES) for n in names}
            self.driver.act_configure(changes)

        @precondition(_ok)
        @rule(
            vals=st.lists(VALUES, min_size=5, max_size=5),
            dt=DTS,
            flags=st.lists(FLAGS, min_size=3, max_size=3),
        )
        def snapshot_restore(self, vals, dt, flags) -> None:
            self.driver.act_snapshot_restore(vals, dt, flags)

        @precondition(_ok)
        @rule()
        def reset(self) -> None:
            self.driver.act_reset()

    Campaign.__name__ = f"Campaign{name}"
    return Campaign


CI = settings(
    max_examples=6,
    stateful_step_count=20,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
    derandomize=True,
)


def test_the_campaign_covers_every_exported_block() -> None:
    exported = {
        n
        for n in ctrlblocks.__all__
        if isinstance(getattr(ctrlblocks, n), type)
        and issubclass(getattr(ctrlblocks, n), ctrlblocks.Block)
        and getattr(ctrlblocks, n) is not ctrlblocks.Block
    }
    # a block added to ctrlblocks without a FuzzSpec (ctrlblocks/testing/generators.py) fails here
    assert exported == set(BLOCKS) == set(fuzz.exported_blocks())
    assert len(BLOCKS) >= 18


@pytest.mark.parametrize("name", sorted(BLOCKS))
def test_block_keeps_its_contract_under_random_actions(name: str) -> None:
    run_state_machine_as_test(_machine(name), settings=CI)


def test_the_long_driver_reports_progress_counts_and_zero_breaches() -> None:
    buf = io.StringIO()
    rc = fuzz.run(["PT1", "PID"], steps=300, seed=5, every=0.0, out=buf)
    text = buf.getvalue()
    assert rc == 0
    assert "PT1=300" in text and "PID=300" in text and "steps/s" in text
    assert "done: 600 steps, 300 to 300 per block, 0 breaches" in text


def test_a_breach_exits_non_zero_with_a_reproducer(monkeypatch) -> None:
    real = Driver.act_step

    def broken(self, vals, dt, flags):
        real(self, vals, dt, flags)
        if self.steps == 50:
            self.block.out = math.nan
            self._check_out(self.block, "step")

    monkeypatch.setattr(Driver, "act_step", broken)
    buf = io.StringIO()
    assert fuzz.run(["Saturation"], steps=200, seed=1, every=1e9, out=buf) == 1
    text = buf.getvalue()
    assert "BREACH in Saturation (seed 1, step" in text and "is not a finite float" in text
    assert "python -m ctrlblocks.testing --block Saturation --seed 1 --steps" in text
    assert "last actions:" in text


def test_the_time_budget_stops_the_campaign_with_its_counts() -> None:
    buf = io.StringIO()
    assert fuzz.run(["DeadBand"], steps=10**9, seed=2, every=1e9, out=buf, minutes=0.002) == 0
    assert "stopped at the time budget:" in buf.getvalue()


def test_the_command_line_runs_a_short_campaign(capsys) -> None:
    assert fuzz.main(["--steps", "50", "--block", "DeadBand", "--every", "0"]) == 0
    assert "DeadBand=50" in capsys.readouterr().out


TWO_PHASE = sorted(n for n, spec in BLOCKS.items() if spec.two_phase)


def test_every_block_with_both_paths_is_driven_on_both() -> None:
    # a block whose compute_output takes __call__'s arguments has the two-phase form
    # (ManualStation's compute_output() is only its present output: one path)
    def same_args(cls) -> bool:
        call = compiled.signature(cls).parameters  # also for a compiled class
        comp = inspect.signature(getattr(cls, "compute_output", lambda self: None)).parameters
        return list(comp)[1:3] == list(call)[1:3] and len(comp) > 2

    expected = {n for n, spec in BLOCKS.items() if same_args(spec.cls)}
    assert set(TWO_PHASE) == expected == {"ADRC", "GainSchedule", "PID"}


@pytest.mark.parametrize("name", TWO_PHASE)
def test_a_state_divergence_the_outputs_hide_is_a_breach(name: str) -> None:
    r = random.Random(3)
    driver = None
    while driver is None or driver.twin is None:
        try:
            driver = Driver(BLOCKS[name], BLOCKS[name].config(r))
        except ctrlblocks.ParameterError:
            continue
    for _ in range(3):
        driver.act_step([30.0, None, 0.0, 0.0, 50.0], None, [True, False, False])
    ctl = driver._ctl(driver.twin)
    field = next(f for f in reversed(ctl._state_fields) if isinstance(getattr(ctl, f), float))
    setattr(ctl, field, getattr(ctl, field) + 1.0)  # a state that is not the output
    with pytest.raises(fuzz.Breach, match="states differ"):
        driver._compare_twin("a tampered twin")


def test_a_snapshot_without_copies_reads_the_state_in_place() -> None:
    ma = ctrlblocks.MovingAverage(n=4)
    ma(1.0)
    assert ma.snapshot()["_buf"] is not ma._buf  # a copy, to keep and restore
    assert ma.snapshot(copy=False)["_buf"] is ma._buf  # the campaign's cheap comparison
    pid = ctrlblocks.PID(kp=1.0, ti=2.0, sp_filter=1.0)
    live = pid.snapshot(copy=False)
    assert live["_subs"]["_sp_filter"] == pid.snapshot()["_subs"]["_sp_filter"]
    sched = ctrlblocks.GainSchedule(pid, breakpoints=(0.0, 1.0), kp=(1.0, 2.0))
    assert sched.snapshot(copy=False)["controller"]["_subs"].keys() == live["_subs"].keys()


def test_states_holding_arrays_are_compared_element_by_element() -> None:
    # The float32 PLC cycle keeps the dead band's window as an array: comparing it
    # with `==` raised ValueError in the checker (the 10^7 PID run, seed 7601).
    import numpy as np

    from ctrlblocks.testing.fuzz import _snap_equal

    w = np.array([1.0, np.nan, 3.0], dtype=np.float32)
    assert _snap_equal({"_plc_state": {"win": w}}, {"_plc_state": {"win": w.copy()}})
    assert not _snap_equal({"win": w}, {"win": np.array([1.0, np.nan, 3.5], np.float32)})
    assert not _snap_equal({"win": w}, {"win": w[:2]})
    assert _snap_equal(np.array([1.0]), np.array([1.0 + 1e-13]), 1e-12)
    assert not _snap_equal(np.array([1.0]), np.array([1.0 + 1e-11]), 1e-12)


# -- blocks of one's own: fuzzed through the protocol -------------------------------------


class MyPI(ctrlblocks.PID):
    """A controller of one's own (here a PI made from the PID): known to the campaign only
    by its FuzzSpec, driven through the Controller interface (the default step: ``sp``,
    ``pv``, ``pv_ok``, ``dt``; the modes ``manual`` and ``awin``)."""


class MyDeadBand(ctrlblocks.DeadBand):
    """A plain block of one's own: called with one value (its call takes no ``dt``)."""


def _my_pi(r: random.Random) -> dict:
    return {"kp": r.uniform(0.1, 10.0), "ti": r.uniform(0.1, 100.0), "ts": 0.1,
            "u_min": r.uniform(-10.0, 0.0), "u_max": r.uniform(0.0, 10.0)}  # fmt: skip


def test_a_block_of_ones_own_is_fuzzed_through_the_protocol() -> None:
    specs = (FuzzSpec("MyPI", MyPI, _my_pi), FuzzSpec("MyDeadBand", MyDeadBand,
                                                       lambda r: {"width": r.uniform(0, 5)}))
    try:
        for spec in specs:
            register_fuzz(spec)
        pi, db = BLOCKS["MyPI"], BLOCKS["MyDeadBand"]
        assert pi.controller and pi.two_phase and pi.bumpless and pi.step is fuzz.controller_step
        assert pi.modes == ("manual", "awin") and not db.controller and not db.two_phase
        buf = io.StringIO()
        assert fuzz.run(["MyPI", "MyDeadBand"], steps=2000, seed=4, every=1e9, out=buf) == 0
        assert "MyPI=2000 MyDeadBand=2000" in buf.getvalue()
        run_state_machine_as_test(_machine("MyPI"), settings=CI)
    finally:
        for spec in specs:
            del BLOCKS[spec.name]


def test_a_broken_block_of_ones_own_is_caught() -> None:
    class Fragile(ctrlblocks.DeadBand):  # float(x) raises on None, a complex, "x" ...
        def __call__(self, x):
            return super().__call__(float(x))

    register_fuzz(FuzzSpec("Fragile", Fragile, lambda r: {"width": 1.0}))
    try:
        buf = io.StringIO()
        assert fuzz.run(["Fragile"], steps=20_000, seed=1, every=1e9, out=buf) == 1
        text = buf.getvalue()
        assert "BREACH in Fragile" in text and "step raised" in text
        assert "python -m ctrlblocks.testing --block Fragile --seed 1" in text
    finally:
        del BLOCKS["Fragile"]
