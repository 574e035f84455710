"""The one-cycle blocks keep their memory finite and their outputs in range under hostile data.

Their cycles treat any value beyond the REAL range as invalid and saturate accumulated
times (``blocks/cycleblock.py``), so no input sequence -- NaN, inf, 1e308, a dt of 1e308,
huge finite values that overflow the law -- leaves a non-finite value in the memory.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from ctrlblocks import SetpointProgram, ThreePoint, TransferFunction, TwoPoint
from ctrlblocks.blocks.transfer import lowpass, notch, tustin
from ctrlblocks.testing import HOSTILE, HOSTILE_DT

VALUES = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from(HOSTILE))
DTS = st.one_of(st.none(), st.sampled_from(HOSTILE_DT), st.floats(1e-6, 1e6))
FLAGS = st.booleans()


def _finite(v: Any) -> bool:
    if isinstance(v, list):
        return all(_finite(x) for x in v)
    if isinstance(v, bool | np.bool_):
        return True
    return bool(abs(float(v)) <= 3.4028235e38)


def _check(block: Any) -> None:
    mem = block.snapshot()["_mem"]
    assert all(_finite(v) for v in mem.values()), mem
    lo, hi = block.output_limits()
    assert math.isfinite(block.out) and lo <= block.out <= hi


def _blocks(precision: str) -> list[Any]:
    return [
        TwoPoint(hysteresis=0.5, t_min_on=0.3, ts=0.1, precision=precision),
        ThreePoint(deadband=0.5, hysteresis=0.5, t_min_off=0.2, ts=0.1, precision=precision),
        TransferFunction(sections=(tustin([1e3], [1.0, 1.0], 0.1), *lowpass(2.0, 0.1, 3),
                                   notch(5.0, 2.0, 0.1)), ts=0.1, precision=precision),
        SetpointProgram(segments=((1e30, 1e30, 1e30), (-5.0, 0.0, 0.1)), repeat=True,
                        holdback_soak=1.0, ts=0.1, precision=precision),
    ]  # fmt: skip


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(VALUES, VALUES, FLAGS, FLAGS, DTS), min_size=1, max_size=40),
       st.sampled_from(["float64", "float32"]))  # fmt: skip
def test_memory_stays_finite_under_hostile_sequences(steps: list, precision: str) -> None:
    tp, th, tf, sp = _blocks(precision)
    for a, b, f1, f2, dt in steps:
        tp(a, b, pv_ok=f1, enable=f2, dt=dt)
        _check(tp)
        th(a, b, pv_ok=f1, dt=dt)
        _check(th)
        tf(b, init=f1 and f2)
        _check(tf)
        sp(b, pv_ok=f1, run=f2, dt=dt)
        _check(sp)


def test_float32_refuses_numbers_no_real_holds_and_keeps_the_old_config() -> None:
    import pytest

    from ctrlblocks import ErrorCode, ParameterError

    tp = TwoPoint(ts=1.0, precision="float32")
    for bad in ({"ts": 1e300}, {"hysteresis": 1e-50}):
        with pytest.raises(ParameterError) as e:
            tp.configure(**bad)
        assert e.value.code == ErrorCode.BAD_PARAMETER
    assert tp.config.ts == 1.0
    TwoPoint(ts=1e300)  # float64 takes it
    with pytest.raises(ParameterError):
        TransferFunction(sections=((1e-50, 0.0, 0.0, 0.0, 0.0),), precision="float32")
