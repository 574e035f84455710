"""PID tuning rules from a process model or from the ultimate point.

All results are for the ISA ("standard", "ideal", non-interacting) form that
:class:`ctrlblocks.PID` implements::

    u = kp (e + 1/ti * integral(e) dt + td * de/dt)

``ti = 0`` means no integral action, ``td = 0`` no derivative action.  The
PID block wants ``kp > 0`` and ``reverse=True`` for a negative action:
:meth:`PIDTuning.as_kwargs` gives exactly that.  A rule
given in series (interacting) form ``kc (1 + 1/(tau_I s)) (1 + tau_D s)`` is
converted with (Åström 1987, Åström 1987, (2.5);
:func:`ctrlblocks.blocks.pid_forms.series_to_isa`)::

    kp = kc (1 + tau_D/tau_I),  ti = tau_I + tau_D,  td = tau_I tau_D / (tau_I + tau_D)

Model notation: FOPDT ``k e^{-L s}/(T s + 1)``; SOPDT with a second time
constant ``T2``; integrating ``k e^{-L s}/s``.  A negative process gain gives a
negative ``kp`` (reverse acting), as the formulas say.

Rules
-----
SIMC -- Skogestad, *Simple analytic rules for model reduction and PID
    controller tuning*, J. Process Control 13 (2003) 291-309, the SIMC rules
    with the tuning parameter ``tau_c`` (default ``tau_c = L``, "tight
    control"):
    ``kc = T/(k (tau_c + L))``, ``tau_I = min(T, 4 (tau_c + L))``,
    ``tau_D = T2`` (series form, SOPDT only; PI for FOPDT).
    Integrating: ``kc = 1/(k (tau_c + L))``, ``tau_I = 4 (tau_c + L)``.
AMIGO -- Åström & Hägglund, *Advanced PID Control*, ISA 2006, chapter 7
    (step-response AMIGO), ISA form:
    PI:  ``kp = 0.15/k + (0.35 - L T/(L + T)^2) T/(k L)``,
    ``ti = 0.35 L + 13 L T^2/(T^2 + 12 L T + 7 L^2)``;
    PID: ``kp = (0.2 + 0.45 T/L)/k``, ``ti = (0.4 L + 0.8 T)/(L + 0.1 T) L``,
    ``td = 0.5 L T/(0.3 L + T)``, with set-point weight ``b = 0`` for
    ``L/(L + T) <= 0.5`` and ``b = 1`` above (returned as ``b``).
    Integrating: PI ``kp = 0.35/(k L)``, ``ti = 13.4 L``; PID ``kp = 0.45/(k L)``,
    ``ti = 8 L``, ``td = 0.5 L``.
Ziegler-Nichols -- Ziegler & Nichols, *Optimum settings for automatic
    controllers*, Trans. ASME 64 (1942) 759-768, as tabulated by Åström &
    Hägglund (2006, chapter 6) in ISA form.  Step response with
    ``a = k L/T``: P ``kp = 1/a``; PI ``0.9/a, ti = 3 L``; PID ``1.2/a, ti = 2 L,
    td = L/2``.  Ultimate gain ``ku`` and period ``pu``: P ``0.5 ku``;
    PI ``0.45 ku, ti = pu/1.2``; PID ``0.6 ku, ti = pu/2, td = pu/8``.
Tyreus-Luyben -- Tyreus & Luyben, Ind. Eng. Chem. Res. 31 (1992) 2625-2628,
    a detuned closed-loop rule for process control:
    PI ``kp = ku/3.2, ti = 2.2 pu``; PID ``kp = ku/2.2, ti = 2.2 pu, td = pu/6.3``.
Lambda / IMC -- Rivera, Morari & Skogestad, *Internal model control 4. PID
    controller design*, Ind. Eng. Chem. Process Des. Dev. 25 (1986) 252-265,
    with the desired closed-loop time constant ``lambda`` (default
    ``max(T, L)``): PI (lambda tuning, dead time as a delay)
    ``kp = T/(k (lambda + L))``, ``ti = T``; PID (first-order Padé of the
    dead time) ``kp = (2T + L)/(k (2 lambda + L))``, ``ti = T + L/2``,
    ``td = T L/(2T + L)``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

from ..blocks.base import (
    ErrorCode,
    ParameterError,
    require_choice,
    require_finite,
    require_nonnegative,
    require_positive,
)
from ..blocks.pid_forms import series_to_isa
from .identify import FOPDT, SOPDT

__all__ = [
    "PIDTuning",
    "amigo",
    "lambda_tuning",
    "pid_from_model",
    "simc",
    "tyreus_luyben",
    "ziegler_nichols_closed",
    "ziegler_nichols_open",
]

_CONTROLLERS = ("p", "pi", "pid")

_R = TypeVar("_R")


def _rule(fn: Callable[..., _R]) -> Callable[..., _R]:
    """A tuning rule whose arithmetic never raises anything but :class:`ParameterError`.

    Finite but extreme model numbers (a gain of ``5e-324``, a dead time of
    ``1e-320`` s) make a rule's denominators underflow to zero: the division
    is refused as a parameter error, as a result that is not finite is by
    :class:`PIDTuning`.
    """

    @functools.wraps(fn)
    def checked(*args: Any, **kwargs: Any) -> _R:
        try:
            return fn(*args, **kwargs)
        except (ZeroDivisionError, OverflowError) as exc:
            raise ParameterError(
                ErrorCode.BAD_PID_COEFFS,
                "gain/time_constant/dead_time",
                f"too extreme for the {fn.__name__} rule ({exc})",
            ) from None

    return checked


@dataclass(frozen=True)
class PIDTuning:
    """PID settings in ISA form.

    Attributes
    ----------
    kp : float
        Proportional gain [MV unit / PV unit]; negative for a negative
        process gain (see :meth:`as_kwargs`).
    ti : float
        Integral time [s]; 0 = no integral action.
    td : float
        Derivative time [s]; 0 = no derivative action.
    rule : str
        The rule that produced them.
    form : str
        Always ``"isa"``, the PID block's ``form`` value (series results are
        converted, see ``note``).
    note : str
        Remarks (conversion from series form, choices made).
    b : float or None
        Set-point weight of the proportional term when the rule prescribes
        one (AMIGO); None otherwise (the PID block's default applies).
    """

    kp: float
    ti: float
    td: float
    rule: str
    form: str = "isa"
    note: str = ""
    b: float | None = None

    def __post_init__(self) -> None:
        for name in ("kp", "ti", "td"):
            v = getattr(self, name)
            # no rule gives kp = 0 for a finite non-zero gain but by underflow (a gain of 1e308)
            if not math.isfinite(v) or (name == "kp" and v == 0.0):
                raise ParameterError(
                    ErrorCode.BAD_PID_COEFFS,
                    name,
                    f"the {self.rule} rule gives {v!r}: the model's numbers are too extreme for it",
                )

    def as_kwargs(self) -> dict[str, float | bool]:
        """Keyword arguments for ``ctrlblocks.PID(**tuning.as_kwargs(), ts=..., ...)``.

        ``{"kp": |kp|, "ti", "td", "reverse": kp < 0}`` (plus ``"b"`` when
        the rule sets a set-point weight): the PID block takes a positive gain
        and a ``reverse`` flag for a negative process gain (controltheplant 2024
        ``ixInverted``).
        """
        out: dict[str, float | bool] = {
            "kp": abs(self.kp),
            "ti": self.ti,
            "td": self.td,
            "reverse": self.kp < 0.0,
        }
        if self.b is not None:
            out["b"] = self.b
        return out


@_rule
def simc(
    gain: float,
    time_constant: float,
    dead_time: float,
    *,
    time_constant_2: float = 0.0,
    tau_c: float | None = None,
    integrating: bool = False,
) -> PIDTuning:
    """Skogestad's SIMC rule (J. Process Control 13 (2003) 291-309).

    Parameters
    ----------
    gain : float
        k [PV unit / MV unit] (integrating: [PV unit / (MV unit s)]).
    time_constant : float
        T (T1 of an SOPDT) [s]; ignored when ``integrating``.
    dead_time : float
        L [s], >= 0.
    time_constant_2 : float
        T2 [s] of an SOPDT; > 0 gives a PID with series ``tau_D = T2``,
        converted to ISA form.
    tau_c : float, optional
        Desired closed-loop time constant [s]; default ``L`` (Skogestad's
        "tight control"); for a model without dead time ``T/10`` (a
        ctrlblocks choice: set it explicitly for a delay-free model).
    integrating : bool
        Use the integrating-process rule ``kc = 1/(k (tau_c + L))``,
        ``tau_I = 4 (tau_c + L)``.

    Returns
    -------
    PIDTuning
    """
    k = _gain(gain)
    L = require_nonnegative("dead_time", dead_time, ErrorCode.BAD_TIME_CONSTANT)
    T = (
        0.0
        if integrating
        else require_positive("time_constant", time_constant, ErrorCode.BAD_TIME_CONSTANT)
    )
    T2 = require_nonnegative("time_constant_2", time_constant_2, ErrorCode.BAD_TIME_CONSTANT)
    if tau_c is None:
        tau_c = L if L > 0.0 else (T / 10.0 if T > 0.0 else 0.0)
    tau_c = require_nonnegative("tau_c", tau_c, ErrorCode.BAD_TIME_CONSTANT)
    if tau_c + L <= 0.0:
        raise ParameterError(ErrorCode.BAD_TIME_CONSTANT, "tau_c", "tau_c + dead_time must be > 0")
    if integrating:
        kc, tau_i = 1.0 / (k * (tau_c + L)), 4.0 * (tau_c + L)
    else:
        kc, tau_i = T / (k * (tau_c + L)), min(T, 4.0 * (tau_c + L))
    note = f"tau_c = {tau_c:.4g} s"
    if T2 > 0.0:
        kp, ti, td = series_to_isa(kc, tau_i, T2)
        note += "; series-form PID (tau_D = T2) converted to ISA form"
    else:
        kp, ti, td = kc, tau_i, 0.0
    return PIDTuning(kp, ti, td, "simc", note=note)


@_rule
def amigo(
    gain: float,
    time_constant: float,
    dead_time: float,
    *,
    controller: str = "pid",
    integrating: bool = False,
) -> PIDTuning:
    """AMIGO step-response rules (Åström & Hägglund, Advanced PID Control, 2006, ch. 7).

    Formulas in the module docstring.  ``controller`` is ``"pi"`` or
    ``"pid"``.  The PID rule is stated for ``0.1 <= L/(L + T) <= 1`` (a note
    is added outside) and comes with the set-point weight ``b = 0`` for
    ``L/(L+T) <= 0.5``, else 1 (in ``b``; the PI rule leaves ``b`` unset).
    """
    k = _gain(gain)
    L = require_positive("dead_time", dead_time, ErrorCode.BAD_TIME_CONSTANT)
    controller = require_choice("controller", controller, ("pi", "pid"))
    note = ""
    if integrating:
        if controller == "pi":
            return PIDTuning(0.35 / (k * L), 13.4 * L, 0.0, "amigo")
        return PIDTuning(0.45 / (k * L), 8.0 * L, 0.5 * L, "amigo", b=0.0)  # tau = 0
    T = require_positive("time_constant", time_constant, ErrorCode.BAD_TIME_CONSTANT)
    if controller == "pi":
        kp = 0.15 / k + (0.35 - L * T / (L + T) ** 2) * T / (k * L)
        ti = 0.35 * L + 13.0 * L * T**2 / (T**2 + 12.0 * L * T + 7.0 * L**2)
        return PIDTuning(kp, ti, 0.0, "amigo")
    tau = L / (L + T)
    if tau < 0.1:
        note = f"normalised dead time L/(L+T) = {tau:.3f} < 0.1: outside the AMIGO PID range"
    kp = (0.2 + 0.45 * T / L) / k
    ti = (0.4 * L + 0.8 * T) / (L + 0.1 * T) * L
    td = 0.5 * L * T / (0.3 * L + T)
    return PIDTuning(kp, ti, td, "amigo", note=note, b=0.0 if tau <= 0.5 else 1.0)


@_rule
def ziegler_nichols_open(
    gain: float, time_constant: float, dead_time: float, *, controller: str = "pid"
) -> PIDTuning:
    """Ziegler-Nichols step-response rule (Trans. ASME 64 (1942) 759-768).

    With ``a = k L/T``: P ``kp = 1/a``; PI ``kp = 0.9/a, ti = 3 L``;
    PID ``kp = 1.2/a, ti = 2 L, td = L/2`` (ISA form as in Åström & Hägglund
    2006, chapter 6).
    """
    k = _gain(gain)
    T = require_positive("time_constant", time_constant, ErrorCode.BAD_TIME_CONSTANT)
    L = require_positive("dead_time", dead_time, ErrorCode.BAD_TIME_CONSTANT)
    controller = require_choice("controller", controller, _CONTROLLERS)
    a = k * L / T
    kp, ti, td = {
        "p": (1.0 / a, 0.0, 0.0),
        "pi": (0.9 / a, 3.0 * L, 0.0),
        "pid": (1.2 / a, 2.0 * L, L / 2.0),
    }[controller]
    return PIDTuning(kp, ti, td, "zn-open")


@_rule
def ziegler_nichols_closed(ku: float, pu: float, *, controller: str = "pid") -> PIDTuning:
    """Ziegler-Nichols ultimate-gain rule (Trans. ASME 64 (1942) 759-768).

    P ``kp = 0.5 ku``; PI ``kp = 0.45 ku, ti = pu/1.2``; PID ``kp = 0.6 ku,
    ti = pu/2, td = pu/8``.

    Parameters
    ----------
    ku : float
        Ultimate gain (sign = controller action) [MV unit / PV unit].
    pu : float
        Ultimate period [s].
    controller : {"p", "pi", "pid"}
    """
    ku = _gain(ku, "ku")
    pu = require_positive("pu", pu, ErrorCode.BAD_TIME_CONSTANT)
    controller = require_choice("controller", controller, _CONTROLLERS)
    kp, ti, td = {
        "p": (0.5 * ku, 0.0, 0.0),
        "pi": (0.45 * ku, pu / 1.2, 0.0),
        "pid": (0.6 * ku, pu / 2.0, pu / 8.0),
    }[controller]
    return PIDTuning(kp, ti, td, "zn-closed")


@_rule
def tyreus_luyben(ku: float, pu: float, *, controller: str = "pid") -> PIDTuning:
    """Tyreus-Luyben ultimate-gain rule (Ind. Eng. Chem. Res. 31 (1992) 2625).

    PI ``kp = ku/3.2, ti = 2.2 pu``; PID ``kp = ku/2.2, ti = 2.2 pu, td = pu/6.3``.
    Less aggressive than Ziegler-Nichols (smaller overshoot, more robust).
    """
    ku = _gain(ku, "ku")
    pu = require_positive("pu", pu, ErrorCode.BAD_TIME_CONSTANT)
    controller = require_choice("controller", controller, ("pi", "pid"))
    if controller == "pi":
        return PIDTuning(ku / 3.2, 2.2 * pu, 0.0, "tyreus-luyben")
    return PIDTuning(ku / 2.2, 2.2 * pu, pu / 6.3, "tyreus-luyben")


@_rule
def lambda_tuning(
    gain: float,
    time_constant: float,
    dead_time: float,
    *,
    lam: float | None = None,
    controller: str = "pi",
) -> PIDTuning:
    """Lambda (IMC) tuning (Rivera, Morari & Skogestad 1986).

    PI: ``kp = T/(k (lam + L))``, ``ti = T``.  PID (Padé of the dead time):
    ``kp = (2T + L)/(k (2 lam + L))``, ``ti = T + L/2``, ``td = T L/(2T + L)``.

    Parameters
    ----------
    lam : float, optional
        Desired closed-loop time constant lambda [s]; default ``max(T, L)``
        (closed loop as fast as the open loop, never faster than the dead time).
    controller : {"pi", "pid"}
    """
    k = _gain(gain)
    T = require_positive("time_constant", time_constant, ErrorCode.BAD_TIME_CONSTANT)
    L = require_nonnegative("dead_time", dead_time, ErrorCode.BAD_TIME_CONSTANT)
    controller = require_choice("controller", controller, ("pi", "pid"))
    lam = max(T, L) if lam is None else require_positive("lam", lam, ErrorCode.BAD_TIME_CONSTANT)
    note = f"lambda = {lam:.4g} s"
    if controller == "pi":
        return PIDTuning(T / (k * (lam + L)), T, 0.0, "lambda", note=note)
    return PIDTuning(
        (2.0 * T + L) / (k * (2.0 * lam + L)),
        T + L / 2.0,
        T * L / (2.0 * T + L),
        "lambda",
        note=note,
    )


def _gain(value: float, name: str = "gain") -> float:
    k = require_finite(name, value)
    if k == 0.0:
        raise ParameterError(ErrorCode.BAD_PARAMETER, name, "must be non-zero")
    return k


def pid_from_model(model: FOPDT | SOPDT, rule: str, *, controller: str = "pid") -> PIDTuning:
    """Apply the named rule (``amigo``, ``simc``, ``zn``, ``lambda``) to a model.

    An SOPDT is used as such by SIMC (PID with ``tau_D = T2``); the other
    rules take its FOPDT reduction by the half rule (``T = T1 + T2/2``,
    ``L = L + T2/2``, Skogestad 2003).
    """
    k, T, L = model.gain, model.time_constant, model.dead_time
    if rule == "simc":
        return simc(k, T, L, time_constant_2=getattr(model, "time_constant_2", 0.0))
    if isinstance(model, SOPDT):
        T, L = T + model.time_constant_2 / 2.0, L + model.time_constant_2 / 2.0
    if rule == "amigo":
        return amigo(k, T, L, controller=controller)
    if rule == "zn":
        return ziegler_nichols_open(k, T, L, controller=controller)
    if rule == "lambda":
        return lambda_tuning(k, T, L, controller=controller)
    raise ParameterError(ErrorCode.BAD_PARAMETER, "rule", "must be one of amigo, simc, zn, lambda")
