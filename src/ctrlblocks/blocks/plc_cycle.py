"""The PLC cycle of the PID, ADRC and lead-lag blocks, and ``precision="float32"``.

A PLC function block is called once per cycle with all its inputs; its state
lives in the instance.  The functions here are that cycle, written with the
blocks' own pure per-cycle functions (DESIGN principle 2: one implementation
of each law): :func:`pid_cycle` calls :func:`.pid.pid_step` (and through it
``derivative_step`` (Åström 1987, (2.13)), ``integral_increment`` ((2.8) /
Tustin), ``clamping_blocks``), :func:`adrc_cycle` calls :func:`.adrc.adrc_step`
(Nowak et al. 2018, (4a), (4b), (11)) and :func:`leadlag_cycle` calls
:func:`.leadlag.leadlag_step`.  What they add is the *plumbing* a PLC block
needs around the law, the same the blocks' ``compute_output``/``update_state``
do for these configurations:

* the coefficients from the tunings, every cycle (so a PLC can retune and
  pass the measured cycle time), through the blocks' ``derivative_coefficients``,
  ``integral_weights``, ``tracking_gain``, ``adrc_switches``,
  ``pt1_coefficient`` and ``leadlag_coefficients``;
* the modes (MANUAL, RESET), bumpless transfer after a mode change, a bad
  input and a retuning;
* NaN / inf / quality-flag handling with the library's error codes, and
  limits written at run time (a reversed pair keeps the last valid one,
  ``BAD_LIMITS``).

The functions use only the restricted Python that :mod:`ctrlblocks.plc`
translates to IEC 61131-3 Structured Text (floats, bools, ints, ``if``,
tuples, calls of such functions): the exported FUNCTION_BLOCKs *are* these
functions.  :func:`run_float32` runs them with every value a numpy
``float32`` (NEP 50 keeps float32 through Python literals) and ``math``
replaced by float32 versions, so each intermediate is rounded as a PLC's
REAL; the blocks' ``precision="float32"`` option runs their cycle that way.

Infinite limits are passed as +-3.402823E38 (:data:`REAL_MAX`, the end of
the REAL range the PLC manuals list; a PLC literal cannot be infinite).
"""

from __future__ import annotations

import functools
import math
import types
from collections.abc import Callable
from typing import Any

import numpy as np

from .adrc import adrc_step, adrc_switches
from .base import ErrorCode, Mode, as_input
from .leadlag import leadlag_coefficients, leadlag_step
from .pid import derivative_coefficients, integral_weights, pid_step, tracking_gain
from .precision import CYCLES
from .signals import clamp, pt1_coefficient

__all__ = [
    "ADRC_RESULTS",
    "LEADLAG_RESULTS",
    "PID_RESULTS",
    "REAL_MAX",
    "adrc_cycle",
    "bandwidth_gains",
    "is_real",
    "leadlag_cycle",
    "pid_cycle",
    "real_args",
    "run_float32",
]

REAL_MAX = 3.4028230607370965e38
"""3.402823E38 as a REAL (float32): the end of the REAL range that CODESYS and
TIA Portal document, written for an infinite limit; a larger magnitude counts
as an overflow (``is_real`` is False)."""

NO_ERROR = int(ErrorCode.NO_ERROR)
BAD_INPUT = int(ErrorCode.BAD_INPUT)
BAD_MEASUREMENT = int(ErrorCode.BAD_MEASUREMENT)
BAD_LIMITS = int(ErrorCode.BAD_LIMITS)
AUTO = int(Mode.AUTO)
MANUAL = int(Mode.MANUAL)
RESET = int(Mode.RESET)
NO_MODE = -1


def is_real(x: float) -> bool:
    """True for a finite REAL: NaN fails every comparison, inf exceeds REAL_MAX."""
    return abs(x) <= REAL_MAX


# ---------------------------------------------------------------------------
# PID
# ---------------------------------------------------------------------------

