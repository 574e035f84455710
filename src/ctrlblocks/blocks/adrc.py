"""The general-purpose ADRC function block of Nowak et al. (2018).

Source
------
P. Nowak, K. Stebel, T. Klopot, J. Czeczot, M. Fratczak, P. Laszczyk:
*Flexible function block for industrial applications of active disturbance
rejection controller*, Archives of Control Sciences 28 (2018);
see docs/references.md; equation numbers below are the paper's.

Model and controller (section 2)
--------------------------------
The process is modelled as ``Y^(n) = h + b0 u`` (n = ADRC order, h = *total
disturbance*), written as the extended state-space chain (1).  The extended
state observer (ESO) (2) estimates ``Y, Y', ..., Y^(n-1)`` and ``h``; the
control law (3) cancels ``h`` and imposes an n-th order linear loop.

One code path for n = 1, 2, 3 (section 3.2)
--------------------------------------------
The ESO (2) is discretised by the Euler method with step ``ts`` and computed
*backwards*, so that the newest ``x4`` reaches ``Y_hat`` in the same cycle
(4a)::

    e_o   = Y_i - Y_hat_{i-1}
    x4_i  = x4_{i-1}    + ts l4 e_o
    aux_i = x4_i + b0 u_{i-1}
    x3_i  = x3_{i-1}    + ts (l3 e_o + k3 aux_i)
    x2_i  = x2_{i-1}    + ts (p2 x3_i + l2 e_o + k2 aux_i)
    Y_hat_i = Y_hat_{i-1} + ts (p1 x2_i + l1 e_o + k1 aux_i)

and the control law is (4b)::

    u_i = (kp (Y_sp,i - Y_hat_i) - kd1 x2_i - kd2 x3_i - x4_i) / b0

The switches come from the two low bits ``n1 n0`` of n (section 3.2):
``p1 = n1``, ``p2 = n1 n0``, ``k1 = (not n1) n0``, ``k2 = n1 (not n0)``,
``k3 = p2``:

===  ==  ==  ==  ==  ==  ===========================================
 n   p1  p2  k1  k2  k3  chain used
===  ==  ==  ==  ==  ==  ===========================================
 1   0   0   1   0   0   Y_hat' = x4 + b0 u;  x4 = h
 2   1   0   0   1   0   Y_hat' = x2, x2' = x4 + b0 u
 3   1   1   0   0   1   Y_hat' = x2, x2' = x3, x3' = x4 + b0 u
===  ==  ==  ==  ==  ==  ===========================================

Whatever n, ``x4`` is the estimate of the total disturbance h.

Gains from bandwidths (section 3.3, Gao's parameterisation)
-----------------------------------------------------------
The observer error of the chain of n+1 integrators with output injection
``L`` has the characteristic polynomial
``s^(n+1) + l1 s^n + ... + l_{n} s + l4`` (the last gain always acts on x4).
Placing all n+1 roots at ``-omega_o`` means matching it with
``(s + omega_o)^(n+1) = sum_j C(n+1, j) omega_o^j s^(n+1-j)``.  Likewise the
loop ``Y^(n) = kp (Y_sp - Y) - kd1 Y' - kd2 Y''`` has the characteristic
polynomial ``s^n + kd_{n-1} s^(n-1) + ... + kd1 s + kp``, matched with
``(s + omega_c)^n``.  Hence (``wo = omega_o``, ``wc = omega_c``):

===  =======  ========  ========  =======  =====  =======  =====
 n   l1       l2        l3        l4       kp     kd1      kd2
===  =======  ========  ========  =======  =====  =======  =====
 1   2 wo     0         0         wo^2     wc     0        0
 2   3 wo     3 wo^2    0         wo^3     wc^2   2 wc     0
 3   4 wo     6 wo^2    4 wo^3    wo^4     wc^3   3 wc^2   3 wc
===  =======  ========  ========  =======  =====  =======  =====

(:func:`adrc_gains` computes this table from the binomial coefficients.)

Poles of the discretised loop ("Euler images")
----------------------------------------------
Because (4a) uses the *new* lower state in each upper recursion, it is a
semi-implicit Euler scheme, not plain forward Euler.  For a chain of m
integrators closed with the binomial gains of bandwidth w (``a = w ts``), the
recursion gives ``(z-1)^m + sum_j c_j ts^j z^(j-1) (z-1)^(m-j) = 0`` with the
continuous coefficients ``c_j = C(m, j) w^j``, i.e.::

    z P_m(z) = (z - 1)^(m+1) + ((1 + a) z - 1)^m

whose m roots (z = 0 excluded) are the discrete poles: the observer has
``P_{n+1}`` with ``a = omega_o ts``, the controller (on the observer's own
model) ``P_n`` with ``a = omega_c ts``.  ``P_m`` has a root at z = -1 when
``(2 + a)^m = 2^(m+1)``, so the Euler observer is unstable beyond
``omega_o ts = 2^((m+1)/m) - 2`` (0.828, 0.520, 0.378 for n = 1, 2, 3).

Exact discretisation (option ``discretisation="exact"``)
--------------------------------------------------------
The current observer of Herbst (2013, ref. [10] of Nowak et al. 2018; also [11, 19]):
``x_pred = Phi x + Gamma u_{i-1}``, ``x_i = x_pred + Lc (Y_i - x_pred[0])``,
with ``Phi = exp(A ts)`` and ``Gamma`` the zero-order-hold images of the
chain (1) and ``Lc`` placed (Ackermann) so that all n+1 poles of
``(I - Lc C) Phi`` lie at ``z = exp(-omega_o ts)``.  For consistency the
controller gains are placed the same way on the ZOH chain (all n poles at
``exp(-omega_c ts)``); they tend to the table above as ``omega_c ts -> 0``.
This is a ctrlblocks option, not the paper's block.

Trustworthy range (status ``WARN_DISCRETISATION``, 16#8301)
------------------------------------------------------------
Euler: the block warns when any root of ``P_{n+1}(omega_o ts)`` or
``P_n(omega_c ts)`` has a modulus above ``exp(-a/2)``, i.e. when a mode of the
discretised observer (or controller) decays less than half as fast as the
bandwidth asks.  The bounds
(``EULER_LIMIT``) are found numerically from the roots of ``P_m`` and checked
by the tests: ``a <= 0.735, 0.484, 0.360`` for m = 2, 3, 4 (and 1.477 for
m = 1), just below the stability limits above.  Exact: the poles are exact for
every ``a``, but a bandwidth near the Nyquist frequency ``pi/ts`` cannot be
read as the continuous design any more (the observer time constant is shorter
than a sample; its poles ``exp(-a)`` approach the dead-beat z = 0); the block
warns when ``omega_o ts > pi/2`` or ``omega_c ts > pi/2`` (half the Nyquist
frequency).

Function-block behaviour (sections 4 and 5)
-------------------------------------------
See :class:`ADRC` for limits and anti-windup (4.1), bumpless MAN/AUTO by (11)
(4.2), the optional anti-backoff action (12a)/(12b) (4.3) and the inputs and
outputs of Fig. 2 (section 5).
"""

from __future__ import annotations

import dataclasses
import math
import sys
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from .base import (
    MAX_TIME,
    Block,
    BlockConfig,
    ErrorCode,
    Mode,
    ParameterError,
    as_flag,
    as_input,
    is_finite,
    require_bool,
    require_choice,
    require_coefficients,
    require_finite,
    require_limits,
    require_nonnegative,
    require_positive,
    require_range,
)
from .pid import pid_output
from .precision import block_limits
from .precision import check_precision as _check_precision
from .precision import float32_cycle as _float32_cycle
from .precision import unsupported as _unsupported
from .signals import clamp, pt1_coefficient, pt1_step, rate_limit_step, scale

__all__ = [
    "ADRC",
    "ADRCConfig",
    "ADRCKernelParams",
    "ADRCKernelState",
    "adrc_gains",
    "adrc_law",
    "adrc_step",
    "adrc_switches",
    "anti_backoff_states",
    "control_law",
    "eso_euler",
    "eso_exact",
    "euler_pole_polynomial",
    "euler_substeps",
    "handover_offset",
    "retune_x4",
    "td_restart",
    "tracking_differentiator",
]

#: Largest ``a = omega ts`` for which every root of the Euler image ``P_m``
#: (module docstring) has modulus <= exp(-a/2), for m = 1..4 (chain length).
#: Computed from the roots of ``P_m`` by bisection; checked by the tests.
EULER_LIMIT: dict[int, float] = {1: 1.477, 2: 0.735, 3: 0.484, 4: 0.360}

#: Largest ``omega ts`` trusted for the exact discretisation (half Nyquist).
EXACT_LIMIT: float = math.pi / 2.0

_INF, _NINF = math.inf, -math.inf
_NO_ERROR, _BAD_LIMITS = ErrorCode.NO_ERROR, ErrorCode.BAD_LIMITS
_WARN = ErrorCode.WARN_DISCRETISATION
# adrc_compute's status codes, as the PLC's DINT holds them (the members themselves)
_OK: int = ErrorCode.NO_ERROR
_BAD_INPUT: int = ErrorCode.BAD_INPUT
_BAD_MEASUREMENT: int = ErrorCode.BAD_MEASUREMENT
_BAD_RESULT: int = ErrorCode.BAD_RESULT

#: The largest valid magnitude of the block's process data (float64): "finite" (adrc_compute).
FLOAT_MAX: float = sys.float_info.max

#: Longest ``input_delay`` [samples of ts] (the history of u the ESO is fed from).
MAX_DELAY_SAMPLES: int = 100_000


def delay_samples(input_delay: float, ts: float) -> int:
    """``input_delay`` [s] in whole samples of ``ts`` (rounded half to even, as ``round``)."""
    d = float(input_delay) / float(ts)
    return round(d) if d < 2.0 * MAX_DELAY_SAMPLES else 2 * MAX_DELAY_SAMPLES


_ANTI_WINDUP = {"directional": 2, "freeze": 1, "off": 0, True: 2, False: 0}


# ---------------------------------------------------------------------------
# Pure per-cycle arithmetic (floats only; one implementation of the law)
# ---------------------------------------------------------------------------


def adrc_switches(n: int) -> tuple[float, float, float, float, float]:
    """Switches ``(p1, p2, k1, k2, k3)`` from the two low bits of the order n.

    Nowak et al. 2018, section 3.2: ``p1 = n1``, ``p2 = n1 n0``, ``k1 = not(n1) n0``,
    ``k2 = n1 not(n0)``, ``k3 = p2`` where ``n = 2 n1 + n0``.
    """
    n1 = float((n >> 1) & 1)
    n0 = float(n & 1)
    p1 = n1
    p2 = n1 * n0
    k1 = (1.0 - n1) * n0
    k2 = n1 * (1.0 - n0)
    k3 = p2
    return p1, p2, k1, k2, k3


def adrc_gains(
    n: int, omega_c: float, omega_o: float
) -> tuple[float, float, float, float, float, float, float]:
    """Gao's bandwidth gains ``(l1, l2, l3, l4, kp, kd1, kd2)`` for order n.

    Observer: ``(s + omega_o)^(n+1)``; controller: ``(s + omega_c)^n``
    (Nowak et al. 2018, section 3.3; derivation and table in the module docstring):
    the binomial coefficients ``C(n+1, j) omega_o^j`` and ``C(n, j) omega_c^j``,
    spelled out for n = 1, 2, 3 by :func:`bandwidth_gains` (the version the PLC
    runs too; the tests check them against ``numpy.poly``).  ``l4`` always
    multiplies the x4 (total disturbance) recursion.
    """
    return bandwidth_gains(n, omega_c, omega_o)


def euler_pole_polynomial(m: int, a: float) -> np.ndarray:
    """Coefficients (highest power first) of the Euler image ``P_m(z)``.

    ``z P_m(z) = (z - 1)^(m+1) + ((1 + a) z - 1)^m`` (module docstring): the
    characteristic polynomial of the semi-implicit Euler recursion (4a) of a
    chain of m integrators closed with binomial gains of bandwidth ``a/ts``.
    """
    zp = np.poly1d([1.0, -1.0]) ** (m + 1) + np.poly1d([1.0 + a, -1.0]) ** m
    return np.asarray(zp.coeffs[:-1], dtype=float)


def eso_euler(
    yh: float,
    x2: float,
    x3: float,
    x4: float,
    u_prev: float,
    y: float,
    w4: float,
    ts: float,
    b0: float,
    l1: float,
    l2: float,
    l3: float,
    l4: float,
    p1: float,
    p2: float,
    k1: float,
    k2: float,
    k3: float,
) -> tuple[float, float, float, float]:
    """One step of the Euler ESO (4a) of Nowak et al. 2018, computed x4 -> x3 -> x2 -> Y_hat.

    ``w4`` multiplies the x4 increment: 1 runs it, 0 freezes x4 (anti-windup,
    section 4.1) while the other states keep running.  Returns
    ``(Y_hat_i, x2_i, x3_i, x4_i)``.
    """
    e = y - yh
    x4n = x4 + w4 * ts * l4 * e
    aux = x4n + b0 * u_prev
    x3n = x3 + ts * (l3 * e + k3 * aux)
    x2n = x2 + ts * (p2 * x3n + l2 * e + k2 * aux)
    yhn = yh + ts * (p1 * x2n + l1 * e + k1 * aux)
    return yhn, x2n, x3n, x4n


def eso_exact(
    yh: float,
    x2: float,
    x3: float,
    x4: float,
    u_prev: float,
    y: float,
    w4: float,
    f01: float,
    f02: float,
    f03: float,
    f12: float,
    f13: float,
    f23: float,
    g0: float,
    g1: float,
    g2: float,
    c0: float,
    c1: float,
    c2: float,
    c3: float,
) -> tuple[float, float, float, float]:
    """One step of the exact (ZOH) current observer (Herbst) in the 4-state layout.

    Prediction ``x_pred = Phi x + Gamma u_prev`` (``Phi`` upper triangular with
    unit diagonal: ``f01 .. f23``; ``Gamma = (g0, g1, g2, 0)``), correction
    ``x = x_pred + Lc (y - x_pred[0])`` with ``Lc = (c0, c1, c2, c3)``.
    ``w4 = 0`` freezes x4 (its prediction is x4 itself).
    """
    p0 = yh + f01 * x2 + f02 * x3 + f03 * x4 + g0 * u_prev
    p1 = x2 + f12 * x3 + f13 * x4 + g1 * u_prev
    p2 = x3 + f23 * x4 + g2 * u_prev
    e = y - p0
    return p0 + c0 * e, p1 + c1 * e, p2 + c2 * e, x4 + w4 * c3 * e


