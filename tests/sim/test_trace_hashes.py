"""Every shipped scenario's traces are bit-identical to the stored hashes.

A refactoring must not change a single bit of any trace.  A change that is
meant to change behaviour regenerates the hashes (and says so in its commit)::

    PYTHONPATH=$PWD/src python -m tests.sim.make_trace_hashes
"""

from __future__ import annotations

import pytest

from ctrlblocks.sim import run_scenario
from ctrlblocks.sim.report import load_shipped, shipped_scenarios

from .make_trace_hashes import hashes_for, load_hash_file, run_hash, run_key, stack_versions

STACK = stack_versions()
STORED = hashes_for(STACK)


def test_hash_file_covers_every_shipped_scenario():
    """The newest set (the first) covers every shipped scenario; no set names another one."""
    sets = load_hash_file()
    assert sets, "no hashes recorded"
    shipped = {p.stem for p in shipped_scenarios()}
    assert {k.split(" / ")[0] for k in sets[0]["hashes"]} == shipped
    for entry in sets[1:]:
        assert {k.split(" / ")[0] for k in entry["hashes"]} <= shipped


@pytest.mark.parametrize("name", sorted(p.stem for p in shipped_scenarios()))
def test_shipped_scenario_traces_match_stored_hashes(name):
    want = {k: v for k, v in (STORED or {}).items() if k.split(" / ")[0] == name}
    if not want:
        recorded = [entry["versions"] for entry in load_hash_file()]
        pytest.skip(f"no hashes of {name} recorded on this stack {STACK}; recorded: {recorded}")
    (sc,) = load_shipped([name])
    got = {run_key(r): run_hash(r) for r in run_scenario(sc).runs}
    changed = sorted(k for k in set(got) | set(want) if got.get(k) != want.get(k))
    assert not changed, (
        f"traces changed: {changed}; if intended, run "
        "`PYTHONPATH=$PWD/src python -m tests.sim.make_trace_hashes` and say so in the commit"
    )
