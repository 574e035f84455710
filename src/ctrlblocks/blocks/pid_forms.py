"""PID forms and their conversions (Åström 1987, section 2, (2.1), (2.4)-(2.6)).

Three ways of writing the same linear PID are offered by :class:`~ctrlblocks.PID`
(``form=...``).  Internally the block always works with the ISA parameters
``(K, Ti, Td)``; the functions here convert.

``form="isa"`` -- ISA standard / ideal / non-interacting form; Åström calls it
the *parallel form* (Åström 1987, (2.1))::

    u = K (e + 1/Ti ∫ e dt + Td de/dt)

``form="parallel"`` -- independent gains, as many PLC blocks offer it::

    u = kp e + (1/ti) ∫ e dt + td de/dt

so ``ki = 1/ti`` [1/s] and ``kd = td`` [s] do not scale with ``kp``.  The ISA
equivalent is ``K = kp, Ti = kp ti, Td = td / kp``.

``form="series"`` -- interacting form (Åström 1987, (2.4), Fig. 2.1)::

    G(s) = K' (1 + 1/(s Ti')) (1 + s Td')

whose ISA equivalent is (2.5)::

    K  = K' (Ti' + Td') / Ti'
    Ti = Ti' + Td'
    Td = Ti' Td' / (Ti' + Td')

The ISA form can be written in series form only if ``Ti >= 4 Td``; then (2.6)::

    K'  = K/2  (1 + sqrt(1 - 4 Td/Ti))
    Ti' = Ti/2 (1 + sqrt(1 - 4 Td/Ti))
    Td' = Ti/2 (1 - sqrt(1 - 4 Td/Ti))

Throughout, ``Ti = 0`` means *no integral action* (an infinite integral time)
and ``Td = 0`` no derivative action, as in the block.
"""

from __future__ import annotations

import math

from .base import ErrorCode, ParameterError, require_finite, require_nonnegative

__all__ = [
    "FORMS",
    "isa_parameters",
    "isa_to_parallel",
    "isa_to_series",
    "parallel_to_isa",
    "parallel_to_series",
    "series_to_isa",
    "series_to_parallel",
]

FORMS = ("isa", "parallel", "series")
"""The values of the ``form`` option of :class:`~ctrlblocks.PID`."""


def _check(k: float, ti: float, td: float) -> tuple[float, float, float]:
    code = ErrorCode.BAD_PID_COEFFS
    return (
        require_finite("kp", k, code),
        require_nonnegative("ti", ti, code),
        require_nonnegative("td", td, code),
    )


def series_to_isa(k: float, ti: float, td: float) -> tuple[float, float, float]:
    """Series (interacting) parameters to ISA / Åström-parallel ones, Åström 1987, (2.5).

    Parameters
    ----------
    k : float
        Series gain K' [-].
    ti : float
        Series integral time Ti' [s]; 0 = no integral action.
    td : float
        Series derivative time Td' [s]; 0 = no derivative action.

    Returns
    -------
    (K, Ti, Td) : tuple of float
        ``K = K'(Ti'+Td')/Ti'``, ``Ti = Ti'+Td'``, ``Td = Ti'Td'/(Ti'+Td')``;
        without integral action (``Ti' = 0``, i.e. infinite) the limits
        ``(K', 0, Td')``.

    Examples
    --------
    >>> series_to_isa(2.0, 4.0, 1.0)
    (2.5, 5.0, 0.8)
    """
    k, ti, td = _check(k, ti, td)
    if ti == 0.0:
        return k, 0.0, td
    s = ti + td
    return k * s / ti, s, ti * td / s


def isa_to_series(k: float, ti: float, td: float) -> tuple[float, float, float]:
    """ISA / Åström-parallel parameters to series (interacting) ones, Åström 1987, (2.6).

    Refused with ``ParameterError(BAD_FORM)`` when ``Ti < 4 Td`` (the series
    form cannot represent complex zeros).  Without integral action (``Ti = 0``)
    the result is ``(K, 0, Td)``.

    Examples
    --------
    >>> isa_to_series(2.5, 5.0, 0.8)
    (2.0, 4.0, 1.0)
    """
    k, ti, td = _check(k, ti, td)
    if ti == 0.0:
        return k, 0.0, td
    if ti < 4.0 * td:
        raise ParameterError(
            ErrorCode.BAD_FORM,
            "ti/td",
            f"series form needs Ti >= 4 Td (Åström 1987, (2.6)); got Ti={ti!r}, Td={td!r}",
        )
    r = math.sqrt(1.0 - 4.0 * td / ti)
    return k / 2.0 * (1.0 + r), ti / 2.0 * (1.0 + r), ti / 2.0 * (1.0 - r)


# Åström's names: his "parallel form" (2.1) is the ISA form of the block.
series_to_parallel = series_to_isa
"""Alias of :func:`series_to_isa` under Åström's (1987) name: Åström's *parallel
form* (2.1) is ``form="isa"`` of the block (not ``form="parallel"``)."""
parallel_to_series = isa_to_series
"""Alias of :func:`isa_to_series` under Åström's (1987) name (see :data:`series_to_parallel`)."""


def parallel_to_isa(kp: float, ti: float, td: float) -> tuple[float, float, float]:
    """Independent-gain parameters (``kp, ki = 1/ti, kd = td``) to ISA ones.

    ``K = kp``, ``Ti = kp ti``, ``Td = td / kp``; needs ``kp > 0``.

    Examples
    --------
    >>> parallel_to_isa(2.0, 0.5, 1.0)
    (2.0, 1.0, 0.5)
    """
    kp, ti, td = _check(kp, ti, td)
    if kp <= 0.0:
        raise ParameterError(ErrorCode.BAD_PID_COEFFS, "kp", f"must be > 0, got {kp!r}")
    return kp, kp * ti, td / kp


def isa_to_parallel(k: float, ti: float, td: float) -> tuple[float, float, float]:
    """ISA parameters to independent gains: ``(kp, ti, td) = (K, Ti/K, K Td)``; needs ``K > 0``."""
    k, ti, td = _check(k, ti, td)
    if k <= 0.0:
        raise ParameterError(ErrorCode.BAD_PID_COEFFS, "kp", f"must be > 0, got {k!r}")
    return k, ti / k, k * td


def isa_parameters(form: str, kp: float, ti: float, td: float) -> tuple[float, float, float]:
    """The ISA parameters ``(K, Ti, Td)`` of a PID given in ``form``."""
    if form == "isa":
        return _check(kp, ti, td)
    if form == "parallel":
        return parallel_to_isa(kp, ti, td)
    if form == "series":
        return series_to_isa(kp, ti, td)
    raise ParameterError(
        ErrorCode.BAD_PARAMETER, "form", f"must be one of {', '.join(FORMS)}; got {form!r}"
    )