PID_RESULTS = (
    "mv", "error_id", "limits_active", "man_value", "p", "i_term", "d_term",
    "out", "i", "d", "w_prev", "e_prev", "lo", "hi", "mode_prev", "cold", "reinit", "reinit_d",
    "k_prev", "ti_prev", "td_prev", "n_prev", "b_prev", "c_prev", "rev_prev",
)  # fmt: skip
"""Names of the values :func:`pid_cycle` returns: outputs, then the new state."""


def pid_cycle(
    sp: float,
    pv: float,
    ff: float,
    pv_ok: bool,
    manual: bool,
    man_value: float,
    rst: bool,
    k: float,
    ti: float,
    td: float,
    n: float,
    b: float,
    c: float,
    ts: float,
    u_min: float,
    u_max: float,
    tt: float,
    reverse: bool,
    i_method: int,
    d_method: int,
    aw: int,
    reset_value: float,
    safe_value: float,
    use_safe: bool,
    out: float,
    i: float,
    d: float,
    w_prev: float,
    e_prev: float,
    lo: float,
    hi: float,
    mode_prev: int,
    cold: bool,
    reinit: bool,
    reinit_d: bool,
    k_prev: float,
    ti_prev: float,
    td_prev: float,
    n_prev: float,
    b_prev: float,
    c_prev: float,
    rev_prev: bool,
) -> tuple[Any, ...]:
    """One cycle of the positional ISA PID (:class:`~ctrlblocks.PID` plain configuration).

    Tunings ``k, ti, td`` are the ISA ``(K, Ti, Td)``; ``tt = 0`` takes the
    block's default ``Ti/5`` (``ts`` without integral action); ``i_method`` /
    ``d_method`` 0 forward, 1 backward, 2 Tustin; ``aw`` 0 clamping,
    1 back-calculation (actuator model).  Returns :data:`PID_RESULTS`.
    """
    lim_err = NO_ERROR
    if u_min <= u_max:
        lo = u_min
        hi = u_max
    else:
        lim_err = BAD_LIMITS
    if cold:
        k_prev = k
        ti_prev = ti
        td_prev = td
        n_prev = n
        b_prev = b
        c_prev = c
        rev_prev = reverse
    if (
        k != k_prev
        or ti != ti_prev
        or td != td_prev
        or n != n_prev
        or b != b_prev
        or c != c_prev
        or reverse != rev_prev
    ):
        reinit = True  # a change of the law is bumpless: re-initialise the integrator
    k_prev = k
    ti_prev = ti
    td_prev = td
    n_prev = n
    b_prev = b
    c_prev = c
    rev_prev = reverse
    mode = AUTO
    if rst:
        mode = RESET
    elif manual:
        mode = MANUAL
    # coefficients of this cycle (PID._set_h)
    sgn = 1.0
    if reverse:
        sgn = -1.0
    ki = 0.0
    if ti > 0.0:
        ki = k / ti
    tt_used = ts
    if tt > 0.0:
        tt_used = tt
    elif ti > 0.0:
        tt_used = ti / 5.0
    ad, bd = derivative_coefficients(k * td, td / n, ts, d_method)
    alpha, beta = integral_weights(i_method)
    prm = (
        k,
        sgn,
        b,
        c,
        ad,
        bd,
        ki * ts,
        alpha,
        beta,
        lo,
        hi,
        float(aw),
        tracking_gain(ts, tt_used),
    )
    # process data
    ok = is_real(sp) and is_real(pv) and is_real(ff)
    err = NO_ERROR
    if not ok:
        err = BAD_INPUT
    if not pv_ok:
        ok = False
        err = BAD_MEASUREMENT
    man_ok = is_real(man_value)
    if mode == MANUAL and not man_ok:
        ok = False
        if err == NO_ERROR:
            err = BAD_INPUT
    p = 0.0
    i_term = i
    d_term = d
    if not ok:
        # hold (or the safe value); the next good cycle continues without a bump
        target = out
        if mode == RESET:
            target = clamp(reset_value, lo, hi)
        elif mode == MANUAL and man_ok:
            target = man_value
        elif mode == AUTO and use_safe:
            target = safe_value
        mv = clamp(target, lo, hi)
        limits_active = target > hi or target < lo
        reinit = True
        reinit_d = True
    else:
        u_target = man_value
        if mode == RESET:
            u_target = clamp(reset_value, lo, hi)
        from_mode = mode == AUTO and mode_prev != NO_MODE and mode_prev != AUTO
        transfer = from_mode or (mode == AUTO and reinit)
        mv, v_raw, p, i_term, i, d, w_prev, e_prev = pid_step(
            sp, pv, ff, mode != AUTO, u_target, cold or reinit_d, transfer,
            i, d, w_prev, e_prev, out, prm,
        )  # fmt: skip
        d_term = d
        limits_active = v_raw > hi or v_raw < lo
        cold = False
        reinit = False
        reinit_d = False
    if err == NO_ERROR:
        err = lim_err
    if mode != MANUAL:
        man_value = mv  # In/Out: outside MANUAL the manual value follows the output
    out = mv
    mode_prev = mode
    return (
        mv, err, limits_active, man_value, p, i_term, d_term,
        out, i, d, w_prev, e_prev, lo, hi, mode_prev, cold, reinit, reinit_d,
        k_prev, ti_prev, td_prev, n_prev, b_prev, c_prev, rev_prev,
    )  # fmt: skip


