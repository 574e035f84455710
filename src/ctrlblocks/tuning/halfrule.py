"""Skogestad's half rule and the inverse half-rule of the ADRC paper.

Half rule (Skogestad, *Simple analytic rules for model reduction and PID
controller tuning*, J. Process Control 13 (2003) 291-309, section 2; Nowak et al. 2018
reference [21]).  A stable model with real lags ``tau_1 >= tau_2 >= ...``,
inverse-response (right-half-plane zero) time constants ``T_inv_j`` and dead
time ``theta_0`` is reduced by giving half of the largest neglected time
constant to the smallest retained one and the other half to the dead time:

* FOPDT:  ``tau = tau_1 + tau_2/2``,
  ``theta = theta_0 + tau_2/2 + sum_{i>=3} tau_i + sum_j T_inv_j + h/2``
* SOPDT:  ``tau_1``, ``tau_2' = tau_2 + tau_3/2``,
  ``theta = theta_0 + tau_3/2 + sum_{i>=4} tau_i + sum_j T_inv_j + h/2``

where ``h`` is the sample time of a digital controller (Skogestad adds h/2 for
the zero-order hold).  Left-half-plane zeros need Skogestad's additional approximation rules for
numerator terms and are not supported here.  (Nowak et al.'s (2018) reference list
prints the volume as 11; the paper is in volume 13.)

Inverse half-rule (Nowak et al. 2018, section 3.3, eqs. (5)-(9) and Table 1).  Given
an FOPDT ``k e^{-T0 s}/(T s + 1)`` and an assumed ADRC order ``n`` of a
process *without* dead time, estimate the ADRC scaling parameter ``b0``:

* ``n = 1``: ``b0 = k/T`` (Nowak et al. 2018, section 6);
* ``n = 2``: the half rule inverted, ``T1 = T - T0``, ``T2 = 2 T0`` and
  ``b0 = k/(T1 T2)`` (the paper's text prints "T1 = T T0": an extraction slip
  for ``T1 = T - T0``);
* ``n = 3``: the time constants are not unique; (5a)/(5b) look for the
  largest/smallest product ``T1 T2 T3`` subject to ``T1 >= T2 >= T3 > 0`` (6)
  and the half-rule equalities ``T = T1 + T2/2``, ``T0 = T2/2 + T3`` (7).
  The maximum is the stationary point (8)::

      T1max = ((2T - T0) + sqrt((T - T0)^2 + T T0)) / 3
      T2max = 2 (T - T1max),   T3max = T0 - T2max/2,   b0_min = k/(T1max T2max T3max)

  and the minimum lies on the boundary of (6) (the text after (9))::

      T2+ = min(T/1.5, 2 T0),  T1- = T - T2+/2,  T3- = T0 - T2+/2
      T1+ = T - T0/3,          T2- = T3+ = T0/1.5
      b0_max = max(k/(T1- T2+ T3-), k/(T1+ T2- T3+))

  The paper prints ``T1+ = T - 0.33 T0``; with ``T2- = T0/1.5`` only the exact
  1/3 satisfies (7) (``T1 + T2/2 = T``), so 1/3 is used.  For Table 1 both
  values give the same ``b0_max`` because the first term of the max wins
  (K2: 0.10218 vs 0.0250/0.0249).  The paper advises ``b0 = b0_min``.

  When ``T >= 3 T0`` the boundary ``T2+ = 2 T0`` makes ``T3- = 0``: a
  second-order process fits the same FOPDT, and ``b0_max`` is infinite.

Table 1 of Nowak et al. 2018: K1 (k = 0.56, T = 11, T0 = 3.3), n = 2 -> b0 = 0.011;
K2 (0.73, 8.3, 3), n = 3 -> b0 in [0.0236, 0.1022].  (Table 2 lists, for the
FOPDT fit of the real pneumatic setup, n = 1: 0.099, n = 2: 0.025,
n = 3: [0.025, 0.13].)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from ..blocks.base import (
    ErrorCode,
    ParameterError,
    require_finite,
    require_nonnegative,
    require_positive,
)
from .identify import FOPDT, SOPDT

__all__ = ["InverseHalfRule", "half_rule", "inverse_half_rule"]


@dataclass(frozen=True)
class InverseHalfRule:
    """Result of :func:`inverse_half_rule`.

    Attributes
    ----------
    b0 : float
        Advised scaling parameter (``b0_min`` for n = 3, as Nowak et al. 2018 advises).
    b0_min, b0_max : float
        Acceptable range (both equal to ``b0`` for n = 1 and n = 2;
        ``b0_max`` may be ``inf`` for n = 3, see the module docstring).
    time_constants : tuple of float
        The process time constants that give ``b0`` [s]
        (``(T,)``, ``(T1, T2)`` or ``(T1max, T2max, T3max)``).
    order : int
        ADRC order n.
    warnings : list of str
        Conditions the user should know (ordering of T1, T2 violated, ...).
    """

    b0: float
    b0_min: float
    b0_max: float
    time_constants: tuple[float, ...]
    order: int
    warnings: list[str] = field(default_factory=list)


def inverse_half_rule(k: float, T: float, T0: float, order: int) -> InverseHalfRule:
    """ADRC scaling parameter ``b0`` from an FOPDT model (Nowak et al. 2018, section 3.3).

    Parameters
    ----------
    k : float
        Process gain [PV unit / MV unit]; any sign (``b0`` takes its sign).
    T : float
        FOPDT time constant [s], > 0.
    T0 : float
        FOPDT dead time [s], >= 0 (> 0 for n = 2, 3).
    order : int
        Assumed process (= ADRC) order n: 1, 2 or 3.

    Returns
    -------
    InverseHalfRule
        ``b0``, ``b0_min``, ``b0_max`` [PV unit / (MV unit s^n)] and the time
        constants behind them.  Formulas: see the module docstring
        (n = 1: ``k/T``; n = 2: ``k/((T - T0) 2 T0)``; n = 3: (8) and the
        boundary limits after (9)).

    Raises
    ------
    ParameterError
        If the numbers are not finite, ``T <= 0``, ``T0 < 0``, ``k == 0``, the
        order is not 1..3, or no process of that order without dead time has
        this FOPDT approximation (n = 2: ``T <= T0``; n = 3: ``T < T0``).
    """
    k = _require_nonzero("k", k)
    T = require_positive("T", T, ErrorCode.BAD_TIME_CONSTANT)
    T0 = require_nonnegative("T0", T0, ErrorCode.BAD_TIME_CONSTANT)
    if order not in (1, 2, 3) or isinstance(order, bool):
        raise ParameterError(ErrorCode.BAD_ORDER, "order", f"must be 1, 2 or 3, got {order!r}")
    warnings: list[str] = []
    if order == 1:
        b0 = k / T
        return InverseHalfRule(b0, b0, b0, (T,), 1, warnings)
    if T0 <= 0.0:
        raise ParameterError(
            ErrorCode.BAD_TIME_CONSTANT,
            "T0",
            f"must be > 0 for order {order}: a lag-only FOPDT is a first-order process",
        )
    if order == 2:
        T1, T2 = T - T0, 2.0 * T0
        if T1 <= 0.0:
            raise ParameterError(
                ErrorCode.BAD_TIME_CONSTANT,
                "T0",
                f"T0 = {T0:.4g} >= T = {T:.4g}: no second-order lag has this FOPDT "
                "(T1 = T - T0 <= 0)",
            )
        if T1 < T2:
            warnings.append(
                f"T < 3 T0 ({T:.4g} < {3 * T0:.4g}): T1 = T - T0 = {T1:.4g} is smaller than "
                f"T2 = 2 T0 = {T2:.4g}; the half rule would pair them the other way round"
            )
        b0 = k / (T1 * T2)
        return InverseHalfRule(b0, b0, b0, (T1, T2), 2, warnings)
    # order 3
    if T0 > T:
        raise ParameterError(
            ErrorCode.BAD_TIME_CONSTANT,
            "T0",
            f"T0 = {T0:.4g} > T = {T:.4g}: no third-order lag T1 >= T2 >= T3 has this FOPDT",
        )
    # (8): stationary point = maximum of T1 T2 T3 -> b0_min
    T1max = ((2.0 * T - T0) + math.sqrt((T - T0) ** 2 + T * T0)) / 3.0
    T2max = 2.0 * (T - T1max)
    T3max = T0 - T2max / 2.0
    b0_min = k / (T1max * T2max * T3max)
    # boundary limits after (9) -> b0_max (1/3 instead of the printed 0.33, see above)
    T2p = min(T / 1.5, 2.0 * T0)
    T1m = T - 0.5 * T2p
    T3m = T0 - 0.5 * T2p
    T1p = T - T0 / 3.0
    T2m = T3p = T0 / 1.5
    second = k / (T1p * T2m * T3p)
    if T3m <= 1e-12 * T0:
        b0_max = math.copysign(math.inf, k)
        warnings.append(
            f"T >= 3 T0: a second-order process (T3 -> 0) has the same FOPDT, "
            f"so b0_max is unbounded; b0 = b0_min = {b0_min:.4g} is advised"
        )
    else:
        first = k / (T1m * T2p * T3m)
        b0_max = first if abs(first) >= abs(second) else second
    return InverseHalfRule(b0_min, b0_min, b0_max, (T1max, T2max, T3max), 3, warnings)


def half_rule(
    gain: float,
    time_constants: Sequence[float],
    dead_time: float = 0.0,
    *,
    inverse_response: Sequence[float] = (),
    order: int = 1,
    ts: float = 0.0,
) -> FOPDT | SOPDT:
    """Reduce a high-order model to FOPDT or SOPDT by Skogestad's half rule.

    Skogestad (2003), J. Process Control 13, 291-309, section 2 (see the
    module docstring for the formulas).

    Parameters
    ----------
    gain : float
        Static gain k.
    time_constants : sequence of float
        Lag time constants ``tau_i`` > 0 [s] of ``prod 1/(tau_i s + 1)``
        (any order; they are sorted, largest first).
    dead_time : float
        Dead time ``theta_0`` [s] of the full model.
    inverse_response : sequence of float
        Time constants ``T_inv > 0`` of right-half-plane zeros
        ``(-T_inv s + 1)`` [s]; each is added to the dead time.
    order : int
        1 for FOPDT, 2 for SOPDT.
    ts : float
        Sample time h of a digital controller [s]; adds h/2 to the dead time.

    Returns
    -------
    FOPDT or SOPDT
        The reduced model (``fit`` is NaN: no data were fitted).
    """
    gain = _require_nonzero("gain", gain)
    theta = require_nonnegative("dead_time", dead_time, ErrorCode.BAD_TIME_CONSTANT)
    taus = sorted(
        (
            require_positive("time_constants", x, ErrorCode.BAD_TIME_CONSTANT)
            for x in time_constants
        ),
        reverse=True,
    )
    inv = [
        require_positive("inverse_response", x, ErrorCode.BAD_TIME_CONSTANT)
        for x in inverse_response
    ]
    theta += sum(inv) + require_nonnegative("ts", ts, ErrorCode.BAD_PARAMETER) / 2.0
    if order not in (1, 2) or isinstance(order, bool):
        raise ParameterError(ErrorCode.BAD_ORDER, "order", f"must be 1 or 2, got {order!r}")
    if len(taus) < order:
        raise ParameterError(
            ErrorCode.BAD_TIME_CONSTANT,
            "time_constants",
            f"need at least {order} time constant(s) for order {order}",
        )
    taus = [*taus, 0.0, 0.0]  # padding: a missing tau contributes nothing
    if order == 1:
        tau = taus[0] + taus[1] / 2.0
        theta += taus[1] / 2.0 + sum(taus[2:])
        return FOPDT(gain, tau, theta, method="half rule")
    tau2 = taus[1] + taus[2] / 2.0
    theta += taus[2] / 2.0 + sum(taus[3:])
    return SOPDT(gain, taus[0], theta, tau2, method="half rule")


def _require_nonzero(name: str, value: float) -> float:
    x = require_finite(name, value)
    if x == 0.0:
        raise ParameterError(ErrorCode.BAD_PARAMETER, name, "must not be zero")
    return x