def control_law(
    r: float,
    yh: float,
    x2: float,
    x3: float,
    x4: float,
    b0: float,
    kp: float,
    kd1: float,
    kd2: float,
) -> float:
    """ADRC control law, Nowak et al. 2018, (4b) (``r`` replaces Y_sp when filtered)."""
    return (kp * (r - yh) - kd1 * x2 - kd2 * x3 - x4) / b0


def x4_update_allowed(rule: int, awin: bool, sat: int, du: float) -> float:
    """Anti-windup decision for the x4 update of this cycle: 1.0 run, 0.0 freeze.

    ``sat`` is +1 (-1) when the control law (4b) of the previous cycle was
    above u_max (below u_min), else 0; ``du`` is the change of this cycle's u
    that the x4 update causes.  ``rule``: 0 ``"off"``; 1 ``"freeze"`` (Nowak et al. 2018,
    section 4.1, literally: x4 frozen while u is outside its range);
    2 ``"directional"``: freeze only an update that pushes u further beyond
    the limit it violates, so an update that brings u back towards the range
    always runs (this cannot lock at a limit, see :class:`ADRC`).  ``awin``
    freezes unconditionally (cascade, section 5), whatever the rule.
    """
    if awin:
        return 0.0
    if rule == 0 or sat == 0:
        return 1.0
    if rule == 1:
        return 0.0
    if (sat > 0 and du > 0.0) or (sat < 0 and du < 0.0):
        return 0.0
    return 1.0


def solve_x4(
    u_target: float,
    u_law: float,
    yh: float,
    x2: float,
    x3: float,
    x4: float,
    s_yh: float,
    s_x2: float,
    s_x3: float,
    s_u: float,
) -> tuple[float, float, float, float]:
    """Re-solve x4 so that the control law gives ``u_target`` (Nowak et al. 2018, (11)).

    All states of cycle i are affine in x4_i (the backward recursion (4a)
    passes x4_i on through aux_i with the constant sensitivities ``s_yh``,
    ``s_x2``, ``s_x3``), and so is u_i with slope ``s_u``.  Shifting x4_i by
    ``d = (u_target - u_law)/s_u`` and the other states by ``s d`` makes (4b)
    return ``u_target``: the exact form of (11), used for bumpless MAN -> AUTO,
    resume after a bad measurement and retuning.
    """
    d = (u_target - u_law) / s_u
    return yh + s_yh * d, x2 + s_x2 * d, x3 + s_x3 * d, x4 + d


def retune_x4(
    r: float,
    yh: float,
    x2: float,
    x3: float,
    u_keep: float,
    b0: float,
    kp: float,
    kd1: float,
    kd2: float,
) -> float:
    """x4 for a retune: the new law (4b) gives ``u_keep`` on the last sample's states.

    A bumpless parameter change (Åström & Hägglund 2006, "bumpless parameter
    changes"; the principle of (11) of Nowak et al. 2018 applied at the instant
    of the change): the committed ESO states ``Y_hat, x2, x3`` and the reference
    ``r`` of the last sample stay, and the disturbance estimate takes the
    difference of the old and the new law, so that the new law's value on
    them, ``(kp (r - Y_hat) - kd1 x2 - kd2 x3 - x4) / b0``, is the old law's
    ``u_keep``.  The next cycle then runs (4a)/(4b) of the new tuning in
    full from these states: the output is continuous at the change, not held
    for a sample (``b0, kp, kd1, kd2`` are the new law's).
    """
    return kp * (r - yh) - kd1 * x2 - kd2 * x3 - b0 * u_keep


def anti_backoff_states(
    y_sat: float,
    r: float,
    u_prev: float,
    l1: float,
    l2: float,
    l3: float,
    l4: float,
    b0: float,
    kp: float,
    kd1: float,
    kd2: float,
    p1: float,
    p2: float,
    k1: float,
    k2: float,
    k3: float,
) -> tuple[float, float, float, float]:
    """ESO states when Y reaches the sensor saturation ``y_sat``: (12a)/(12b) of Nowak et al. 2018.

    Re-derived from (4a) (section 4.3): with Y frozen at ``y_sat`` the ESO is
    put at rest, i.e. the increments of Y_hat, x2 and x3 in (4a) vanish:

    * ``p1 x2 + l1 e + k1 aux = 0``  ->  ``x2 = -p1 (l1 e + k1 aux)``,
    * ``p2 x3 + l2 e + k2 aux = 0``  ->  ``x3 = -p2 (l2 e + k2 aux)``,
    * ``k1 l1 e + k2 l2 e + k3 l3 e + (k1 + k2 + k3) aux = 0`` (the equation of
      the state that receives aux) -> ``x4 = -(k1 l1 + k2 l2 + k3 l3) e
      - (k1 + k2 + k3) b0 u_prev``,

    with ``e = y_sat - Y_hat`` and ``aux = x4 + b0 u_prev``.  (The extraction
    of (12a) prints ``- k aux`` inside the brackets; the sign is immaterial
    because ``p1 k1 = p2 k2 = 0`` for every n.)  Inserting them in (4b) and
    asking ``u_i = u_{i-1}`` gives ``kp (r - Y_hat) + Gamma e = 0`` with
    ``Gamma = p1 kd1 l1 + p2 kd2 l2 + k1 l1 + k2 l2 + k3 l3``, hence (12b)
    ``Y_hat = (kp r + Gamma y_sat) / (kp + Gamma)``.  The same ``e`` (with
    this Y_hat) is used in (12a), so that u does not jump at all.
    """
    gamma = p1 * kd1 * l1 + p2 * kd2 * l2 + k1 * l1 + k2 * l2 + k3 * l3
    den = kp + gamma
    yh = y_sat  # gains that underflowed to 0 (omega = 5e-324): Y_hat on the saturation
    if den != 0.0:
        yh = (kp * r + gamma * y_sat) / den
    e = y_sat - yh
    x4 = -(k1 * l1 + k2 * l2 + k3 * l3) * e - (k1 + k2 + k3) * b0 * u_prev
    aux = x4 + b0 * u_prev
    x3 = -p2 * (l2 * e + k2 * aux)
    x2 = -p1 * (l1 * e + k1 * aux)
    return yh, x2, x3, x4


def adrc_law(
    r_in: float,
    y: float,
    ff: float,
    manual: bool,
    target: float,
    tracking: bool,
    started: bool,
    sat: int,
    awin: bool,
    exact: bool,
    ab_on: bool,
    yh: float,
    x2: float,
    x3: float,
    x4: float,
    u_eso: float,
    u_prev: float,
    ref: float,
    q: float,
    ab_sat: int,
    ab_wait: float,
    prm: tuple[float, ...],
    ecoef: tuple[float, ...],
    ab: tuple[float, ...],
) -> tuple[float, float, float, float, float, float, float, float, bool, int, int, float]:
    """The ADRC's cycle on a valid measurement ``y``, every option: the one cycle of every executor.

    The block (:meth:`ADRC.compute_output`), its per-call fast lane, the
    compiled kernels (:func:`adrc_step`, numba and Cython), the float32 cycle
    and the exported function block (:mod:`.plc_cycle`) all run this function
    -- written once, in the subset the PLC translator accepts (no lists, no
    exceptions).  In Åström's (1987, section 6) computational order it is the
    ``compute`` half: from the committed state to this cycle's output and the
    state to commit; the caller commits it with the value actually applied.

    * ``started`` False: the first valid measurement starts the ESO at rest on
      it (``Y_hat = y``, ``x2 = x3 = 0``, ``x4 = -b0 u_eso``, reference ``y``),
      where a block that starts ``tracking`` (in MAN) takes the held output
      ``target`` as ``u_eso``: the plant rests at what it is given, not at the
      configured ``u0``;
    * ``ff`` (finite; 0: none) is the feed-forward, added to the law's output
      before the limits as in the PID; the ESO is fed ``u_eso`` -- the applied u
      *less the ff of its cycle* (the caller's bookkeeping), so the ESO sees the
      feed-forward's effect as part of the total disturbance and the loop stays
      offset-free: the feed-forward only acts earlier than the observer can
      (docs/blocks/adrc.md, "Feed-forward");
    * the reference trajectory (section 5): the exact PT1 ``a_ref`` of the
      setpoint ``r_in``; in MAN with a filter it follows ``y``;
    * the ESO (4a) by :func:`eso_euler`, or the exact current observer by
      :func:`eso_exact` (``exact``, coefficients ``ecoef``), fed ``u_eso`` --
      the applied u, or that of ``input_delay`` ago (Zhao & Gao 2014);
    * ``tracking`` (MAN, a bad setpoint, the cycle after MAN or a bad
      measurement): the output is ``target`` (limited by the caller).  The ESO
      runs on, undisturbed, and the *handover offset* ``q`` of the reference
      is solved so that (4b) gives ``target`` (:func:`handover_offset`); only
      where that cannot be done (``kp`` underflowed) x4 is re-solved by (11)
      with :func:`solve_x4`;
    * else ``q`` decays by ``a_q = exp(-omega_c h)`` and the law (4b) runs on
      the reference ``ref + q`` (docs/blocks/adrc.md, "Modes and bumpless
      transfer": the output continues without a bump and its first move goes
      toward the setpoint), by :func:`control_law`, the x4 anti-windup rule
      (section 4.1, :func:`x4_update_allowed`; ``awin`` freezes x4, section 5)
      and, with ``ab_on``, the anti-backoff action (12a)/(12b) of section 4.3
      (``ab = (y_sat, y_sat_lo, tau_wait)``): the states of
      :func:`anti_backoff_states` when y reaches the sensor's saturation, u
      held for ``tau_wait`` after it leaves (``u_prev``, the applied u).

    ``prm`` is :class:`ADRCKernelParams` (sample time, gains, switches,
    sensitivities, limits, anti-windup rule, reference pole, handover pole,
    Euler sub-steps: the Euler ESO runs ``nsub`` steps of ``ts/nsub`` with u
    and y held, :func:`euler_substeps`).  Returns ``(u, u_raw, Y_hat, x2,
    x3, x4, ref, q, track_next, sat_next, ab_sat, ab_wait)``: ``track_next``
    asks the next cycle to track (the end of the anti-backoff wait); the
    caller adds its own reasons (MAN, bad data).
    """
    (ts, b0, l1, l2, l3, l4, p1, p2, k1, k2, k3, kp, kd1, kd2,
     s_yh, s_x2, s_x3, s_u, lo, hi, rule, a_ref, a_q, nsub) = prm  # fmt: skip
    f01, f02, f03, f12, f13, f23, g0, g1, g2, c0, c1, c2, c3 = ecoef
    y_sat, y_sat_lo, tau_wait = ab
    if not started:
        if tracking:  # started in MAN (or holding): the plant rests at the held output
            u_eso = target - ff
        yh = y
        x2 = 0.0
        x3 = 0.0
        x4 = -b0 * u_eso
        ref = y
    # in manual with a reference filter the reference follows y
    ref = y if manual and a_ref != 0.0 else a_ref * ref + (1.0 - a_ref) * r_in
    if exact:
        z0, z1, z2, z3 = eso_exact(yh, x2, x3, x4, u_eso, y, 1.0, f01, f02, f03, f12, f13,
                                   f23, g0, g1, g2, c0, c1, c2, c3)  # fmt: skip
    elif nsub == 1.0:
        z0, z1, z2, z3 = eso_euler(yh, x2, x3, x4, u_eso, y, 1.0, ts, b0, l1, l2, l3, l4,
                                   p1, p2, k1, k2, k3)  # fmt: skip
    else:
        z0, z1, z2, z3 = eso_euler_substeps(yh, x2, x3, x4, u_eso, y, 1.0, ts, nsub, b0, l1,
                                            l2, l3, l4, p1, p2, k1, k2, k3)  # fmt: skip
    if tracking:
        if kp != 0.0:
            q = handover_offset(target - ff, ref, z0, z1, z2, z3, b0, kp, kd1, kd2)
            if q - q == 0.0:  # finite: the ESO runs on, the reference takes the offset
                return target, target, z0, z1, z2, z3, ref, q, False, 0, ab_sat, ab_wait
        u_free = control_law(ref, z0, z1, z2, z3, b0, kp, kd1, kd2)
        yh, x2, x3, x4 = solve_x4(target - ff, u_free, z0, z1, z2, z3, s_yh, s_x2, s_x3, s_u)
        return target, target, yh, x2, x3, x4, ref, 0.0, False, 0, ab_sat, ab_wait
    q = a_q * q
    r = ref + q
    u_free = control_law(r, z0, z1, z2, z3, b0, kp, kd1, kd2)
    du = s_u * (z3 - x4)
    if x4_update_allowed(int(rule), awin, sat, du) == 1.0:
        yh = z0
        x2 = z1
        x3 = z2
        x4 = z3
        u_raw = u_free + ff
    else:
        if exact:
            yh, x2, x3, x4 = eso_exact(yh, x2, x3, x4, u_eso, y, 0.0, f01, f02, f03, f12,
                                       f13, f23, g0, g1, g2, c0, c1, c2, c3)  # fmt: skip
        elif nsub == 1.0:
            yh, x2, x3, x4 = eso_euler(yh, x2, x3, x4, u_eso, y, 0.0, ts, b0, l1, l2, l3, l4,
                                       p1, p2, k1, k2, k3)  # fmt: skip
        else:
            yh, x2, x3, x4 = eso_euler_substeps(yh, x2, x3, x4, u_eso, y, 0.0, ts, nsub, b0,
                                                l1, l2, l3, l4, p1, p2, k1, k2,
                                                k3)  # fmt: skip
        u_raw = control_law(r, yh, x2, x3, x4, b0, kp, kd1, kd2) + ff
    end_wait = False
    if ab_on:
        now = 0
        if y >= y_sat:
            now = 1
        elif y <= y_sat_lo:
            now = -1
        if now != 0 and ab_sat == 0:
            # Y has just reached the sensor saturation: (12a)/(12b)
            ysat = y_sat_lo
            if now > 0:
                ysat = y_sat
            yh, x2, x3, x4 = anti_backoff_states(ysat, r, u_eso, l1, l2, l3, l4, b0, kp,
                                                 kd1, kd2, p1, p2, k1, k2, k3)  # fmt: skip
            u_raw = control_law(r, yh, x2, x3, x4, b0, kp, kd1, kd2) + ff
            ab_wait = 0.0
        elif now == 0 and ab_sat != 0:
            ab_wait = tau_wait  # Y has left the saturation
        ab_sat = now
        if ab_wait > 0.0:
            # hold u for tau_wait while the ESO converges (section 4.3)
            u_raw = clamp(u_prev, lo, hi)
            ab_wait = max(ab_wait - ts, 0.0)
            if ab_wait < 1e-9 * ts:
                ab_wait = 0.0
                end_wait = True  # leave the wait bumplessly, x4 by (11)
    sat_next = 0
    if u_raw > hi:
        sat_next = 1
    elif u_raw < lo:
        sat_next = -1
    return (clamp(u_raw, lo, hi), u_raw, yh, x2, x3, x4, ref, q, end_wait, sat_next, ab_sat,
            ab_wait)  # fmt: skip


