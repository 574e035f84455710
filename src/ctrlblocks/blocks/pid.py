"""The industrial PID block: controltheplant 2024, Åström 1987, Bonde et al. 2021.

Control law (ISA form inside; see :mod:`.pid_forms` for ``form="parallel"``
and ``form="series"``), after optional scaling of SP and PV to 0..100 %:

* proportional action with setpoint weight ``b``, Åström 1987, (2.2), (2.7)::

      P[k] = K (b r[k] - y[k])

* integral action, ``dI/dt = (K/Ti) e + (u - v)/Tt`` (Åström 1987, Fig. 3.6 and
  the Simnon module ``pid`` of Appendix A), ``e = r - y``.  The error part is
  discretised by ``integral_method``:

  - ``"forward"``  (Åström 1987, (2.8)): ``I[k] = I[k-1] + K h/Ti e[k-1]``
  - ``"backward"``: ``I[k] = I[k-1] + K h/Ti e[k]``
  - ``"tustin"``  (trapezoid, controltheplant 2024, section 2.3.1; Bonde et al.
    2021, "I-leddet"; default):
    ``I[k] = I[k-1] + K h/(2 Ti) (e[k] + e[k-1])``

  The tracking part ``(u - v)/Tt`` is applied in ``update_state`` once the
  applied value ``u`` is known (Åström 1987, section 6, (6.6)), discretised by
  implicit Euler, ``I += h/(Tt + h) (u - v)``: stable for every ``Tt > 0`` and
  ``Tt -> 0`` sets ``v = u`` in one sample.

* derivative action with setpoint weight ``c`` (``c = 0``: derivative on the
  measurement, Åström 1987, (2.3), Bonde et al. 2021, "Derivasjonskick") and filter time
  constant ``Tf = Td/N`` (Bonde et al. 2021 sum form; Åström 1987, (2.9))::

      Tf dD/dt + D = K Td d/dt (c r - y)

  discretised as Åström 1987, (2.13), ``D[k] = a D[k-1] + bd (w[k] - w[k-1])`` with
  ``w = c r - y`` and, by ``derivative_method`` (``kd = K Td``):

  - ``"forward"``  (2.10): ``a = 1 - h/Tf``,          ``bd = kd/Tf``
  - ``"backward"`` (2.11): ``a = Tf/(Tf + h)``,        ``bd = kd/(Tf + h)`` (default)
  - ``"tustin"``   (2.12): ``a = (2Tf - h)/(2Tf + h)``, ``bd = 2 kd/(2Tf + h)``
    (Bonde et al. 2021, "D-leddet", with ``tau = Td/n``).

* output ``v = P + I + D + FF`` (Åström 1987, (6.1); the feed-forward ``FF`` is
  the ``ff`` input plus the lead-lag path of Bonde et al. 2021 version 4), limited to
  ``[u_min, u_max]`` and passed through the output ramp.

The velocity (incremental) algorithm (controltheplant 2024, section 2.3.1;
Åström 1987, Figs. 2.2-2.5)
adds the increments of the same P, I, D and FF terms to an output integrator
that is limited itself.  Without integral action the integrator has the reset
feedback of Fig. 2.4 (switch B of Fig. 2.5), time constant ``tt``, so that P
and PD controllers keep the proper steady state ``P + D + FF + bias``.

Everything around the law follows controltheplant 2024, section 2.3; see the class
docstring and ``docs/blocks/pid.md``.
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import math
import operator
import sys
from collections.abc import Callable
from typing import Any, Literal, NamedTuple

from .base import (
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
from .leadlag import LeadLag, LeadLagConfig, leadlag_coefficients, leadlag_step
from .pid_forms import FORMS, isa_parameters
from .precision import block_limits
from .precision import check_precision as _check_precision
from .precision import float32_cycle as _float32_cycle
from .precision import unsupported as _unsupported
from .signals import (
    MAX_WINDOW,
    PT1,
    MovingAverage,
    RateLimiter,
    SteadyStateDetector,
    clamp,
    deadband,
    pt1_coefficient,
    pt1_step,
    rate_limit_step,
    scale,
    steady_step,
)

__all__ = [
    "PID",
    "AntiWindup",
    "Bumpless",
    "PIDConfig",
    "PIDKernelParams",
    "PIDKernelState",
    "PIDOptions",
    "pid_step",
    "retune_states",
]

log = logging.getLogger(__name__)


class AntiWindup:
    """Anti-windup methods (controltheplant 2024, ``enumAntiWindupMethods``)."""

    CLAMPING = "clamping"
    """Conditional integration: stop integrating while the output is limited
    (by ``u_min``/``u_max`` or by the output ramp) and the error drives it
    further into the limit (controltheplant 2024, section 2.3.12)."""
    BACK_CALC_MODEL = "back_calc_model"
    """Back-calculation with an actuator model (limits + output ramp), time
    constant ``tt`` (controltheplant 2024, section 2.3.12; Åström 1987, Fig. 3.2 B)."""
    BACK_CALC_REAL = "back_calc_real"
    """Back-calculation with the measured actuator position ``actuator_pos``
    (controltheplant 2024, section 2.3.12; Åström 1987, Fig. 3.2 A)."""
    ALL = (CLAMPING, BACK_CALC_MODEL, BACK_CALC_REAL)


class Bumpless:
    """Bumpless manual-to-auto methods (controltheplant 2024, ``enumBumplessTransferMethods``).

    ``INTEGRATOR`` is the integrator tracking of Åström 1987, Fig. 4.4.
    """

    INTEGRATOR = "integrator"
    """The integrator tracks the output in every non-auto mode and is set at the
    switch so that the output continues exactly (Åström 1987, Fig. 4.4; default)."""
    TRACK_SETPOINT = "track_setpoint"
    """In non-auto modes the working setpoint follows the PV; after the switch
    it ramps back to the SP with ``sp_rate`` (controltheplant 2024; needs ``sp_rate > 0``,
    else 16#8202)."""
    SUPPRESS_P_ACTION = "suppress_p_action"
    """After the switch the P action is off until ``|e| <= dev_tol`` (controltheplant 2024)."""
    ALL = (INTEGRATOR, TRACK_SETPOINT, SUPPRESS_P_ACTION)


METHODS = ("forward", "backward", "tustin")
_INF, _NINF = math.inf, -math.inf
_BIG = sys.float_info.max  # the largest valid magnitude of a double (pid_compute's ``big``)
_FORWARD, _BACKWARD, _TUSTIN = 0, 1, 2


# ---------------------------------------------------------------------------
# The control law: pure functions over floats (one implementation, DESIGN 2)
# ---------------------------------------------------------------------------


def derivative_coefficients(kd: float, tf: float, h: float, method: int) -> tuple[float, float]:
    """``(a, bd)`` of Åström 1987, (2.13) for ``Tf dD/dt + D = kd dw/dt``.

    ``method`` 0 forward (2.10), 1 backward (2.11), 2 Tustin (2.12);
    ``kd = K Td``, ``Tf = Td/N``.  ``kd == 0`` gives ``(0, 0)`` (no derivative).
    The forward difference's pole ``1 - h/Tf`` leaves the unit circle for
    ``h >= 2 Tf`` (the configuration refuses such a ``ts``); a measured period
    that long gets the backward difference (2.11), stable for any ``h``.
    """
    if kd == 0.0:
        return 0.0, 0.0
    if method == _FORWARD and h < 2.0 * tf:
        return 1.0 - h / tf, kd / tf
    if method != _TUSTIN:  # forward beyond 2 Tf, or backward
        return tf / (tf + h), kd / (tf + h)
    return (2.0 * tf - h) / (2.0 * tf + h), 2.0 * kd / (2.0 * tf + h)


def integral_weights(method: int) -> tuple[float, float]:
    """Weights ``(alpha, beta)`` of ``e[k-1]`` and ``e[k]`` in the integral increment.

    ``method`` 0 forward (Åström 1987, (2.8)): ``(1, 0)``; 1 backward Euler:
    ``(0, 1)``; 2 Tustin (controltheplant 2024, section 2.3.1; Bonde et al. 2021,
    "I-leddet"): ``(1/2, 1/2)``.
    """
    if method == _FORWARD:
        return 1.0, 0.0
    if method == _BACKWARD:
        return 0.0, 1.0
    return 0.5, 0.5


def derivative_step(a: float, bd: float, d_prev: float, w: float, w_prev: float) -> float:
    """Åström 1987, (2.13): ``D[k] = a D[k-1] + bd (w[k] - w[k-1])`` with ``w = c r - y``."""
    return a * d_prev + bd * (w - w_prev)


def integral_increment(ki_h: float, alpha: float, beta: float, e_prev: float, e: float) -> float:
    """``(K h / Ti) (alpha e[k-1] + beta e[k])``: (2.8), backward Euler or trapezoid."""
    return ki_h * (alpha * e_prev + beta * e)


def clamping_blocks(di: float, v: float, lo: float, hi: float) -> bool:
    """Conditional integration (controltheplant 2024 CLAMPING): True if the increment ``di``
    would drive the limited output ``v`` further into its limit."""
    return (v > hi and di > 0.0) or (v < lo and di < 0.0)


def clamping_integral(i: float, di: float, rest: float, lo: float, hi: float) -> float:
    """The integrator when conditional integration stops it at a limit (CLAMPING).

    controltheplant 2024, anti-windup method CLAMPING, made to settle on the limit.

    ``rest = P + D + FF``.  The increment ``di`` would drive ``v = rest + i + di``
    beyond the limit: the integrator moves only as far as puts ``v`` on the
    limit (``i = limit - rest``), never backwards (if ``v`` was already beyond it
    with ``i``, ``i`` stays).  So the output settles *at* the limit, not one
    increment below it, and a primary controller sees the limit status.
    """
    if di > 0.0:
        return max(i, hi - rest)
    return min(i, lo - rest)


def ramp_blocks(di: float, v: float, y_prev: float, step_max: float) -> bool:
    """Conditional integration at the output ramp: True if the ramp (largest step
    ``step_max`` per cycle, 0 = no ramp) holds the output back in the direction
    the increment ``di`` pushes."""
    if step_max <= 0.0:
        return False
    step = v - y_prev
    return (step > step_max and di > 0.0) or (step < -step_max and di < 0.0)


def tracking_gain(h: float, tt: float) -> float:
    """Implicit-Euler gain ``h/(Tt + h)`` of the tracking term ``(u - v)/Tt``.

    Åström 1987, Fig. 3.6 and the Simnon module ``pid`` (``dI = ... + (v - u)/Tt``).
    """
    return h / (tt + h)


def retune_states(
    sp_w: float,
    pv_f: float,
    p_old: float,
    d_old: float,
    i: float,
    bias: float,
    x: float,
    ff_prev: float,
    k: float,
    sgn: float,
    b: float,
    c: float,
    kd: float,
    ki: float,
    ki_old: float,
    velocity: bool,
    suppressed: bool,
) -> tuple[float, float, float, float, float, float]:
    """Bumpless parameter change: the states that keep the output when the law is retuned.

    Åström & Hägglund 2006 (implementation, "bumpless parameter changes"): a
    change of the parameters changes the output of the P (and D) terms for
    the same signals; the integrator takes the difference, ``I_new = I_old +
    K_old (b_old r - y) - K_new (b_new r - y)``, so that the output at the
    instant of the change is what it was -- the principle of Åström 1987,
    Fig. 4.4 (the integrator set so that the output continues), applied to a
    parameter change instead of a mode change.  It is evaluated on the last
    cycle's working setpoint ``sp_w`` and filtered PV ``pv_f`` [%], so the
    next cycle runs the new law in full (its P kick to a setpoint step, its
    integral increment): the output is continuous at the change, not held.

    ``p_old``, ``d_old``: the P term (as used, 0 while suppressed) and D term
    of the last cycle; the D term is kept as the derivative filter's state
    (the new filter continues from it) unless the new law has no derivative
    (``kd = K Td = 0``), then it is 0 and its last value goes to the integrator
    too.  The velocity algorithm keeps its output integrator ``x``; its
    increments start from the new P and D (so no increment is a bump); without
    integral action its reset-feedback bias takes the shift (or, when the
    integral action was just removed, the value that makes the feedback's
    target the present output ``x``).  ``k``, ``sgn``, ``b``, ``c``, ``kd``,
    ``ki`` are the new law's, ``ki_old = K/Ti`` the old one's (0: no integral).

    Returns ``(i, bias, p_new, d_new, w_prev, e_prev)``: the integrator, the
    bias, the P and D terms of the new law on the last cycle's signals (the
    velocity form's ``p_prev``/``d_prev`` and the D state), and the
    derivative's and integral's histories ``w = sgn (c r - y)``,
    ``e = sgn (r - y)`` in the new law's weights and sign.
    """
    p_new = 0.0
    if not suppressed:
        p_new = k * sgn * (b * sp_w - pv_f)
    d_new = d_old
    if kd == 0.0:
        d_new = 0.0
    shift = (p_old - p_new) + (d_old - d_new)
    bias_new = bias
    if velocity and ki == 0.0:
        # the integral action was just removed: the reset feedback's target is the output
        bias_new = bias + shift if ki_old == 0.0 else x - p_new - d_new - ff_prev
    return i + shift, bias_new, p_new, d_new, sgn * (c * sp_w - pv_f), sgn * (sp_w - pv_f)


def tracking_time(tt: float, ti: float, ts: float) -> float:
    """The tracking time constant ``Tt`` in force [s]: ``tt`` if > 0, else the default.

    The default is ``Ti/5`` (Åström 1987, Fig. 3.9 uses ``Tt = Ti/5``), or ``ts``
    without integral action (``Ti = 0``: the reset feedback of the velocity form).
    """
    if tt > 0.0:
        return tt
    if ti > 0.0:
        return ti / 5.0
    return ts


def pid_parameters(
    k: float,
    ti: float,
    td: float,
    n: float,
    b: float,
    c: float,
    h: float,
    lo: float,
    hi: float,
    reverse: bool,
    d_method: int,
    i_method: int,
    aw: float,
    tt: float,
) -> tuple[float, float, float, float, float, float, float, float, float, float, float, float,
           float]:  # fmt: skip
    """The parameter tuple of :func:`pid_law` (:class:`PIDKernelParams`) from the ISA tuning.

    ``(K, Ti, Td)`` ISA, ``n`` the derivative filter (``Tf = Td/n``), ``h`` the
    sample time of the cycle, ``d_method`` / ``i_method`` 0 forward, 1 backward,
    2 Tustin, ``aw`` 0 clamping, 1 back-calculation (model), 2 on the measured
    actuator position, ``tt`` the tracking time (0: :func:`tracking_time`'s
    default).  The one derivation of the parameters: the block, the PLC cycle
    and the compiled banks call it.
    """
    ad, bd = derivative_coefficients(k * td, td / n, h, d_method)
    ki = 0.0
    if ti > 0.0:
        ki = k / ti
    alpha, beta = integral_weights(i_method)
    sgn = 1.0
    if reverse:
        sgn = -1.0
    g = tracking_gain(h, tracking_time(tt, ti, h))
    return k, sgn, b, c, ad, bd, ki * h, alpha, beta, lo, hi, aw, g


NO_OPTIONS: tuple[float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0)
"""The ``opt`` of :func:`pid_law` (:class:`PIDOptions`) for the plain positional law (no
velocity form, no P suppression, no output ramp, no dead band, integration at any error):
what the compiled kernels pass."""


def pid_law(
    sp: float,
    pv: float,
    ff: float,
    held: bool,
    target: float,
    hist: bool,
    transfer: bool,
    suppressed: bool,
    awin: bool,
    db_active: bool,
    db_hold: float,
    i: float,
    d: float,
    w_prev: float,
    e_prev: float,
    x: float,
    bias: float,
    p_prev: float,
    d_prev: float,
    ff_prev: float,
    out_prev: float,
    ramp_y: float,
    prm: tuple[float, ...],
    opt: tuple[float, ...],
) -> tuple[float, float, bool, float, float, float, float, float, float, bool, bool]:
    """The PID's cycle from its working signals: the one law of every executor (compute half).

    The block (:meth:`PID.compute_output` and its per-call fast lane), the
    compiled kernels (:func:`pid_step`, numba and Cython), the float32 cycle
    and the exported function block (:func:`.plc_cycle.pid_cycle`) all run
    this function, written once in the subset the PLC translator accepts.  In
    Åström's computational order (1987, section 6) it is ``ComputeOutput``:
    from the committed state to this cycle's output and what
    :func:`pid_commit` commits with the value actually applied.

    ``sp``, ``pv`` are the working setpoint and the (filtered, scaled)
    measurement, ``ff`` the whole feed-forward.  ``held``: a mode other than
    AUTO, whose output is ``target``; ``hist`` restarts the derivative's and
    the error's histories on this sample (the first cycle, after a bad
    input); ``transfer`` continues from ``out_prev`` (the first AUTO cycle
    after another mode, a re-initialisation: Åström 1987, Fig. 4.4);
    ``suppressed`` the P action is off until ``|e| <= dev_tol``
    (SUPPRESS_P_ACTION); ``awin`` freezes the integrator; ``db_active`` the
    adaptive dead band holds the output at ``db_hold`` while the error stays
    in the band (controltheplant 2024, section 2.3.10).  The state: the
    integrator ``i``, ``D[k-1]``, ``w[k-1] = c r - y``, ``e[k-1]``, the
    velocity form's output integrator ``x``, its bias and the last P, D, FF;
    ``ramp_y`` the output ramp's last value.

    ``prm`` is :class:`PIDKernelParams` (:func:`pid_parameters`), ``opt`` is
    :class:`PIDOptions` -- ``(velocity, dev_tol, rate_h, db, i_band)``: the
    velocity algorithm (1.0), the deviation tolerance of SUPPRESS_P_ACTION,
    the output ramp's largest step per cycle (0: off), the dead band's
    half-width (0: off), the integral band (0: off; conditional integration,
    Åström & Hägglund 2006, section 3.5: the error is integrated only while
    ``|e| <= i_band``); :data:`NO_OPTIONS` for the plain positional law.

    Returns ``(out, v_raw, limiting, p, i_k, d, w, e, bias, suppressed,
    db_held)``: the limited (and ramped) output, the law's value before the
    limits, whether the output ramp set the output, the P term as used, the
    I term of this cycle (the integrator before the tracking of
    :func:`pid_commit`; the velocity form: ``v - P - D - FF``), the D term,
    ``w`` and ``e`` (with the action sign), the velocity form's bias, P still
    suppressed, and whether the dead band held the output.
    """
    k, sgn, b, c, ad, bd, ki_h, alpha, beta, lo, hi, aw, g = prm
    velocity, dev_tol, rate_h, db, i_band = opt
    e = sgn * (sp - pv)
    p = k * sgn * (b * sp - pv)
    w = sgn * (c * sp - pv)
    if hist:
        w_prev = w
        d = 0.0
        e_prev = e
    dn = derivative_step(ad, bd, d, w, w_prev)
    if suppressed and abs(e) <= dev_tol:
        transfer = True  # the P action comes back: re-initialise the integrator
        suppressed = False
    if suppressed:
        p = 0.0
    # conditional integration (Åström & Hägglund 2006, section 3.5): no increment of the
    # integral while the error is outside the integral band
    frozen = hist or awin or (i_band > 0.0 and abs(e) > i_band)
    db_held = False
    if db_active and not held and db > 0.0:
        if deadband(e, db) == 0.0:
            db_held = True  # the error stays in the band: hold the output at the average
            held = True
            target = db_hold
        else:
            transfer = True  # the dead band released: continue without a bump
    i_k = i
    if held:
        v_raw = target
    elif velocity != 0.0:
        # the velocity algorithm (controltheplant 2024, 2.3.1; Åström 1987, Figs. 2.2-2.5)
        if transfer:
            bias = out_prev - p - dn - ff
            i_k = bias
            v_raw = out_prev
        else:
            if hist:
                p_prev = 0.0
                d_prev = 0.0
                ff_prev = 0.0
            v_raw = x + (p - p_prev) + (dn - d_prev) + (ff - ff_prev)
            if ki_h != 0.0:  # switch A of Fig. 2.5: the increments of I
                if not frozen:
                    v_raw = v_raw + integral_increment(ki_h, alpha, beta, e_prev, e)
            else:  # switch B: reset feedback of Fig. 2.4 towards P + D + FF + bias
                v_raw = v_raw + g * (p + dn + ff + bias - v_raw)
            i_k = v_raw - p - dn - ff
    elif transfer:
        i_k = out_prev - p - dn - ff
        v_raw = p + i_k + dn + ff
    elif ki_h == 0.0 or frozen:
        v_raw = p + i_k + dn + ff
    else:
        di = integral_increment(ki_h, alpha, beta, e_prev, e)
        i_k = i + di
        v_raw = p + i_k + dn + ff
        if aw == 0.0 and clamping_blocks(di, v_raw, lo, hi):
            # integrate up to the limit, not beyond (clamping_integral); v_raw stays the
            # demand, beyond the limit, so that the limit status is set
            i_k = clamping_integral(i, di, p + dn + ff, lo, hi)
        else:
            if aw == 0.0 and clamping_blocks(di, p + i_k + ff, lo, hi):
                # a derivative kick of the other sign hides the limit: the integral may
                # still not take P + I + FF beyond it (no windup behind a D spike)
                i_k = clamping_integral(i, di, p + ff, lo, hi)
            elif aw == 0.0 and ramp_blocks(di, clamp(v_raw, lo, hi), ramp_y, rate_h):
                i_k = i  # the output ramp holds the output back
            v_raw = p + i_k + dn + ff
    out, limiting = pid_output(v_raw, ramp_y, lo, hi, rate_h)
    return out, v_raw, limiting, p, i_k, dn, w, e, bias, suppressed, db_held


def pid_output(v: float, ramp_y: float, lo: float, hi: float, rate_h: float) -> tuple[float, bool]:
    """The output stage: ``v`` limited to ``[lo, hi]``, then the output ramp; ``(out, limiting)``.

    The ramp (controltheplant 2024, section 2.3.8; :func:`.signals.rate_limit_step`)
    moves at most ``rate_h`` per cycle from its last value ``ramp_y`` (0: off) and
    acts in every mode (RESET presets it: the caller passes the reset value as
    ``ramp_y``); limits narrowed at run time win over it.  ``limiting``: the ramp
    set the output.
    """
    out = clamp(v, lo, hi)
    if rate_h > 0.0:
        out, limiting = rate_limit_step(out, ramp_y, rate_h, rate_h, 1.0)
        return clamp(out, lo, hi), limiting
    return out, False


def pid_commit(
    u: float,
    out: float,
    v_raw: float,
    p: float,
    i_k: float,
    d: float,
    ff: float,
    held: bool,
    pos_ok: bool,
    actuator_pos: float,
    ki_h: float,
    aw: float,
    g: float,
    velocity: float,
) -> tuple[float, float]:
    """The PID's state after a cycle of :func:`pid_law` with the applied value ``u`` (update half).

    ``UpdateState`` of Åström 1987, Listing 6.3.  In AUTO the integrator
    tracks ``u`` with time constant ``Tt`` (Åström 1987, Fig. 3.6, implicit
    Euler :func:`tracking_gain`): with clamping on ``u - out`` (0 when the
    block's own output is applied), with back-calculation on ``u - v_raw``
    (``aw`` 1) or ``actuator_pos - v_raw`` (``aw`` 2, while ``pos_ok``; Åström
    1987, Fig. 3.2 A); the velocity form's output integrator tracks from the
    output.  While ``held`` (another mode, the dead band) the integrator is set
    so that ``P + I + D + FF = u`` (Åström 1987, Fig. 4.4).  Returns ``(i, x)``:
    the integrator and the velocity form's output integrator for the next cycle
    (the positional form keeps ``x``'s input, the velocity form ``i``'s: the caller's).
    ``ki_h``, ``aw``, ``g`` and ``velocity`` are those of :func:`pid_law`'s ``prm`` and ``opt``.
    """
    if held:
        return u - p - d - ff, u
    ref = u
    if aw == 2.0 and pos_ok:
        ref = actuator_pos
    if velocity != 0.0:
        return i_k, out + g * (ref - out)
    if ki_h != 0.0 and (aw != 0.0 or u != out):
        v = out
        if aw != 0.0:
            v = v_raw
        return i_k + g * (ref - v), out
    return i_k, out


def pid_step(
    sp: float,
    pv: float,
    ff: float,
    manual: bool,
    u_man: float,
    cold: bool,
    transfer: bool,
    i: float,
    d: float,
    w_prev: float,
    e_prev: float,
    out_prev: float,
    prm: tuple[float, ...],
) -> tuple[float, float, float, float, float, float, float, float]:
    """One cycle of the positional PID with ``applied = out``: :func:`pid_law` for the kernels.

    The compiled loops, banks and lanes of :mod:`ctrlblocks.fast` run this
    function (numba inlines it): :func:`pid_law` with :data:`NO_OPTIONS`
    followed by :func:`pid_commit` with the block's own output.  ``manual``
    outputs ``u_man`` (limited) and sets the integrator so that ``P + I + D +
    FF`` equals it (Åström 1987, Fig. 4.4); ``transfer`` (first auto cycle
    after manual) continues from ``out_prev``; ``cold`` (first cycle after a
    reset) starts the histories on this sample.  ``prm`` is
    :class:`PIDKernelParams`.

    Returns ``(out, v_raw, p, i_shown, i_new, d, w, e)``: the limited output,
    the output before the limits, the P term, the I term of this cycle, the
    integrator for the next cycle, the D term, ``w = c r - y`` and
    ``e = r - y`` (with the action sign).
    """
    out, v_raw, _lim, p, i_k, dn, w, e, _bias, _sup, _dbh = pid_law(
        sp, pv, ff, manual, u_man, cold, transfer, False, False, False, 0.0, i, d, w_prev,
        e_prev, 0.0, 0.0, 0.0, 0.0, 0.0, out_prev, out_prev, prm, NO_OPTIONS,
    )  # fmt: skip
    i_new, _x = pid_commit(out, out, v_raw, p, i_k, dn, ff, manual, False, 0.0, prm[6], prm[11],
                           prm[12], 0.0)  # fmt: skip
    if manual:
        i_k = i_new  # the I term shown: what makes P + I + D + FF the output
    return out, v_raw, p, i_k, i_new, dn, w, e


# ---------------------------------------------------------------------------
# The process data of one cycle around the law: one implementation (DESIGN 2)
# ---------------------------------------------------------------------------

_AUTO, _MANUAL, _TRACK, _HOLD, _RESET = 0, 1, 2, 3, 4  # Mode
_NO_MODE = -1  # no cycle ran since the reset
_NO_ERROR, _BAD_INPUT, _BAD_MEASUREMENT = 0x0000, 0x8101, 0x8102  # ErrorCode
_TRACK_SETPOINT, _SUPPRESS_P = 1, 2  # Bumpless.ALL


def is_valid(x: float, big: float) -> bool:
    """True for a value the cycle computes with: not NaN and ``|x| <= big``.

    ``big`` is the largest valid magnitude of the executor's number format: the
    largest double for the block (the test is then ``isfinite``), ``REAL_MAX``
    for a PLC's REAL (:func:`.plc_cycle.is_real`).  The NaN is caught by ``x ==
    x`` first, a *quiet* comparison (IEEE 754: no invalid-operation exception for
    a quiet NaN), so that a runtime that traps floating-point exceptions does not
    stop at a NaN in the ordered comparison (docs/plc.md, "Traps").
    """
    if x == x:  # the NaN test
        return abs(x) <= big
    return False


def pid_mode(rst: bool, track: bool, hold: bool, manual: bool) -> int:
    """The active mode from the mode inputs, by the priority RESET > TRACK > HOLD > MANUAL > AUTO
    (controltheplant 2024; :class:`~ctrlblocks.Mode`)."""
    if rst:
        return _RESET
    if track:
        return _TRACK
    if hold:
        return _HOLD
    if manual:
        return _MANUAL
    return _AUTO


def pid_compute(
    sp: float,
    pv: float,
    ff: float,
    dv: float,
    pv_ok: bool,
    mode: int,
    man_value: float,
    track_value: float,
    reset_value: float,
    use_safe: bool,
    safe_value: float,
    out: float,
    ramp_y: float,
    scale_pv: bool,
    pv_lo: float,
    pv_hi: float,
    a_sp: float,
    a_pv: float,
    sp_rate: float,
    ff_on: bool,
    ll_b0: float,
    ll_b1: float,
    ll_a1: float,
    bumpless: int,
    h: float,
    cold: bool,
    reinit: bool,
    reinit_d: bool,
    mode_prev: int,
    suppressed: bool,
    awin: bool,
    db_active: bool,
    db_hold: float,
    i: float,
    d: float,
    w_prev: float,
    e_prev: float,
    x: float,
    bias: float,
    p_prev: float,
    d_prev: float,
    ff_prev: float,
    sp_f: float,
    pv_f: float,
    sp_w: float,
    sp_ramping: bool,
    ll_out: float,
    ll_x: float,
    prm: tuple[float, ...],
    opt: tuple[float, ...],
    big: float,
) -> tuple[float, int, bool, bool, bool, bool, float, float, float, float, float, float, float,
           float, float, bool, bool, float, float, float, bool, float, float]:  # fmt: skip
    """The PID's cycle from its process data to its output: the compute half of every executor.

    The block (:meth:`PID.compute_output`), its float32 cycle and the exported
    function block (:func:`.plc_cycle.pid_cycle`) run this function; the law
    itself is :func:`pid_law`.  It is ``ComputeOutput`` of Åström 1987
    (section 6, Listing 6.3); :func:`pid_update` commits it.

    * The output of a mode other than AUTO (``mode``: :func:`pid_mode`): RESET
      the limited ``reset_value`` at once (past the output ramp, controltheplant
      2024, section 2.3.5), TRACK ``track_value``, HOLD the last output ``out``,
      MANUAL ``man_value``; a mode value that is not valid (NaN, beyond ``big``)
      is a bad input and holds the output.
    * SP, PV, FF, DV are judged (:func:`is_valid` with ``big``, the largest
      valid magnitude), then the quality flag ``pv_ok``: ``BAD_INPUT``,
      ``BAD_MEASUREMENT``.  A cycle with a bad input holds the output (in AUTO
      ``safe_value`` if ``use_safe``) through the output stage
      (:func:`pid_output`) and runs nothing else.
    * The input stage: SP and PV scaled from ``pv_lo..pv_hi`` to 0..100 %
      (``scale_pv``; controltheplant 2024, section 2.3.4), a PT1 each (pole
      ``a_sp``, ``a_pv`` from :func:`.signals.pt1_coefficient`, 0: off;
      :func:`.signals.pt1_step`, section 2.3.7), the setpoint ramp of
      ``sp_rate`` units/s (:func:`.signals.rate_limit_step`, section 2.3.8);
      ``cold`` (the first cycle) starts the filters and the ramp at their input.
      In a mode other than AUTO with ``bumpless`` track-setpoint the working
      setpoint follows the filtered PV.  ``ff_on``: the lead-lag feed-forward on
      ``dv`` with the Tustin coefficients ``ll_b0, ll_b1, ll_a1`` (Bonde et al.
      2021, Fig. 10; :func:`.leadlag.leadlag_step`, limited to ``big``) is added
      to ``ff``.  A memory that is not valid (after an overflow) restarts from 0.
    * The transfer to AUTO: the first AUTO cycle after another mode, or after
      a re-initialisation, continues from ``out`` (Åström 1987, Fig. 4.4); with
      ``bumpless`` suppress-P the P action is off until ``|e| <= dev_tol``.
    * The law (:func:`pid_law`, with ``prm``, ``opt``); the I term shown while
      the output is held is what makes ``P + I + D + FF`` the output.  A law
      whose value, derivative memory or I term is not valid has failed: its
      output is the last one (or ``safe_value``), limited (``law_ok`` False).

    Returns ``(mv, err, ok, law_ok, limits_active, limiting, v_raw, p, i_k,
    i_shown, d, w, e, bias, ff, suppressed, held, sp_f, pv_f, sp_w, sp_ramping,
    ll_out, ll_x)``: the output, the status of the inputs (0, ``BAD_INPUT``,
    ``BAD_MEASUREMENT``), whether they were good, whether the law's values are
    valid, the limit status, whether the output ramp set the output, the
    law's value before the limits, the terms (``i_k`` the integrator for
    :func:`pid_commit`, ``i_shown`` the I term shown), ``w`` and ``e``, the
    velocity form's bias, the whole feed-forward, P still suppressed, whether
    the output was held (a mode, the dead band), and the input stage's new
    memories.
    """
    k, sgn, b, c, ad, bd, ki_h, alpha, beta, lo, hi, aw, g = prm
    velocity, dev_tol, rate_h, db, i_band = opt
    ok = is_valid(sp, big) and is_valid(pv, big) and is_valid(ff, big) and is_valid(dv, big)
    err = _NO_ERROR
    if not ok:
        err = _BAD_INPUT
    if not pv_ok:
        ok = False
        err = _BAD_MEASUREMENT
    # the output of a mode other than AUTO
    target = out
    if mode == _RESET:
        target = clamp(reset_value, lo, hi)
        ramp_y = target  # the output ramp is preset: RESET acts immediately
    elif mode in (_MANUAL, _TRACK):
        value = man_value
        if mode == _TRACK:
            value = track_value
        if is_valid(value, big):
            target = value
        else:
            ok = False
            if err == _NO_ERROR:
                err = _BAD_INPUT
    held = mode != _AUTO
    if not ok:
        # hold (or the safe value); the next good cycle continues without a bump
        if mode == _AUTO and use_safe:
            target = safe_value
        mv, limiting = pid_output(target, ramp_y, lo, hi, rate_h)
        limits_active = limiting or target > hi or target < lo
        return (mv, err, False, True, limits_active, limiting, target, 0.0, i, 0.0, d, w_prev,
                e_prev, bias, ff, suppressed, held, sp_f, pv_f, sp_w, sp_ramping, ll_out,
                ll_x)  # fmt: skip
    # input stage: scaling, filters, setpoint ramp, lead-lag feed-forward
    x_sp = sp
    x_pv = pv
    if scale_pv:
        x_sp = scale(sp, pv_lo, pv_hi, 0.0, 100.0)
        x_pv = scale(pv, pv_lo, pv_hi, 0.0, 100.0)
    if not is_valid(sp_f, big):
        sp_f = 0.0  # a memory that overflowed restarts from 0
    if not is_valid(pv_f, big):
        pv_f = 0.0
    if cold:
        sp_f = x_sp  # the first cycle starts the filters at their input
        pv_f = x_pv
    sp_f = pt1_step(a_sp, sp_f, 1.0, x_sp)
    pv_f = pt1_step(a_pv, pv_f, 1.0, x_pv)
    ramp_in = sp_f
    follow = bumpless == _TRACK_SETPOINT and mode != _AUTO
    if follow:
        ramp_in = pv_f  # in a non-auto mode the working setpoint follows the PV
    if not is_valid(sp_w, big):
        sp_w = 0.0
    if cold or follow:
        sp_w = ramp_in
    sp_w, sp_ramping = rate_limit_step(ramp_in, sp_w, sp_rate, sp_rate, h)
    ff_tot = ff
    if ff_on:
        if not is_valid(ll_out, big):
            ll_out = 0.0
            ll_x = 0.0
        ll_out = leadlag_step(dv, ll_x, ll_out, ll_b0, ll_b1, ll_a1, -big, big)
        ll_x = dv
        ff_tot = ff + ll_out
    # the transfer to AUTO and the P suppression
    from_mode = mode == _AUTO and mode_prev != _NO_MODE and mode_prev != _AUTO
    if from_mode and bumpless == _SUPPRESS_P:
        suppressed = True
    transfer = from_mode or (mode == _AUTO and reinit)
    # the PID's one law
    law_prm = (k, sgn, b, c, ad, bd, ki_h, alpha, beta, lo, hi, aw, g)
    law_opt = (velocity, dev_tol, rate_h, db, i_band)
    (mv, v_raw, limiting, p, i_k, dn, w, e, bias, suppressed, db_held) = pid_law(
        sp_w, pv_f, ff_tot, held, target, cold or reinit_d, transfer, suppressed, awin,
        db_active, db_hold, i, d, w_prev, e_prev, x, bias, p_prev, d_prev, ff_prev, out, ramp_y,
        law_prm, law_opt,
    )  # fmt: skip
    held = held or db_held
    limits_active = limiting or v_raw > hi or v_raw < lo
    i_shown = i_k
    if held:
        i_shown = mv - p - dn - ff_tot  # the I term shown: P + I + D + FF is the output
    v_ok = is_valid(v_raw, big)
    law_ok = v_ok and is_valid(dn, big) and is_valid(w, big) and is_valid(i_shown, big)
    if not v_ok:
        # the law overflowed: hold the output (or the safe value), limited
        mv = out
        if use_safe:
            mv = safe_value
        mv = clamp(mv, lo, hi)
    return (mv, err, True, law_ok, limits_active, limiting, v_raw, p, i_k, i_shown, dn, w, e,
            bias, ff_tot, suppressed, held, sp_f, pv_f, sp_w, sp_ramping, ll_out, ll_x)  # fmt: skip


def valid_or_zero(x: float, big: float) -> float:
    """``x`` if it is valid (:func:`is_valid`), else 0: a memory made finite after a failure."""
    if is_valid(x, big):
        return x
    return 0.0


_DB_TOLERANCE = 0.5
"""Tolerance of the dead band's steady-state detector (fed with 0: only its time counts)."""


def pid_update(
    u: float,
    out: float,
    ok: bool,
    mode: int,
    man_value: float,
    v_raw: float,
    p_k: float,
    i_k: float,
    d_k: float,
    w_k: float,
    e_k: float,
    ff_k: float,
    bias_k: float,
    supp_k: bool,
    held: bool,
    actuator_pos: float,
    ki_h: float,
    aw: float,
    g: float,
    velocity: float,
    db: float,
    t_stab: float,
    h: float,
    i: float,
    x: float,
    bias: float,
    d: float,
    w_prev: float,
    e_prev: float,
    p_prev: float,
    d_prev: float,
    ff_prev: float,
    suppressed: bool,
    cold: bool,
    reinit: bool,
    reinit_d: bool,
    db_active: bool,
    steady: bool,
    st_anchor: float,
    st_elapsed: float,
    st_started: bool,
    big: float,
) -> tuple[float, float, float, float, float, float, float, float, float, float, bool, bool,
           bool, bool, bool, bool, bool, bool, float, float, bool]:  # fmt: skip
    """The PID's state after a cycle of :func:`pid_compute` with the applied value ``u``.

    The commit half of every executor: the block (:meth:`PID.update_state`) and
    the exported function block (:func:`.plc_cycle.pid_cycle`, which applies its
    own output).  ``UpdateState`` of Åström 1987, Listing 6.3: outside MANUAL the
    manual value follows ``u`` (In/Out); a cycle with good inputs (``ok``)
    commits the law's values (the ``_k`` arguments, :func:`pid_compute`'s) with
    :func:`pid_commit` (the integrator's tracking of ``u``, Åström 1987, Fig. 3.6;
    with back-calculation on ``actuator_pos`` while it is valid, Fig. 3.2 A; set
    so that ``P + I + D + FF = u`` while ``held``, Fig. 4.4), the velocity form's
    output integrator, bias and last P, D, FF (controltheplant 2024, 2.3.1; Åström
    1987, Figs. 2.2-2.5), and ends the first cycle and a re-initialisation.  The
    adaptive dead band (controltheplant 2024, section 2.3.10; ``db`` > 0): the
    steady-state detector (:func:`.signals.steady_step`, controltheplant 2024,
    ``FindSteadyState``) counts the time the error stays inside the band in AUTO,
    restarting outside it; the moving average of the applied output follows
    ``u`` until the band holds the output.  The average's ring is an ARRAY,
    which a PLC FUNCTION cannot take: the caller runs it (``feed``) and, on
    ``latch``, holds the output at its mean (``db_active`` is already set).  A
    cycle with a bad input re-initialises on recovery and leaves the dead band.
    ``ki_h``, ``aw``, ``g``, ``velocity`` are those of :func:`pid_law`'s ``prm``
    and ``opt``; ``big`` the largest valid magnitude (:func:`is_valid`).

    Returns ``(man_value, i, x, bias, d, w_prev, e_prev, p_prev, d_prev,
    ff_prev, suppressed, cold, reinit, reinit_d, db_active, feed, latch, steady,
    st_anchor, st_elapsed, st_started)``.
    """
    if mode != _MANUAL:
        man_value = u  # In/Out: outside MANUAL the manual value follows the output
    feed = False
    latch = False
    if not ok:
        # bad input: nothing is known, re-initialise on recovery
        reinit = True
        reinit_d = True
        if db_active:  # leave the dead band: the recovery continues from u
            db_active = False
            steady, st_anchor, st_elapsed, st_started = steady_step(
                0.0, _DB_TOLERANCE, t_stab, h, True, st_anchor, st_elapsed, st_started
            )
    else:
        i_new, x_new = pid_commit(u, out, v_raw, p_k, i_k, d_k, ff_k, held,
                                  is_valid(actuator_pos, big), actuator_pos, ki_h, aw, g,
                                  velocity)  # fmt: skip
        if velocity != 0.0:
            x = x_new
            bias = bias_k
            if held:
                bias = i_new
            p_prev = p_k
            d_prev = d_k
            ff_prev = ff_k
        else:
            i = i_new
        d = d_k
        w_prev = w_k
        e_prev = e_k
        suppressed = supp_k
        cold = False
        reinit = False
        reinit_d = False
        if db > 0.0:
            # the detector counts the time inside the band in AUTO; the average follows the
            # applied output until the band holds it
            inside = mode == _AUTO and deadband(e_prev, db) == 0.0
            steady, st_anchor, st_elapsed, st_started = steady_step(
                0.0, _DB_TOLERANCE, t_stab, h, not inside, st_anchor, st_elapsed, st_started
            )
            if not inside:
                db_active = False
            feed = not (inside and db_active)
            latch = feed and inside and steady
            if latch:
                db_active = True
    return (man_value, i, x, bias, d, w_prev, e_prev, p_prev, d_prev, ff_prev, suppressed, cold,
            reinit, reinit_d, db_active, feed, latch, steady, st_anchor, st_elapsed,
            st_started)  # fmt: skip


def pid_restart(
    held: float,
    d: float,
    w: float,
    e: float,
    p_prev: float,
    d_prev: float,
    ff_prev: float,
    big: float,
) -> tuple[float, float, float, float, float, float, float, float, float]:
    """After a failed cycle (``BAD_RESULT``): the memory made finite, a bumpless restart.

    The block's ``_resume`` and the exported FB's law overflow: the integrator,
    the velocity form's output integrator and bias restart from the ``held``
    output (the next good cycle re-initialises from it, Åström 1987, Fig. 4.4),
    the derivative's and the error's histories and the velocity form's last P,
    D, FF keep their value if valid, else 0.  Returns ``(i, x, bias, d, w, e,
    p_prev, d_prev, ff_prev)``.
    """
    return (held, held, held, valid_or_zero(d, big), valid_or_zero(w, big),
            valid_or_zero(e, big), valid_or_zero(p_prev, big), valid_or_zero(d_prev, big),
            valid_or_zero(ff_prev, big))  # fmt: skip


# ---------------------------------------------------------------------------
# Configuration
# ---------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class PIDConfig(BlockConfig):
    """Configuration of :class:`PID` (controltheplant 2024, ``typePIDSettings`` and more).

    Units: "%" means percent of the PV range when ``pv_range`` is given
    (controltheplant 2024 scaling), otherwise the engineering units of SP/PV.  The output is in
    % (or in the user's units without scaling).

    Attributes
    ----------
    kp : float
        Gain [%/%], > 0 (controltheplant 2024: "must be positive"; use ``reverse`` for a
        negative action).  Meaning per ``form`` (see :mod:`.pid_forms`).
    ti : float
        Integral time [s] (``form="parallel"``: 1/ki [s]); 0 = no integral action.
    td : float
        Derivative time [s] (``form="parallel"``: kd [s]); 0 = no derivative.
    n : float
        Derivative filter: ``Tf = Td/n`` (Bonde et al. 2021, ``n``, Åström 1987, ``N``), > 0.
    b, c : float
        Setpoint weights of P (Åström 1987, (2.2)) and D (``c = 0``: derivative on PV).
    ts : float
        Sample time [s] > 0.
    u_min, u_max : float
        Output limits [%] (controltheplant 2024, ``irOutLimitL/H``); infinite = no limit.
    integral_method, derivative_method : str
        ``"forward"``, ``"backward"`` or ``"tustin"`` (module docstring).
    form : str
        ``"isa"`` (default), ``"parallel"`` (independent gains) or ``"series"``.
    algorithm : str
        ``"positional"`` (default) or ``"velocity"`` (incremental, controltheplant 2024).
    reverse : bool
        Reverse action: the output falls when PV rises (controltheplant 2024, ``ixInverted``).
    pv_range : tuple of float or None
        ``(lo, hi)`` of SP and PV [eng. units] scaled to 0..100 % (controltheplant 2024
        ``rangeLo/rangeHi``); None = no scaling.
    sp_filter, pv_filter : float
        PT1 time constants of the SP and PV filters [s]; 0 = off.
    sp_rate : float
        Setpoint ramp [%/s], >= 0; 0 = off.
    out_rate : float
        Output ramp [%/s], >= 0; 0 = off.  Active in every mode
        (controltheplant 2024, section 2.3.8).
    anti_windup : str
        One of :class:`AntiWindup`.
    tt : float or None
        Tracking / back-calculation time constant [s] > 0 (controltheplant 2024
        ``irBackCalcFactor``, Åström 1987, ``Tt``).  None: ``ti_isa/5`` (Åström 1987
        Fig. 3.9 uses ``Tt = Ti/5``), or ``ts`` without integral action.
    bumpless : str
        One of :class:`Bumpless`.
    dev_tol : float
        Deviation tolerance [%] in (0, 50] for SUPPRESS_P_ACTION (controltheplant 2024
        ``irDeviationTolerance``).
    deadband : float
        Adaptive dead band half-width [%] (controltheplant 2024, section 2.3.10); 0 = off; negative
        acts as its absolute value.
    t_stab : float
        Stabilisation time [s] > 0 of the adaptive dead band.
    reset_value : float
        Output (and integrator) value while ``reset_active`` (controltheplant 2024
        ``irResetValue``); also the initial output.
    safe_value : float or None
        Output while SP/PV/FF are not finite; None = hold the last output.
    ff_k, ff_t_lead, ff_t_lag : float
        Lead-lag feed-forward ``ff_k (1 + ff_t_lead s)/(1 + ff_t_lag s)`` on the
        ``dv`` input (Bonde et al. 2021 version 4, Tustin); ``ff_k = 0`` = off.
    precision : str
        ``"float64"`` (default) or ``"float32"``: compute the cycle as a PLC's
        REAL does, every intermediate rounded to single precision (the cycle
        of :mod:`.plc_cycle`, which :mod:`ctrlblocks.plc` exports); only for
        the configurations the export covers.
    i_band : float
        Integral band [%], >= 0: the error is integrated only while ``|e| <=
        i_band`` (conditional integration, Åström & Hägglund 2006, section 3.5:
        no integral build-up during a large setpoint change or upset, so less
        overshoot after it); 0 (default) = always.  The anti-windup tracking
        and the bumpless transfers act as without it.
    tdf : float or None
        The derivative filter as an absolute time [s] > 0 (controltheplant 2024,
        ``irTdF``, default there 0.5 s): given, it sets ``n = Td/tdf`` (ISA ``Td``)
        and ``n`` is ignored; None (default): ``n`` as given.  Without derivative
        action it has no effect.
    """

    kp: float = 1.0
    ti: float = 0.0
    td: float = 0.0
    n: float = 10.0
    b: float = 1.0
    c: float = 0.0
    ts: float = 0.1
    u_min: float = 0.0
    u_max: float = 100.0
    integral_method: str = "tustin"
    derivative_method: str = "backward"
    form: str = "isa"
    algorithm: str = "positional"
    reverse: bool = False
    pv_range: tuple[float, float] | None = None
    sp_filter: float = 0.0
    pv_filter: float = 0.0
    sp_rate: float = 0.0
    out_rate: float = 0.0
    anti_windup: str = AntiWindup.CLAMPING
    tt: float | None = None
    bumpless: str = Bumpless.INTEGRATOR
    dev_tol: float = 1.0
    deadband: float = 0.0
    t_stab: float = 2.0
    reset_value: float = 0.0
    safe_value: float | None = None
    ff_k: float = 0.0
    ff_t_lead: float = 0.0
    ff_t_lag: float = 1.0
    precision: str = "float64"
    i_band: float = 0.0
    tdf: float | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        # the derivative filter as an absolute time (controltheplant 2024, irTdF): n = Td/tdf
        tdf = self.tdf
        if isinstance(tdf, float) and math.isfinite(tdf) and tdf > 0.0:
            try:
                td = self.isa()[2]
            except (ArithmeticError, ValueError, TypeError):
                return  # validate refuses the gains
            if isinstance(td, float) and math.isfinite(td) and td > 0.0:
                object.__setattr__(self, "n", td / tdf)

    def isa(self) -> tuple[float, float, float]:
        """The ISA parameters ``(K, Ti, Td)`` of this configuration."""
        return isa_parameters(self.form, self.kp, self.ti, self.td)

    def validate(self) -> None:
        if self.tdf is not None:
            require_positive("tdf", self.tdf, ErrorCode.BAD_TIME_CONSTANT)
        kp = self._validate_gains()
        ts = require_positive("ts", self.ts, ErrorCode.NO_CYCLE)
        require_limits("u_min", self.u_min, "u_max", self.u_max)
        require_choice("integral_method", self.integral_method, METHODS)
        require_choice("derivative_method", self.derivative_method, METHODS)
        require_choice("algorithm", self.algorithm, ("positional", "velocity"))
        require_bool("reverse", self.reverse)
        require_range("pv_range", self.pv_range)
        require_nonnegative("sp_filter", self.sp_filter, ErrorCode.BAD_TIME_CONSTANT)
        require_nonnegative("pv_filter", self.pv_filter, ErrorCode.BAD_TIME_CONSTANT)
        require_nonnegative("sp_rate", self.sp_rate, ErrorCode.BAD_RATE)
        require_nonnegative("out_rate", self.out_rate, ErrorCode.BAD_RATE)
        require_choice("anti_windup", self.anti_windup, AntiWindup.ALL, ErrorCode.BAD_ANTIWINDUP)
        self._validate_tt()
        require_choice("bumpless", self.bumpless, Bumpless.ALL)
        if self.bumpless == Bumpless.TRACK_SETPOINT and self.sp_rate == 0.0:
            raise ParameterError(
                ErrorCode.CANT_TRACK_SETP,
                "sp_rate",
                "bumpless TRACK_SETPOINT needs a setpoint ramp sp_rate > 0 (controltheplant 2024)",
            )
        tol = require_finite("dev_tol", self.dev_tol, ErrorCode.BAD_DEV_TOL)
        if not 0.0 <= tol <= 50.0 or (self.bumpless == Bumpless.SUPPRESS_P_ACTION and tol == 0):
            raise ParameterError(
                ErrorCode.BAD_DEV_TOL,
                "dev_tol",
                f"deviation tolerance must lie in 0..50 % (> 0 for SUPPRESS_P_ACTION); "
                f"got {self.dev_tol!r}",
            )
        require_finite("deadband", self.deadband)
        require_nonnegative("i_band", self.i_band, ErrorCode.BAD_PARAMETER)
        t_stab = require_positive("t_stab", self.t_stab, ErrorCode.BAD_STAB_TIME)
        if t_stab / ts > MAX_WINDOW:
            raise ParameterError(
                ErrorCode.BAD_STAB_TIME,
                "t_stab",
                f"t_stab/ts = {t_stab / ts:.3g} samples exceeds the longest moving-average "
                f"window ({MAX_WINDOW})",
            )
        require_finite("reset_value", self.reset_value)
        if self.safe_value is not None:
            require_finite("safe_value", self.safe_value)
        require_finite("ff_k", self.ff_k)
        LeadLagConfig(k=1.0, t_lead=self.ff_t_lead, t_lag=self.ff_t_lag, ts=ts).validate()
        self._validate_derivative(kp, ts)
        if self.precision != "float64":
            _check_precision(self, "pid")

    def validate_tuning(self) -> None:
        """The checks of :meth:`validate` that read a tuning field (:data:`TUNING_FIELDS`).

        Enough for a configuration made from a valid one by changing tuning
        fields only: every other check reads fields that did not change.
        """
        kp = self._validate_gains()
        self._validate_tt()
        self._validate_derivative(kp, float(self.ts))

    def _validate_gains(self) -> float:
        coeffs = ErrorCode.BAD_PID_COEFFS
        require_choice("form", self.form, FORMS)
        kp = require_positive("kp", self.kp, coeffs)
        require_nonnegative("ti", self.ti, coeffs)
        require_nonnegative("td", self.td, coeffs)
        require_positive("n", self.n, coeffs)
        require_finite("b", self.b, coeffs)
        require_finite("c", self.c, coeffs)
        return kp

    def _validate_tt(self) -> None:
        if self.tt is not None:
            require_positive("tt", self.tt, ErrorCode.BACK_CALC_T)

    def _validate_derivative(self, kp: float, ts: float) -> None:
        _k, _ti, td = isa_parameters(self.form, kp, self.ti, self.td)
        if self.derivative_method == "forward" and td > 0.0 and td / self.n <= ts / 2.0:
            raise ParameterError(
                ErrorCode.BAD_PID_COEFFS,
                "td",
                f"forward-difference derivative (Åström 1987, (2.10)) is unstable for "
                f"Td/N <= ts/2 (Td={td!r}, N={self.n!r}, ts={ts!r}); use 'backward'",
            )


TUNING_FIELDS = frozenset(("kp", "ti", "td", "n", "b", "c", "tt"))
"""The PID's tuning fields: a change of only these retunes the law without touching
its filters, ramps and limits (:meth:`PID.configure`)."""


# ---------------------------------------------------------------------------
# The block
# ---------------------------------------------------------------------------


def _law(c: PIDConfig) -> tuple[Any, ...]:
    """The parameters whose change would make the positional output jump."""
    return (c.isa(), c.n, c.b, c.c, c.reverse, c.pv_range, c.algorithm)


_SUB_COMPUTE = ("_sp_filter", "_pv_filter", "_sp_ramp", "_ll")
"""The sub-blocks whose states ``compute_output``'s input stage (:func:`pid_compute`) reads;
the states it reaches travel in the pending cycle (the output ramp's is a value of the law,
:func:`pid_output`)."""

_SKIP, _BAD, _LAW = 0, 1, 2
_MODES = tuple(sorted(Mode))  # Mode by its value


class _Cycle(NamedTuple):
    """One PID cycle computed by ``compute_output``, committed by ``update_state``.

    The pending value of the two-phase contract (:mod:`.base`): everything the
    second phase needs, nothing stored on the block in between.  The lean
    cycle (:meth:`PID.compute_output` in plain auto operation) is pending as
    ``PID._pending is True`` with its values in ``PID._lean_cycle``
    (:data:`_LEAN_FIELDS`; in the compiled build a C struct); what it does not
    cover turns it into this tuple first (:meth:`PID._full_cycle`).
    """

    kind: int  # _SKIP bad dt (nothing to commit), _BAD bad input, _LAW the law ran
    out_prev: float  # the committed output this cycle started from [%]
    mode: Mode
    h: float  # this cycle's sample time [s]
    subs: tuple[tuple[Any, ...], ...] = ()  # states of _SUB_COMPUTE after the cycle
    e: float = 0.0  # control deviation [%]
    w: float = 0.0  # c r - y of the derivative [%]
    d: float = 0.0  # D term [%]
    p: float = 0.0  # P term as used (0 while suppressed) [%]
    ff: float = 0.0  # feed-forward [%]
    i: float = 0.0  # integrator before tracking (velocity form: the I term) [%]
    v_raw: float = 0.0  # output before the limits [%]
    bias: float = 0.0  # velocity form: bias of the reset feedback [%]
    suppressed: bool = False  # P action suppressed (SUPPRESS_P_ACTION)
    held: bool = False  # a mode other than AUTO, or the adaptive dead band, held the output
    ramp: float = 0.0  # the output ramp's state to commit [%]
    limiting: bool = False  # the output ramp set the output


_LEAN_FIELDS = ("out_prev", "sp_prev", "pv_prev", "sp", "pv", "e", "w", "d", "p", "ff", "i",
                "v_raw", "out")  # fmt: skip
"""``PID._lean_cycle``, the lean pending cycle: the committed output, working setpoint and
PV it started from (``out``, ``sp_w``, ``pv_f`` until the commit), its inputs, and the
values of :class:`_Cycle` that :func:`pid_commit` reads."""


@functools.cache
def _state_setter(names: tuple[str, ...]) -> Callable[[Any, tuple[Any, ...]], None]:
    """``put(block, values)``: one assignment of ``values`` to the attributes ``names``.

    Generated once per tuple of names, as :mod:`dataclasses` generates its
    methods: an unpacking assignment is several times cheaper than a loop of
    ``setattr`` (the two-phase cycle puts states back every sample).
    """
    if not all(n.isidentifier() for n in names):
        raise ValueError(f"not attribute names: {names!r}")
    namespace: dict[str, Any] = {}
    targets = ", ".join(f"b.{n}" for n in names)
    exec(f"def put(b, v):\n    {targets}, = v\n", namespace)  # names checked above
    return namespace["put"]


class _SubStates:
    """Takes and puts back the state (fields and status) of the sub-blocks a cycle calls.

    :meth:`take` gives plain tuples, :meth:`put` writes such tuples back.
    """

    __slots__ = ("_subs",)

    def __init__(self, subs: tuple[Block, ...]) -> None:
        names = [(*b._state_fields, "error_id") for b in subs]
        self._subs = tuple(
            (b, operator.attrgetter(*n), _state_setter(n)) for b, n in zip(subs, names, strict=True)
        )

    def take(self) -> tuple[tuple[Any, ...], ...]:
        """The states now."""
        return tuple([get(b) for b, get, _put in self._subs])

    def put(self, states: tuple[tuple[Any, ...], ...]) -> None:
        """Put back states from :meth:`take`."""
        for (b, _get, put), st in zip(self._subs, states, strict=True):
            put(b, st)


class PID(Block):
    """Industrial PID block (controltheplant 2024; Bonde et al. 2021; Åström 1987).

    See the module docstring for the law.

    One cycle: ``u = pid(sp, pv)`` (optionally ``ff=`` feed-forward/offset [%],
    ``dv=`` input of the lead-lag feed-forward path, ``dt=`` measured sample
    time [s]).  Two-phase form (Åström 1987, section 6, Listing 6.3)::

        v = pid.compute_output(sp, pv)   # ComputeOutput (no state committed)
        u = shape(v)                     # ShapeOutput: selector, saturation, ...
        pid.update_state(u)              # UpdateState with the applied value

    Inputs as attributes (controltheplant 2024): ``manual``, ``manual_value`` (In/Out:
    follows the applied output when not in manual), ``track``,
    ``track_value``, ``hold``, ``reset_active`` (controltheplant 2024, ``reset``),
    ``actuator_pos`` (for BACK_CALC_REAL), ``awin`` (freeze the integrator,
    cascade).  Priority: RESET > TRACK > HOLD > MANUAL > AUTO (:class:`Mode`).

    Readable: ``out``, ``p``, ``i``, ``d``, ``ff`` (terms of the last cycle),
    ``mode``, ``limits_active`` (= ``awout``), ``error``, ``error_id``,
    ``sp_w`` (working setpoint after filter/ramp, %), ``pv_f`` (filtered PV,
    %), ``e`` (control deviation, %), ``deadband_active``, ``p_suppressed``.

    Never raises on process data: NaN/inf ``sp``/``pv``/``ff``/``dv`` hold the
    last output (or ``safe_value``), set ``BAD_INPUT`` and recover without a
    bump; a bad ``dt`` holds the output and sets ``NO_CYCLE``.

    Examples
    --------
    >>> pid = PID(kp=2.0, ti=1.0, ts=0.1, u_min=-10.0, u_max=10.0)
    >>> pid(1.0, 0.0)  # P = K (b r - y) = 2; the first cycle adds no integral
    2.0
    >>> round(pid(1.0, 0.0), 12)  # trapezoid: + K h/(2 Ti) (e[k] + e[k-1]) = 0.2
    2.2
    >>> pid(float("nan"), 0.0), pid.error_name  # bad SP: output held
    (2.2, 'BAD_INPUT')
    """

    Config = PIDConfig
    _guarded_steps = ()
    # the attributes the compiled build keeps in the C struct (pid.pxd), which
    # configure's rollback saves by name; tests/blocks/test_compiled.py keeps both in step
    _declared = (
        "error_id _config manual track hold reset_active awin manual_value _lean _mode_prev "
        "_cold _reinit _pending _prm _lean_cycle _two_phase_lean limits_active _limits_status "
        "_lean_ran _law_in_force "
        "deadband_active p_suppressed out _h _ts _i _d _w_prev _e_prev p i d e sp_w pv_f ff "
        "_lo _hi _x _bias _ff_prev"
    )

    @property
    def config(self) -> PIDConfig:
        """The configuration in force (:meth:`Block.config`)."""
        return self._config

    _config: PIDConfig
    _law_in_force: tuple[Any, ...]
    # state read by the retune (_carry_over) before _reset_state assigns it
    _cold: bool
    _reinit: bool
    _mode_prev: int
    deadband_active: bool
    p_suppressed: bool
    _i: float
    _d: float
    _x: float
    _bias: float
    _ff_prev: float
    _state_fields = (
        "out",
        "p",
        "i",
        "d",
        "ff",
        "e",
        "sp_w",
        "pv_f",
        "limits_active",
        "manual_value",
        "deadband_active",
        "p_suppressed",
        "_i",
        "_d",
        "_x",
        "_bias",
        "_w_prev",
        "_e_prev",
        "_p_prev",
        "_d_prev",
        "_ff_prev",
        "_mode_prev",
        "_cold",
        "_reinit",
        "_reinit_d",
        "_db_hold",
        "_limits_status",
        "_plc_state",
    )

    def __init__(self, config: PIDConfig | None = None, /, **params: Any) -> None:
        # mode inputs (controltheplant 2024); not part of the state, reset() leaves them
        self.manual = False
        self.track = False
        self.track_value = 0.0
        self.hold = False
        self.reset_active = False
        self.actuator_pos = math.nan
        self.awin = False
        # filters, ramps, lead-lag, detector by name (several block classes, used by name)
        self._subs: dict[str, Any] = {}
        self._pending: _Cycle | Literal[True] | None = None
        self._lean_cycle = (0.0,) * len(_LEAN_FIELDS)
        # compute_output's lean cycle (False: always the general one; a switch for the tests
        # that compare the two, tests/blocks/test_pid_two_phase_lean.py)
        self._two_phase_lean = True
        super().__init__(config, **params)

    # -- configuration ---------------------------------------------------------

    def _apply_config(self, old: BlockConfig | None) -> None:
        if old is not None:
            if self._pending is True:  # the commit will see the new configuration
                self._full_cycle()
            self._sync_subs()
        c = self._config
        self._imeth = METHODS.index(c.integral_method)
        self._dmeth = METHODS.index(c.derivative_method)
        self._alpha, self._beta = integral_weights(self._imeth)
        self._lo, self._hi = block_limits(float(c.u_min), float(c.u_max), c.precision)
        self._sgn = -1.0 if c.reverse else 1.0
        self._velocity = c.algorithm == "velocity"
        self._range = (float(c.pv_range[0]), float(c.pv_range[1])) if c.pv_range else None
        self._db = abs(float(c.deadband))
        self._ts = ts = float(c.ts)
        self._safe = float(c.safe_value) if c.safe_value is not None else 0.0
        self._set_tuning(c)
        # the per-call fast lane runs pid_step: the configurations of the compiled kernels
        self._lean = not (_unsupported(c, "pid") or self._option_blockers())
        self._sync("_sp_filter", PT1, t=c.sp_filter, ts=ts)
        self._sync("_pv_filter", PT1, t=c.pv_filter, ts=ts)
        self._sync("_sp_ramp", RateLimiter, rate_up=c.sp_rate, rate_down=c.sp_rate, ts=ts)
        self._sync("_out_ramp", RateLimiter, rate_up=c.out_rate, rate_down=c.out_rate, ts=ts)
        self._sync("_ll", LeadLag, k=c.ff_k, t_lead=c.ff_t_lead, t_lag=c.ff_t_lag, ts=ts)
        self._sync("_det", SteadyStateDetector, tolerance=0.5, t_stab=c.t_stab, ts=ts)
        window = max(1, round(c.t_stab / ts))
        self._sync("_ma", MovingAverage, n=window)
        if old is None:  # the sub-blocks are made once; configure re-parameterises them
            self._cycle_subs = _SubStates(tuple(self._subs[name] for name in _SUB_COMPUTE))
        self._relaw(old)  # type: ignore[arg-type]

    def _relaw(self, old: PIDConfig | None) -> None:
        """Note the law in force; a change of it from ``old`` is bumpless (:meth:`_carry_over`)."""
        law = _law(self._config)
        if old is not None and law != self._law_in_force and not self._carry_over(old):
            self._reinit = True  # the next cycle continues from the output, without a bump
        self._law_in_force = law

    def _carry_over(self, old: PIDConfig) -> bool:
        """Bumpless retuning at the instant of the change (:func:`retune_states`).

        In auto, with a committed last cycle, the integrator (velocity form:
        the increments' starting point and the bias) is moved so that the new
        law gives the last output on the last cycle's signals; the next cycle
        then runs the new law in full.  Returns False where that is not
        possible -- the last cycle was not in auto, a two-phase cycle is
        pending, a re-initialisation is pending anyway, the adaptive dead band
        holds the output, or the scaling or the algorithm changed (the
        signals of the last cycle are in other units) -- and the caller
        re-initialises instead: the next cycle continues from the output.
        """
        if self._cold:
            return True  # no history: the next cycle starts afresh
        c = self._config
        if (
            self._mode_prev != Mode.AUTO
            or self._reinit
            or self._pending is not None
            or self.deadband_active
            or old.pv_range != c.pv_range
            or old.algorithm != c.algorithm
        ):
            return False
        k_old, ti_old, _td_old = old.isa()
        ki_old = k_old / ti_old if ti_old > 0.0 else 0.0
        states = retune_states(
            self.sp_w, self.pv_f, self.p, self._d, self._i, self._bias, self._x, self._ff_prev,
            self._k, self._sgn, float(c.b), float(c.c), self._kd, self._ki, ki_old,
            self._velocity, self.p_suppressed,
        )  # fmt: skip
        if not all(_NINF < v < _INF for v in states):
            return False  # a gain so large that the shift overflows: hold one cycle instead
        i, bias, p_new, d_new, self._w_prev, self._e_prev = states
        self._d = d_new
        if self._velocity:
            self._bias, self._p_prev, self._d_prev = bias, p_new, d_new
        else:
            self._i = i
        return True

    def _set_tuning(self, c: PIDConfig) -> None:
        """The law's gains from the tuning fields of ``c``, at the sample time ``ts``.

        Refuses coefficients that are not finite (``BAD_PID_COEFFS``) before it
        changes anything.
        """
        k, ti, td = c.isa()
        ki = k / ti if ti > 0.0 else 0.0
        kd = k * td
        tf = td / c.n
        tt = tracking_time(float(c.tt) if c.tt is not None else 0.0, ti, float(c.ts))
        ts = self._ts
        try:
            ad, bd = derivative_coefficients(kd, tf, ts, self._dmeth)
        except ArithmeticError:  # a gain that overflowed (kd NaN, Tf 0): refused just below
            ad = bd = math.nan
        require_coefficients(
            "kp/ti/td/n", ErrorCode.BAD_PID_COEFFS, k, ki, kd, tf, ad, bd, ki * ts, tt
        )
        self._k, self._ti, self._td = k, ti, td
        self._ki, self._kd, self._tf, self._tt = ki, kd, tf, tt
        self._set_h(ts)

    def _sync(self, name: str, cls: type[Block], **params: Any) -> None:
        sub = self._subs.get(name)
        if sub is None:
            self._subs[name] = cls(**params)
        elif any(getattr(sub.config, k) != v for k, v in params.items()):
            sub.configure(**params)

    def _set_h(self, h: float) -> None:
        """The law's parameters (:func:`pid_parameters`) and options at the sample time ``h``."""
        self._h = h
        c = self._config
        aw = float(AntiWindup.ALL.index(c.anti_windup))
        self._prm = pid_parameters(
            self._k, self._ti, self._td, float(c.n), float(c.b), float(c.c), h, self._lo,
            self._hi, c.reverse, self._dmeth, self._imeth, aw, self._tt,
        )  # fmt: skip
        self._opt = (1.0 if self._velocity else 0.0, float(c.dev_tol), c.out_rate * h, self._db,
                     float(c.i_band))  # fmt: skip
        # the input stage's coefficients at h (pid_compute): the filters' poles, the lead-lag's
        ff_on = c.ff_k != 0.0
        ll = leadlag_coefficients(c.ff_k, c.ff_t_lead, c.ff_t_lag, h, True) if ff_on else (0.0,) * 3
        rng = self._range if self._range is not None else (0.0, 100.0)
        self._stage = (self._range is not None, rng[0], rng[1],
                       pt1_coefficient(float(c.sp_filter), h, "exact"),
                       pt1_coefficient(float(c.pv_filter), h, "exact"), float(c.sp_rate), ff_on,
                       *ll, Bumpless.ALL.index(c.bumpless))  # fmt: skip

    def configure(self, **changes: Any) -> None:
        """As :meth:`Block.configure`; a valid new ``u_min``/``u_max`` clears ``BAD_LIMITS``.

        A change of tuning fields only (:data:`TUNING_FIELDS`, e.g. a gain
        schedule retuning every cycle) takes a shorter path with the same
        result: the checks that read those fields
        (:meth:`PIDConfig.validate_tuning`), the gains derived from them and
        the bumpless re-initialisation; the filters, ramps and limits, which
        do not depend on them, stay as they are.
        """
        if changes and TUNING_FIELDS.issuperset(changes) and self._config.precision == "float64":
            self._retune(changes)
            return
        super().configure(**changes)
        if "u_min" in changes or "u_max" in changes:
            self._limits_status = ErrorCode.NO_ERROR
            if self.error_id == ErrorCode.BAD_LIMITS:
                self.error_id = ErrorCode.NO_ERROR

    def _retune(self, changes: dict[str, Any]) -> None:
        """:meth:`configure` for tuning fields only (its docstring)."""
        old = self._config
        new: PIDConfig = self._replace_config(old, changes)  # type: ignore[assignment]
        new.validate_tuning()
        self._config = new
        try:
            self._set_tuning(new)
        except Exception:
            self._config = old
            raise
        if self._pending is True:  # the re-initialisation of _relaw is the general commit's
            self._full_cycle()
        self._sync_subs()
        self._relaw(old)

    def output_limits(self) -> tuple[float, float]:
        """``(u_min, u_max)`` in force."""
        return self._lo, self._hi

    def _fallback(self, prev: float) -> float:
        """When the law fails: ``safe_value`` if configured, else the last valid output."""
        sv = self._config.safe_value
        return prev if sv is None else float(sv)

    def _resume(self, held: float) -> None:
        """After a failed cycle (``BAD_RESULT``): finite memory, bumpless restart from ``held``.

        The cycle counts as one with bad inputs: the next good cycle re-initialises
        the integrator (and the velocity form's output integrator) so that the
        output continues from ``held``; filters and ramps whose state overflowed
        restart on the next sample.  A failed two-phase cycle (the guard of
        ``compute_output``) keeps the derivative's memory and the deviation it
        computed (``w``, ``e``, D), as a failed fast-lane cycle, which committed
        them before the guard ran (:func:`pid_step`).
        """
        cycle = self._pending
        if cycle is True:
            cycle = self._full_cycle()
        if cycle is not None and cycle.kind == _LAW:
            self._d, self._w_prev, self._e_prev = cycle.d, cycle.w, cycle.e
        for name in ("p", "i", "d", "ff", "e", "sp_w", "pv_f"):  # the terms shown
            if not _NINF < getattr(self, name) < _INF:
                setattr(self, name, 0.0)
        (self._i, self._x, self._bias, self._d, self._w_prev, self._e_prev, self._p_prev,
         self._d_prev, self._ff_prev) = pid_restart(
            held, self._d, self._w_prev, self._e_prev, self._p_prev, self._d_prev, self._ff_prev,
            _BIG,
        )  # fmt: skip
        self._db_hold = held
        self.deadband_active = False
        subs = self._cycle_subs
        if cycle is not None:  # repair the states the pending cycle would commit
            committed = subs.take()
            subs.put(cycle.subs)
        for sub in self._subs.values():
            if not _NINF < sub.out < _INF:
                sub.reset()
        self._subs["_out_ramp"].preset(held)
        if cycle is not None:
            # update_state: nothing is known, re-initialise on recovery
            self._pending = cycle._replace(kind=_BAD, subs=subs.take(), ramp=held,
                                           limiting=False)  # fmt: skip
            subs.put(committed)
        self.limits_active = False
        if not self.manual:
            self.manual_value = held
        self._reinit = self._reinit_d = True
        self._plc_state = None  # the float32 cycle restarts too

    def _relimit(self) -> None:
        """Limit ``out`` to the limits now in force, and the output ramp with it.

        The ramp's state is the output (:func:`pid_output` ramps the limited law);
        left at the old output it would hold the next cycles back (or, on the
        first good cycle after bad data, ramp away from the held output: a
        bump).  A pending two-phase cycle's ramp state is limited as well.
        """
        before = self.out
        super()._relimit()
        if self.out == before:
            return
        self._subs["_out_ramp"].preset(self.out)
        cycle = self._pending
        if cycle is True:
            cycle = self._full_cycle()
        if cycle is not None:  # the state update_state will commit
            self._pending = cycle._replace(ramp=self.out, limiting=False)

    def set_limits(self, u_min: float, u_max: float) -> None:
        """Change the output limits at run time; never raises.

        A reversed or NaN pair sets the status ``BAD_LIMITS`` (16#8201) and the
        last valid limits stay in force until a valid pair is written.
        """
        try:
            self.configure(u_min=u_min, u_max=u_max)
        except (ParameterError, TypeError):
            self._limits_status = ErrorCode.BAD_LIMITS
            self.error_id = ErrorCode.BAD_LIMITS
            return
        self._limits_status = ErrorCode.NO_ERROR

    @property
    def u_min(self) -> float:
        """Output low limit in force [%]."""
        return self._lo

    @property
    def u_max(self) -> float:
        """Output high limit in force [%]."""
        return self._hi

    # -- state -----------------------------------------------------------------

    def _reset_state(self) -> None:
        c = self._config
        self._lean_ran = False
        for sub in self._subs.values():
            sub.reset()
        u0 = clamp(float(c.reset_value), self._lo, self._hi)
        self._subs["_out_ramp"].preset(u0)
        self.out = u0
        self.p = self.d = self.ff = self.e = 0.0
        self.i = float(c.reset_value)
        self.sp_w = self.pv_f = 0.0
        self.limits_active = False
        self.manual_value = u0
        self.deadband_active = False
        self.p_suppressed = False
        self._i = float(c.reset_value)
        self._x = u0
        self._bias = float(c.reset_value)
        self._d = 0.0
        self._w_prev = self._e_prev = self._p_prev = self._d_prev = self._ff_prev = 0.0
        self._mode_prev = -1
        self._cold = True
        self._reinit = False
        self._reinit_d = False
        self._db_hold = u0
        self._limits_status = ErrorCode.NO_ERROR
        self._pending = None
        self._plc_state = None  # the precision="float32" cycle starts afresh

    def _sync_subs(self) -> None:
        """Bring the (inactive) filters and ramps up to date after fast-lane cycles.

        The fast lane (:func:`pid_step`) does not call the sub-blocks, which
        are pass-throughs in the configurations it serves; their outputs are
        set here to what those calls would have left, before a snapshot or a
        reconfiguration that may switch them on.  While a lean two-phase cycle
        is pending, the committed values are those it started from.
        """
        if not self._lean_ran:
            return
        sp_w, pv_f, out = self.sp_w, self.pv_f, self.out
        if self._pending is True:  # (indexed: in the build a C struct, not made a tuple)
            out, sp_w, pv_f = self._lean_cycle[0], self._lean_cycle[1], self._lean_cycle[2]
        subs = self._subs
        subs["_sp_filter"].out = subs["_sp_ramp"].out = sp_w
        subs["_pv_filter"].out = pv_f
        subs["_out_ramp"].out = out
        for name in ("_sp_filter", "_pv_filter", "_sp_ramp", "_out_ramp"):
            subs[name].error_id = ErrorCode.NO_ERROR
        subs["_sp_ramp"].limiting = subs["_out_ramp"].limiting = False
        self._lean_ran = False

    def snapshot(self, *, copy: bool = True) -> dict[str, Any]:
        self._sync_subs()
        snap = super().snapshot(copy=copy)
        snap["_subs"] = {name: sub.snapshot(copy=copy) for name, sub in self._subs.items()}
        return snap

    def restore(self, snapshot: dict[str, Any]) -> None:
        self._lean_ran = False
        super().restore(snapshot)
        for name, sub_snap in snapshot.get("_subs", {}).items():
            self._subs[name].restore(sub_snap)
        self._pending = None

    # -- status ----------------------------------------------------------------

    @property
    def mode(self) -> Mode:
        """The active mode from the inputs, by the priority of :class:`Mode` (:func:`pid_mode`)."""
        return _MODES[pid_mode(self.reset_active, self.track, self.hold, self.manual)]

    @property
    def awout(self) -> bool:
        """Anti-windup signal for a primary controller in cascade (= ``limits_active``)."""
        return self.limits_active

    @property
    def tt(self) -> float:
        """Tracking time constant in force [s] (``config.tt`` or its default)."""
        return self._tt

    # -- the cycle -------------------------------------------------------------

    def __call__(
        self,
        sp: float,
        pv: float,
        *,
        ff: float = 0.0,
        dv: float = 0.0,
        dt: float | None = None,
        pv_ok: bool = True,
    ) -> float:
        """Run one cycle: :meth:`compute_output`, then :meth:`update_state` with its own output.

        Fast lane: in plain auto operation (no filters, ramps, scaling, dead
        band, lead-lag, velocity form; finite inputs; ``ts`` sample time) the
        cycle is :func:`pid_step`'s (:func:`pid_law`, then :func:`pid_commit`
        with the block's own output), which gives exactly the same result as
        the two phases.
        """
        # the output guard (Block._checked) around the body, with the inputs converted
        # first: the compiled build's _call takes C doubles (docs/performance.md)
        if type(sp) is not float:
            sp = as_input(sp)
        if type(pv) is not float:
            pv = as_input(pv)
        if type(ff) is not float:
            ff = as_input(ff)
        if type(dv) is not float:
            dv = as_input(dv)
        prev = self.out
        v = self._call(sp, pv, ff, dv, dt, pv_ok)
        u = self.out
        if self._lo <= u <= self._hi and _NINF < u < _INF:
            return v  # the guard's test inline: no call on the usual path
        return self._checked(prev, v)

    def _plain_auto(self, dt: float | None, pv_ok: Any, dv: float) -> bool:
        """Whether this cycle is plain auto operation, the one test of both lean paths.

        The per-call fast lane (:meth:`_call`) and the lean two-phase cycle
        (:meth:`_compute_output`) run the law with the kernels' options and no
        sub-block only when this holds (besides finite inputs and no pending
        cycle of the other kind): the lean configuration, the sample time
        ``ts``, a good PV, no lead-lag input, the last cycle in auto, no first
        cycle or re-initialisation, no mode input, and the P action not
        suppressed -- a flag of state that outlives a change of ``bumpless``.
        """
        return (
            self._lean
            and dt is None
            and pv_ok is True
            and dv == 0.0
            and self._mode_prev == 0
            and not (self._cold or self._reinit or self.p_suppressed)
            and self._h == self._ts
            and not (self.manual or self.track or self.hold or self.reset_active or self.awin)
        )

    def _call(
        self, sp: float, pv: float, ff: float, dv: float, dt: float | None, pv_ok: bool
    ) -> float:
        """The body of :meth:`__call__` (inputs converted, output not yet checked)."""
        if (
            self._pending is None
            and self._plain_auto(dt, pv_ok, dv)
            # finite inputs: a finite sum has no infinite or NaN term (one that overflows
            # takes the general path, which gives the same result)
            and _NINF < sp + pv + ff < _INF
        ):
            # pid_step's auto cycle, its two calls made here (one frame and one tuple less):
            # the law, then its commit with the block's own output applied
            prm = self._prm
            out_prev = self.out
            out, v_raw, _lim, p, i_k, d, self._w_prev, e, _bias, _sup, _dbh = pid_law(
                sp, pv, ff, False, 0.0, False, False, False, False, False, 0.0, self._i,
                self._d, self._w_prev, self._e_prev, 0.0, 0.0, 0.0, 0.0, 0.0, out_prev,
                out_prev, prm, NO_OPTIONS,
            )  # fmt: skip
            self._i, _x = pid_commit(out, out, v_raw, p, i_k, d, ff, False, False, 0.0, prm[6],
                                     prm[11], prm[12], 0.0)  # fmt: skip
            self.p, self.i = p, i_k
            self.d = self._d = d
            self.e = self._e_prev = e
            self.sp_w, self.pv_f, self.ff = sp, pv, ff
            self.out = self.manual_value = out if _NINF < v_raw < _INF else math.nan
            self.limits_active = v_raw > self._hi or v_raw < self._lo
            self.error_id = self._limits_status
            self._lean_ran = True
            return out
        if self._config.precision == "float32":
            if self._cycle_time(dt, self._ts) is None:
                return self.out
            return _float32_cycle("pid")(self, sp, pv, ff, pv_ok, dt, dv)
        v = self.compute_output(sp, pv, ff=ff, dv=dv, dt=dt, pv_ok=pv_ok)
        self.update_state(v)
        return self.out

    def compute_output(
        self,
        sp: float,
        pv: float,
        *,
        ff: float = 0.0,
        dv: float = 0.0,
        dt: float | None = None,
        pv_ok: bool = True,
    ) -> float:
        """ComputeOutput of Åström 1987, Listing 6.3: the limited output of this cycle.

        Commits no state (the two-phase contract of :mod:`.base`): the cycle
        is computed from the committed state and kept as one pending value
        that :meth:`update_state` commits; calling this again in the same
        cycle starts from the committed state again and gives the same result
        for the same inputs.

        Lean cycle: in plain auto operation (the conditions of the per-call
        fast lane, :meth:`__call__`) the cycle is one call of :func:`pid_law`
        -- no filters, ramps or sub-block states -- and the pending value a
        few floats (a C struct in the compiled build), which
        :meth:`update_state` commits with :func:`pid_commit`; the results are
        those of the general cycle.

        Parameters
        ----------
        sp, pv : float
            Setpoint and process value [eng. units; scaled when ``pv_range``].
        ff : float
            Feed-forward / offset added before the limits [%] (controltheplant 2024, ``offset``).
        dv : float
            Input of the lead-lag feed-forward path (Bonde et al. 2021 version 4).
        dt : float, optional
            Sample time of this cycle [s]; default ``ts``.
        pv_ok : bool
            Quality flag of the measurement; False is treated like a NaN PV
            (status ``BAD_MEASUREMENT``).

        Returns
        -------
        float
            The output ``v`` [%] (limited, ramped); also ``self.out``.
        """
        # the output guard (Block._checked) around the body, as in __call__
        if type(sp) is not float:
            sp = as_input(sp)
        if type(pv) is not float:
            pv = as_input(pv)
        if type(ff) is not float:
            ff = as_input(ff)
        if type(dv) is not float:
            dv = as_input(dv)
        prev = self.out
        v = self._compute_output(sp, pv, ff, dv, dt, pv_ok)
        u = self.out
        if self._lo <= u <= self._hi and _NINF < u < _INF:
            return v
        return self._checked(prev, v)

    def _compute_output(
        self, sp: float, pv: float, ff: float, dv: float, dt: float | None, pv_ok: Any
    ) -> float:
        """The body of :meth:`compute_output` (inputs converted, output not yet checked)."""
        pending = self._pending
        if (
            self._two_phase_lean
            and (pending is None or pending is True)
            and self._plain_auto(dt, pv_ok, dv)
            and _NINF < sp < _INF
            and _NINF < pv < _INF
            and _NINF < ff < _INF
        ):
            # the lean cycle: the fast lane's conditions (_plain_auto), in which
            # the general cycle's sub-blocks pass their inputs through and the law's options
            # are off (NO_OPTIONS, as pid_step); the committed values it starts from are kept
            # for _sync_subs and _full_cycle
            out_prev, sp_prev, pv_prev = self.out, self.sp_w, self.pv_f
            if pending is True:  # computed again: from the values the pending cycle kept
                out_prev = self._lean_cycle[0]
                sp_prev, pv_prev = self._lean_cycle[1], self._lean_cycle[2]
            out, v_raw, _lim, p, i_k, d, w, e, _bias, _sup, _dbh = pid_law(
                sp, pv, ff, False, 0.0, False, False, False, False, False, 0.0, self._i, self._d,
                self._w_prev, self._e_prev, 0.0, 0.0, 0.0, 0.0, 0.0, out_prev, out_prev,
                self._prm, NO_OPTIONS,
            )  # fmt: skip
            if (
                _NINF < v_raw < _INF
                and _NINF < d < _INF
                and _NINF < w < _INF
                and _NINF < i_k < _INF
            ):
                self.sp_w, self.pv_f, self.e = sp, pv, e
                self.out = out
                self.limits_active = v_raw > self._hi or v_raw < self._lo
                self.p, self.d, self.ff, self.i = p, d, ff, i_k
                self.error_id = self._limits_status
                self._lean_cycle = (out_prev, sp_prev, pv_prev, sp, pv, e, w, d, p, ff, i_k, v_raw,
                                    out)  # fmt: skip
                self._pending = True
                return out
            # an overflow: the general cycle's failed cycle (BAD_RESULT, _resume)
        pv_ok = as_flag(pv_ok, False)
        if pending is True:
            pending = self._full_cycle()
        self._sync_subs()  # the committed states of the sub-blocks the cycle reads
        out_prev = self.out if pending is None else pending.out_prev
        # the filters', ramp's and lead-lag's states after the cycle travel in the pending cycle
        cycle, law_ok = self._compute(sp, pv, ff, dv, dt, pv_ok, out_prev)
        self._pending = cycle
        if not law_ok:
            # the law failed (pid_compute): an overflowed law holds the output (or the safe
            # value); a memory that overflowed behind an output that did not need it (a mode's
            # target, the dead band's hold: a forward-Euler derivative over an absurd dt) lets
            # the output stand; as a failed cycle, the memory is made finite and
            # re-initialised bumplessly from the output on recovery (_resume)
            self.error_id = ErrorCode.BAD_RESULT
            self._resume(self.out)
        return self.out

    def _full_cycle(self) -> _Cycle:
        """The lean pending cycle as the general one (:class:`_Cycle`), pending instead.

        For what the lean commit does not cover between the two phases: a
        reconfiguration or retune, limits narrowed below the output, the
        restart after a failed cycle, ``compute_output`` again on the general
        path.  The sub-blocks run from their committed states on the cycle's
        inputs, as :func:`pid_compute`'s input stage does (with every option
        of the lean configuration off), and their new states travel in the
        cycle.
        """
        (out_prev, _sp_prev, _pv_prev, sp, pv, e, w, d, p, ff, i_k, v_raw,
         out) = self._lean_cycle  # fmt: skip
        self._sync_subs()
        subs, named, h = self._cycle_subs, self._subs, self._ts
        committed = subs.take()
        named["_sp_ramp"](named["_sp_filter"](sp, dt=h), dt=h)
        named["_pv_filter"](pv, dt=h)
        cycle = _Cycle(_LAW, out_prev, Mode.AUTO, h, subs.take(), e, w, d, p, ff, i_k, v_raw,
                       self._bias, False, False, out, False)  # fmt: skip
        subs.put(committed)
        self._pending = cycle
        return cycle

    def _compute(
        self, sp: float, pv: float, ff: float, dv: float, dt: float | None, pv_ok: bool,
        out_prev: float,
    ) -> tuple[_Cycle, bool]:  # fmt: skip
        """The cycle from the committed state (:func:`pid_compute`); sets the outputs, returns
        it and whether the law's values are valid."""
        committed = self._cycle_subs.take()
        h = self._cycle_time(dt, self._ts)
        if h is None:
            self.error_id = ErrorCode.NO_CYCLE
            self.out = out_prev
            return _Cycle(_SKIP, out_prev, Mode.AUTO, self._h, committed), True
        if h != self._h:
            self._set_h(h)
        mode = self.mode
        c = self._config
        man, trk = self.manual_value, self.track_value
        if type(man) is not float:
            man = as_input(man)
        if type(trk) is not float:
            trk = as_input(trk)
        sp_s, pv_s, ramp_s, ll_s = committed
        scale_pv, pv_lo, pv_hi, a_sp, a_pv, sp_rate, ff_on, b0, b1, a1, bumpless = self._stage
        (out, err, ok, law_ok, limits_active, limiting, v_raw, p, i_k, i_shown, d, w, e, bias,
         ff_tot, suppressed, held, sp_f, pv_f, sp_w, sp_ramping, ll_out, ll_x) = pid_compute(
            sp, pv, ff, dv, pv_ok, mode, man, trk, float(c.reset_value), c.safe_value is not None,
            self._safe, out_prev, self._subs["_out_ramp"].out, scale_pv, pv_lo, pv_hi, a_sp, a_pv,
            sp_rate, ff_on, b0, b1, a1, bumpless, h, self._cold, self._reinit, self._reinit_d,
            self._mode_prev, self.p_suppressed, bool(self.awin), self.deadband_active,
            self._db_hold, self._i, self._d, self._w_prev, self._e_prev, self._x, self._bias,
            self._p_prev, self._d_prev, self._ff_prev, sp_s[0], pv_s[0], ramp_s[0], ramp_s[1],
            ll_s[0], ll_s[2], self._prm, self._opt, _BIG,
        )  # fmt: skip
        self.out = out
        self.limits_active = limits_active
        if not ok:
            self.error_id = ErrorCode(err)
            return _Cycle(_BAD, out_prev, mode, h, committed, ramp=out, limiting=limiting), True
        self.sp_w, self.pv_f, self.e = sp_w, pv_f, e
        self.p, self.d, self.ff, self.i = p, d, ff_tot, i_shown
        # controltheplant 2024: RESET clears the limits' status
        self.error_id = self._limits_status if mode != Mode.RESET else ErrorCode.NO_ERROR
        # the sub-blocks' states the cycle leaves (their fields and status, _SubStates)
        ok_ = ErrorCode.NO_ERROR
        subs = ((sp_f, ok_), (pv_f, ok_), (sp_w, sp_ramping, ok_),
                (ll_out, True, ll_x, ll_s[3], ok_) if ff_on else ll_s)  # fmt: skip
        return _Cycle(_LAW, out_prev, mode, h, subs, e, w, d, p, ff_tot, i_k, v_raw, bias,
                      suppressed, held, out, limiting), law_ok  # fmt: skip

    def update_state(self, applied: float) -> None:
        """UpdateState of Åström 1987, Listing 6.3 with the value actually applied [%].

        Commits the cycle :meth:`compute_output` left pending (:func:`pid_commit`).
        In auto the integrator tracks ``applied`` with time constant ``tt``
        (Åström 1987, Fig. 3.6); with CLAMPING on ``applied - out``, with
        BACK_CALC_MODEL on ``applied - v`` (``v`` before limits), with
        BACK_CALC_REAL on ``actuator_pos - v``.  In the other modes (and while
        the dead band holds the output) the integrator is set so that ``P + I
        + D + FF = applied``.  A non-finite ``applied`` counts as ``out``.
        """
        cycle = self._pending
        if cycle is None:
            log.debug("PID.update_state without compute_output: ignored")
            return
        self._pending = None
        u = float(applied) if is_finite(applied) else self.out
        if cycle is True:
            # the lean cycle (compute_output): the commit below for a _LAW cycle in auto of the
            # positional law, nothing held, no dead band -- the sub-blocks are brought up to
            # date when next needed (_sync_subs)
            (_out_prev, _sp_prev, _pv_prev, _sp, _pv, e, w, d, p, ff, i_k, v_raw,
             _out) = self._lean_cycle  # fmt: skip
            self.manual_value = u
            self._i, _x = pid_commit(u, self.out, v_raw, p, i_k, d, ff, False, False, 0.0,
                                     self._prm[6], self._prm[11], self._prm[12], 0.0)  # fmt: skip
            self._d, self._w_prev, self._e_prev = d, w, e
            self.p_suppressed = False
            self._lean_ran = True
            return
        if cycle.kind == _SKIP:
            return
        self._cycle_subs.put(cycle.subs)
        subs = self._subs
        ramp = subs["_out_ramp"]
        ramp.out, ramp.limiting = cycle.ramp, cycle.limiting
        mode = cycle.mode
        if mode == Mode.RESET:
            self._limits_status = ErrorCode.NO_ERROR  # controltheplant 2024: reset clears
        pos = self.actuator_pos
        if type(pos) is not float:
            pos = as_input(pos)
        prm, det = self._prm, subs["_det"]
        (self.manual_value, self._i, self._x, self._bias, self._d, self._w_prev, self._e_prev,
         self._p_prev, self._d_prev, self._ff_prev, self.p_suppressed, self._cold, self._reinit,
         self._reinit_d, self.deadband_active, feed, latch, steady, anchor, elapsed,
         started) = pid_update(
            u, self.out, cycle.kind == _LAW, mode, self.manual_value, cycle.v_raw, cycle.p,
            cycle.i, cycle.d, cycle.w, cycle.e, cycle.ff, cycle.bias, cycle.suppressed,
            cycle.held, pos, prm[6], prm[11], prm[12], self._opt[0], self._db,
            self._config.t_stab, cycle.h, self._i, self._x, self._bias, self._d, self._w_prev,
            self._e_prev, self._p_prev, self._d_prev, self._ff_prev, self.p_suppressed,
            self._cold, self._reinit, self._reinit_d, self.deadband_active, det.steady,
            det._anchor, det._elapsed, det._started, _BIG,
        )  # fmt: skip
        self._mode_prev = mode
        if self._db != 0.0:  # the dead band (pid_update): its detector, its moving average
            det.steady, det._anchor, det._elapsed, det._started = steady, anchor, elapsed, started
            det.out = 1.0 if steady else 0.0
            if feed:
                ma = subs["_ma"]
                ma(u)
                if latch:
                    self._db_hold = ma.out

    # -- the public seam of the compiled paths (fast/, plc/) ---------------------------

    def fast_path_blockers(self, *, manual_ok: bool = True) -> list[str]:
        """Why :func:`pid_step` cannot run this PID as it is now (empty: it can).

        The one decision for every compiled path: configuration options the
        kernel does not cover (velocity algorithm, PV scaling, SP/PV filters,
        SP or output ramps, the lead-lag feed-forward, the adaptive dead band,
        bumpless methods other than ``"integrator"``, anti-windup
        ``back_calc_real``), inputs it does not read (``track``, ``hold``,
        ``reset_active``, ``awin``), a re-initialisation in progress, and the P
        action still suppressed after a switch (the kernels never suppress it).
        ``manual_ok`` False also refuses a block that last ran in manual (the
        banks start in auto).
        """
        bad = _unsupported(self._config, "pid")  # the options (also the PLC cycle's check)
        bad += [name for name in self._option_blockers() if name not in bad]
        bad += [n for n in ("track", "hold", "reset_active", "awin") if getattr(self, n)]
        if self._reinit and not self._cold:
            bad.append("re-initialising after a change (run one cycle first)")
        if self.p_suppressed:  # state, not configuration: it outlives a change of bumpless
            bad.append("P action suppressed after a switch (until |e| <= dev_tol)")
        if not manual_ok and self._mode_prev not in (-1, Mode.AUTO):
            bad.append("last cycle not in auto")
        return bad

    def _option_blockers(self) -> list[str]:
        """The law's options (:class:`PIDOptions`) not at :data:`NO_OPTIONS`, the kernels' law.

        ``dev_tol`` is read only while P is suppressed, which the kernels never are.
        """
        return [name for name, v, off in zip(PIDOptions._fields, self._opt, NO_OPTIONS, strict=True)
                if v != off and name != "dev_tol"]  # fmt: skip

    def fast_path_supported(self, *, manual_ok: bool = True) -> bool:
        """True when :func:`pid_step` runs this PID exactly (:meth:`fast_path_blockers`)."""
        return not self.fast_path_blockers(manual_ok=manual_ok)

    def kernel_params(self) -> PIDKernelParams:
        """The parameters of :func:`pid_step` at the configured sample time ``ts``."""
        self._set_h(float(self._config.ts))
        return PIDKernelParams(*self._prm)

    def kernel_state(self) -> PIDKernelState:
        """The state :func:`pid_step` carries from one sample to the next."""
        return PIDKernelState(
            self._i,
            self._d,
            self._w_prev,
            self._e_prev,
            self.out,
            self._cold,
            self._reinit,
            self._mode_prev not in (-1, Mode.AUTO),
        )

    def load_kernel_state(self, state: PIDKernelState) -> None:
        """Put back a state after :func:`pid_step` cycles run outside the block.

        The block continues as if it had run those cycles itself (in auto, or
        in manual when ``state.manual``).
        """
        self._sync_subs()
        self._pending = None
        self._i, self._d = float(state.i), float(state.d)
        self._w_prev, self._e_prev = float(state.w_prev), float(state.e_prev)
        self.out = float(state.out)
        self._cold, self._reinit = bool(state.cold), bool(state.reinit)
        self._reinit_d = self._reinit
        if self._cold:
            self._mode_prev = -1
        else:
            self._mode_prev = Mode.MANUAL if state.manual else Mode.AUTO


class PIDKernelParams(NamedTuple):
    """The parameter tuple of :func:`pid_step` (:meth:`PID.kernel_params`), by name."""

    k: float  # gain K
    sgn: float  # action sign (+1 direct, -1 reverse)
    b: float  # setpoint weight of P, Åström 1987 (2.2)
    c: float  # setpoint weight of D
    ad: float  # derivative coefficient a of Åström 1987 (2.13)
    bd: float  # derivative coefficient bd of (2.13)
    ki_h: float  # K h / Ti
    alpha: float  # weight of e[k-1] in the integral increment
    beta: float  # weight of e[k]
    lo: float  # output limits
    hi: float
    aw: float  # anti-windup: 0 clamping, 1 back-calculation
    g: float  # tracking gain h / (Tt + h)


class PIDOptions(NamedTuple):
    """The options of :func:`pid_law` beyond :class:`PIDKernelParams` (its ``opt``), by name.

    The compiled kernels run the law with :data:`NO_OPTIONS`: a block whose
    options differ (but for ``dev_tol``, read only while P is suppressed) is
    not theirs (:meth:`PID.fast_path_blockers`).
    """

    velocity: float  # 1.0: the velocity algorithm
    dev_tol: float  # deviation tolerance of SUPPRESS_P_ACTION [%]
    rate_h: float  # the output ramp's largest step per cycle [%] (0: off)
    db: float  # half-width of the adaptive dead band [%] (0: off)
    i_band: float  # integral band [%] (0: off)


class PIDKernelState(NamedTuple):
    """What :func:`pid_step` carries from sample to sample (:meth:`PID.kernel_state`)."""

    i: float  # the integrator
    d: float  # the derivative term D[k-1]
    w_prev: float  # w[k-1] = c r - y
    e_prev: float  # e[k-1]
    out: float  # the last output
    cold: bool  # no history yet: the next cycle starts it
    reinit: bool  # re-initialising after a change or a bad input
    manual: bool  # the last cycle ran in a non-auto mode
