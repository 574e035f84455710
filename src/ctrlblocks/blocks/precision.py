"""The ``precision`` option of the PID, ADRC and lead-lag blocks (checked in their configs).

``"float64"`` is the blocks' normal arithmetic; ``"float32"`` runs their PLC
cycle (:mod:`.plc_cycle`) with every intermediate rounded to single precision,
as a PLC computing in REAL does.  That cycle covers the configurations the PLC
export covers; :func:`check_precision` refuses the others where the
configuration is made.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from .base import ErrorCode, ParameterError, require_choice

__all__ = [
    "CYCLES",
    "PLC_MAX_WINDOW",
    "PRECISIONS",
    "check_precision",
    "float32_cycle",
    "plc_unsupported",
    "real_exp",
    "real_ln",
    "real_sqrt",
    "unsupported",
]

CYCLES: dict[str, Callable[..., float]] = {}
"""Block kind -> its ``precision="float32"`` cycle; filled by :mod:`.plc_cycle` when the
package is imported (plc_cycle is built on the blocks' functions, so the blocks cannot
import it)."""


def float32_cycle(kind: str) -> Callable[..., float]:
    """The ``precision="float32"`` cycle of a block kind (``"pid"``, ``"adrc"``, ``"leadlag"``)."""
    return CYCLES[kind]


PRECISIONS = ("float64", "float32")

# ---------------------------------------------------------------------------
# The standard functions of the float32 cycle, defined
# ---------------------------------------------------------------------------

_ROUND_TO_INF = 3.4028235677973366e38
"""The smallest float64 that rounds to float32 +inf (FLT_MAX plus half its ulp)."""

_F32_INF = np.float32(np.inf)


def _to_real(r: float) -> np.float32:
    """A float64 rounded to the nearest float32 (ties to even), overflow to +-inf, no warning."""
    if -_ROUND_TO_INF < r < _ROUND_TO_INF:
        return np.float32(r)
    return _F32_INF if r > 0.0 else -_F32_INF if r < 0.0 else np.float32(r)


def real_exp(x: Any) -> np.float32:
    """EXP of a REAL in the float32 cycle: DEFINED as ``float32(exp(float64(x)))``.

    The float64 ``math.exp`` (error below one float64 ulp) rounded once to
    float32 is the correctly rounded float32 exponential except where the
    exact value lies within about 2^-29 relative of a float32 rounding
    boundary; on a grid of 400 001 points over the whole range of EXP no such
    point occurs, while the C library's ``expf`` (glibc 2.36) is off by one
    ulp at 0.06 % of them and numpy's float32 ``exp`` at 36 %
    (tests/blocks/test_real_functions.py checks it against a 60-digit
    ``decimal`` exponential).  One definition, so that the block, the float32
    cycle, the test interpreter of the exported ST and the docs agree; a PLC's
    EXP may differ from it by an ulp where its library does not round
    correctly (docs/plc.md).
    """
    v = float(x)
    try:
        r = math.exp(v)
    except OverflowError:
        return _F32_INF
    return _to_real(r)


def real_ln(x: Any) -> np.float32:
    """LN of a REAL, defined as :func:`real_exp` is: ``float32(log(float64(x)))``.

    ``LN(0) = -inf``, ``LN(x < 0) = NaN`` (IEEE 754 ``log``), never an exception.
    """
    v = float(x)
    if v > 0.0:
        return _to_real(math.log(v)) if v != math.inf else _F32_INF
    if v == 0.0:
        return -_F32_INF
    return np.float32(math.nan)


def real_sqrt(x: Any) -> np.float32:
    """SQRT of a REAL: ``float32(sqrt(float64(x)))``, correctly rounded (NaN below 0)."""
    v = float(x)
    if v >= 0.0:
        return np.float32(math.sqrt(v)) if v != math.inf else _F32_INF
    return np.float32(math.nan)

def block_limits(lo: float, hi: float, precision: str) -> tuple[float, float]:
    """Output limits as the block holds them: a float32 block's as the REALs its FB gets.

    The float32 cycle limits in REAL; the output guard, which also acts when no cycle
    runs (a limit written with a bad TS), must limit to the same REAL values, else the
    held output would be the float64 limit, which no REAL is (the MATIEC campaign's
    find).  Infinite limits stay infinite (a finite REAL output is inside both).
    """
    if precision != "float32":
        return lo, hi
    with np.errstate(all="ignore"):
        return tuple(  # type: ignore[return-value]
            v if not math.isfinite(v) else float(np.float32(v)) for v in (lo, hi)
        )


PLC_MAX_WINDOW = 100_000
"""Longest dead-band window ``t_stab/ts`` [samples] of the PLC cycle: its ARRAY of REAL
(400 kB at this length) is declared in the function block."""


def unsupported(config: Any, kind: str) -> list[str]:
    """Options of a block configuration the PLC cycle does not cover (empty: all covered).

    ``kind`` is ``"pid"``, ``"adrc"`` or ``"leadlag"``.  The PLC cycle and the
    compiled kernels run the same per-cycle functions, so this is also the
    configuration part of ``PID.fast_path_blockers`` / ``ADRC.fast_path_blockers``.
    """
    bad: list[str] = []
    if kind == "pid":
        if config.algorithm != "positional":
            bad.append("algorithm")
        if config.pv_range is not None:
            bad.append("pv_range")
        for name in ("sp_filter", "pv_filter", "sp_rate", "out_rate", "ff_k", "deadband"):
            if getattr(config, name) != 0.0:
                bad.append(name)
        if config.bumpless != "integrator":
            bad.append("bumpless")
        if config.anti_windup not in ("clamping", "back_calc_model"):
            bad.append("anti_windup")
    elif kind == "adrc":
        bad = [n for n in ("u_real_on", "anti_backoff", "reverse") if getattr(config, n, False)]
        if config.discretisation != "euler":
            bad.append("discretisation")
        if getattr(config, "input_delay", 0.0) != 0.0:
            # the kernels carry a controller's state as a fixed tuple of floats in registers
            # (loops, banks, lanes): a delay line of up to 100,000 samples is an array per
            # controller, which their state layout does not have (docs/blocks/adrc.md)
            bad.append("input_delay")
        if getattr(config, "pv_range", None) is not None:
            bad.append("pv_range")
        # the input stage's chains (and the tracking differentiator's) are state the
        # kernels' fixed layout lacks, as the PID's
        for name in ("out_rate", "sp_filter", "pv_filter", "sp_rate", "td_time"):
            if getattr(config, name, 0.0) != 0.0:
                bad.append(name)
    return bad


def plc_unsupported(config: Any, kind: str) -> list[str]:
    """Options of a block configuration the PLC cycle (and so the export) does not cover.

    A subset of :func:`unsupported`: the PLC cycle of :mod:`.plc_cycle` has
    the PID's velocity algorithm, PV scaling, filters, ramps, lead-lag
    feed-forward, adaptive dead band, every bumpless and anti-windup method,
    and the ADRC's exact discretisation, ``u_real``, anti-backoff, ``reverse``,
    ``input_delay``, ``out_rate``, input stage (PV range, SP/PV filters, SP
    ramp) and tracking differentiator, which the compiled kernels lack.  Not covered: a dead-band
    window ``t_stab/ts`` beyond :data:`PLC_MAX_WINDOW` samples (the ARRAY the
    function block holds).
    """
    if kind == "pid" and round(config.t_stab / config.ts) > PLC_MAX_WINDOW:
        return ["t_stab"]
    return []


_REAL_MAX = 3.4028234663852886e38  # the largest float32
_REAL_MIN = 1.401298464324817e-45  # the smallest positive float32 (subnormal)


def _check_real_range(config: Any) -> None:
    """Refuse a finite parameter a REAL cannot hold: beyond its range, or non-zero but below it.

    A PLC's REAL (and the float32 cycle) would turn 1e300 into inf and 1e-50 into
    0 (a b0 of 0 divides by zero); infinite limits stay allowed (they are +-REAL_MAX).
    """
    for f in dataclasses.fields(config):
        v = getattr(config, f.name)
        if isinstance(v, bool) or not isinstance(v, float | int):
            continue
        x = abs(float(v))
        if x != math.inf and (x > _REAL_MAX or 0.0 < x < _REAL_MIN / 2.0):
            raise ParameterError(
                ErrorCode.BAD_PARAMETER,
                f.name,
                f'{v!r} is outside the range of REAL, which precision="float32" computes in',
            )


def check_precision(config: Any, kind: str) -> None:
    """Refuse an unknown precision, or ``"float32"`` with options its cycle does not cover."""
    require_choice("precision", config.precision, PRECISIONS)
    if config.precision == "float32":
        _check_real_range(config)
    bad = plc_unsupported(config, kind) if config.precision == "float32" else []
    if bad:
        raise ParameterError(
            ErrorCode.BAD_PARAMETER,
            "precision",
            f'precision="float32" (the PLC cycle) does not cover the options {bad}; '
            'use the defaults of those options or precision="float64"',
        )