# ---------------------------------------------------------------------------
# ADRC
# ---------------------------------------------------------------------------

ADRC_RESULTS = (
    "mv", "error_id", "awout", "u_raw", "u_man", "x4_out",
    "out", "yh", "x2", "x3", "x4", "u_prev", "ref", "started", "track", "sat", "lo", "hi",
    "tuned", "order_prev", "b0_prev", "wc_prev", "wo_prev", "ts_prev",
)  # fmt: skip
"""Names of the values :func:`adrc_cycle` returns: outputs, then the new state."""


def bandwidth_gains(
    n: int, omega_c: float, omega_o: float
) -> tuple[float, float, float, float, float, float, float]:
    """Gao's gains ``(l1, l2, l3, l4, kp, kd1, kd2)`` for n = 1, 2, 3, written out.

    The binomial coefficients of ``(s + omega_o)^(n+1)`` and ``(s + omega_c)^n``
    (Nowak et al. 2018, section 3.3) as :func:`.adrc.adrc_gains` computes them
    with ``math.comb`` -- spelled out here because a PLC has no lists; the
    tests check both agree for every order.
    """
    wo2 = omega_o * omega_o
    wc2 = omega_c * omega_c
    if n == 1:
        return 2.0 * omega_o, 0.0, 0.0, wo2, omega_c, 0.0, 0.0
    if n == 2:
        return 3.0 * omega_o, 3.0 * wo2, 0.0, wo2 * omega_o, wc2, 2.0 * omega_c, 0.0
    return (4.0 * omega_o, 6.0 * wo2, 4.0 * (wo2 * omega_o), wo2 * wo2,
            wc2 * omega_c, 3.0 * wc2, 3.0 * omega_c)  # fmt: skip


