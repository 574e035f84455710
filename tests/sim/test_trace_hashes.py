"""Every shipped scenario's traces are bit-identical to the stored hashes.

A refactoring must not change a single bit of any trace.  A change that is
meant to change behaviour regenerates the hashes (and says so in its commit)::

    PYTHONPATH=$PWD/src python -m tests.sim.make_trace_hashes

The scenarios run in a subprocess in the pinned numeric configuration
(``make_trace_hashes.PINNED_ENV``: numpy's and OpenBLAS's kernels fixed to the
AVX2 level), so the same hashes hold on every x86-64 machine with AVX2, with or
without AVX-512 (the module docstring of ``make_trace_hashes`` says which
operations differ otherwise).
"""

from __future__ import annotations

import json

import pytest

from ctrlblocks.sim.report import shipped_scenarios

from .make_trace_hashes import hashes_for, load_hash_file, pinned_run

NAMES = sorted(p.stem for p in shipped_scenarios())


@pytest.fixture(scope="module")
def computed():
    """The stack and the hashes of every shipped run, computed in the pinned configuration."""
    done = pinned_run("--json")
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout)


def test_hash_file_covers_every_shipped_scenario():
    """The newest set (the first) covers every shipped scenario; no set names another one."""
    sets = load_hash_file()
    assert sets, "no hashes recorded"
    assert {k.split(" / ")[0] for k in sets[0]["hashes"]} == set(NAMES)
    for entry in sets[1:]:
        assert {k.split(" / ")[0] for k in entry["hashes"]} <= set(NAMES)


@pytest.mark.parametrize("name", NAMES)
def test_shipped_scenario_traces_match_stored_hashes(computed, name):
    stored = hashes_for(computed["stack"])
    want = {k: v for k, v in (stored or {}).items() if k.split(" / ")[0] == name}
    if not want:
        recorded = [entry["versions"] for entry in load_hash_file()]
        pytest.skip(f"no hashes of {name} recorded on this stack {computed['stack']}; "
                    f"recorded: {recorded}")
    got = {k: v for k, v in computed["hashes"].items() if k.split(" / ")[0] == name}
    changed = sorted(k for k in set(got) | set(want) if got.get(k) != want.get(k))
    assert not changed, (
        f"traces changed: {changed}; if intended, run "
        "`PYTHONPATH=$PWD/src python -m tests.sim.make_trace_hashes` and say so in the commit"
    )
