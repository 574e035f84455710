"""Every shipped scenario's traces are bit-identical to the stored hashes.

A refactoring must not change a single bit of any trace.  A change that is
meant to change behaviour regenerates the hashes (and says so in its commit)::

    PYTHONPATH=$PWD/src python -m tests.sim.make_trace_hashes
"""

from __future__ import annotations

import pytest

from ctrlblocks.sim import run_scenario
from ctrlblocks.sim.report import load_shipped, shipped_scenarios

from .make_trace_hashes import load_hash_file, run_hash, run_key, stack_versions

STORED = load_hash_file()


def test_hash_file_covers_every_shipped_scenario():
    stored_scenarios = {k.split(" / ")[0] for k in STORED["hashes"]}
    assert stored_scenarios == {p.stem for p in shipped_scenarios()}


@pytest.mark.parametrize("name", sorted(p.stem for p in shipped_scenarios()))
def test_shipped_scenario_traces_match_stored_hashes(name):
    if STORED["versions"] != stack_versions():
        pytest.skip(f"hashes recorded with {STORED['versions']}, this is {stack_versions()}")
    (sc,) = load_shipped([name])
    got = {run_key(r): run_hash(r) for r in run_scenario(sc).runs}
    want = {k: v for k, v in STORED["hashes"].items() if k.split(" / ")[0] == name}
    changed = sorted(k for k in set(got) | set(want) if got.get(k) != want.get(k))
    assert not changed, (
        f"traces changed: {changed}; if intended, run "
        "`PYTHONPATH=$PWD/src python -m tests.sim.make_trace_hashes` and say so in the commit"
    )