def handover_offset(
    target: float,
    ref: float,
    yh: float,
    x2: float,
    x3: float,
    x4: float,
    b0: float,
    kp: float,
    kd1: float,
    kd2: float,
) -> float:
    """The offset ``q`` of the reference for which the law (4b) gives ``target`` on these states.

    ``(kp (ref + q - Y_hat) - kd1 x2 - kd2 x3 - x4) / b0 = target`` gives
    ``q = Y_hat - ref + (b0 target + kd1 x2 + kd2 x3 + x4) / kp`` (Nowak et al.
    2018, (4b), solved for the reference instead of for x4 as in (11):
    docs/blocks/adrc.md, "Modes and bumpless transfer").  At a steady state in
    MAN the ESO holds ``Y_hat = y``, ``x2 = x3 = 0``, ``x4 = -b0 u``, so
    ``ref + q = y``: the handover starts the reference at the measurement.
    The caller checks ``kp != 0`` first (an underflowed bandwidth) and, where
    ``q`` is not finite, re-solves x4 instead.
    """
    return yh - ref + (b0 * target + kd1 * x2 + kd2 * x3 + x4) / kp


def eso_euler_substeps(
    yh: float,
    x2: float,
    x3: float,
    x4: float,
    u_prev: float,
    y: float,
    w4: float,
    ts: float,
    nsub: float,
    b0: float,
    l1: float,
    l2: float,
    l3: float,
    l4: float,
    p1: float,
    p2: float,
    k1: float,
    k2: float,
    k3: float,
) -> tuple[float, float, float, float]:
    """The Euler ESO (4a) over a sample ``ts`` in ``nsub`` steps of ``ts/nsub`` (u and y held).

    The Euler image of the observer is unstable beyond ``omega_o h = 0.828,
    0.520, 0.378`` (n = 1, 2, 3; module docstring); a runtime that measures a
    longer period than the block was designed for would make the block
    diverge.  Sub-stepping keeps every step inside the trusted range
    (:func:`euler_substeps`) for any period: the continuous ESO (2) driven by
    the sample's held input and measurement, integrated more finely.
    """
    h = ts / nsub
    for _k in range(int(nsub)):
        yh, x2, x3, x4 = eso_euler(yh, x2, x3, x4, u_prev, y, w4, h, b0, l1, l2, l3, l4,
                                   p1, p2, k1, k2, k3)  # fmt: skip
    return yh, x2, x3, x4


def euler_sensitivities(
    h: float, p1: float, p2: float, k1: float, k2: float, k3: float
) -> tuple[float, float, float]:
    """``(s_x3, s_x2, s_yh)``: how the states of one Euler step (4a) move with x4_i (for (11)).

    The backward recursion passes x4_i on through ``aux_i``: ``s_x3 = h k3``,
    ``s_x2 = h (p2 s_x3 + k2)``, ``s_yh = h (p1 s_x2 + k1)`` (:func:`solve_x4`).
    """
    s_x3 = h * k3
    s_x2 = h * (p2 * s_x3 + k2)
    s_yh = h * (p1 * s_x2 + k1)
    return s_x3, s_x2, s_yh


def handover_pole(omega_c: float, h: float) -> float:
    """``exp(-omega_c h)``: the decay per sample of the handover offset of the reference.

    The offset that made a transfer bumpless fades with the loop's own time
    constant ``1/omega_c`` (docs/blocks/adrc.md, "Modes and bumpless transfer").
    """
    return math.exp(-omega_c * h)


def euler_substeps(n: int, omega_o: float, h: float) -> float:
    """Steps of the Euler ESO over a sample ``h``: 1 where ``omega_o h`` is trusted, else enough.

    ``ceil(omega_o h / EULER_LIMIT[n+1])`` (the bound of the trusted range,
    module docstring, for the chain of n+1 states), at least 1 -- so a block
    configured inside the trusted range runs its one step at its ``ts`` and
    sub-steps only for longer periods -- and at most 100: the observer is
    stable for periods up to 100 trusted steps (at least 100 ``ts`` for a
    block designed in the trusted range); beyond, the block keeps its
    contract (a finite, limited output; an overflowing observer restarts) but
    its observer is not guaranteed to converge.  A float (the PLC's REAL), whole.
    """
    lim = 1.477
    if n == 1:
        lim = 0.735
    elif n == 2:
        lim = 0.484
    elif n == 3:
        lim = 0.360
    a = omega_o * h / lim
    if not a > 1.0:
        return 1.0
    if not a < 100.0:
        return 100.0  # the bound: periods up to 100 trusted steps (docs/blocks/adrc.md)
    m = float(int(a))
    if m < a:
        m = m + 1.0
    return m


NO_EXACT: tuple[float, ...] = (0.0,) * 13
"""The ``ecoef`` of :func:`adrc_law` for the Euler ESO (not read)."""

NO_ANTI_BACKOFF: tuple[float, float, float] = (math.inf, -math.inf, 0.0)
"""The ``ab`` of :func:`adrc_law` without the anti-backoff action (not read)."""


def adrc_step(
    sp: float,
    y: float,
    manual: bool,
    u_man: float,
    started: bool,
    track: bool,
    sat: int,
    yh: float,
    x2: float,
    x3: float,
    x4: float,
    u_prev: float,
    ref: float,
    q: float,
    prm: tuple[float, ...],
    awin: bool = False,
) -> tuple[float, float, float, float, float, float, float, float, bool, int]:
    """One whole cycle of the Euler ADRC with ``applied = u``: :func:`adrc_law` for the kernels.

    The compiled loops of :mod:`ctrlblocks.fast` run this function (numba
    inlines it): :func:`adrc_law` with the Euler ESO, no anti-backoff and no
    input delay, the target of (11) the manual value (MAN) or the last u.
    ``started`` is False before the first measurement; ``sat`` is +1/-1/0
    when the previous raw output was above/below/inside the limits; ``prm``
    is :class:`ADRCKernelParams`; ``awin`` the anti-windup input (a
    cascade's AW handshake, section 5: x4 frozen this cycle).

    Returns ``(u, u_raw, Y_hat, x2, x3, x4, ref, q, track_next, sat_next)``
    (``q``: the handover offset of the reference).
    """
    lo = prm[18]
    hi = prm[19]
    target = clamp(u_prev, lo, hi)
    if manual:
        target = clamp(u_man, lo, hi)
    u, u_raw, yh, x2, x3, x4, ref, q, end_wait, sat_next, _ab_sat, _ab_wait = adrc_law(
        sp, y, 0.0, manual, target, manual or track, started, sat, awin, False, False, yh, x2,
        x3, x4, u_prev, u_prev, ref, q, 0, 0.0, prm, NO_EXACT, NO_ANTI_BACKOFF,
    )  # fmt: skip
    return u, u_raw, yh, x2, x3, x4, ref, q, manual or end_wait, sat_next


def input_stage(
    sp: float,
    y: float,
    sp_ok: bool,
    y_ok: bool,
    sp_filter: float,
    pv_filter: float,
    sp_rate: float,
    h: float,
    preset: bool,
    sp_f: float,
    pv_f: float,
    sp_w: float,
) -> tuple[float, float, float]:
    """The input stage of the ADRC, as the PID's: SP and PV filters, then the setpoint ramp.

    One sample of the PID's input stage (controltheplant 2024, sections 2.3.4
    scaling, 2.3.7 filters, 2.3.8 rate limit; :class:`~ctrlblocks.PID`): ``sp``
    and ``y`` -- already scaled to 0..100 % where a PV range is configured --
    each pass a PT1 with the exact pole
    ``exp(-h/T)`` (:func:`.signals.pt1_coefficient`, ``T = 0``: off), and the
    filtered setpoint a ramp of ``sp_rate`` units/s both ways (0: off,
    :func:`.signals.rate_limit_step`).  A value that is not valid (``sp_ok``,
    ``y_ok`` False) leaves its chain where it is.  ``preset`` (the ESO is not yet
    started: the first valid measurement, or a restart) starts each chain at its
    input, and a setpoint not yet valid then at the PV, so the ramp later starts
    from the process.  With every option off the stage passes its inputs through
    exactly.  Returns the new ``(sp_f, pv_f, sp_w)``: the working setpoint is
    ``sp_w``, the measurement the ESO and the law see ``pv_f``.
    """
    if y_ok:
        if preset:
            pv_f = y
        pv_f = pt1_step(pt1_coefficient(pv_filter, h, "exact"), pv_f, 1.0, y)
        if sp_ok:
            if preset:
                sp_f = sp
                sp_w = sp
            sp_f = pt1_step(pt1_coefficient(sp_filter, h, "exact"), sp_f, 1.0, sp)
            sp_w, _ramping = rate_limit_step(sp_f, sp_w, sp_rate, sp_rate, h)
            if sp_w - sp_w != 0.0:  # the ramp's step overflowed: the filtered setpoint
                sp_w = sp_f
        elif preset:
            sp_f = pv_f
            sp_w = pv_f
    return sp_f, pv_f, sp_w


def tracking_differentiator(
    r: float,
    y: float,
    sp_ok: bool,
    y_ok: bool,
    held: bool,
    preset: bool,
    n: int,
    td_time: float,
    h: float,
    kp: float,
    kd1: float,
    kd2: float,
    z1: float,
    z2: float,
    z3: float,
) -> tuple[float, float, float, float, float, float, float, float]:
    """The linear tracking differentiator of order n and the reference ``r_eff`` of (4b) it gives.

    The chain of n identical first-order lags ``z_k' = w (z_{k-1} - z_k)`` with
    ``z_0 = r`` and ``w = 1/td_time``: the filtered reference ``r_f = z_n`` is
    ``w^n/(s + w)^n r`` (critically damped: no overshoot), and its derivatives
    are read off the states, ``r_f^(k) = w^k sum_j C(k, j) (-1)^(k-j) z_{n-j}``
    (k = 1..n; the n-th uses ``z_0 = r``): the tracking differentiator of Han
    2009 in a linear form.  Discretised exactly for ``r`` held over the sample
    (zero-order hold): ``z(t+h) = r + Phi (z(t) - r)`` with ``Phi_kj = exp(-a)
    a^(k-j)/(k-j)!`` (``a = h/td_time``) -- the same as ``Phi z + Gamma r``
    with ``Gamma = (I - Phi) 1``, written on the deviations so that a chain at
    rest stays exactly at rest, in REAL too.  ``r_f`` and the derivatives
    below the n-th belong to the sample's instant (the states before the step);
    the n-th, which u acts on directly, is its mean over the sample,
    ``(r_f^(n-1)(t + h) - r_f^(n-1)(t))/h`` -- the value a u held over the
    sample must have for the chain's (n-1)-th derivative to move as the
    reference's (the point value at t lags by about ``w h``: in closed loop on
    ``b0/s^n`` the error to ``w^n/(s + w)^n`` falls from 1-2.4 % to below
    0.03 % of a step at ``w h = 0.04``, tests/blocks/test_adrc_td.py).

    The control law with the reference's derivatives fed forward (docs/blocks/
    adrc.md, "Tracking differentiator"), ``u = (kp (r_f - Y_hat) + kd1 (r_f' -
    x2) + kd2 (r_f'' - x3) + r_f^(n) - x4) / b0``, is (4b) of Nowak et al. 2018
    on the reference ``r_eff = r_f + (kd1 r_f' + kd2 r_f'' + r_f^(n)) / kp``
    (``kd1 = 0`` for n = 1 and ``kd2 = 0`` for n < 3, so each derivative enters
    once): the caller hands ``r_eff`` to :func:`adrc_law` as its setpoint, and
    the law, the ESO and the handover offset stay as they are.

    ``td_time <= 0``: off, ``r`` passes through and the states stay.  ``held``
    (a held mode) puts the chain at rest on the measurement ``y`` and keeps it
    there (``r_eff = y``); ``preset`` (the ESO not yet started) puts it at rest
    on ``y`` and runs it.  A bad setpoint or measurement holds the chain.  A
    step that overflows restarts it at rest on ``r``; derivatives that
    overflow (a ``td_time`` so short that ``1/td_time`` does) are 0, and an
    ``r_eff`` that overflows (or ``kp = 0``) is ``r_f``.  Spelled out for n = 1, 2, 3 (a PLC
    has no lists): the block, the float32 cycle and the exported FB run this
    one function.  Returns ``(r_eff, r_f, d1, d2, d3, z1, z2, z3)``, ``dk``
    the k-th derivative of ``r_f`` (the n-th: its mean over the sample; 0
    beyond n).
    """
    if not td_time > 0.0:
        return r, r, 0.0, 0.0, 0.0, z1, z2, z3
    run = sp_ok and y_ok and not held
    if y_ok and (held or preset):
        z1 = y
        z2 = y
        z3 = y
    if not run:
        rf, _d1, _d2 = td_state(n, 0.0, z1, z2, z3)
        return rf, rf, 0.0, 0.0, 0.0, z1, z2, z3
    w = 1.0 / td_time
    a = h / td_time
    ea = math.exp(-a)
    _d, q = pole_distance(w, h)  # (1 - exp(-a))/h, accurate for a tiny a
    # r_f and the derivatives below the n-th at the sample's instant (td_state); the n-th
    # is fed forward as its mean over the sample, (D_(n-1)(t + h) - D_(n-1)(t))/h: the value
    # a u held over the sample must have (its point value w^n (...) at t would lag by about
    # w h)
    rf, d1, d2 = td_state(n, w, z1, z2, z3)
    d3 = 0.0
    if n == 1:
        d1 = q * (r - z1)
        dn = d1
        z1 = r + ea * (z1 - r)
    elif n == 2:
        d2 = w * (q * (z2 - z1) + ea * w * (r - z1))
        dn = d2
        z2 = r + ea * ((z2 - r) + a * (z1 - r))
        z1 = r + ea * (z1 - r)
    else:
        d3 = w * (w * (q * ((z2 - z1) - (z3 - z2))
                       + ea * w * ((z2 - z1) + (1.0 - a / 2.0) * (r - z1))))  # fmt: skip
        dn = d3
        z3 = r + ea * ((z3 - r) + a * (z2 - r) + a * a / 2.0 * (z1 - r))
        z2 = r + ea * ((z2 - r) + a * (z1 - r))
        z1 = r + ea * (z1 - r)
    if d1 - d1 != 0.0 or d2 - d2 != 0.0 or d3 - d3 != 0.0:
        d1 = 0.0  # a td_time so short that w overflows: no derivative to feed forward
        d2 = 0.0
        d3 = 0.0
        dn = 0.0
    r_eff = rf
    if kp > 0.0:
        r_eff = rf + (kd1 * d1 + kd2 * d2 + dn) / kp
        if r_eff - r_eff != 0.0:
            r_eff = rf
    if z1 - z1 != 0.0 or z2 - z2 != 0.0 or z3 - z3 != 0.0:
        z1 = r
        z2 = r
        z3 = r
    return r_eff, rf, d1, d2, d3, z1, z2, z3


