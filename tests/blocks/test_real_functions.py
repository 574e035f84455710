"""EXP, LN and SQRT of the float32 cycle are DEFINED as the float64 function rounded once.

``real_exp(x) = float32(math.exp(float64(x)))`` is checked against the C
library's ``expf`` over a dense grid of the whole range of EXP; where the two
differ, a 60-digit ``decimal`` exponential decides which one is the correctly
rounded float32 (it is always the definition on this grid).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import math
from decimal import Decimal, localcontext

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ctrlblocks import ADRC
from ctrlblocks.blocks.precision import real_exp, real_ln, real_sqrt

_LIBM = ctypes.util.find_library("m")


def _bits(x: np.float32) -> int:
    return int(np.float32(x).view(np.int32))


def correctly_rounded_exp(x: np.float32) -> np.float32:
    """The float32 nearest to exp(x) (ties to even), from a 60-digit decimal exponential."""
    with localcontext() as ctx:
        ctx.prec = 60
        v = Decimal(float(x)).exp()
        if v >= Decimal(2) ** 128 - Decimal(2) ** 103:  # FLT_MAX + half an ulp: rounds to inf
            return np.float32(np.inf)
        f = np.float32(float(v))
        cands = [np.nextafter(f, np.float32(-np.inf)), f, np.nextafter(f, np.float32(np.inf))]
        return min(cands, key=lambda c: (abs(Decimal(float(c)) - v), _bits(c) & 1))


@pytest.mark.skipif(_LIBM is None, reason="no C math library")
def test_real_exp_is_expf_except_where_expf_is_not_correctly_rounded() -> None:
    libm = ctypes.CDLL(_LIBM)
    libm.expf.restype, libm.expf.argtypes = ctypes.c_float, [ctypes.c_float]
    xs = np.linspace(-104.0, 89.0, 400_001).astype(np.float32)  # subnormal results to overflow
    ours = np.array([real_exp(x) for x in xs], dtype=np.float32)
    theirs = np.array([libm.expf(float(x)) for x in xs], dtype=np.float32)
    differ = np.nonzero(ours.view(np.int32) != theirs.view(np.int32))[0]
    assert len(differ) < 0.002 * len(xs)  # glibc 2.36: 0.06 %
    for i in differ:
        assert _bits(ours[i]) == _bits(correctly_rounded_exp(xs[i]))
        assert abs(_bits(ours[i]) - _bits(theirs[i])) == 1  # expf one ulp off
    # and on a sample where they agree the definition is correctly rounded too
    for i in range(0, len(xs), 2_000):
        assert _bits(ours[i]) == _bits(correctly_rounded_exp(xs[i]))


def test_real_exp_at_the_edges_of_real() -> None:
    assert real_exp(np.float32(0.0)) == 1.0
    assert real_exp(np.float32(89.0)) == np.float32(np.inf)
    assert real_exp(np.float32(3e38)) == np.float32(np.inf)  # math.exp raises there
    assert real_exp(np.float32(-np.inf)) == 0.0
    assert real_exp(np.float32(np.inf)) == np.float32(np.inf)
    assert math.isnan(real_exp(np.float32(np.nan)))
    # the largest x whose exp is finite in REAL: 88.72283 (exp = 3.4027985e38)
    assert real_exp(np.float32(88.72283)) == np.float32(3.4027985e38)
    assert real_exp(np.nextafter(np.float32(88.72283), np.float32(89.0))) == np.inf
    assert type(real_exp(1.0)) is np.float32


@settings(max_examples=300, deadline=None)
@given(st.floats(width=32, allow_nan=False))
def test_real_ln_and_sqrt_are_the_float64_functions_rounded_once(x: float) -> None:
    x32 = np.float32(x)
    if x32 > 0:
        assert real_ln(x32) == np.float32(math.log(float(x32)))
        assert real_sqrt(x32) == np.float32(math.sqrt(float(x32)))
        assert real_sqrt(x32) == np.sqrt(x32)  # IEEE sqrt is correctly rounded: the same
    elif x32 == 0:
        assert real_ln(x32) == -np.inf and real_sqrt(x32) == 0.0
    else:
        assert math.isnan(real_ln(x32)) and math.isnan(real_sqrt(x32))


def test_the_float32_adrc_uses_the_defined_exp_for_its_reference_filter_pole() -> None:
    # the pole exp(-ts/t_ref) in REAL, where numpy's float32 exp is one ulp off the definition
    x = np.float32(-np.float32(0.1)) / np.float32(0.7)
    assert real_exp(x) != np.exp(x)
    adrc = ADRC(ts=0.1, t_ref=0.7, precision="float32")
    adrc(1.0, 0.0)  # the reference starts on y = 0 and takes one step toward sp = 1
    ref = adrc._plc_state["ref"]
    assert ref == np.float32(1.0) - real_exp(x)
    assert ref != np.float32(1.0) - np.exp(x)
