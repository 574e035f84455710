"""The ``precision`` option of the PID, ADRC and lead-lag blocks (checked in their configs).

``"float64"`` is the blocks' normal arithmetic; ``"float32"`` runs their PLC
cycle (:mod:`.plc_cycle`) with every intermediate rounded to single precision,
as a PLC computing in REAL does.  That cycle covers the configurations the PLC
export covers; :func:`check_precision` refuses the others where the
configuration is made.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from .base import ErrorCode, ParameterError, require_choice

__all__ = [
    "CYCLES",
    "PLC_MAX_WINDOW",
    "PRECISIONS",
    "check_precision",
    "float32_cycle",
    "plc_unsupported",
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
            bad.append("input_delay")
    return bad


def plc_unsupported(config: Any, kind: str) -> list[str]:
    """Options of a block configuration the PLC cycle (and so the export) does not cover.

    A subset of :func:`unsupported`: the PLC cycle of :mod:`.plc_cycle` has
    the PID's velocity algorithm, PV scaling, filters, ramps, lead-lag
    feed-forward, adaptive dead band, every bumpless and anti-windup method,
    and the ADRC's exact discretisation, ``u_real``, anti-backoff and
    ``reverse``, which the compiled kernels lack.  Not covered: a dead-band
    window ``t_stab/ts`` beyond :data:`PLC_MAX_WINDOW` samples (the ARRAY the
    function block holds).
    """
    if kind == "pid" and round(config.t_stab / config.ts) > PLC_MAX_WINDOW:
        return ["t_stab"]
    if kind == "adrc" and getattr(config, "input_delay", 0.0) != 0.0:
        return ["input_delay"]  # the delay line of the ESO's input is not in the PLC cycle yet
    return []


def check_precision(config: Any, kind: str) -> None:
    """Refuse an unknown precision, or ``"float32"`` with options its cycle does not cover."""
    require_choice("precision", config.precision, PRECISIONS)
    bad = plc_unsupported(config, kind) if config.precision == "float32" else []
    if bad:
        raise ParameterError(
            ErrorCode.BAD_PARAMETER,
            "precision",
            f'precision="float32" (the PLC cycle) does not cover the options {bad}; '
            'use the defaults of those options or precision="float64"',
        )