def td_state(n: int, w: float, z1: float, z2: float, z3: float) -> tuple[float, float, float]:
    """The filtered reference ``r_f`` of a tracking differentiator of order n and the
    derivatives its states determine, ``(r_f, r_f', r_f'')`` (0 at and beyond the order).

    ``r_f^(k) = w^k sum_j C(k, j) (-1)^(k-j) z_{n-j}`` (k < n; :func:`tracking_differentiator`,
    after Han 2009) of the chain ``z_k' = w (z_{k-1} - z_k)``, ``r_f = z_n``: the chain's
    value at its states' instant, for the law (:func:`tracking_differentiator`) and for the
    restart after a retune (:func:`td_restart`), which continues them.  ``w = 1/td_time``;
    ``w = 0`` gives ``r_f`` alone.
    """
    if n == 1:
        return z1, 0.0, 0.0
    if n == 2:
        return z2, w * (z1 - z2), 0.0
    return z3, w * (z2 - z3), w * (w * ((z1 - z2) - (z2 - z3)))


def td_restart(
    n_old: int,
    td_old: float,
    n: int,
    td_time: float,
    sp_w: float,
    z1: float,
    z2: float,
    z3: float,
) -> tuple[float, float, float]:
    """The states of the tracking differentiator after a change of its ``td_time`` or order.

    The new chain continues the old one's filtered reference and its derivatives
    below the order (those the states determine): with ``D_k = r_f^(k)`` of the old
    chain (``w = 1/td_old``; :func:`tracking_differentiator`), the new states are
    ``z_{n-j} = sum_k C(j, k) D_k td_time^k`` (the inverse of ``D_k = w^k sum_j
    C(k, j) (-1)^(k-j) z_{n-j}``), ``D_k = 0`` where the old order had no such
    state derivative.  So ``r_f`` and its slope do not jump; only the n-th
    derivative, which the new time constant sets, does -- as at a set-point step.
    An old chain that was off starts at rest on the working setpoint ``sp_w``.
    """
    d0 = sp_w
    d1 = 0.0
    d2 = 0.0
    if td_old > 0.0:
        d0, d1, d2 = td_state(n_old, 1.0 / td_old, z1, z2, z3)
    t = td_time
    if not t > 0.0:
        return d0, d0, d0
    s1 = d0 + d1 * t
    s2 = d0 + 2.0 * (d1 * t) + d2 * (t * t)
    if n == 1:
        return d0, d0, d0
    if n == 2:
        return s1, d0, d0
    return s2, s1, d0


def mode_output(
    rst: bool,
    track: bool,
    hold: bool,
    manual: bool,
    reset_value: float,
    track_value: float,
    u_prev: float,
    u_man: float,
) -> tuple[bool, float]:
    """The mode in force and the output it asks for, by the PID's priority of modes.

    RESET > TRACK > HOLD > MANUAL > AUTO (controltheplant 2024, section 2.3.5;
    :class:`~ctrlblocks.blocks.base.Mode`): the reset value (the ADRC's ``u0``),
    the tracking value, the last applied u, the manual value.  Returns ``(held,
    wanted)``: ``held`` is any mode but AUTO (the law then tracks ``wanted``, which
    the caller checks and limits).
    """
    wanted = u_man
    if rst:
        wanted = reset_value
    elif track:
        wanted = track_value
    elif hold:
        wanted = u_prev
    return rst or track or hold or manual, wanted


def adrc_compute(
    sp: float,
    y: float,
    ff: float,
    y_ok: bool,
    rst: bool,
    track: bool,
    hold: bool,
    manual: bool,
    awin: bool,
    track_value: float,
    u_man: float,
    scale_pv: bool,
    n: int,
    reverse: bool,
    exact: bool,
    ab_on: bool,
    status: int,
    out: float,
    u_prev: float,
    ff_prev: float,
    u_eso: float,
    yh: float,
    x2: float,
    x3: float,
    x4: float,
    ref: float,
    q: float,
    started: bool,
    resolve: bool,
    sat: int,
    ab_sat: int,
    ab_wait: float,
    e: float,
    y_last: float,
    sp_f: float,
    pv_f: float,
    sp_w: float,
    td1: float,
    td2: float,
    td3: float,
    opt: tuple[float, ...],
    prm: tuple[float, ...],
    ecoef: tuple[float, ...],
    ab: tuple[float, ...],
) -> tuple[
    float, float, int, float, float, float, float, float, float, float, float, float, float,
    float, bool, bool, int, int, float, float, float, float, float, float, float, float, float,
    bool,
]:  # fmt: skip
    """The ADRC's process data of one cycle around its law: the one body of every executor.

    The block (:meth:`ADRC.compute_output`, float64) and the PLC cycle
    (:func:`.plc_cycle.adrc_cycle`: the exported FB ``CB_ADRC`` and the block's
    ``precision="float32"`` lane) both run this function, in the subset the PLC
    translator accepts; around it each keeps only what it needs beyond it (the
    block: configuration, the pending commit, the output guard; the FB: the
    configuration changes it detects in its cycle, the coefficients, the delay
    line and its commit).  In order:

    * SP and PV scaled from ``pv_lo..pv_hi`` to 0..100 % (``scale_pv``; the PID's
      input scaling, controltheplant 2024, section 2.3.4);
    * the process data judged (Nowak et al. 2018, section 5, input ``y_ok``): a
      measurement not ``y_ok`` is ``BAD_MEASUREMENT``; a PV, SP, feed-forward
      or held mode's output that is no number of magnitude ``<= x_max``
      (the block passes the largest double, the FB ``REAL_MAX``: :func:`.plc_cycle.is_real`,
      its NaN test first) ``BAD_INPUT``; a bad ``ff`` is replaced by the last one (``ff_prev``) and
      holds the output as a bad SP does;
    * the mode in force and its output (:func:`mode_output`, RESET > TRACK >
      HOLD > MANUAL, controltheplant 2024, section 2.3.5), limited;
    * the PID's input stage (:func:`input_stage`) and the tracking
      differentiator (:func:`tracking_differentiator`, Han 2009, ``td_time > 0``)
      whose ``r_eff`` is the reference of (4b);
    * reverse action: the cycle runs on ``-sp`` and ``-y`` (``reverse``);
    * an invalid measurement: the safe value ``u_sf`` (the held mode's output),
      the ESO frozen, x4 re-solved by (11) when it returns (``resolve``);
    * else the law, :func:`adrc_law` (the ESO (4a), the law (4b), the bumpless
      transfer by (11) and the handover offset, the anti-windup of section 4.1,
      the anti-backoff (12a)/(12b)); ``e = sp - y`` held where it is no number;
      a failure (``BAD_RESULT``) restarts the ESO at rest with x4 by (11) on
      the next valid measurement: a law that overflowed (``u_raw`` no number,
      the output guard's case of the block, ``Block._contain``) holds the last
      output ``out`` with the feed-forward it was made with (``ff_prev``) and
      keeps this cycle's reference (0 if it is no number); an ESO that
      overflowed behind an output that did not need it (MAN, the re-solve by
      (11), the anti-backoff wait) lets the output of the cycle stand;
    * the PID's output ramp (:func:`.pid.pid_output`, ``out_rate``, from the
      last output ``out``), in every mode but RESET;
    * the status: the process data's, else the caller's ``status`` (its
      configuration's: limits, delay, discretisation).

    ``opt`` is ``(reset_value, u_sf, pv_lo, pv_hi, sp_filter, pv_filter,
    sp_rate, out_rate, td_time, x_max)``: the reset value (``u0``), the safe
    value, the PV range, the input stage's time constants and ramp, the output
    ramp, the TD's time constant, the largest valid magnitude.  ``prm``,
    ``ecoef``, ``ab`` are :func:`adrc_law`'s (``prm``'s ``ts`` is the sample
    time of the cycle); ``u_eso`` the u the ESO is fed (the applied u less its
    feed-forward, ``input_delay`` samples before the last).  ``e``, ``y_last``
    and the states are in the cycle's units (reversed: of ``-y``).  A law that
    overflowed is held here; what else its caller restarts (the block's
    delay history and attributes, ``ADRC._resume``; the FB's delay line) it
    learns from ``failed``.  Returns ``(u, u_raw, error, e, y_last, sp_td,
    td_d1, td_d2, td_d3, Y_hat, x2, x3, x4, ref, started, resolve, sat, ab_sat,
    ab_wait, q, ff, sp_f, pv_f, sp_w, td1, td2, td3, failed)``: the outputs,
    then the state to commit (from ``Y_hat`` to ``td3``, in the order of
    :class:`ADRC`'s pending cycle), then whether the law failed.
    """
    (reset_value, u_sf, pv_lo, pv_hi, sp_filter, pv_filter, sp_rate, out_rate, td_time,
     x_max) = opt  # fmt: skip
    (h, _b0, _l1, _l2, _l3, _l4, _p1, _p2, _k1, _k2, _k3, kp, kd1, kd2, _s_yh, _s_x2, _s_x3,
     _s_u, lo, hi, _rule, _a_ref, _a_q, _nsub) = prm  # fmt: skip
    if scale_pv:  # SP and PV in % of the PV range (ADRCConfig.pv_range)
        sp = scale(sp, pv_lo, pv_hi, 0.0, 100.0)
        y = scale(y, pv_lo, pv_hi, 0.0, 100.0)
    # a value is valid when it is a number of magnitude <= x_max (the largest double for the
    # block, REAL_MAX for the FB's REAL); its NaN test comes first: x == x is a quiet
    # comparison (IEEE 754: no invalid-operation exception for a quiet NaN), so that a runtime
    # that traps floating-point exceptions never reaches the ordered comparison with a NaN
    # (docs/plc.md, section Traps; plc_cycle.is_real)
    y_valid = abs(y) <= x_max if y == y else False
    sp_valid = abs(sp) <= x_max if sp == sp else False
    ff_valid = abs(ff) <= x_max if ff == ff else False
    err = _OK
    if not y_ok:
        y_valid = False
        err = _BAD_MEASUREMENT
    elif not y_valid:
        err = _BAD_INPUT
    if not sp_valid and err == _OK:
        err = _BAD_INPUT
    if not ff_valid:
        ff = ff_prev  # a bad FF: the last one, the output held (as a bad SP)
        if err == _OK:
            err = _BAD_INPUT
    # the output of a held mode, by the priority RESET > TRACK > HOLD > MANUAL (as the PID's)
    held, wanted = mode_output(rst, track, hold, manual, reset_value, track_value, u_prev,
                               u_man)  # fmt: skip
    target = u_prev
    if held:  # a held mode: the law tracks its output
        wanted_valid = abs(wanted) <= x_max if wanted == wanted else False
        if wanted_valid:
            target = wanted
        elif err == _OK:
            err = _BAD_INPUT
    target = clamp(target, lo, hi)
    # the PID's input stage (filters, setpoint ramp), in the units of the PV
    sp_f, pv_f, sp_w = input_stage(sp, y, sp_valid, y_valid, sp_filter, pv_filter, sp_rate, h,
                                   not started, sp_f, pv_f, sp_w)  # fmt: skip
    if sp_valid:
        sp = sp_w
    if y_valid:
        y = pv_f
    # the tracking differentiator on the working setpoint: the reference r_eff of (4b)
    r_law = sp  # off: the working setpoint (what tracking_differentiator passes through)
    sp_td = sp_w
    td_d1 = 0.0
    td_d2 = 0.0
    td_d3 = 0.0
    if td_time > 0.0:
        r_law, sp_td, td_d1, td_d2, td_d3, td1, td2, td3 = tracking_differentiator(
            sp_w, y, sp_valid, y_valid, held, not started, n, td_time, h, kp, kd1, kd2, td1,
            td2, td3,
        )  # fmt: skip
    if reverse:  # a reverse-acting process: the cycle runs on -sp and -y (ADRCConfig.reverse)
        sp = -sp
        y = -y
        r_law = -r_law
    failed = False
    if not y_valid:
        # measurement invalid: safe value (the held mode's output), ESO frozen
        u = clamp(u_sf, lo, hi)
        if held:
            u = target
        u_raw = u
        resolve = True
        sat = 0
    else:
        r_in = r_law
        if not sp_valid:
            r_in = ref
            if not started:
                r_in = y
        # the ADRC's one law (adrc_law); x4 by (11) after a held mode, a bad SP or FF
        u, u_raw, yh, x2, x3, x4, ref, q, end_wait, sat, ab_sat, ab_wait = adrc_law(
            r_in, y, ff, held, target, held or not sp_valid or not ff_valid or resolve,
            started, sat, awin, exact, ab_on, yh, x2, x3, x4, u_eso, u_prev, ref, q, ab_sat,
            ab_wait, prm, ecoef, ab,
        )  # fmt: skip
        # x4 by (11) next cycle: after a held mode or a bad SP or FF, at the end of the wait
        resolve = end_wait or held or not sp_valid or not ff_valid
        started = True
        y_last = y
        if sp_valid:
            e_new = sp - y
            e_valid = abs(e_new) <= x_max if e_new == e_new else False
            if e_valid:
                e = e_new  # else held: SP - Y beyond the range (a finite SP and PV far apart)
        failed = True
        if u_raw == u_raw:  # the NaN test first, as above
            failed = abs(u_raw) > x_max
        eso_valid = False
        if yh == yh and x2 == x2 and x3 == x3 and x4 == x4:
            eso_valid = (abs(yh) <= x_max and abs(x2) <= x_max and abs(x3) <= x_max
                         and abs(x4) <= x_max)  # fmt: skip
        if failed:
            # the law overflowed: the last output, limited, with the feed-forward it was
            # made with (the restarted ESO is fed the held u less it); this cycle's reference
            u = clamp(out, lo, hi)
            u_raw = u
            ff_held = abs(ff_prev) <= x_max if ff_prev == ff_prev else False
            ff = 0.0
            if ff_held:
                ff = ff_prev
            ref_valid = abs(ref) <= x_max if ref == ref else False
            if not ref_valid:
                ref = 0.0
        if failed or not eso_valid:
            # the ESO restarts at rest on the next valid measurement with x4 by (11); an ESO
            # that overflowed behind an output that did not need it (MAN, the re-solve by
            # (11), the anti-backoff wait) lets the output of this cycle stand
            yh = 0.0
            x2 = 0.0
            x3 = 0.0
            x4 = 0.0
            q = 0.0
            started = False
            resolve = True
            sat = 0
            ab_sat = 0
            ab_wait = 0.0
            err = _BAD_RESULT
    if out_rate > 0.0 and not rst and not failed:
        # the output ramp of the PID (pid_output), in every mode but RESET (which acts at
        # once, as the PID's): at most out_rate h a cycle (not after a failed law: held)
        u, _ramping = pid_output(u, out, lo, hi, out_rate * h)
    if err == _OK:
        err = status  # the configuration's: limits, delay, discretisation
    return (u, u_raw, err, e, y_last, sp_td, td_d1, td_d2, td_d3, yh, x2, x3, x4, ref, started,
            resolve, sat, ab_sat, ab_wait, q, ff, sp_f, pv_f, sp_w, td1, td2, td3,
            failed)  # fmt: skip


