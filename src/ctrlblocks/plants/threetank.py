"""The pneumatic three-tank process of Nowak et al. 2018, section 6, as a physical model.

The setup (Nowak et al. 2018, section 6 and Fig. 3): three tanks of volumes
``V1 = 5 L``, ``V2 = 2 L``, ``V3 = 0.75 L`` in series; air at the supply
pressure ``p_s`` (0..5 bar gauge, set by a Festo MPPES proportional valve)
flows through the constant pneumatic resistances ``R_pa``, ``R_pb``, ``R_pc``
[1/(m s)] into and between the tanks and leaves the last tank through the
outlet resistance ``R_pout`` to the atmosphere (``p_4 = 0`` bar gauge).
``R_pout`` is switched between two valves.  Input ``u = p_s``, output
``y = p_3`` [bar gauge].

Model
-----
Assumptions: the air is an ideal gas at a constant temperature ``T`` in every
tank (isothermal: the tanks are metal and the flows small), and every
restriction is a laminar (capillary-like) one, whose mass flow for a
compressible isothermal gas is (Hagen-Poiseuille with density proportional to
pressure)

    m_dot = (P_a^2 - P_b^2) / (2 p_atm R) = (P_a - P_b)/R * (P_a + P_b)/(2 p_atm)      (T1)

with absolute pressures ``P``.  ``R`` is then exactly the paper's resistance
``Delta p / m_dot`` [Pa s/kg = 1/(m s)] at a mean absolute pressure of one
atmosphere; at higher pressure the denser gas flows more easily.  The mass
balance of tank ``i`` with ``m_i = P_i V_i / (R_g T)`` gives

    dP1/dt = R_g T/V1 * (m_dot(P_s, P1; R_a) - m_dot(P1, P2; R_b))
    dP2/dt = R_g T/V2 * (m_dot(P1, P2; R_b) - m_dot(P2, P3; R_c))                   (T2)
    dP3/dt = R_g T/V3 * (m_dot(P2, P3; R_c) - m_dot(P3, p_atm; R_out))

(with ``P`` in bar inside the code: ``dP_i/dt = g (P_a^2 - P_b^2) - ...``,
``g = R_g T / (2 p_atm V_i R)`` [1/(bar s)]).  Because of the squares the
model is nonlinear and its linearisation depends on the operating point.  The
steady state is in closed form: all mass flows are equal, so ``P^2`` falls
linearly with the accumulated resistance,

    P_i^2 = p_atm^2 + (P_s^2 - p_atm^2) * R_down,i / (R_a + R_b + R_c + R_out)         (T3)

with ``R_down,i`` the sum of the resistances downstream of tank ``i``.

Parameters and how they were found
----------------------------------
``R_g = 287.05 J/(kg K)``, ``T = 293.15 K``, ``p_atm = 1.01325 bar``.  The four
resistances were fitted once, offline, with ``scipy.optimize.least_squares``
on log(R) (from 40 random starts around 1e8 1/(m s)), so that the
linearisation of (T2) at the operating point ``y0 = p3 = 1.5 bar`` (then
``u0 = 2.1904 bar``, ``p1 = 2.1306``, ``p2 = 1.8560 bar``) has exactly the gain
and time constants of Nowak et al. 2018, (10b), ``0.73 / ((7.3 s + 1)(2.2 s + 1)(1.4 s + 1))``.
Two exact solutions exist; the one with the more even resistances was kept
(the other: 8.781e7, 6.908e8, 1.162e9, 2.601e9).  Rounded to seven digits the
linearisation matches (10b) to 1e-7.  Outlet valve ``"b"`` is a second valve
with half the resistance of ``"a"``; at ``u0`` it lowers the output from 1.5 to
1.162 bar, the gain from 0.730 to 0.591 (-19 %) and the time constants to
6.38, 2.17, 1.40 s (see docs/plants.md for a table over operating points).

Integration
-----------
Classical fourth-order Runge-Kutta with ``substeps`` equal steps per sample and
the input held (ZOH).  With the default ``substeps = 2`` at ``ts = 0.1`` the
error against ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-12) stays below
1e-7 bar over the whole 0..5 bar range (tests/plants/test_threetank.py).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np

from ..blocks.base import ErrorCode, ParameterError, require_limits, require_positive
from ..blocks.signals import clamp
from .base import Plant

__all__ = ["MAX_STEPS", "OUTLETS", "R_BETWEEN", "ThreeTank", "ThreeTankModel", "threetank_rk4"]

MAX_STEPS = 1_000_000
"""The most RK4 steps a sample may take (a longer ``ts`` is refused)."""

R_GAS = 287.05
"""Specific gas constant of air [J/(kg K)]."""
T_AIR = 293.15
"""Air temperature [K] (20 degC)."""
P_ATM = 1.01325
"""Atmospheric pressure [bar absolute]."""
VOLUMES = (5.0e-3, 2.0e-3, 0.75e-3)
"""Tank volumes V1, V2, V3 [m^3] (Nowak et al. 2018, section 6: 5, 2, 0.75 L)."""
R_BETWEEN = (1.457572e8, 6.338925e8, 7.357391e8)
"""Resistances R_pa (supply to tank 1), R_pb (1 to 2), R_pc (2 to 3) [1/(m s)], fitted."""
OUTLETS = {"a": 2.030845e9, "b": 0.5 * 2.030845e9}
"""Outlet resistance R_pout of the two switchable valves [1/(m s)]; "a" is fitted to (10b)."""
Y_OPERATING = 1.5
"""Output p3 [bar gauge] of the operating point where the linearisation is (10b)."""


def threetank_rk4(
    p1: float,
    p2: float,
    p3: float,
    ps: float,
    g: tuple[float, float, float, float, float, float],
    h: float,
    n: int,
) -> tuple[float, float, float]:
    """``n`` RK4 steps of length ``h`` of (T2) with constant supply ``ps``; absolute bar.

    ``g = (g1a, g1b, g2b, g2c, g3c, g3o)``: ``dP1/dt = g1a (ps^2 - P1^2) - g1b (P1^2 - P2^2)``,
    ``dP2/dt = g2b (P1^2 - P2^2) - g2c (P2^2 - P3^2)``,
    ``dP3/dt = g3c (P2^2 - P3^2) - g3o (P3^2 - p_atm^2)``.
    """
    g1a, g1b, g2b, g2c, g3c, g3o = g
    s2 = ps * ps
    a2 = P_ATM * P_ATM
    h2 = 0.5 * h
    h6 = h / 6.0
    for _ in range(n):
        q1, q2, q3 = p1 * p1, p2 * p2, p3 * p3
        k1a = g1a * (s2 - q1) - g1b * (q1 - q2)
        k1b = g2b * (q1 - q2) - g2c * (q2 - q3)
        k1c = g3c * (q2 - q3) - g3o * (q3 - a2)
        x1, x2, x3 = p1 + h2 * k1a, p2 + h2 * k1b, p3 + h2 * k1c
        q1, q2, q3 = x1 * x1, x2 * x2, x3 * x3
        k2a = g1a * (s2 - q1) - g1b * (q1 - q2)
        k2b = g2b * (q1 - q2) - g2c * (q2 - q3)
        k2c = g3c * (q2 - q3) - g3o * (q3 - a2)
        x1, x2, x3 = p1 + h2 * k2a, p2 + h2 * k2b, p3 + h2 * k2c
        q1, q2, q3 = x1 * x1, x2 * x2, x3 * x3
        k3a = g1a * (s2 - q1) - g1b * (q1 - q2)
        k3b = g2b * (q1 - q2) - g2c * (q2 - q3)
        k3c = g3c * (q2 - q3) - g3o * (q3 - a2)
        x1, x2, x3 = p1 + h * k3a, p2 + h * k3b, p3 + h * k3c
        q1, q2, q3 = x1 * x1, x2 * x2, x3 * x3
        k4a = g1a * (s2 - q1) - g1b * (q1 - q2)
        k4b = g2b * (q1 - q2) - g2c * (q2 - q3)
        k4c = g3c * (q2 - q3) - g3o * (q3 - a2)
        p1 += h6 * (k1a + 2.0 * (k2a + k3a) + k4a)
        p2 += h6 * (k1b + 2.0 * (k2b + k3b) + k4b)
        p3 += h6 * (k1c + 2.0 * (k2c + k3c) + k4c)
    return p1, p2, p3


class ThreeTankModel(NamedTuple):
    """What a compiled path needs to step a :class:`ThreeTank` with :func:`threetank_rk4`."""

    g: tuple[float, float, float, float, float, float]
    """The coefficients ``g`` of (T2) with the current outlet valve [1/(bar s)]."""
    h: float
    """The RK4 step ``ts / substeps`` [s]."""
    substeps: int
    """RK4 steps per sample (:attr:`ThreeTank.steps`: ``substeps``, or more for a long ``ts``)."""
    u_min: float
    """Lowest supply pressure [bar gauge]."""
    u_max: float
    """Highest supply pressure [bar gauge]."""
    outlet_g: Mapping[str, float]
    """The outlet coefficient ``g[5]`` of every outlet valve, by name [1/(bar s)]."""


class ThreeTank(Plant):
    """Pneumatic three-tank process of Nowak et al. 2018, section 6 (model (T1)-(T3) above).

    Parameters
    ----------
    ts : float
        Sample time [s] (Nowak et al. 2018: the PLC ran at 0.1 s).
    outlet : {"a", "b"}
        Outlet valve in use; switch at run time with ``plant.outlet = "b"``.
    substeps : int
        RK4 steps per sample, >= 1; more are taken when a step would be
        longer than the fastest mode allows (:attr:`steps`).
    u_min, u_max : float
        Range of the proportional valve [bar gauge]; the supply pressure is
        clamped to it (default 0..5 bar, Nowak et al. 2018).
    resistances : (float, float, float), optional
        ``(R_pa, R_pb, R_pc)`` [1/(m s)]; default the fitted :data:`R_BETWEEN`.
    outlets : dict, optional
        ``{"a": R_out_a, "b": R_out_b}`` [1/(m s)]; default :data:`OUTLETS`.

    Attributes
    ----------
    p1, p2, p3 : float
        Tank pressures [bar gauge] (read-only properties); ``y`` is ``p3``.
    u : float
        Supply pressure applied in the last sample [bar gauge] (after clamping).

    Examples
    --------
    >>> plant = ThreeTank(ts=0.1)
    >>> plant.reset(plant.u_for_y(1.5))
    >>> round(plant.y, 9)
    1.5
    >>> gain, taus = plant.linear_model(plant.u)
    >>> round(gain, 4), [round(t, 4) for t in taus]
    (0.73, [7.3, 2.2, 1.4])
    >>> plant.outlet = "b"       # switch the outlet valve
    """

    def __init__(
        self,
        ts: float = 0.1,
        *,
        outlet: str = "a",
        substeps: int = 2,
        u_min: float = 0.0,
        u_max: float = 5.0,
        resistances: tuple[float, float, float] = R_BETWEEN,
        outlets: dict[str, float] | None = None,
    ) -> None:
        self.ts = require_positive("ts", ts, ErrorCode.NO_CYCLE)
        if not isinstance(substeps, int) or isinstance(substeps, bool) or substeps < 1:
            raise ParameterError(ErrorCode.BAD_PARAMETER, "substeps", "must be an integer >= 1")
        self.substeps = substeps
        lo, hi = require_limits("u_min", u_min, "u_max", u_max, allow_infinite=False)
        if not lo > -P_ATM:
            raise ParameterError(
                ErrorCode.BAD_LIMITS, "u_min/u_max", "need -p_atm < u_min <= u_max < inf"
            )
        self.u_min, self.u_max = lo, hi
        if len(resistances) != 3:
            raise ParameterError(ErrorCode.BAD_PARAMETER, "resistances", "give three")
        self.resistances = tuple(
            require_positive(f"resistances[{i}]", r) for i, r in enumerate(resistances)
        )
        outs = dict(OUTLETS if outlets is None else outlets)
        for name, r in outs.items():
            outs[name] = require_positive(f"outlets[{name!r}]", r)
        self.outlets = outs
        self.outlet = outlet
        rate = self._fastest_rate()
        if not self.ts * rate <= MAX_STEPS:  # (also a rate that overflowed: u_max = 1e308)
            raise ParameterError(
                ErrorCode.NO_CYCLE,
                "ts",
                f"{ts!r} s needs more than {MAX_STEPS:,} RK4 steps per sample "
                f"(steps of at most {1.0 / rate:.3g} s keep the integration stable)",
            )
        self._h_max = 1.0 / rate if rate > 0.0 else math.inf
        self.reset(0.0)

    def _fastest_rate(self) -> float:
        """A bound on ``|lambda|`` of (T2)'s Jacobian [1/s] at every pressure and outlet.

        Gershgorin's bound on the rows of the linearisation (:meth:`linearise`)
        with every pressure at its highest, ``u_max``, and the widest outlet.
        """
        g1a, g1b, g2b, g2c, g3c, _ = self._g
        g3o = max(self._coefficients(r)[5] for r in self.outlets.values())
        p = self.u_max + P_ATM
        return 2.0 * p * max(g1a + 2.0 * g1b, 2.0 * g2b + 2.0 * g2c, 2.0 * g3c + g3o)

    @property
    def steps(self) -> int:
        """RK4 steps per sample: ``substeps``, more if a step would be longer than stable.

        Each step is at most ``1/|lambda|`` of the fastest mode (:meth:`_fastest_rate`;
        ``h |lambda| <= 1``, well inside RK4's stability bound of 2.78): with
        ``ts = 10`` s two steps of 5 s grew without bound (to 4e150 bar in a sample).
        """
        return max(self.substeps, math.ceil(self.ts / self._h_max))

    # -- the outlet valve ------------------------------------------------------

    @property
    def outlet(self) -> str:
        """Name of the outlet valve in use; assign to switch (takes effect at the next step)."""
        return self._outlet

    @outlet.setter
    def outlet(self, name: str) -> None:
        if name not in self.outlets:
            raise ParameterError(
                ErrorCode.BAD_PARAMETER, "outlet", f"must be one of {sorted(self.outlets)}"
            )
        self._outlet = name
        self.r_out = self.outlets[name]
        self._g = self._coefficients(self.r_out)

    def set_parameter(self, name: str, value: Any) -> None:
        """Run-time change: ``set_parameter("outlet", "b")`` is ``plant.outlet = "b"``.

        Also ``"substeps"`` (int >= 1).  Other names raise ``BAD_PARAMETER``.
        """
        if name == "outlet":
            self.outlet = value
        elif name == "substeps":
            if not isinstance(value, int) or isinstance(value, bool) or value < 1:
                raise ParameterError(ErrorCode.BAD_PARAMETER, "substeps", "must be an int >= 1")
            self.substeps = value
        else:
            raise ParameterError(
                ErrorCode.BAD_PARAMETER,
                name,
                "not a run-time parameter of ThreeTank (known: outlet, substeps)",
            )

    def _coefficients(self, r_out: float) -> tuple[float, float, float, float, float, float]:
        ra, rb, rc = self.resistances
        v1, v2, v3 = VOLUMES
        c = R_GAS * T_AIR / (2.0 * P_ATM)
        return (c / (v1 * ra), c / (v1 * rb), c / (v2 * rb), c / (v2 * rc), c / (v3 * rc),
                c / (v3 * r_out))  # fmt: skip

    def discrete_model(self) -> ThreeTankModel:
        """The public seam for compiled paths: coefficients, RK4 step and limits.

        The state is in :meth:`snapshot` (``"p"``: absolute pressures [bar]).
        """
        return ThreeTankModel(
            self._g,
            self.ts / self.steps,
            self.steps,
            self.u_min,
            self.u_max,
            {name: self._coefficients(r)[5] for name, r in self.outlets.items()},
        )

    # -- the contract ------------------------------------------------------------

    @property
    def y(self) -> float:
        """Output ``p3`` [bar gauge]."""
        return self._p3 - P_ATM

    @property
    def p1(self) -> float:
        """Pressure in tank 1 [bar gauge]."""
        return self._p1 - P_ATM

    @property
    def p2(self) -> float:
        """Pressure in tank 2 [bar gauge]."""
        return self._p2 - P_ATM

    @property
    def p3(self) -> float:
        """Pressure in tank 3 [bar gauge]."""
        return self._p3 - P_ATM

    def step(self, u: float) -> float:
        """Hold the supply pressure ``u`` [bar gauge] for one sample; return ``p3``.

        ``u`` is clamped to ``[u_min, u_max]``; a non-finite ``u`` holds the
        previous supply pressure.
        """
        if not math.isfinite(u):
            u = self.u
        u = float(clamp(u, self.u_min, self.u_max))
        self.u = u
        n = self.steps
        self._p1, self._p2, self._p3 = threetank_rk4(
            self._p1, self._p2, self._p3, u + P_ATM, self._g, self.ts / n, n
        )
        return self._p3 - P_ATM

    def reset(self, u0: float = 0.0) -> None:
        """Steady state (T3) for the supply pressure ``u0`` [bar gauge] (clamped)."""
        u0 = float(u0) if math.isfinite(u0) else 0.0
        u0 = clamp(u0, self.u_min, self.u_max)
        self.u = u0
        p = self.steady_state(u0)
        self._p1, self._p2, self._p3 = (v + P_ATM for v in p)

    def snapshot(self) -> dict[str, Any]:
        """A copy of the state (pressures, last input, outlet valve)."""
        return {"p": (self._p1, self._p2, self._p3), "u": self.u, "outlet": self._outlet}

    def restore(self, snap: dict[str, Any]) -> None:
        """Put back a state taken by :meth:`snapshot` (the outlet valve included)."""
        self._p1, self._p2, self._p3 = (float(v) for v in snap["p"])
        self.u = float(snap["u"])
        self.outlet = snap["outlet"]

    # -- analysis ----------------------------------------------------------------

    def _r_chain(self) -> tuple[float, float, float, float]:
        ra, rb, rc = self.resistances
        return ra, rb, rc, self.r_out

    def steady_state(self, u0: float) -> tuple[float, float, float]:
        """Steady pressures ``(p1, p2, p3)`` [bar gauge] for the supply ``u0``, by (T3).

        Uses the outlet valve in use.
        """
        ra, rb, rc, ro = self._r_chain()
        total = ra + rb + rc + ro
        a2 = P_ATM * P_ATM
        d = (u0 + P_ATM) ** 2 - a2
        return tuple(  # type: ignore[return-value]
            math.sqrt(a2 + d * rest / total) - P_ATM for rest in (rb + rc + ro, rc + ro, ro)
        )

    def u_for_y(self, y0: float) -> float:
        """Supply pressure [bar gauge] whose steady state has ``p3 = y0`` (inverse of (T3)).

        NaN when no supply pressure gives ``y0`` (a ``y0`` so far below the
        atmosphere that the squared supply pressure would be negative, or so
        large that it overflows); never raises.
        """
        ra, rb, rc, ro = self._r_chain()
        a2 = P_ATM * P_ATM
        p3 = y0 + P_ATM
        ps2 = a2 + (p3 * p3 - a2) * (ra + rb + rc + ro) / ro
        if not (0.0 <= ps2 < math.inf):
            return math.nan
        return math.sqrt(ps2) - P_ATM

    def derivatives(self, p: Any, u: float) -> np.ndarray:
        """Right-hand side of (T2): ``d(p1, p2, p3)/dt`` [bar/s] for gauge ``p`` and supply ``u``.

        No clamping of ``u``; for analysis and reference integration.
        """
        g1a, g1b, g2b, g2c, g3c, g3o = self._g
        p1, p2, p3 = (float(v) + P_ATM for v in p)
        ps = float(u) + P_ATM
        qa, qb = ps * ps - p1 * p1, p1 * p1 - p2 * p2
        qc, qo = p2 * p2 - p3 * p3, p3 * p3 - P_ATM * P_ATM
        return np.array([g1a * qa - g1b * qb, g2b * qb - g2c * qc, g3c * qc - g3o * qo])

    def linearise(self, u0: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Continuous linearisation ``(A, B, C)`` of (T2) at the steady state for ``u0``.

        States and input are deviations of the gauge pressures [bar]; ``C``
        selects ``p3``.  The Jacobian is analytic (derivatives of ``P^2`` terms).
        """
        g1a, g1b, g2b, g2c, g3c, g3o = self._g
        p1, p2, p3 = (v + P_ATM for v in self.steady_state(u0))
        ps = u0 + P_ATM
        a = np.array(
            [
                [-2.0 * p1 * (g1a + g1b), 2.0 * p2 * g1b, 0.0],
                [2.0 * p1 * g2b, -2.0 * p2 * (g2b + g2c), 2.0 * p3 * g2c],
                [0.0, 2.0 * p2 * g3c, -2.0 * p3 * (g3c + g3o)],
            ]
        )
        b = np.array([[2.0 * ps * g1a], [0.0], [0.0]])
        c = np.array([[0.0, 0.0, 1.0]])
        return a, b, c

    def linear_model(self, u0: float) -> tuple[float, tuple[float, float, float]]:
        """Gain and time constants (largest first) of the linearisation at ``u0``.

        The linearisation is ``gain / prod(t_i s + 1)`` (three real poles, no
        zeros); at ``u_for_y(1.5)`` with outlet "a" it is (10b) of Nowak et al. 2018.
        """
        a, b, c = self.linearise(u0)
        gain = float(-(c @ np.linalg.solve(a, b))[0, 0])
        taus = sorted((-1.0 / ev.real for ev in np.linalg.eigvals(a)), reverse=True)
        return gain, (float(taus[0]), float(taus[1]), float(taus[2]))

    def __repr__(self) -> str:
        return (
            f"ThreeTank(ts={self.ts!r}, outlet={self._outlet!r}, substeps={self.substeps}) "
            f"<p=({self.p1:.4f}, {self.p2:.4f}, {self.p3:.4f}) bar, u={self.u!r}>"
        )
