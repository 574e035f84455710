"""The PLC cycle run in float64 is the float64 block over seeded hostile sequences.

``test_cycle.py`` compares them over the project's traces; the hostile
generator (:mod:`.hostile`) adds what those traces do not do: retunes of any
tuning field through ``configure()`` at random moments (REVERSE, the
discretisation, the algorithm, the order ...), hostile set points, measurements,
manual, tracking and actuator values in the same cycles, random modes.  Every
output of the FB -- for the ADRC also the outputs of Nowak et al. 2018, Fig. 2
(E, Y, Y_REF, X1..X3, DISTURBANCE) -- must be the block's, to float64
rounding.  (The float32 block and the compiled FB are compared bit for bit by
``test_matiec.py``; this test is where a cycle that differs from the block's
*behaviour* shows, whatever the precision.)

The process values are those both compute alike in float64: NaN, +-inf,
denormals, +-0, 1e30, 1e-30 -- not 1.7e308 or 3e38, which the cycle (written
for REAL) sees as beyond REAL where the float64 block computes on.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from ctrlblocks.blocks import plc_cycle as pc
from ctrlblocks.plc.specs import spec_for

from .hostile import HOSTILE, STARTS, hostile_trace

POOL = tuple(v for v in HOSTILE if not 1e38 < abs(v) < math.inf)

CASES = STARTS

_CYCLE = {
    "pid": (pc.pid_cycle, pc.PID_RESULTS, pc.pid_state),
    "adrc": (pc.adrc_cycle, pc.ADRC_RESULTS, pc.adrc_state),
    "leadlag": (pc.leadlag_cycle, pc.LEADLAG_RESULTS, pc.leadlag_state),
}


def _close(got: Any, want: Any, scale: float) -> bool:
    if isinstance(want, bool | int) or isinstance(got, bool):
        return bool(got == want)
    g, w = float(got), float(want)
    if math.isnan(w) or math.isnan(g):
        return math.isnan(w) and math.isnan(g)
    return g == w or abs(g - w) <= 1e-9 * (abs(w) + scale)


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
@pytest.mark.parametrize("case", range(len(CASES)))
def test_float64_cycle_is_the_float64_block_over_seeded_hostile_sequences(case, seed):
    kind, cfg = CASES[case]
    start, run = hostile_trace(kind, 600, seed + 100 * case, precision="float64", pool=POOL,
                               p_hostile=0.05, **cfg)  # fmt: skip
    spec = spec_for(start)
    fn, results, state = _CYCLE[kind]
    py = {st: name for name, st in spec.names().items()}
    args = {k: spec.values[k] for k in (*(v.py for v in spec.inputs), *state(start.config))}
    retunes = 0
    for k, (inp, out) in enumerate(zip(run.inputs, run.outputs, strict=True)):
        retunes += any(name not in spec.process for name in inp)
        for name, v in inp.items():
            args[py[name]] = v
        res = dict(zip(results, fn(**args), strict=True))
        for name in args:
            if name in res:
                args[name] = res[name]
        scale = max(abs(float(v)) for v in out.values() if np.isfinite(float(v))) + 1.0
        for name, want in out.items():
            got = res[py[name]]
            assert _close(got, want, scale), (
                f"sample {k}: {name} = {got!r} in the cycle, {want!r} in the block; "
                f"inputs {inp}")  # fmt: skip
    assert retunes >= 3  # the run did retune