# ---------------------------------------------------------------------------
# Configuration
# ---------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class ADRCConfig(BlockConfig):
    """Configuration of :class:`ADRC` (the tuning and parameterisation inputs of Fig. 2).

    Attributes
    ----------
    order : int
        ADRC order n = 1, 2 or 3 (section 3.1).
    b0 : float
        Scaling parameter b0 > 0 [units of Y^(n) per unit of u].
    omega_c : float
        Controller bandwidth [rad/s], > 0.
    omega_o : float
        Observer (ESO) bandwidth [rad/s], > 0; the paper advises 3..10 omega_c.
    ts : float
        Sample time [s], > 0.
    u_min, u_max : float
        Limits of the manipulated variable (infinite = none).  Runtime changes:
        :meth:`ADRC.set_limits`.
    t_ref : float
        Time constant [s] of the reference trajectory (first-order filter of
        the setpoint, section 5); 0 = off.
    discretisation : str
        ``"euler"``: the paper's (4a) (default); ``"exact"``: ZOH current
        observer and discretely placed controller poles (module docstring).
    u_sf : float
        Safe value of u applied while the measurement is invalid (section 5),
        limited to [u_min, u_max].
    u0 : float
        Output after ``reset()``; the first cycle starts bumplessly from it.
    anti_windup : str or bool
        ``"directional"`` (default, also ``True``), ``"freeze"`` (section 4.1
        read literally) or ``"off"`` (also ``False``).
    u_real_on : bool
        Use the measured actuator value ``u_real`` in the ESO (section 5).
    anti_backoff : bool
        Enable the derivative anti-backoff action (12a)/(12b) (section 4.3);
        off by default as in the paper.
    y_sat : float
        Upper saturation of the sensor (for the anti-backoff action).
    y_sat_lo : float
        Lower saturation of the sensor (for the anti-backoff action).
    tau_wait : float
        Time [s] u is frozen after Y leaves the saturation; ``0`` = the
        paper's ``3.5/omega_o`` (section 4.3 advises 3..4 / omega_o).
    precision : str
        ``"float64"`` (default) or ``"float32"``: compute the cycle as a PLC's
        REAL does, every intermediate rounded to single precision (the cycle
        of :mod:`.plc_cycle`, which :mod:`ctrlblocks.plc` exports); only for
        the configurations the export covers.
    reverse : bool
        A reverse-acting process (a negative process gain: more MV, less PV --
        cooling, an outlet valve).  The block then works on ``-y`` and ``-sp``,
        so that the process it sees has a positive gain and ``b0`` stays > 0
        (the model ``Y^(n) = h + b0 u`` of section 2); u, its limits and the
        manual value keep their meaning, and ``y``, ``e``, ``y_ref`` and
        ``y_sat``/``y_sat_lo`` stay in PV units.  As the PID's ``reverse``
        (controltheplant 2024, ``ixInverted``).  The PLC cycle
        (``precision="float32"``) and the export have it (input ``REVERSE``);
        the compiled kernels (:mod:`ctrlblocks.fast`) do not, so the simulator
        runs such an ADRC on its Python path.
    input_delay : float
        Dead time [s] of the process input, rounded to whole samples of ``ts``
        (default 0: off).  The ESO is fed the applied u of that many samples
        ago, so that the input it sees is aligned with the output the process
        shows: the delay-compensated ("predictive") observer of Zhao & Gao
        (2014).  The control law is unchanged.  Refused beyond
        :data:`MAX_DELAY_SAMPLES` samples.  The PLC cycle and the export have
        it (input ``DELAY``); the compiled kernels do not
        (``fast_path_blockers``): the simulator runs such an ADRC on its
        Python path.
    out_rate : float
        Largest change of the output per second [MV units/s]; 0 (default): off.
        The output ramp of the PID (controltheplant 2024, section 2.3.8; the
        same stage, :func:`~ctrlblocks.blocks.pid.pid_output`): the limited
        output moves at most ``out_rate h`` from the last one, in every mode.
        The ESO is fed the ramped (applied) u, so the loop stays consistent
        -- a slow actuator the observer knows.  The PLC cycle and the export
        have it (``OUT_RATE``); the compiled kernels do not.
    pv_range : tuple of float or None
        ``(lo, hi)`` of SP and PV [eng. units] scaled to 0..100 % before the
        cycle, as the PID's (controltheplant 2024, section 2.3.4, ``rangeLo/
        rangeHi``); None (default): no scaling.  The cycle then runs in % of the
        range: ``b0`` is in %/s^n per unit of u, and ``y``, ``e``, ``y_ref``,
        ``sp_w`` and the ESO state are in %; ``y_sat``/``y_sat_lo`` stay in PV
        units (the block scales them).  A change of the range while running
        restarts the ESO at rest on the next measurement, bumplessly (x4 by (11)).
    sp_filter, pv_filter : float
        Time constants [s] of the PID's SP and PV filters (PT1 with the exact
        pole ``exp(-h/T)``, section 2.3.7; :func:`input_stage`); 0 (default):
        off.  The PV filter is part of the loop: the ESO and the law see the
        filtered PV, so tune with it in the plant model (``tune adrc``'s margins
        include it).  Refused together with ``anti_backoff``: the sensor's
        saturation is a property of the raw PV, which a filtered PV only
        approaches.
    sp_rate : float
        Setpoint ramp [PV units/s, or %/s with ``pv_range``], both ways, after
        the SP filter (section 2.3.8); 0 (default): off.  Unlike ``t_ref`` (the
        paper's first-order reference trajectory, which the ESO-based handover
        offsets), a ramp bounds the speed of the reference the law sees.
    td_time : float
        Time constant [s] of the tracking differentiator (Han 2009, linear): the
        working setpoint through n identical lags ``1/(td_time s + 1)`` (n =
        ``order``), and the law (4b) fed the derivatives of that filtered
        reference forward (:func:`tracking_differentiator`) -- with a good
        observer the set-point response is ``1/(td_time s + 1)^n`` (no overshoot)
        whatever ``omega_c``, which then only sets the rejection of disturbances:
        a two-degree-of-freedom design.  0 (default): off.  Refused together with
        ``t_ref`` (two reference filters in a row).  The PLC cycle and the export
        have it (``TD_TIME``); the compiled kernels do not.
    """

    order: int = 2
    b0: float = 1.0
    omega_c: float = 1.0
    omega_o: float = 5.0
    ts: float = 0.1
    u_min: float = -math.inf
    u_max: float = math.inf
    t_ref: float = 0.0
    discretisation: str = "euler"
    u_sf: float = 0.0
    u0: float = 0.0
    anti_windup: Any = "directional"
    u_real_on: bool = False
    anti_backoff: bool = False
    y_sat: float = math.inf
    y_sat_lo: float = -math.inf
    tau_wait: float = 0.0
    precision: str = "float64"
    reverse: bool = False
    input_delay: float = 0.0
    out_rate: float = 0.0
    pv_range: tuple[float, float] | None = None
    sp_filter: float = 0.0
    pv_filter: float = 0.0
    sp_rate: float = 0.0
    td_time: float = 0.0

    def validate(self) -> None:
        if isinstance(self.order, bool) or self.order not in (1, 2, 3):
            raise ParameterError(
                ErrorCode.BAD_ORDER, "order", f"must be 1, 2 or 3, got {self.order!r}"
            )
        require_positive("b0", self.b0, ErrorCode.BAD_B0)
        require_positive("omega_c", self.omega_c, ErrorCode.BAD_BANDWIDTH)
        require_positive("omega_o", self.omega_o, ErrorCode.BAD_BANDWIDTH)
        require_positive("ts", self.ts, ErrorCode.NO_CYCLE)
        require_limits("u_min", self.u_min, "u_max", self.u_max)
        require_nonnegative("t_ref", self.t_ref, ErrorCode.BAD_TIME_CONSTANT)
        require_choice("discretisation", self.discretisation, ("euler", "exact"))
        require_finite("u_sf", self.u_sf)
        require_finite("u0", self.u0)
        if not isinstance(self.anti_windup, bool):  # True/False: "directional"/"off"
            rules = ("directional", "freeze", "off")
            require_choice("anti_windup", self.anti_windup, rules, ErrorCode.BAD_ANTIWINDUP)
        require_bool("u_real_on", self.u_real_on)
        require_bool("anti_backoff", self.anti_backoff)
        require_limits("y_sat_lo", self.y_sat_lo, "y_sat", self.y_sat)
        require_nonnegative("tau_wait", self.tau_wait, ErrorCode.BAD_TIME_CONSTANT)
        require_bool("reverse", self.reverse)
        require_nonnegative("input_delay", self.input_delay, ErrorCode.BAD_TIME_CONSTANT)
        if delay_samples(self.input_delay, self.ts) > MAX_DELAY_SAMPLES:
            raise ParameterError(
                ErrorCode.BAD_TIME_CONSTANT,
                "input_delay",
                f"at most {MAX_DELAY_SAMPLES} samples of ts, got {self.input_delay!r} s",
            )
        require_nonnegative("out_rate", self.out_rate, ErrorCode.BAD_RATE)
        require_range("pv_range", self.pv_range)
        require_nonnegative("sp_filter", self.sp_filter, ErrorCode.BAD_TIME_CONSTANT)
        require_nonnegative("pv_filter", self.pv_filter, ErrorCode.BAD_TIME_CONSTANT)
        require_nonnegative("sp_rate", self.sp_rate, ErrorCode.BAD_RATE)
        require_nonnegative("td_time", self.td_time, ErrorCode.BAD_TIME_CONSTANT)
        if self.td_time > 0.0 and self.t_ref > 0.0:
            raise ParameterError(
                ErrorCode.BAD_PARAMETER, "td_time",
                "the tracking differentiator filters the reference itself; t_ref would filter "
                "it twice (and hide its derivatives): use one of them",
            )  # fmt: skip
        if self.anti_backoff and self.pv_filter > 0.0:
            raise ParameterError(
                ErrorCode.BAD_PARAMETER, "pv_filter",
                "anti_backoff detects the sensor's saturation on the raw PV, which a filtered "
                "PV only approaches: use one of them",
            )  # fmt: skip
        if self.precision != "float64":
            _check_precision(self, "adrc")


# ---------------------------------------------------------------------------
# Coefficients for one sample time
# ---------------------------------------------------------------------------


ONE_THIRD = 1.0 / 3.0
ELEVEN_SIXTHS = 11.0 / 6.0


def bandwidth_gains(
    n: int, omega_c: float, omega_o: float
) -> tuple[float, float, float, float, float, float, float]:
    """Gao's gains ``(l1, l2, l3, l4, kp, kd1, kd2)`` for n = 1, 2, 3, written out.

    The binomial coefficients of ``(s + omega_o)^(n+1)`` and ``(s + omega_c)^n``
    (Nowak et al. 2018, section 3.3) as :func:`adrc_gains` computes them with
    ``math.comb`` -- spelled out because a PLC has no lists (the float32 cycle
    and the export run it); the tests check both agree for every order.
    """
    wo2 = omega_o * omega_o
    wc2 = omega_c * omega_c
    if n == 1:
        return 2.0 * omega_o, 0.0, 0.0, wo2, omega_c, 0.0, 0.0
    if n == 2:
        return 3.0 * omega_o, 3.0 * wo2, 0.0, wo2 * omega_o, wc2, 2.0 * omega_c, 0.0
    return (4.0 * omega_o, 6.0 * wo2, 4.0 * (wo2 * omega_o), wo2 * wo2,
            wc2 * omega_c, 3.0 * wc2, 3.0 * omega_c)  # fmt: skip


def pole_distance(omega: float, h: float) -> tuple[float, float]:
    """``(d, q) = (1 - exp(-omega h), d/h)``: distance of the pole ``exp(-omega h)`` from 1.

    Without ``expm1`` (which a PLC lacks): for ``a = omega h < 0.1`` by the
    Taylor series of ``(1 - exp(-a))/a`` to ``a^8`` (relative error below
    3e-14, checked against ``expm1``), so that ``d/h`` stays accurate for a
    tiny ``a``; above by ``1 - EXP(-a)``.
    """
    a = omega * h
    if a < 0.1:
        r = 1.0 - a / 2.0 * (1.0 - a / 3.0 * (1.0 - a / 4.0 * (1.0 - a / 5.0 * (
            1.0 - a / 6.0 * (1.0 - a / 7.0 * (1.0 - a / 8.0 * (1.0 - a / 9.0)))))))  # fmt: skip
        return a * r, omega * r
    d = 1.0 - math.exp(-a)
    return d, omega * (d / a)


