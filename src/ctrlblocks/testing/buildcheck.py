"""Checking an installation's compiled blocks against the interpreted ones (``compile --check``).

The compiled PID and ADRC are built from the same sources as the interpreted
blocks and must compute exactly what they compute (``ctrlblocks.compiled``).
:func:`check` holds an installed build to that, with the campaign's seeded
actions of :func:`.fuzz.traces`; the release CI runs it on every binary wheel
it builds, on the machine that built it.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from typing import Any

from .. import compiled
from ..compiled import BuildError
from .fuzz import traces

_TRACES_SCRIPT = """
import json, sys
from ctrlblocks.testing import traces
print(json.dumps(traces(*(int(a) for a in sys.argv[1:4]))))
"""


def check(steps: int = 300, seeds: int = 2, float32_seeds: int = 1) -> str:
    """Check that the compiled blocks are loaded and compute what the interpreted ones do.

    Runs the fuzz campaign's seeded actions (:func:`ctrlblocks.testing.traces`:
    NaN, infinite and huge inputs, modes, limits, refused and accepted
    reconfiguration, snapshot/restore, on every block, PID and ADRC also in
    ``precision="float32"``) here and in a child process with
    ``CTRLBLOCKS_COMPILED=off``, and raises :class:`BuildError` naming the
    first difference, or when the compiled blocks are not in use.  Returns a
    one-line summary.  ``ctrlblocks compile --check`` runs it; the release CI
    runs that on every binary wheel it builds (docs/performance.md, "The release
    CI").
    """
    st = compiled.status()
    if not st["active"]:
        raise BuildError(f"the compiled blocks are not in use: {st['reason']}")
    # through JSON as the child's, so both hold lists of [repr(out), error code]
    mine = json.loads(json.dumps(traces(steps, seeds, float32_seeds)))["traces"]
    env = {**os.environ, "CTRLBLOCKS_COMPILED": "off"}
    args = [str(steps), str(seeds), str(float32_seeds)]
    run = subprocess.run([sys.executable, "-c", _TRACES_SCRIPT, *args], capture_output=True,
                         text=True, env=env, timeout=900)  # fmt: skip
    if run.returncode != 0:
        raise BuildError(f"the interpreted run failed: {run.stderr.strip()[-400:]}")
    compare_traces(mine, json.loads(run.stdout)["traces"])
    return (
        f"compiled blocks in use ({st['folder']}): every block bit-equal to the "
        f"interpreted blocks over {len(mine)} runs of {steps} campaign actions"
    )


def compare_traces(compiled: dict[str, list[Any]], interpreted: dict[str, list[Any]]) -> None:
    """Raise :class:`BuildError` naming the first difference of two ``traces()`` results."""
    if compiled.keys() != interpreted.keys():
        raise BuildError(f"the runs differ: {sorted(compiled.keys() ^ interpreted.keys())[:5]}")
    for key, trace in compiled.items():
        other = interpreted[key]
        for i, (a, b) in enumerate(zip(trace, other, strict=False)):
            if a != b:
                raise BuildError(
                    f"{key}: action {i}: the compiled block gives {a}, the interpreted {b}"
                )
        if len(trace) != len(other):
            raise BuildError(f"{key}: {len(trace)} actions compiled, {len(other)} interpreted")