def adrc_cycle(
    sp: float,
    y: float,
    y_ok: bool,
    manual: bool,
    u_man: float,
    order: int,
    b0: float,
    omega_c: float,
    omega_o: float,
    ts: float,
    u_min: float,
    u_max: float,
    t_ref: float,
    u_sf: float,
    aw_rule: int,
    out: float,
    yh: float,
    x2: float,
    x3: float,
    x4: float,
    u_prev: float,
    ref: float,
    started: bool,
    track: bool,
    sat: int,
    lo: float,
    hi: float,
    tuned: bool,
    order_prev: int,
    b0_prev: float,
    wc_prev: float,
    wo_prev: float,
    ts_prev: float,
) -> tuple[Any, ...]:
    """One cycle of the Euler ADRC (:class:`~ctrlblocks.ADRC`, orders 1..3 in one body).

    ``aw_rule`` 0 off, 1 freeze, 2 directional (section 4.1).  Returns
    :data:`ADRC_RESULTS`.
    """
    lim_err = NO_ERROR
    if u_min <= u_max:
        lo = u_min
        hi = u_max
    else:
        lim_err = BAD_LIMITS
    if tuned and (
        order != order_prev
        or b0 != b0_prev
        or omega_c != wc_prev
        or omega_o != wo_prev
        or ts != ts_prev
    ):
        track = True  # bumpless retuning: x4 re-solved by (11) in this cycle
        if order < 3:
            x3 = 0.0
        if order < 2:
            x2 = 0.0
    tuned = True
    order_prev = order
    b0_prev = b0
    wc_prev = omega_c
    wo_prev = omega_o
    ts_prev = ts
    # coefficients of this cycle (ADRC._coefficients, Euler)
    p1, p2, k1, k2, k3 = adrc_switches(order)
    l1, l2, l3, l4, kp, kd1, kd2 = bandwidth_gains(order, omega_c, omega_o)
    s_x3 = ts * k3
    s_x2 = ts * (p2 * s_x3 + k2)
    s_yh = ts * (p1 * s_x2 + k1)
    s_u = -(1.0 + kp * s_yh + kd1 * s_x2 + kd2 * s_x3) / b0
    a_ref = pt1_coefficient(t_ref, ts, "exact")
    prm = (ts, b0, l1, l2, l3, l4, p1, p2, k1, k2, k3, kp, kd1, kd2, s_yh, s_x2, s_x3, s_u,
           lo, hi, float(aw_rule), a_ref)  # fmt: skip
    # process data
    err = NO_ERROR
    y_valid = y_ok and is_real(y)
    if not y_ok:
        err = BAD_MEASUREMENT
    elif not is_real(y):
        err = BAD_INPUT
    sp_valid = is_real(sp)
    if not sp_valid and err == NO_ERROR:
        err = BAD_INPUT
    man_ok = is_real(u_man)
    if manual and not man_ok and err == NO_ERROR:
        err = BAD_INPUT
    u_target = u_prev
    if man_ok:
        u_target = u_man
    if not y_valid:
        # measurement invalid: safe value (manual value in MAN), ESO frozen
        mv = clamp(u_sf, lo, hi)
        if manual:
            mv = clamp(u_target, lo, hi)
        u_raw = mv
        track = True
        sat = 0
    else:
        r_in = sp
        if not sp_valid:
            r_in = ref
            if not started:
                r_in = y
        mv, u_raw, yh, x2, x3, x4, ref, track, sat = adrc_step(
            r_in, y, manual, u_target, started, track or not sp_valid, sat,
            yh, x2, x3, x4, u_prev, ref, prm,
        )  # fmt: skip
        track = track or not sp_valid
        started = True
    if err == NO_ERROR:
        err = lim_err
    u_prev = mv
    if not manual:
        u_man = mv  # In/Out: outside MAN the manual value follows the output
    out = mv
    return (
        mv, err, sat != 0, u_raw, u_man, x4,
        out, yh, x2, x3, x4, u_prev, ref, started, track, sat, lo, hi,
        tuned, order_prev, b0_prev, wc_prev, wo_prev, ts_prev,
    )  # fmt: skip


# ---------------------------------------------------------------------------
# Lead-lag
# ---------------------------------------------------------------------------

LEADLAG_RESULTS = ("out", "error_id", "x_prev", "lo", "hi")
"""Names of the values :func:`leadlag_cycle` returns: outputs, then the new state."""