def exact_coefficients(
    n: int, b0: float, omega_c: float, omega_o: float, h: float
) -> tuple[
    float, float, float, float, float, float, float, float, float, float, float, float, float,
    float, float, float,
]:  # fmt: skip
    """The ZOH current observer and controller gains of ``discretisation="exact"``: the one design.

    ``(f01, f02, f03, f12, f13, f23, g0, g1, g2, c0, c1, c2, c3, kp, kd1, kd2)``:
    the chain of ``m = n + 1`` integrators (Y, its derivatives, h) has
    ``Phi[i][j] = h^(j-i)/(j-i)!`` and the zero-order-hold input vector ``g``;
    Ackermann's formula places all observer poles of the current observer
    ``(I - Lc C) Phi`` at ``exp(-omega_o h)`` and all controller poles of the
    n-chain at ``exp(-omega_c h)`` (Herbst 2013 via Nowak et al. 2018).  In
    the scaled state ``x_i h^i`` the chain is the constant ``exp(N)``, so the
    gains are polynomials in ``d = 1 - exp(-omega h)`` and ``q = d/h``
    (:func:`pole_distance`): accurate for every ``omega h`` (no cancellation
    when it is tiny, no singular matrix at ``h = 1e-300``).  Spelled out for
    n = 1, 2, 3 (a PLC has no matrices): the block, the float32 cycle and the
    exported FB run this one function; the tests check it against scipy's
    matrix exponential with Ackermann's formula and a closed form of the
    constant vectors (tests/blocks/exact_oracle.py).  Example, n = 1: ``Lc =
    (1 - z_o^2, (1 - z_o)^2/h)``.
    """
    d, q = pole_distance(omega_o, h)
    dc, qc = pole_distance(omega_c, h)
    hh = h * h
    f01, f02, f03, f12, f13, f23 = 0.0, 0.0, h, 0.0, 0.0, 0.0
    g0, g1, g2 = b0 * h, 0.0, 0.0
    c0, c1, c2, c3 = 2.0 * d - d * d, 0.0, 0.0, q * d
    kp, kd1, kd2 = qc, 0.0, 0.0
    if n == 2:
        f01 = h
        f03 = hh / 2.0
        f13 = h
        g0 = b0 * hh / 2.0
        g1 = b0 * h
        c0 = 3.0 * d - 3.0 * (d * d) + d * d * d
        c1 = 3.0 * q * d - 1.5 * q * (d * d)
        c3 = q * q * d
        kp = qc * qc
        kd1 = 2.0 * qc - 0.5 * qc * dc
    elif n == 3:
        d2 = d * d
        q2 = q * q
        qc2 = qc * qc
        f01 = h
        f02 = hh / 2.0
        f03 = hh * h / 6.0
        f12 = h
        f13 = hh / 2.0
        f23 = h
        g0 = b0 * (hh * h) / 6.0
        g1 = b0 * hh / 2.0
        g2 = b0 * h
        c0 = 4.0 * d - 6.0 * d2 + 4.0 * (d2 * d) - d2 * d2
        c1 = 6.0 * q * d - 6.0 * q * d2 + ELEVEN_SIXTHS * q * (d2 * d)
        c2 = 4.0 * q2 * d - 2.0 * q2 * d2
        c3 = q2 * q * d
        kp = qc2 * qc
        kd1 = 3.0 * qc2 - qc2 * dc
        kd2 = 3.0 * qc - 1.5 * qc * dc + ONE_THIRD * qc * (dc * dc)
    return f01, f02, f03, f12, f13, f23, g0, g1, g2, c0, c1, c2, c3, kp, kd1, kd2


def discretisation_trusted(
    n: int, omega_c: float, omega_o: float, ts: float, discretisation: str
) -> bool:
    """True when ``omega_o ts`` and ``omega_c ts`` lie in the trusted range (module docstring)."""
    if discretisation == "exact":
        return omega_o * ts <= EXACT_LIMIT and omega_c * ts <= EXACT_LIMIT
    return omega_o * ts <= EULER_LIMIT[n + 1] and omega_c * ts <= EULER_LIMIT[n]


# ---------------------------------------------------------------------------
# The block
# ---------------------------------------------------------------------------


def _resize_history(hist: tuple[float, ...], nd: int, u_prev: float) -> tuple[float, ...]:
    """The u history for a new ``input_delay`` of ``nd`` samples (the newest values kept).

    A longer delay pads the history at its old end with its oldest value (the
    last u when it was empty), as if u had rested there.
    """
    if nd <= len(hist):
        return hist[len(hist) - nd :]
    pad = hist[0] if hist else u_prev
    return (pad,) * (nd - len(hist)) + hist


