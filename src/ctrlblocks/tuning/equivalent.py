"""A controller read as a PID: the low-frequency expansion of its discrete 2-DOF law.

Any linear controller ``u = C_r(z) r - C_y(z) y`` -- the ADRC's ESO (4a) and
law (4b) of Nowak et al. 2018 as the block runs them, read off by
:func:`ctrlblocks.tuning.margins.controller_ss` -- is, at low frequencies, a
PID with set-point weights.  With ``z = e^{s h}``::

    C_y(e^{s h}) = ki/s + kp + kd s + O(s^2)
    C_r(e^{s h}) = ki/s + b kp + c kd s + O(s^2)

``kp``, ``ki = kp/Ti`` and ``kd = kp Td`` are the *equivalent PID* of the
controller: the gains a PID engineer compares with their own (Herbst 2013,
section 4, reads the linear ADRC of order 1 as a PI with a first-order
lag filter and that of order 2 as a PID with a second-order filter, in the
continuous domain; here the same expansion is taken of the discrete law that
runs).  A negative ``kd`` is a lag (a filter), not a derivative.  The rest of
the law, the ``O(s^2)`` part, is the controller's filtering: the full
frequency responses stay available (:meth:`ctrlblocks.tuning.margins.Loop.controller`).

The expansion is computed from the state space at real ``z = e^{s h}`` for
small ``s`` (a polynomial fit of ``s C(e^{s h})`` on Chebyshev nodes inside
the radius set by the controller's slowest pole), so it needs no symbolic
algebra and no continuous approximation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .margins import DiscreteSS

__all__ = ["EquivalentPID", "equivalent_pid"]


@dataclass(frozen=True)
class EquivalentPID:
    """The low-frequency PID of a linear controller (module docstring).

    Attributes
    ----------
    kp : float
        Proportional gain [MV/PV].
    ki : float
        Integral gain [MV/(PV s)] (``kp/Ti``).
    kd : float
        Derivative gain [MV s/PV] (``kp Td``); negative: a lag.
    b, c : float
        Set-point weights of the proportional and derivative parts (NaN when
        the part is zero).
    """

    kp: float
    ki: float
    kd: float
    b: float
    c: float

    @property
    def ti(self) -> float:
        """Integral time [s] (``inf`` without integral action)."""
        return self.kp / self.ki if self.ki != 0.0 else math.inf

    @property
    def td(self) -> float:
        """Derivative time [s] (negative: a lag)."""
        return self.kd / self.kp if self.kp != 0.0 else math.nan

    def as_dict(self) -> dict[str, float]:
        """``kp_eq, ti_eq, td_eq, b_eq`` (the keys of ``tune adrc --json``)."""
        return {"kp_eq": self.kp, "ti_eq": self.ti, "td_eq": self.td, "b_eq": self.b}

    def summary(self) -> str:
        """One line, e.g. ``as a PID: kp 2.31, Ti 8.12 s, Td -0.0210 s (a lag), b 0.842``."""
        td = f"Td {self.td:.4g} s" + (" (a lag)" if self.td < 0.0 else "")
        return f"as a PID: kp {self.kp:.4g}, Ti {self.ti:.4g} s, {td}, b {self.b:.3g}"


def _series(ss: DiscreteSS, column: int, radius: float) -> np.ndarray:
    """``c0, c1, c2`` of ``s C(e^{s h}) = c0 + c1 s + c2 s^2 + ...`` for input ``column``."""
    h = ss.ts
    n = ss.a.shape[0]
    k = 16  # even: no node at s = 0, where the integrator's pole z = 1 is
    nodes = radius * np.cos(np.pi * (np.arange(k) + 0.5) / k)  # Chebyshev nodes in (-r, r)
    vals = []
    for s in nodes:
        z = math.exp(s * h)
        g = ss.d[0, column]
        if n:
            x = np.linalg.solve(z * np.eye(n) - ss.a, ss.b[:, column])
            g = g + float(ss.c[0] @ x)
        vals.append(s * g)
    # fit in the scaled variable s/r (well conditioned), then unscale
    coef = np.polynomial.polynomial.polyfit(nodes / radius, np.array(vals), 8)
    return coef[:3] / radius ** np.arange(3)


def equivalent_pid(ss: DiscreteSS) -> EquivalentPID:
    """The equivalent PID of the 2-DOF controller ``ss`` (inputs ``[r, y]``, output u)."""
    h = ss.ts
    lam = np.linalg.eigvals(ss.a) if ss.a.size else np.array([])
    # continuous images of the poles that are neither the integrator (1) nor a pure delay (0)
    rates = [abs(complex(np.log(complex(v)))) / h for v in lam
             if abs(v) > 1e-12 and abs(v - 1.0) > 1e-9]  # fmt: skip
    slowest = min(rates) if rates else 1.0 / h
    radius = 0.05 * min(slowest, 1.0 / h)
    cy = -_series(ss, 1, radius)  # the feedback part: u = C_r r - C_y y
    cr = _series(ss, 0, radius)
    ki, kp, kd = (float(v) for v in cy)
    b = float(cr[1]) / kp if kp != 0.0 else math.nan
    c = float(cr[2]) / kd if kd != 0.0 else math.nan
    return EquivalentPID(kp, ki, kd, b, c)