def leadlag_cycle(
    x: float,
    enable: bool,
    k: float,
    t_lead: float,
    t_lag: float,
    ts: float,
    tustin: bool,
    out_min: float,
    out_max: float,
    out: float,
    x_prev: float,
    lo: float,
    hi: float,
) -> tuple[Any, ...]:
    """One sample of :class:`~ctrlblocks.LeadLag` (Tustin or Euler; Bonde et al. 2021, Fig. 10).

    Returns :data:`LEADLAG_RESULTS`.
    """
    err = NO_ERROR
    if out_min <= out_max:
        lo = out_min
        hi = out_max
    else:
        err = BAD_LIMITS
    if not is_real(x):
        err = BAD_INPUT
    elif not enable:
        out = 0.0
        x_prev = x
    else:
        b0, b1, a1 = leadlag_coefficients(k, t_lead, t_lag, ts, tustin)
        out = leadlag_step(x, x_prev, out, b0, b1, a1, lo, hi)
        x_prev = x
    return out, err, x_prev, lo, hi


# ---------------------------------------------------------------------------
# float32 execution
# ---------------------------------------------------------------------------


def _f32_unary(fn: Callable[[Any], Any]) -> Callable[[float], np.float32]:
    def f(x: float) -> np.float32:
        return np.float32(fn(np.float32(x)))

    return f


_MATH32 = types.SimpleNamespace(
    exp=_f32_unary(np.exp),
    sqrt=_f32_unary(np.sqrt),
    log=_f32_unary(np.log),
    isfinite=lambda x: bool(np.isfinite(x)),
    inf=np.float32(np.inf),
    nan=np.float32(np.nan),
    pi=np.float32(math.pi),
)
"""The ``math`` functions the cycles use, computed in float32 (as a PLC's REAL EXP, SQRT, LN)."""


@functools.cache
def _float32_function(fn: Callable[..., Any]) -> Callable[..., Any]:
    """``fn`` with the same code, its globals seeing float32 ``math``/``float`` and helpers."""
    glb = dict(fn.__globals__)
    glb["math"] = _MATH32
    glb["float"] = np.float32
    for name in fn.__code__.co_names:
        val = glb.get(name)
        if isinstance(val, types.FunctionType) and val.__module__.startswith("ctrlblocks."):
            glb[name] = _float32_function(val)
    return types.FunctionType(fn.__code__, glb, fn.__name__, fn.__defaults__, fn.__closure__)


def _to32(v: Any) -> Any:
    if isinstance(v, bool | np.bool_ | int | np.integer):
        return v
    with np.errstate(over="ignore"):  # a limit beyond REAL_MAX: clipped below, no warning
        x = np.float32(v)
    return np.float32(np.clip(x, -REAL_MAX, REAL_MAX)) if np.isinf(x) else x


def run_float32(fn: Callable[..., tuple[Any, ...]], /, **args: Any) -> tuple[Any, ...]:
    """Run a cycle function as a PLC computing in REAL does.

    The arguments should already be REALs (:func:`to_real`, :func:`limit_real`);
    the function runs with the same code but with float32 ``math`` and
    ``float``, so every operation rounds to single precision.
    """
    f = _float32_function(fn)
    with np.errstate(all="ignore"):
        return f(**args)  # type: ignore[no-any-return]


def to_real(x: Any) -> Any:
    """A process value as a REAL: float32, keeping NaN and inf (a value beyond REAL_MAX is inf)."""
    if isinstance(x, bool | np.bool_ | int | np.integer):
        return x
    with np.errstate(all="ignore"):
        return np.float32(x)


def limit_real(x: float) -> np.float32:
    """A configured limit as a REAL: float32, infinite limits as +-REAL_MAX."""
    return _to32(x)  # type: ignore[no-any-return]


# ---------------------------------------------------------------------------
# Interface values from a block's configuration (shared by the export)
# ---------------------------------------------------------------------------