class ADRC(Block):
    """ADRC function block of Nowak et al. 2018 for orders 1..3 (one code path).

    ``u = adrc(sp, y)`` runs one cycle: ESO (4a), control law (4b), limits.

    Parameters
    ----------
    See :class:`ADRCConfig`: ``order, b0, omega_c, omega_o, ts, u_min, u_max,
    t_ref, discretisation, u_sf, u0, anti_windup, u_real_on, anti_backoff,
    y_sat, y_sat_lo, tau_wait, precision, reverse, input_delay, out_rate,
    pv_range, sp_filter, pv_filter, sp_rate, td_time``.

    Inputs (attributes written between cycles, like PLC inputs)
    -----------------------------------------------------------
    manual : bool
        MAN mode (A_M input): u = ``u_man`` (limited), the ESO runs on the
        applied u and x4 is re-solved from (11) every cycle, so that the next
        AUTO cycle starts exactly at the last applied u (section 4.2).
    u_man : float
        Manual value, also ``manual_value`` (the name every controller uses,
        :class:`~ctrlblocks.blocks.protocols.Controller`; ``u_man`` stays as
        its alias for one release).  In/Out as in the PID block:
        outside MAN it follows the applied u, so AUTO -> MAN holds the output.
    awin : bool
        Freeze the x4 update (this block is a primary controller whose
        secondary is at a limit; section 5).
    track, track_value, hold : bool, float, bool
        The PID's TRACK and HOLD modes (controltheplant 2024, section 2.3.5;
        priority TRACK > HOLD > MANUAL > AUTO, :attr:`mode`): u = ``track_value``
        (limited; NaN: the last u, ``BAD_INPUT``) or the last applied u.  As in
        MAN the ESO runs on the applied u and the law is kept on it, so the
        return to AUTO is bumpless; ``u_man`` follows the applied u.
    reset_active : bool
        The PID's RESET mode (controltheplant 2024, section 2.3.5; priority over
        all others): u = ``u0`` (limited) at once, past the output ramp; the
        law tracks it as in MAN, so the return is bumpless.

    Outputs
    -------
    u / out (applied value computed this cycle), ``u_raw`` (4b before the
    limits), ``e = sp_w - y``, ``y`` (the PV the law sees: scaled and filtered
    where configured), ``sp_w`` (the working setpoint after the SP filter and
    ramp), ``y_ref`` (the reference of (4b): with ``td_time`` the TD's ``r_eff``),
    ``sp_td`` and ``sp_td_d1..3`` (the tracking differentiator's filtered setpoint
    and its derivatives; ``sp_w`` and 0 while it is off), ``x = (Y_hat, x2, x3, x4)``,
    ``awout`` (u_raw beyond a limit), ``error``, ``error_id``, ``warning``.

    Anti-windup (section 4.1) and why the default rule is *directional*
    ---------------------------------------------------------------------
    The paper freezes x4 while the computed u is outside (u_min, u_max).  Read
    literally this can lock: if x4 is frozen at a value below ``-b0 u_max``
    (for example the limit was lowered while u was high, or the ESO
    over-estimated a disturbance), the other ESO states settle around the
    frozen x4 with a constant output error, and (4b) stays above u_max even
    when Y is above the setpoint -- forever.  The default rule freezes only an
    x4 update that would push u *further* beyond the violated limit; an update
    that brings u back is always applied.  At a limit x4 can then only move
    towards the value that releases the output, which keeps the paper's
    "immediate reversal" (x4 cannot wind up) and cannot lock (at a steady
    state with u = u_max and Y > sp, the innovation drives x4 to ``-b0
    u_max`` where (4b) is below u_max).  Both cases are closed-loop tests.

    Two-phase form (Åström 1987, section 6)
    ------------------------------------
    ``v = compute_output(sp, y)`` computes the cycle without committing (it can
    be called again with other inputs); ``update_state(applied)`` commits it
    with the value actually applied, which drives the ESO in the next cycle.

    Fallbacks (never raise in the cycle)
    ------------------------------------
    * ``y_ok`` false or Y NaN/inf: u = ``u_sf`` (``u_man`` in MAN) in the same
      cycle, ESO frozen, ``BAD_MEASUREMENT`` / ``BAD_INPUT``; when Y returns the
      first cycle re-solves x4 so that u continues from the applied value.
    * setpoint NaN/inf: hold the last applied u (as one MAN cycle), ``BAD_INPUT``.
    * ``u_man`` NaN/inf in MAN: hold the last applied u, ``BAD_INPUT``.
    * bad ``dt``: hold everything, ``NO_CYCLE``.
    * ``set_limits`` with a reversed or NaN pair: ``BAD_LIMITS`` status, the
      last valid limits stay.

    Examples
    --------
    >>> adrc = ADRC(order=2, b0=0.05, omega_c=0.35, omega_o=1.75, ts=0.1,
    ...             u_min=0.0, u_max=5.0)
    >>> u = adrc(1.0, 0.0)
    """

    Config = ADRCConfig
    _guarded_steps = ()
    # the attributes the compiled build keeps in the C struct (adrc.pxd), which
    # configure's rollback saves by name; tests/blocks/test_compiled.py keeps both in step
    _declared = (
        "error_id _config manual awin u_man _lean _started _pending _track _prm _sat "
        "_limits_bad _warn awout _eso _eso_coef _gains _law _sens out _h _ts _yh _x2 _x3 _x4 "
        "_u_prev _ref u_raw y e y_ref _u_lo _u_hi _ab_sat _nd _u_hist _q _ff_prev ff track hold "
        "track_value reset_active _sp_f _pv_f _sp_w sp_w _td1 _td2 _td3 sp_td sp_td_d1 sp_td_d2 "
        "sp_td_d3"
    )

    @property
    def config(self) -> ADRCConfig:
        """The configuration in force (:meth:`Block.config`)."""
        return self._config

    _config: ADRCConfig
    _eso: Callable[..., tuple[float, float, float, float]]  # eso_euler or eso_exact
    _eso_coef: tuple[float, ...]  # the arguments of _eso after (Y_hat, x2, x3, x4, u, y, w4)
    _gains: tuple[float, float, float, float, float, float, float]  # l1..l4, kp, kd1, kd2
    _law: tuple[float, float, float, float]  # (b0, kp, kd1, kd2) of (4b) in force
    _sens: tuple[float, float, float, float]  # (s_yh, s_x2, s_x3, s_u) of solve_x4
    _yh: float
    _x2: float
    _x3: float
    _x4: float
    _ref: float
    _started: bool
    _track: bool
    _ab_sat: int  # the sensor's saturation side (+1, -1, 0) in the cycle's units
    _u_prev: float  # the u applied last
    _q: float  # the handover offset of the reference (handover_offset)
    _nd: int  # input_delay in samples
    _u_hist: tuple[float, ...]  # the ESO's u (applied less ff) of the _nd samples before the last
    _ff_prev: float  # the feed-forward of the last cycle (the ESO is fed the applied u less it)
    _td1: float  # the tracking differentiator's chain (tracking_differentiator), PV units
    _td2: float
    _td3: float
    _state_fields = (
        "out",
        "u_man",
        "u_raw",
        "e",
        "y",
        "y_ref",
        "awout",
        "_yh",
        "_x2",
        "_x3",
        "_x4",
        "_u_prev",
        "_ff_prev",
        "ff",
        "_ref",
        "_started",
        "_track",
        "_sat",
        "_ab_sat",
        "_ab_wait",
        "_plc_state",
        "_u_hist",
        "_q",
        "_sp_f",
        "_pv_f",
        "_sp_w",
        "sp_w",
        "_td1",
        "_td2",
        "_td3",
        "sp_td",
        "sp_td_d1",
        "sp_td_d2",
        "sp_td_d3",
    )

    # -- configuration -------------------------------------------------------

    def __init__(self, config: ADRCConfig | None = None, /, **params: Any) -> None:
        self.manual = False
        self.u_man = 0.0
        self.awin = False
        self.track = False
        self.track_value = 0.0
        self.hold = False
        self.reset_active = False
        self._limits_bad = False
        self._pending: tuple[Any, ...] | None = None
        super().__init__(config, **params)

    def _apply_config(self, old: BlockConfig | None) -> None:
        c = self._config
        old_law = self._law if old is not None else (1.0, 0.0, 0.0, 0.0)
        self._prm: tuple[float, ...] | None = None
        self._nd = delay_samples(c.input_delay, c.ts)
        self._lean = (
            c.discretisation == "euler"
            and not c.u_real_on
            and not c.anti_backoff
            and not c.reverse
            and self._nd == 0
            and c.out_rate == 0.0
            and c.pv_range is None
            and c.sp_filter == 0.0
            and c.pv_filter == 0.0
            and c.sp_rate == 0.0
            and c.td_time == 0.0
        )
        rng = None if c.pv_range is None else (float(c.pv_range[0]), float(c.pv_range[1]))
        if old is not None:
            self._u_hist = _resize_history(self._u_hist, self._nd, self._u_prev)
        # reverse: the block works on -y and -sp (ADRCConfig.reverse); the sensor's
        # saturation in those units
        self._sgn = -1.0 if c.reverse else 1.0
        self._reverse = bool(c.reverse)
        self._scale_pv = rng is not None
        pv_lo, pv_hi = rng if rng is not None else (0.0, 100.0)
        # adrc_compute's options: the reset and safe values, the input stage, the output
        # ramp, the TD, the largest valid magnitude of the process data (float64: finite)
        self._opt = (float(c.u0), float(c.u_sf), pv_lo, pv_hi, float(c.sp_filter),
                     float(c.pv_filter), float(c.sp_rate), float(c.out_rate), float(c.td_time),
                     FLOAT_MAX)  # fmt: skip
        ys_hi, ys_lo = float(c.y_sat), float(c.y_sat_lo)
        if rng:  # the sensor's saturation in % of the PV range, as the cycle's PV
            ys_hi, ys_lo = (scale(v, rng[0], rng[1], 0.0, 100.0) for v in (ys_hi, ys_lo))
        self._ysat_hi = -ys_lo if c.reverse else ys_hi
        self._ysat_lo = -ys_hi if c.reverse else ys_lo
        self._n = int(c.order)
        self._ts = float(c.ts)
        self._b0 = float(c.b0)
        self._rule = _ANTI_WINDUP[c.anti_windup]
        self._exact = c.discretisation == "exact"
        self._h = -1.0
        self._coefficients(self._ts)
        require_coefficients(
            "b0/omega_c/omega_o/ts", ErrorCode.BAD_BANDWIDTH,
            *self._gains, *self._law, *self._sens, *self._eso_coef,
        )  # fmt: skip
        if old is None or (old.u_min, old.u_max) != (c.u_min, c.u_max):  # type: ignore[attr-defined]
            self._u_lo, self._u_hi = block_limits(float(c.u_min), float(c.u_max), c.precision)
            self._limits_bad = False
        # (the default saturates: omega_o = 5e-324 would make the wait +inf)
        self._tau_wait = float(c.tau_wait) if c.tau_wait > 0 else min(3.5 / c.omega_o, MAX_TIME)
        self._ab = (self._ysat_hi, self._ysat_lo, self._tau_wait)  # adrc_law's ab
        if old is not None:
            assert isinstance(old, ADRCConfig)
            tuning = ("order", "b0", "omega_c", "omega_o", "ts", "discretisation")
            if any(getattr(old, f) != getattr(c, f) for f in tuning):
                self._retune(old_law)
            if old.reverse != c.reverse:
                self._reverse_states()
            if old.pv_range != c.pv_range:
                self._restart_units()
            if old.td_time > 0.0 or c.td_time > 0.0:
                self._td_retune(old)

    def _td_retune(self, old: ADRCConfig) -> None:
        """A change with the tracking differentiator in force (or turned on or off).

        A new ``td_time`` or ``order`` restarts the chain on its filtered reference and
        the derivatives the states carry (:func:`td_restart`; at rest on the working
        setpoint when it was off).  A new ``td_time``, ``order``, ``b0``, ``omega_c``,
        ``omega_o`` or discretisation changes ``r_eff`` (the weights of the
        derivatives, the n-th derivative), so the next cycle re-solves the handover
        offset (``_track``, as after MAN): the output continues from the last u.
        (Not ``ts``: a cycle's ``dt`` is not a retune.)
        """
        c = self._config
        fields = ("td_time", "order", "b0", "omega_c", "omega_o", "discretisation")
        if not any(getattr(old, f) != getattr(c, f) for f in fields):
            return
        pend = self._pending
        restart = old.td_time != c.td_time or old.order != c.order
        args = (int(old.order), float(old.td_time), int(c.order), float(c.td_time))
        if pend is None:
            if restart:
                self._td1, self._td2, self._td3 = td_restart(
                    *args, self._sp_w, self._td1, self._td2, self._td3
                )
            self._track = True
        else:
            z = pend[15:18]
            if restart:
                z = td_restart(*args, pend[14], *z)
            self._pending = (*pend[:6], True, *pend[7:15], *z)

    def _restart_units(self) -> None:
        """``pv_range`` changed: the states were in the old units of the PV.

        The ESO restarts at rest on the next valid measurement (its filters preset
        on it) and x4 is re-solved by (11) there, so the output continues from the
        last u (as after a failed cycle, :meth:`_resume`, but the outputs stand).
        """
        pend = self._pending
        if pend is None:
            self._started, self._track = False, True
        else:
            self._pending = (*pend[:5], False, True, *pend[7:])

    def _reverse_states(self) -> None:
        """``reverse`` changed: the states in the units of the measurement change sign.

        Y_hat, x2, x3, x4 and the reference are negated (the cycle's units are
        now those of the other sign of y) and x4 is re-solved by (11) in the
        next cycle (``_track``), so the output continues from the last u.
        """
        pend = self._pending
        if pend is None:
            self._yh, self._x2, self._x3, self._x4 = -self._yh, -self._x2, -self._x3, -self._x4
            self._ref, self._ab_sat, self._q = -self._ref, -self._ab_sat, -self._q
            self._track = True
        else:
            yh, x2, x3, x4, ref, started, _track, sat, ab_sat, ab_wait, q, *rest = pend
            self._pending = (-yh, -x2, -x3, -x4, -ref, started, True, sat, -ab_sat, ab_wait, -q,
                             *rest)  # fmt: skip

    def _retune(self, old_law: tuple[float, float, float, float]) -> None:
        """Bumpless retuning at the instant of the change (:func:`retune_x4`).

        The state the next cycle starts from (the committed one, or that of a
        two-phase cycle computed but not yet committed) keeps its Y_hat, x2, x3
        and reference; x4 takes the value that makes the new law (4b) give what
        the old law gave on them.  When the order drops, the unused x2/x3 are
        zeroed first.  Before the first measurement and while x4 is to be
        re-solved by (11) anyway (``_track``: after MAN, a bad measurement, a
        failed cycle) the next cycle's (11) does it; so it does if the shift is
        not finite (an overflowing law).  The modes do not enter: a mode switched
        in the same cycle as the retune (the PLC writes both before its cycle)
        must give what the PLC cycle gives, and a held mode tracks its output
        whatever x4 is.
        """
        pend = self._pending
        if pend is None:
            yh, x2, x3, x4, ref = self._yh, self._x2, self._x3, self._x4, self._ref
            started, track = self._started, self._track
        else:
            yh, x2, x3, x4, ref, started, track = pend[:7]
        q = self._q if pend is None else pend[10]
        u_keep = control_law(ref + q, yh, x2, x3, x4, *old_law)
        if self._n < 3:
            x3 = 0.0
        if self._n < 2:
            x2 = 0.0
        x4_new = retune_x4(ref + q, yh, x2, x3, u_keep, *self._law)
        # (not the modes: they are inputs of the next cycle, which the PLC cycle decides
        # on, and a held mode tracks its output from whatever x4)
        if not started or track or not (_NINF < x4_new < _INF):
            track = True  # the next cycle re-solves x4 by (11)
        else:
            x4 = x4_new
        if pend is None:
            self._x2, self._x3, self._x4, self._track = x2, x3, x4, track
        else:
            self._pending = (yh, x2, x3, x4, ref, started, track, *pend[7:])

    def _coefficients(self, h: float) -> None:
        """Derive the per-cycle coefficients for the sample time ``h`` [s]."""
        if h == self._h:
            return
        c = self._config
        n, b0 = self._n, self._b0
        p1, p2, k1, k2, k3 = adrc_switches(n)
        l1, l2, l3, l4, kp, kd1, kd2 = bandwidth_gains(n, float(c.omega_c), float(c.omega_o))
        nsub = 1.0
        if self._exact:
            (f01, f02, f03, f12, f13, f23, g0, g1, g2, c0, c1, c2, c3, kp, kd1,
             kd2) = exact_coefficients(n, b0, float(c.omega_c), float(c.omega_o), h)  # fmt: skip
            self._eso = eso_exact
            self._eso_coef = (f01, f02, f03, f12, f13, f23, g0, g1, g2, c0, c1, c2, c3)
            s_yh = s_x2 = s_x3 = 0.0  # the current observer does not pass x4_i on
        else:
            self._eso = eso_euler
            self._eso_coef = (h, b0, l1, l2, l3, l4, p1, p2, k1, k2, k3)
            nsub = euler_substeps(n, float(c.omega_o), h)
            s_x3, s_x2, s_yh = euler_sensitivities(h / nsub if nsub > 1.0 else h, p1, p2, k1,
                                                   k2, k3)  # fmt: skip
        self._nsub = nsub
        self._gains = (l1, l2, l3, l4, kp, kd1, kd2)
        self._switches = (p1, p2, k1, k2, k3)
        self._law = (b0, kp, kd1, kd2)
        self._sens = (s_yh, s_x2, s_x3, -(1.0 + kp * s_yh + kd1 * s_x2 + kd2 * s_x3) / b0)
        self._a_ref = pt1_coefficient(float(c.t_ref), h, "exact")
        self._a_q = handover_pole(float(c.omega_c), h)
        self._warn = not discretisation_trusted(
            n, float(c.omega_c), float(c.omega_o), h, c.discretisation
        )
        self._h = h
        self._prm = None

    def _reset_state(self) -> None:
        c = self._config
        self._h = -1.0
        self._coefficients(self._ts)
        u0 = clamp(float(c.u0), self._u_lo, self._u_hi)
        self.out = self.u_raw = u0
        self.e = self.y = self.y_ref = 0.0
        self.awout = False
        self._yh = self._x2 = self._x3 = self._x4 = 0.0
        self._u_prev = u0
        self._ff_prev = self.ff = 0.0
        self._sp_f = self._pv_f = self._sp_w = self.sp_w = 0.0
        self._td1 = self._td2 = self._td3 = 0.0
        self.sp_td = self.sp_td_d1 = self.sp_td_d2 = self.sp_td_d3 = 0.0
        self._u_hist = (u0,) * self._nd
        self.u_man = u0
        self._ref = 0.0
        self._q = 0.0
        self._started = False
        self._track = False
        self._sat = 0
        self._ab_sat = 0
        self._ab_wait = 0.0
        self._pending = None
        self._plc_state = None  # the precision="float32" cycle starts afresh
        if self._warn:
            self.error_id = ErrorCode.WARN_DISCRETISATION

    def output_limits(self) -> tuple[float, float]:
        """``(u_min, u_max)`` in force (``set_limits`` included)."""
        return self._u_lo, self._u_hi

    def _resume(self, held: float) -> None:
        """After a failed cycle (``BAD_RESULT``): the ESO restarts at rest, from ``held``.

        As after ``reset()`` the next valid measurement starts the ESO at rest on
        it (x4 = -b0 u), and x4 is re-solved by (11) (``_track``) so that the first
        output equals ``held``.
        """
        self.out = self.u_raw = held
        self.awout = False
        for name in ("e", "y", "y_ref", "_ref"):
            if not _NINF < getattr(self, name) < _INF:
                setattr(self, name, 0.0)
        self._q = 0.0
        self._yh = self._x2 = self._x3 = self._x4 = 0.0
        self._u_prev = held
        if not _NINF < self._ff_prev < _INF:
            self._ff_prev = self.ff = 0.0
        self._u_hist = (held - self._ff_prev,) * self._nd
        if not self.manual:
            self.u_man = held
        self._started = False
        self._track = True
        self._plc_state = None  # the float32 cycle restarts too
        self._sat = self._ab_sat = 0
        self._ab_wait = 0.0
        if self._pending is not None:
            # a two-phase cycle in progress: commit this cycle's reference (y_ref, made
            # finite above), as the per-call cycle, which committed it before the guard
            ref = self._sgn * self.y_ref  # in the cycle's units (reverse: -y_ref)
            self._pending = (0.0, 0.0, 0.0, 0.0, ref, False, True, 0, 0, 0.0, 0.0, self._ff_prev,
                             *self._pending[12:])  # fmt: skip

    def restore(self, snapshot: dict[str, Any]) -> None:
        """Restore a state taken by :meth:`snapshot`; a pending two-phase cycle is dropped.

        A snapshot taken before ``input_delay`` existed (no ``_u_hist``) restores
        with the history at rest on its last u; one of another delay is resized.
        """
        if "_u_hist" not in snapshot and "_u_prev" in snapshot:
            snapshot = {**snapshot, "_u_hist": ()}
        if "_q" not in snapshot:  # a snapshot of before the handover offset
            snapshot = {**snapshot, "_q": 0.0}
        if "_ff_prev" not in snapshot:  # a snapshot of before the feed-forward input
            snapshot = {**snapshot, "_ff_prev": 0.0, "ff": 0.0}
        if "_sp_w" not in snapshot and "y" in snapshot:
            # a snapshot of before the input stage: its chains at the last PV and setpoint
            y, sp = snapshot["y"], snapshot["y"] + snapshot.get("e", 0.0)
            snapshot = {**snapshot, "_pv_f": y, "_sp_f": sp, "_sp_w": sp, "sp_w": sp}
        if "_td1" not in snapshot:  # a snapshot of before the tracking differentiator
            sw = snapshot.get("_sp_w", 0.0)
            snapshot = {**snapshot, "_td1": sw, "_td2": sw, "_td3": sw, "sp_td": sw,
                        "sp_td_d1": 0.0, "sp_td_d2": 0.0, "sp_td_d3": 0.0}  # fmt: skip
        super().restore(snapshot)
        self._u_hist = _resize_history(tuple(self._u_hist), self._nd,
                                       self._u_prev - self._ff_prev)  # fmt: skip
        self._pending = None

    # -- inputs and outputs ----------------------------------------------------

    @property
    def u(self) -> float:
        """Manipulated variable of the last cycle (limited), same as ``out``."""
        return self.out

    @property
    def x(self) -> tuple[float, float, float, float]:
        """ESO state vector ``(Y_hat, x2, x3, x4)``; x4 estimates the total disturbance h.

        In the units the cycle runs in: with ``reverse`` those of ``-y``.
        """
        return (self._yh, self._x2, self._x3, self._x4)

    @property
    def manual_value(self) -> float:
        """Alias of ``u_man`` (the name the PID block uses)."""
        return self.u_man

    @manual_value.setter
    def manual_value(self, value: float) -> None:
        self.u_man = value

    @property
    def mode(self) -> Mode:
        """The active mode from the inputs, by the priority of :class:`Mode` (RESET > TRACK >
        HOLD > MANUAL > AUTO); assigning a Mode sets its input and clears the others."""
        if self.reset_active:
            return Mode.RESET
        if self.track:
            return Mode.TRACK
        if self.hold:
            return Mode.HOLD
        return Mode.MANUAL if self.manual else Mode.AUTO

    @mode.setter
    def mode(self, value: Mode) -> None:
        if value not in tuple(Mode):
            raise ParameterError(
                ErrorCode.BAD_PARAMETER, "mode",
                f"ADRC supports AUTO, MANUAL, TRACK, HOLD and RESET, got {value!r}",
            )  # fmt: skip
        self.reset_active = value == Mode.RESET
        self.manual = value == Mode.MANUAL
        self.track = value == Mode.TRACK
        self.hold = value == Mode.HOLD

    @property
    def u_min(self) -> float:
        """Lower limit of u in force."""
        return self._u_lo

    @property
    def u_max(self) -> float:
        """Upper limit of u in force."""
        return self._u_hi

    @property
    def warning(self) -> bool:
        """True when omega_o ts or omega_c ts is outside the trusted range (16#8301)."""
        return self._warn

    @property
    def gains(self) -> dict[str, float]:
        """The gains in force: ``l1..l4`` (continuous, Gao) and ``kp, kd1, kd2`` (as used)."""
        l1, l2, l3, l4, _, _, _ = self._gains
        _, kp, kd1, kd2 = self._law
        return {"l1": l1, "l2": l2, "l3": l3, "l4": l4, "kp": kp, "kd1": kd1, "kd2": kd2}

    @property
    def switches(self) -> dict[str, float]:
        """The switches ``p1, p2, k1, k2, k3`` of (4a) for the configured order."""
        return dict(zip(("p1", "p2", "k1", "k2", "k3"), self._switches, strict=True))

    def set_limits(self, u_min: float, u_max: float) -> None:
        """Write the limits of u (updatable every cycle, section 4.1); never raises.

        A reversed or NaN pair sets ``BAD_LIMITS`` (16#8201) as a status and the
        last valid limits stay in force until a valid pair is written.
        """
        try:
            lo, hi = require_limits("u_min", u_min, "u_max", u_max)
        except ParameterError:
            self._limits_bad = True
            self.error_id = ErrorCode.BAD_LIMITS
            return
        self._u_lo, self._u_hi = block_limits(lo, hi, self._config.precision)
        self._limits_bad = False
        self._prm = None
        self._relimit()

    # -- the cycle ---------------------------------------------------------------

    def __call__(
        self,
        sp: float,
        y: float,
        *,
        ff: float = 0.0,
        pv_ok: bool = True,
        y_ok: bool = True,
        u_real: float | None = None,
        dt: float | None = None,
    ) -> float:
        """Run one cycle; return the manipulated variable u.

        ``ff`` is the feed-forward [MV units], added to the law's output before
        the limits as in the PID (docs/blocks/adrc.md, "Feed-forward"); a NaN/inf
        ``ff`` holds the output as a bad setpoint does (``BAD_INPUT``).

        ``pv_ok`` is the quality of the measurement (the name of every
        controller, :class:`~ctrlblocks.blocks.protocols.Controller`); ``y_ok``
        is its older alias, kept for one release (False in either is bad).
        ``u_real`` is used for the ESO when ``u_real_on`` is configured (a
        missing or NaN ``u_real`` then falls back to u and sets ``BAD_INPUT``).
        """
        # the output guard (Block._checked) around the body, with the inputs converted
        # first: the compiled build's _call takes C doubles (docs/performance.md)
        if type(sp) is not float:
            sp = as_input(sp)
        if type(y) is not float:
            y = as_input(y)
        if type(ff) is not float:
            ff = as_input(ff)
        prev = self.out
        v = self._call(sp, y, pv_ok, y_ok, u_real, dt, ff)
        u = self.out
        if self._u_lo <= u <= self._u_hi and _NINF < u < _INF:
            return v  # the guard's test inline: no call on the usual path
        return self._checked(prev, v)

    def _call(
        self, sp: float, y: float, pv_ok: Any, y_ok: Any, u_real: Any, dt: float | None,
        ff: float = 0.0,
    ) -> float:
        """The body of :meth:`__call__` (inputs converted, output not yet checked)."""
        if pv_ok is not True:
            y_ok = as_flag(y_ok, False) and as_flag(pv_ok, False)
        if (
            self._lean
            and dt is None
            and y_ok is True
            and self._started
            and self._h == self._ts
            and self._pending is None
            and not (self._track or self.manual or self.awin or self.track or self.hold
                     or self.reset_active)
            and ff == 0.0
            and self._ff_prev == 0.0
            and _NINF < sp < _INF
            and _NINF < y < _INF
        ):
            return self._fast_cycle(sp, y)
        if self._config.precision == "float32":
            if self._cycle_time(dt, self._ts) is None:
                return self.out
            return _float32_cycle("adrc")(self, sp, y, y_ok, dt, u_real, ff)
        v = self.compute_output(sp, y, ff=ff, y_ok=y_ok, dt=dt)
        applied = v
        if self._config.u_real_on and self._pending is not None:
            if u_real is not None and is_finite(u_real):
                applied = float(u_real)
            elif self.error_id in (ErrorCode.NO_ERROR, ErrorCode.WARN_DISCRETISATION):
                self.error_id = ErrorCode.BAD_INPUT
        self.update_state(applied)
        return v

    def _fast_cycle(self, sp: float, y: float) -> float:
        """Fast lane of ``__call__``: the whole auto cycle as one :func:`adrc_step` call.

        Same result and state as :meth:`compute_output` + :meth:`update_state`
        (tests/fast/test_lanes.py checks it cycle by cycle).
        """
        prm = self._prm
        if prm is None:
            prm = self._prm = self._kernel_params()
        u_prev = self._u_prev
        (u, u_raw, self._yh, self._x2, self._x3, self._x4, ref, q, _end, self._sat, _abs,
         _abw) = adrc_law(
            sp, y, 0.0, False, u_prev, False, True, self._sat, False, False, False, self._yh,
            self._x2, self._x3, self._x4, u_prev, u_prev, self._ref, self._q, 0, 0.0, prm,
            NO_EXACT, NO_ANTI_BACKOFF,
        )  # fmt: skip
        self._q = q
        self.error_id = _BAD_LIMITS if self._limits_bad else _WARN if self._warn else _NO_ERROR
        self.out = u if _NINF < u_raw < _INF else math.nan  # overflow: the guard's case
        self.u_raw = u_raw
        self.awout = self._sat != 0
        self.y = y
        self.e = sp - y
        self.y_ref = self._ref = ref
        self._u_prev = self.u_man = u
        self._pv_f = y  # the input stage passes its inputs through (input_stage)
        self._sp_f = self._sp_w = self.sp_w = self.sp_td = sp  # the TD is off (_lean)
        return u

    def _kernel_params(self) -> tuple[float, ...]:
        """The ``prm`` tuple of :func:`adrc_step` for the coefficients and limits in force."""
        h, b0 = self._h, self._b0
        l1, l2, l3, l4 = self._gains[:4]
        p1, p2, k1, k2, k3 = self._switches
        _b0, kp, kd1, kd2 = self._law
        s_yh, s_x2, s_x3, s_u = self._sens
        return tuple(
            float(v)
            for v in (h, b0, l1, l2, l3, l4, p1, p2, k1, k2, k3, kp, kd1, kd2, s_yh, s_x2,
                      s_x3, s_u, self._u_lo, self._u_hi, self._rule, self._a_ref, self._a_q,
                      self._nsub)
        )  # fmt: skip

    def compute_output(
        self,
        sp: float,
        y: float,
        *,
        ff: float = 0.0,
        pv_ok: bool = True,
        y_ok: bool = True,
        dt: float | None = None,
    ) -> float:
        """Compute this cycle's u without committing the state (Åström 1987, section 6).

        Idempotent within a cycle: it always starts from the committed state.
        ``pv_ok`` (``y_ok``, its older alias) is the quality of the measurement;
        ``ff`` the feed-forward (:meth:`__call__`).
        """
        prev = self.out
        v = self._compute_output(sp, y, pv_ok, y_ok, dt, ff)
        u = self.out
        if self._u_lo <= u <= self._u_hi and _NINF < u < _INF:
            return v  # the guard's test inline (as __call__): no call on the usual path
        return self._checked(prev, v)

    def _compute_output(
        self, sp: Any, y: Any, pv_ok: Any, y_ok: Any, dt: float | None, ff: Any = 0.0
    ) -> float:
        """The body of :meth:`compute_output` (output not yet checked).

        The cycle's process data is :func:`adrc_compute` (also the PLC cycle's); the block
        adds its edge (inputs converted, the sample time), its coefficients, the
        status of its configuration, the outputs and the pending commit.
        """
        if pv_ok is not True:
            y_ok = as_flag(y_ok, False) and as_flag(pv_ok, False)
        self._pending = None
        # the edge: the conversions only where needed (as_input passes a float, as_flag True)
        if type(sp) is not float:
            sp = as_input(sp)
        if type(y) is not float:
            y = as_input(y)
        if type(ff) is not float:
            ff = as_input(ff)
        if y_ok is not True:
            y_ok = as_flag(y_ok, False)
        tv, um = self.track_value, self.u_man
        if type(tv) is not float:
            tv = as_input(tv)
        if type(um) is not float:
            um = as_input(um)
        h = self._ts if dt is None else self._cycle_time(dt, self._ts)
        if h is None:
            return self.out
        if h != self._h:
            self._coefficients(h)
        c = self._config
        prm = self._prm
        if prm is None:
            prm = self._prm = self._kernel_params()
        sgn = self._sgn
        # the u the ESO is fed: the applied u less its feed-forward, input_delay samples
        # older (Zhao & Gao 2014)
        u_eso = self._u_hist[0] if self._nd else self._u_prev - self._ff_prev
        res = adrc_compute(
            sp, y, ff, y_ok, bool(self.reset_active), bool(self.track), bool(self.hold),
            bool(self.manual), bool(self.awin), tv, um, self._scale_pv, self._n, self._reverse,
            self._exact, c.anti_backoff, _BAD_LIMITS if self._limits_bad else _WARN if self._warn
            else _NO_ERROR, self.out, self._u_prev, self._ff_prev, u_eso, self._yh, self._x2,
            self._x3, self._x4, self._ref, self._q, self._started, self._track, self._sat,
            self._ab_sat, self._ab_wait, sgn * self.e, sgn * self.y, self._sp_f, self._pv_f,
            self._sp_w, self._td1, self._td2, self._td3, self._opt, prm,
            self._eso_coef if self._exact else NO_EXACT, self._ab,
        )  # fmt: skip
        u, u_raw, err, e, y_out, sp_td, td_d1, td_d2, td_d3 = res[:9]
        self.error_id = err
        self.out = u
        self.u_raw = u_raw
        self.awout = res[16] != 0  # sat
        self.y = sgn * y_out
        self.e = sgn * e
        self.y_ref = sgn * res[13]  # the reference trajectory (Fig. 2's Y_ref)
        self.sp_w = res[23]
        self.sp_td, self.sp_td_d1, self.sp_td_d2, self.sp_td_d3 = sp_td, td_d1, td_d2, td_d3
        # (yh, x2, x3, x4, ref, started, track_next, sat, ab_sat, ab_wait, q, ff, sp_f, pv_f,
        # sp_w, td1, td2, td3): committed by update_state
        self._pending = res[9:-1]
        if res[-1]:
            # the law failed (held, the ESO restarts: adrc_compute): the delay history and
            # the attributes restart as after any failed cycle (the output guard's _resume)
            self._resume(u)
        return u

    def update_state(self, applied: float) -> None:
        """Commit the cycle computed by :meth:`compute_output`.

        ``applied`` is the u actually applied to the process (after external
        saturation, selectors, a cascade); it drives the ESO in the next cycle.
        A NaN/inf ``applied`` is replaced by the block's own u (``BAD_INPUT``).
        Without a preceding ``compute_output`` this does nothing.
        """
        if self._pending is None:
            return
        a = as_input(applied)
        if not _NINF < a < _INF:
            a = self.out
            self.error_id = ErrorCode.BAD_INPUT
        (
            self._yh,
            self._x2,
            self._x3,
            self._x4,
            self._ref,
            self._started,
            self._track,
            self._sat,
            self._ab_sat,
            self._ab_wait,
            self._q,
            ff,
            self._sp_f,
            self._pv_f,
            self._sp_w,
            self._td1,
            self._td2,
            self._td3,
        ) = self._pending
        if self._nd:
            self._u_hist = (*self._u_hist[1:], self._u_prev - self._ff_prev)
        self._u_prev = a
        self._ff_prev = self.ff = ff
        if not self.manual:
            self.u_man = a  # In/Out as in the PID: AUTO -> MAN holds the output
        self._pending = None

    # -- the public seam of the compiled paths (fast/, plc/) ---------------------------

    def fast_path_blockers(self, *, manual_ok: bool = True) -> list[str]:
        """Why :func:`adrc_step` cannot run this ADRC as it is now (empty: it can).

        The one decision for every compiled path: ``discretisation="exact"``,
        ``u_real_on`` and ``anti_backoff`` are not covered, nor the ``awin``
        input, nor a feed-forward in force (the kernels have no ``ff``: a block
        whose last cycle had one is refused); ``manual_ok`` False also refuses a
        block in manual (the banks run in auto).
        """
        bad = _unsupported(self._config, "adrc")  # the options (also the PLC cycle's check)
        if self.awin:
            bad.append("awin")
        if self._ff_prev != 0.0:
            bad.append("feed-forward")
        bad += [n for n in ("track", "hold", "reset_active") if getattr(self, n)]
        if not manual_ok and self.manual:
            bad.append("manual")
        return bad

    def fast_path_supported(self, *, manual_ok: bool = True) -> bool:
        """True when :func:`adrc_step` runs this ADRC exactly (:meth:`fast_path_blockers`)."""
        return not self.fast_path_blockers(manual_ok=manual_ok)

    def kernel_params(self) -> ADRCKernelParams:
        """The parameters of :func:`adrc_step` at the configured sample time ``ts``."""
        self._coefficients(float(self._config.ts))
        return ADRCKernelParams(*self._kernel_params())

    def kernel_state(self) -> ADRCKernelState:
        """The state :func:`adrc_step` carries from one sample to the next."""
        return ADRCKernelState(
            self._yh,
            self._x2,
            self._x3,
            self._x4,
            self._u_prev,
            self._ref,
            self._started,
            self._track,
            self._sat,
            self._q,
        )

    def load_kernel_state(self, state: ADRCKernelState) -> None:
        """Put back a state after :func:`adrc_step` cycles run outside the block."""
        self._pending = None
        self._yh, self._x2, self._x3, self._x4 = (float(v) for v in state[:4])
        self._u_prev, self._ref = float(state.u_prev), float(state.ref)
        self._started, self._track = bool(state.started), bool(state.track)
        self._sat = int(state.sat)
        self._q = float(state.q)