_PID_AW = {"clamping": 0, "back_calc_model": 1}
_METHODS = ("forward", "backward", "tustin")
_ADRC_AW = {"off": 0, "freeze": 1, "directional": 2, False: 0, True: 2}


def pid_inputs(config: Any) -> dict[str, Any]:
    """The tuning/mode inputs of :func:`pid_cycle` for a PIDConfig (floats as Python floats)."""
    k, ti, td = config.isa()
    return {
        "k": float(k), "ti": float(ti), "td": float(td), "n": float(config.n),
        "b": float(config.b), "c": float(config.c), "ts": float(config.ts),
        "u_min": float(config.u_min), "u_max": float(config.u_max),
        "tt": float(config.tt) if config.tt is not None else 0.0,
        "reverse": bool(config.reverse),
        "i_method": _METHODS.index(config.integral_method),
        "d_method": _METHODS.index(config.derivative_method),
        "aw": _PID_AW[config.anti_windup],
        "reset_value": float(config.reset_value),
        "safe_value": float(config.safe_value) if config.safe_value is not None else 0.0,
        "use_safe": config.safe_value is not None,
    }  # fmt: skip


def pid_state(config: Any) -> dict[str, Any]:
    """The state of :func:`pid_cycle` after a reset (PID.reset)."""
    lo, hi = float(config.u_min), float(config.u_max)
    return {
        "out": clamp(float(config.reset_value), lo, hi), "i": float(config.reset_value),
        "d": 0.0, "w_prev": 0.0, "e_prev": 0.0, "lo": lo, "hi": hi, "mode_prev": NO_MODE,
        "cold": True, "reinit": False, "reinit_d": False, "k_prev": 0.0, "ti_prev": 0.0,
        "td_prev": 0.0, "n_prev": 0.0, "b_prev": 0.0, "c_prev": 0.0, "rev_prev": False,
    }  # fmt: skip


def adrc_inputs(config: Any) -> dict[str, Any]:
    """The tuning inputs of :func:`adrc_cycle` for an ADRCConfig."""
    return {
        "order": int(config.order), "b0": float(config.b0), "omega_c": float(config.omega_c),
        "omega_o": float(config.omega_o), "ts": float(config.ts),
        "u_min": float(config.u_min), "u_max": float(config.u_max),
        "t_ref": float(config.t_ref), "u_sf": float(config.u_sf),
        "aw_rule": _ADRC_AW[config.anti_windup],
    }  # fmt: skip


def adrc_state(config: Any) -> dict[str, Any]:
    """The state of :func:`adrc_cycle` after a reset (ADRC.reset)."""
    lo, hi = float(config.u_min), float(config.u_max)
    u0 = clamp(float(config.u0), lo, hi)
    return {
        "out": u0, "yh": 0.0, "x2": 0.0, "x3": 0.0, "x4": 0.0, "u_prev": u0, "ref": 0.0,
        "started": False, "track": False, "sat": 0, "lo": lo, "hi": hi, "tuned": False,
        "order_prev": 0, "b0_prev": 0.0, "wc_prev": 0.0, "wo_prev": 0.0, "ts_prev": 0.0,
    }  # fmt: skip


def leadlag_inputs(config: Any) -> dict[str, Any]:
    """The parameter inputs of :func:`leadlag_cycle` for a LeadLagConfig."""
    return {
        "k": float(config.k), "t_lead": float(config.t_lead), "t_lag": float(config.t_lag),
        "ts": float(config.ts), "tustin": config.method == "tustin",
        "out_min": float(config.out_min), "out_max": float(config.out_max),
    }  # fmt: skip


def leadlag_state(config: Any) -> dict[str, Any]:
    """The state of :func:`leadlag_cycle` after a reset (LeadLag.reset)."""
    return {"out": 0.0, "x_prev": 0.0, "lo": float(config.out_min), "hi": float(config.out_max)}


_LIMITS = {"u_min", "u_max", "out_min", "out_max", "lo", "hi"}


def real_args(values: dict[str, Any]) -> dict[str, Any]:
    """Interface values as REALs: limits infinite -> +-REAL_MAX, process values kept (NaN, inf)."""
    return {k: limit_real(v) if k in _LIMITS else to_real(v) for k, v in values.items()}


def _lane(
    block: Any,
    fn: Callable[..., tuple[Any, ...]],
    names: tuple[str, ...],
    inputs: dict[str, Any],
    config_inputs: dict[str, Any],
    initial: Callable[[Any], dict[str, Any]],
) -> dict[str, Any]:
    """One float32 cycle of ``block``: its state in ``block._plc_state`` (None after reset)."""
    state = block.__dict__.get("_plc_state")
    if state is None:
        state = real_args(initial(block.config))
    # The block's edge (blocks/base.py): process values and the attribute inputs
    # (manual value) become floats once, anything unusable NaN; flags stay bools.
    process = {k: v if type(v) is bool else as_input(v) for k, v in inputs.items()}
    args = {**real_args(process), **real_args(config_inputs), **state}
    res = dict(zip(names, run_float32(fn, **args), strict=True))
    block._plc_state = {k: res[k] for k in state}
    return res


def pid_float32(pid: Any, sp: float, pv: float, ff: float, pv_ok: bool, dt: float | None) -> float:
    """The cycle of a PID with ``precision="float32"``: :func:`pid_cycle` in REAL."""
    prm = pid_inputs(pid.config)
    if dt is not None:
        prm["ts"] = float(dt)
    res = _lane(pid, pid_cycle, PID_RESULTS, {
        "sp": sp, "pv": pv, "ff": ff, "pv_ok": bool(pv_ok), "manual": bool(pid.manual),
        "man_value": pid.manual_value, "rst": bool(pid.reset_active)}, prm, pid_state)  # fmt: skip
    pid.out = float(res["mv"])
    pid.error_id = ErrorCode(res["error_id"])
    pid.limits_active = bool(res["limits_active"])
    pid.manual_value = float(res["man_value"])
    pid.p, pid.i, pid.d = float(res["p"]), float(res["i_term"]), float(res["d_term"])
    return pid.out


def adrc_float32(adrc: Any, sp: float, y: float, y_ok: bool, dt: float | None) -> float:
    """The cycle of an ADRC with ``precision="float32"``: :func:`adrc_cycle` in REAL."""
    prm = adrc_inputs(adrc.config)
    prm["u_min"], prm["u_max"] = adrc.u_min, adrc.u_max  # as written by set_limits
    if dt is not None:
        prm["ts"] = float(dt)
    res = _lane(adrc, adrc_cycle, ADRC_RESULTS, {
        "sp": sp, "y": y, "y_ok": bool(y_ok), "manual": bool(adrc.manual),
        "u_man": adrc.u_man}, prm, adrc_state)  # fmt: skip
    adrc.out = float(res["mv"])
    adrc.error_id = ErrorCode(res["error_id"])
    adrc.awout = bool(res["awout"])
    adrc.u_raw = float(res["u_raw"])
    adrc.u_man = float(res["u_man"])
    return adrc.out


def leadlag_float32(ll: Any, x: float, enable: bool, dt: float | None) -> float:
    """The sample of a LeadLag with ``precision="float32"``: :func:`leadlag_cycle` in REAL."""
    prm = leadlag_inputs(ll.config)
    if dt is not None:
        prm["ts"] = float(dt)
    res = _lane(
        ll, leadlag_cycle, LEADLAG_RESULTS, {"x": x, "enable": bool(enable)}, prm, leadlag_state
    )
    ll.out = float(res["out"])
    ll.error_id = ErrorCode(res["error_id"])
    ll.enabled = bool(enable)
    return ll.out


CYCLES.update(pid=pid_float32, adrc=adrc_float32, leadlag=leadlag_float32)