class ADRCKernelParams(NamedTuple):
    """The parameter tuple of :func:`adrc_step` (:meth:`ADRC.kernel_params`), by name."""

    ts: float  # sample time h [s]
    b0: float
    l1: float  # observer gains (adrc_gains, Nowak et al. 2018, section 3.3)
    l2: float
    l3: float
    l4: float
    p1: float  # order switches of the ESO
    p2: float
    k1: float
    k2: float
    k3: float
    kp: float  # control law gains
    kd1: float
    kd2: float
    s_yh: float  # sensitivities of the states to u (x4 solve, (11))
    s_x2: float
    s_x3: float
    s_u: float
    lo: float  # output limits
    hi: float
    rule: float  # anti-windup rule
    a_ref: float  # PT1 coefficient of the reference filter
    a_q: float  # decay per sample of the handover offset, exp(-omega_c ts)
    nsub: float  # Euler steps of the ESO per sample (euler_substeps; 1 in the trusted range)


class ADRCKernelState(NamedTuple):
    """What :func:`adrc_step` carries from sample to sample (:meth:`ADRC.kernel_state`)."""

    yh: float  # the ESO's estimate of y
    x2: float
    x3: float
    x4: float  # the total disturbance estimate
    u_prev: float  # the u applied last
    ref: float  # the filtered reference
    started: bool
    track: bool  # re-solve x4 at the next cycle (bumpless)
    sat: int  # the limit the output is at (-1, 0, 1)
    q: float = 0.0  # the handover offset of the reference (handover_offset)
