"""The PLC cycle of the PID, ADRC and lead-lag blocks, and ``precision="float32"``.

A PLC function block is called once per cycle with all its inputs; its state
lives in the instance.  The functions here are that cycle, written with the
blocks' own pure per-cycle functions (DESIGN principle 2: one implementation
of each law): :func:`pid_cycle` calls :func:`.pid.pid_law` and
:func:`.pid.pid_commit` (the PID's one law, also the block's, the compiled
kernels' and the float32 lane's), :func:`adrc_cycle` calls :func:`.adrc.adrc_compute`
(the block's own process data of a cycle around its one law :func:`.adrc.adrc_law`,
Nowak et al. 2018, (4a), (4b), (11)) and :func:`leadlag_cycle` calls
:func:`.leadlag.leadlag_law` (the block's cycle too).  What they add is the *plumbing* a PLC block
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
from typing import Any, TypeVar

import numpy as np

from ..compiled import interpreted as _interpreted
from .base import ErrorCode, Mode, as_input
from .precision import CYCLES, real_exp, real_ln, real_sqrt

# the law functions as Python functions even when the compiled blocks are loaded: the
# float32 cycle rebuilds them with float32 math and the PLC export reads their source
_adrc = _interpreted("adrc")
EULER_LIMIT = _adrc.EULER_LIMIT
EXACT_LIMIT = _adrc.EXACT_LIMIT
adrc_law = _adrc.adrc_law
bandwidth_gains = _adrc.bandwidth_gains
exact_coefficients = _adrc.exact_coefficients
pole_distance = _adrc.pole_distance
euler_sensitivities = _adrc.euler_sensitivities
euler_substeps = _adrc.euler_substeps
handover_pole = _adrc.handover_pole
input_stage = _adrc.input_stage
adrc_compute = _adrc.adrc_compute
mode_output = _adrc.mode_output
tracking_differentiator = _adrc.tracking_differentiator
td_restart = _adrc.td_restart
adrc_step = _adrc.adrc_step
adrc_switches = _adrc.adrc_switches
anti_backoff_states = _adrc.anti_backoff_states
control_law = _adrc.control_law
eso_euler = _adrc.eso_euler
eso_exact = _adrc.eso_exact
retune_x4 = _adrc.retune_x4
solve_x4 = _adrc.solve_x4
x4_update_allowed = _adrc.x4_update_allowed
_leadlag = _interpreted("leadlag")
leadlag_coefficients = _leadlag.leadlag_coefficients
leadlag_law = _leadlag.leadlag_law
_pid = _interpreted("pid")
pid_commit = _pid.pid_commit
pid_compute = _pid.pid_compute
pid_law = _pid.pid_law
pid_mode = _pid.pid_mode
pid_output = _pid.pid_output
pid_parameters = _pid.pid_parameters
pid_restart = _pid.pid_restart
pid_update = _pid.pid_update
retune_states = _pid.retune_states
tracking_time = _pid.tracking_time
valid_or_zero = _pid.valid_or_zero
_signals = _interpreted("signals")
clamp = _signals.clamp
deadband = _signals.deadband
pt1_coefficient = _signals.pt1_coefficient
scale = _signals.scale
SUM_LOSS_REAL = _signals.SUM_LOSS_REAL

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
NO_CYCLE = int(ErrorCode.NO_CYCLE)
BAD_INPUT = int(ErrorCode.BAD_INPUT)
BAD_MEASUREMENT = int(ErrorCode.BAD_MEASUREMENT)
BAD_LIMITS = int(ErrorCode.BAD_LIMITS)
BAD_RESULT = int(ErrorCode.BAD_RESULT)
AUTO = int(Mode.AUTO)
MANUAL = int(Mode.MANUAL)
RESET = int(Mode.RESET)
NO_MODE = -1


def is_real(x: float) -> bool:
    """True for a finite REAL: NaN fails every comparison, inf exceeds REAL_MAX.

    The NaN is caught by ``x == x`` first, a *quiet* comparison (IEEE 754: no invalid-operation
    exception for a quiet NaN), so that a runtime that traps floating-point exceptions does not
    stop at a NaN input in the ordered comparison ``abs(x) <= REAL_MAX`` (docs/plc.md, "Traps").
    """
    if x == x:  # the NaN test
        return abs(x) <= REAL_MAX
    return False


def cycle_time_ok(ts: float) -> bool:
    """True for a usable sample time: a finite REAL > 0.  Else the cycle does not run: the
    outputs and the state hold and the status is ``NO_CYCLE`` (the block's bad ``dt``)."""
    if is_real(ts):
        return ts > 0.0
    return False


# ---------------------------------------------------------------------------
# Small blocks with memory (each its own FUNCTION_BLOCK in the export)
# ---------------------------------------------------------------------------

_F = TypeVar("_F", bound=Callable[..., Any])


def plc_block(short: str, results: tuple[str, ...], hidden: tuple[str, ...] = ()) -> Callable[
    [_F], _F
]:  # fmt: skip
    """Mark a function as a small block with memory, exported as FUNCTION_BLOCK ``CB_<short>``.

    The function is pure: its parameters are the inputs and the memory, it
    returns ``results`` (named in order); a result named like a parameter is
    that memory's new value.  The caller passes its memory in and takes it back
    (``u, buf, idx, n_prev, ok = delay_line(push, n, restart, buf, idx, n_prev)``); in
    the PLC an instance of the FB,
    declared in the caller's VAR, holds it, and the caller reads it as the
    instance's output (``hidden`` memories are no outputs).  Only the call
    writes that memory, so the two stay the same value (the translator checks).
    """

    def mark(fn: _F) -> _F:
        fn.plc_block = (short, results, hidden)  # type: ignore[attr-defined]
        return fn

    return mark


# the moving average's one cycle (signals.moving_average_step, MovingAverage's), exported as
# the FB CB_MOVAVG_<n>: its ring is an ARRAY, which a FUNCTION cannot take
moving_average = plc_block(
    "MOVAVG",
    ("mean", "buf", "idx", "count", "since", "total", "spread", "mag", "n_prev"),
    hidden=("buf", "idx", "count", "since", "total", "spread", "mag", "n_prev"),
)(_signals.moving_average_step)


@plc_block("DELAY", ("u", "buf", "idx", "n_prev", "ok"), hidden=("buf", "idx", "n_prev"))
def delay_line(
    push: float, n: int, restart: bool, buf: list[float], idx: int, n_prev: int
) -> tuple[float, list[float], int, int, bool]:
    """A delay line: ``push`` enters, out comes the value pushed ``n`` calls before it.

    The ADRC's ESO input (``ADRCConfig.input_delay``, Zhao & Gao 2014): pushed the
    last applied u each cycle, it gives the applied u of ``n`` samples before that,
    as the block's history ``ADRC._u_hist``.  ``buf`` is a ring of ``len(buf) >= n
    + 1`` values (in the PLC an ARRAY sized at export), ``idx`` the next place to
    write, ``n_prev`` the delay in force.  A new ``n`` keeps the newest values; a
    longer one pads the line at its old end with its oldest value (as if u had
    rested there: ``adrc._resize_history``) -- so the first call (``n_prev = 0``)
    fills the line with ``push``, as ``ADRC.reset`` does with ``u0``; ``restart``
    fills it with ``push`` (after an overflow, ``ADRC._resume``).  An ``n`` beyond
    the ring is refused (``ok`` False) and the delay in force stays.  Returns
    ``(u, buf, idx, n_prev, ok)``.
    """
    cap = len(buf)
    buf[idx] = push
    idx = (idx + 1) % cap
    if restart:
        for j in range(cap):
            buf[j] = push
    ok = True
    if n != n_prev:
        if n < 0 or n >= cap:
            ok = False
        else:
            if n > n_prev:
                pad = buf[(idx + cap - 1 - n_prev) % cap]
                for j in range(n - n_prev):
                    buf[(idx + cap - 1 - n + j) % cap] = pad
            n_prev = n
    u = buf[(idx + cap - 1 - n_prev) % cap]
    return u, buf, idx, n_prev, ok


def deadband_window(t_stab: float, ts: float, cap: int, window: int) -> tuple[int, bool]:
    """The moving-average window ``round(t_stab/ts)`` (half to even, >= 1) and whether it is valid.

    As :class:`~ctrlblocks.PID` sizes its average (``max(1, round(t_stab/ts))``);
    a ``t_stab <= 0``, a non-finite ratio or a window beyond the ``cap``
    values the PLC's ARRAY holds is not valid: ``window`` (the one in force)
    is returned with False.
    """
    r = t_stab / ts
    if not (t_stab > 0.0 and r > 0.0 and r < float(cap) + 0.5):
        return window, False
    n = int(r + 0.5)
    if float(n) - r == 0.5 and n % 2 == 1:
        n = n - 1  # a tie rounds to even, as Python's round()
    return max(1, n), True


# ---------------------------------------------------------------------------
# PID
# ---------------------------------------------------------------------------

PID_RESULTS = (
    "mv", "error_id", "limits_active", "man_value", "p", "i_term", "d_term",
    "out", "i", "d", "w_prev", "e_prev", "x", "bias", "p_prev", "d_prev", "ff_prev",
    "sp_f", "pv_f", "sp_w", "ll_x", "ll_out", "suppressed", "ramp_out", "lo", "hi", "mode_prev",
    "cold", "reinit", "reinit_d", "k_prev", "ti_prev", "td_prev", "n_prev", "b_prev",
    "c_prev", "rev_prev", "vel_prev", "scale_prev", "pv_lo_prev", "pv_hi_prev",
    "db_active", "db_hold", "db_win", "db_t", "db_mean", "db_buf", "ma_idx", "ma_count",
    "ma_since", "ma_total", "ma_spread", "ma_mag", "ma_n", "st_anchor", "st_elapsed",
    "st_started",
)  # fmt: skip
"""Names of the values :func:`pid_cycle` returns: outputs, then the new state."""

TRACK = int(Mode.TRACK)
HOLD = int(Mode.HOLD)
CLAMPING = 0
BACK_CALC_REAL = 2
BUMPLESS_TRACK_SP = 1
BUMPLESS_SUPPRESS_P = 2
BAD_STAB_TIME = int(ErrorCode.BAD_STAB_TIME)
BAD_TIME_CONSTANT = int(ErrorCode.BAD_TIME_CONSTANT)


def pid_cycle(
    sp: float,
    pv: float,
    ff: float,
    dv: float,
    pv_ok: bool,
    manual: bool,
    man_value: float,
    rst: bool,
    track: bool,
    track_value: float,
    hold: bool,
    awin: bool,
    actuator_pos: float,
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
    velocity: bool,
    scale_pv: bool,
    pv_lo: float,
    pv_hi: float,
    sp_filter: float,
    pv_filter: float,
    sp_rate: float,
    out_rate: float,
    ff_k: float,
    ff_t_lead: float,
    ff_t_lag: float,
    bumpless: int,
    dev_tol: float,
    reset_value: float,
    safe_value: float,
    use_safe: bool,
    db_width: float,
    t_stab: float,
    i_band: float,
    out: float,
    p: float,
    i_term: float,
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
    ll_x: float,
    ll_out: float,
    suppressed: bool,
    ramp_out: float,
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
    vel_prev: bool,
    scale_prev: bool,
    pv_lo_prev: float,
    pv_hi_prev: float,
    db_active: bool,
    db_hold: float,
    db_win: int,
    db_t: float,
    db_mean: float,
    db_buf: list[float],
    ma_idx: int,
    ma_count: int,
    ma_since: int,
    ma_total: float,
    ma_spread: float,
    ma_mag: float,
    ma_n: int,
    st_anchor: float,
    st_elapsed: float,
    st_started: bool,
) -> tuple[Any, ...]:
    """One cycle of the ISA PID (:class:`~ctrlblocks.PID`, every option).

    Tunings ``k, ti, td`` are the ISA ``(K, Ti, Td)``; ``tt = 0`` takes the
    block's default ``Ti/5`` (``ts`` without integral action); ``i_method`` /
    ``d_method`` 0 forward, 1 backward, 2 Tustin; ``aw`` 0 clamping,
    1 back-calculation (actuator model), 2 back-calculation on ``actuator_pos``;
    ``bumpless`` 0 integrator, 1 track setpoint, 2 suppress P action.
    The adaptive dead band (controltheplant 2024, section 2.3.10; ``db_width``
    > 0, a negative width acts as its absolute value) holds the output at the
    mean of the applied output over the last ``t_stab/ts`` samples once the
    error has stayed inside the band for ``t_stab`` (:func:`.pid.pid_update`,
    :func:`moving_average`) and releases it bumplessly when the error leaves;
    a ``t_stab`` whose window exceeds the array (``db_buf``) is refused with
    ``BAD_STAB_TIME`` and the window in force stays.
    The process data of the cycle -- the modes' outputs, the judgement of the
    inputs, the input stage (PV scaling to 0..100 %, the SP and PV filters:
    PT1, exact pole; the setpoint ramp; the lead-lag feed-forward on ``dv``,
    Bonde et al. 2021 version 4, Tustin), the transfer to AUTO and the law
    (:func:`.pid.pid_law`) -- is :func:`.pid.pid_compute`, the block's too; what
    is this cycle's own: the coefficients from the inputs every cycle, a change
    of tuning, algorithm or scaling detected here (the block's ``configure``),
    the limits and the dead band's window written at run time.
    Returns :data:`PID_RESULTS`.
    """
    lim_err = NO_ERROR
    if u_min <= u_max:
        lo = u_min
        hi = u_max
    else:
        lim_err = BAD_LIMITS
    out = clamp(out, lo, hi)  # new limits contain the last output (Block.configure)
    # a change of the law is bumpless (not on the first cycle, which starts from the
    # output anyway)
    retuned = not cold and (
        k != k_prev
        or ti != ti_prev
        or td != td_prev
        or n != n_prev
        or b != b_prev
        or c != c_prev
        or reverse != rev_prev
    )
    if not cold and (
        velocity != vel_prev
        or scale_pv != scale_prev
        or (scale_pv and (pv_lo != pv_lo_prev or pv_hi != pv_hi_prev))
        or (retuned and (mode_prev != AUTO or reinit or db_active))
    ):
        # a change of the units or the algorithm (or a retune outside a running auto
        # cycle, or while the dead band holds) is bumpless too: the next good cycle
        # re-initialises the integrator
        reinit = True
        retuned = False
    if retuned:
        # bumpless retuning at the instant of the change (PID._carry_over): the new law
        # gives the last output on the last cycle's signals, and acts from this cycle on
        sgn_old = 1.0
        if rev_prev:
            sgn_old = -1.0
        p_old = 0.0
        if not suppressed:
            p_old = k_prev * sgn_old * (b_prev * sp_w - pv_f)
        ki_old = 0.0
        if ti_prev > 0.0:
            ki_old = k_prev / ti_prev
        sgn_new = 1.0
        if reverse:
            sgn_new = -1.0
        ki_new = 0.0
        if ti > 0.0:
            ki_new = k / ti
        i_r, bias_r, p_r, d_r, w_r, e_r = retune_states(
            sp_w, pv_f, p_old, d, i, bias, x, ff_prev, k, sgn_new, b, c, k * td, ki_new,
            ki_old, velocity, suppressed,
        )  # fmt: skip
        if is_real(i_r) and is_real(bias_r) and is_real(p_r) and is_real(w_r) and is_real(e_r):
            d = d_r
            w_prev = w_r
            e_prev = e_r
            if velocity:
                bias = bias_r
                p_prev = p_r
                d_prev = d_r
            else:
                i = i_r
        else:
            reinit = True  # the shift overflows REAL: hold one cycle instead
    k_prev = k
    ti_prev = ti
    td_prev = td
    n_prev = n
    b_prev = b
    c_prev = c
    rev_prev = reverse
    vel_prev = velocity
    scale_prev = scale_pv
    pv_lo_prev = pv_lo
    pv_hi_prev = pv_hi
    db = abs(db_width)
    db_ok = True
    if db > 0.0:
        db_win, db_ok = deadband_window(t_stab, ts, len(db_buf), db_win)
        if db_ok:
            db_t = t_stab
    mode = pid_mode(rst, track, hold, manual)
    # the law's parameters of this cycle (PID._set_h): pid_parameters, tracking_time
    (k_p, sgn, b_p, c_p, ad, bd, ki_h, alpha, beta, lo_p, hi_p, aw_p,
     g) = pid_parameters(k, ti, td, n, b, c, ts, lo, hi, reverse, d_method, i_method,
                         float(aw), tracking_time(tt, ti, ts))  # fmt: skip
    prm = (k_p, sgn, b_p, c_p, ad, bd, ki_h, alpha, beta, lo_p, hi_p, aw_p, g)
    vel = 0.0
    if velocity:
        vel = 1.0
    opt = (vel, dev_tol, out_rate * ts, db, i_band)
    # the input stage's coefficients of this cycle (the filters' poles, the lead-lag's)
    a_sp = pt1_coefficient(sp_filter, ts, "exact")
    a_pv = pt1_coefficient(pv_filter, ts, "exact")
    ff_on = ff_k != 0.0
    ll_b0 = 0.0
    ll_b1 = 0.0
    ll_a1 = 0.0
    if ff_on:
        ll_b0, ll_b1, ll_a1 = leadlag_coefficients(ff_k, ff_t_lead, ff_t_lag, ts, True)
    # the process data of the cycle and the law (pid.pid_compute, the block's too)
    (mv, err, ok, law_ok, limits_active, _limiting, v_raw, p_k, i_k, i_shown, d_k, w_k, e_k,
     bias_k, ff_tot, supp_k, held, sp_f, pv_f, sp_w, _sp_ramping, ll_out, ll_x) = pid_compute(
        sp, pv, ff, dv, pv_ok, mode, man_value, track_value, reset_value, use_safe, safe_value,
        out, ramp_out, scale_pv, pv_lo, pv_hi, a_sp, a_pv, sp_rate, ff_on, ll_b0, ll_b1, ll_a1,
        bumpless, ts, cold, reinit, reinit_d, mode_prev, suppressed, awin, db_active, db_hold, i,
        d, w_prev, e_prev, x, bias, p_prev, d_prev, ff_prev, sp_f, pv_f, sp_w, False, ll_out,
        ll_x, prm, opt, REAL_MAX,
    )  # fmt: skip
    # the terms shown (P, I_TERM, D_TERM) are those of the last cycle that ran the law: a
    # cycle that holds (bad input, bad mode value) shows them unchanged, as the block does
    d_term = d
    overflow = ok and not law_ok
    ramp_out = mv
    if overflow:
        # the law overflowed REAL (PID._resume): an overflowed law holds the output (or the
        # safe value: pid_compute); a memory that overflowed behind an output that did not
        # need it (a mode's target) lets this cycle's output stand; the memory is made finite
        # and the next good cycle restarts bumplessly from MV (pid.pid_restart)
        i, x, bias, d, w_prev, e_prev, p_prev, d_prev, ff_prev = pid_restart(
            mv, d_k, w_k, e_k, p_prev, d_prev, ff_prev, REAL_MAX
        )
        p = valid_or_zero(p_k, REAL_MAX)
        i_term = valid_or_zero(i_shown, REAL_MAX)
        d_term = valid_or_zero(d_k, REAL_MAX)
        limits_active = False
        reinit = True
        reinit_d = True
        db_hold = mv
        db_active = False
        if mode != MANUAL:
            man_value = mv  # In/Out: outside MANUAL the manual value follows the output
    else:
        # the commit with the applied value = MV (pid.pid_update, the block's too)
        (man_value, i, x, bias, d, w_prev, e_prev, p_prev, d_prev, ff_prev, suppressed, cold,
         reinit, reinit_d, db_active, feed, latch, _steady, st_anchor, st_elapsed,
         st_started) = pid_update(
            mv, mv, ok, mode, man_value, v_raw, p_k, i_k, d_k, w_k, e_k, ff_tot, bias_k, supp_k,
            held, actuator_pos, ki_h, aw_p, g, vel, db, db_t, ts, i, x, bias, d, w_prev, e_prev,
            p_prev, d_prev, ff_prev, suppressed, cold, reinit, reinit_d, db_active, False,
            st_anchor, st_elapsed, st_started, REAL_MAX,
        )  # fmt: skip
        if ok:
            p = p_k
            i_term = i_shown
            d_term = d_k
        if feed:
            # the dead band's moving average of the applied output (an ARRAY: an instance)
            (db_mean, db_buf, ma_idx, ma_count, ma_since, ma_total, ma_spread, ma_mag,
             ma_n) = moving_average(
                mv, db_win, SUM_LOSS_REAL, db_mean, db_buf, ma_idx, ma_count, ma_since,
                ma_total, ma_spread, ma_mag, ma_n,
            )  # fmt: skip
            if latch:
                db_hold = db_mean
    if err == NO_ERROR:
        err = lim_err
    if err == NO_ERROR and db > 0.0 and not db_ok:
        err = BAD_STAB_TIME
    if overflow:
        err = BAD_RESULT
    out = mv
    mode_prev = mode
    return (
        mv, err, limits_active, man_value, p, i_term, d_term,
        out, i, d, w_prev, e_prev, x, bias, p_prev, d_prev, ff_prev,
        sp_f, pv_f, sp_w, ll_x, ll_out, suppressed, ramp_out, lo, hi, mode_prev,
        cold, reinit, reinit_d, k_prev, ti_prev, td_prev, n_prev, b_prev,
        c_prev, rev_prev, vel_prev, scale_prev, pv_lo_prev, pv_hi_prev,
        db_active, db_hold, db_win, db_t, db_mean, db_buf, ma_idx, ma_count,
        ma_since, ma_total, ma_spread, ma_mag, ma_n, st_anchor, st_elapsed, st_started,
    )  # fmt: skip


# ---------------------------------------------------------------------------
# ADRC
# ---------------------------------------------------------------------------

ADRC_RESULTS = (
    "mv", "error_id", "awout", "u_raw", "u_man", "x4_out", "e_out", "y_out", "y_ref",
    "x1_out", "x2_out", "x3_out", "sp_td",
    "out", "yh", "x2", "x3", "x4", "u_prev", "ff_prev", "ref", "q", "e", "y_last", "started",
    "resolve",
    "sat", "ab_sat",
    "ab_wait", "lo", "hi", "tuned", "order_prev", "b0_prev", "wc_prev", "wo_prev", "ts_prev",
    "exact_prev", "rev_prev", "u_buf", "d_idx", "nd_prev", "d_restart", "sp_f", "pv_f",
    "sp_w", "scale_prev", "pv_lo_prev", "pv_hi_prev", "td1", "td2", "td3", "td_time_prev",
)  # fmt: skip
"""Names of the values :func:`adrc_cycle` returns: outputs, then the new state."""

EULER_LIMIT_1 = EULER_LIMIT[1]
EULER_LIMIT_2 = EULER_LIMIT[2]
EULER_LIMIT_3 = EULER_LIMIT[3]
EULER_LIMIT_4 = EULER_LIMIT[4]
WARN_DISCRETISATION = int(ErrorCode.WARN_DISCRETISATION)


def law_gains(
    n: int, b0: float, omega_c: float, omega_o: float, ts: float, exact: bool
) -> tuple[float, float, float]:
    """The control law's gains ``(kp, kd1, kd2)`` of (4b) for a tuning (Euler or exact)."""
    if exact:
        (_f01, _f02, _f03, _f12, _f13, _f23, _g0, _g1, _g2, _c0, _c1, _c2, _c3, kp, kd1,
         kd2) = exact_coefficients(n, b0, omega_c, omega_o, ts)  # fmt: skip
        return kp, kd1, kd2
    _l1, _l2, _l3, _l4, kp, kd1, kd2 = bandwidth_gains(n, omega_c, omega_o)
    return kp, kd1, kd2


def discretisation_ok(n: int, omega_c: float, omega_o: float, ts: float, exact: bool) -> bool:
    """:func:`.adrc.discretisation_trusted` with its table spelled out (False: 16#8301)."""
    if exact:
        return omega_o * ts <= EXACT_LIMIT and omega_c * ts <= EXACT_LIMIT
    lim_o = EULER_LIMIT_4
    lim_c = EULER_LIMIT_3
    if n == 1:
        lim_o = EULER_LIMIT_2
        lim_c = EULER_LIMIT_1
    elif n == 2:
        lim_o = EULER_LIMIT_3
        lim_c = EULER_LIMIT_2
    return omega_o * ts <= lim_o and omega_c * ts <= lim_c


def adrc_cycle(
    sp: float,
    y: float,
    ff: float,
    y_ok: bool,
    manual: bool,
    u_man: float,
    track: bool,
    track_value: float,
    hold: bool,
    rst: bool,
    awin: bool,
    u_real: float,
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
    exact: bool,
    u_real_on: bool,
    anti_backoff: bool,
    y_sat: float,
    y_sat_lo: float,
    tau_wait: float,
    reverse: bool,
    nd: int,
    out_rate: float,
    u0: float,
    scale_pv: bool,
    pv_lo: float,
    pv_hi: float,
    sp_filter: float,
    pv_filter: float,
    sp_rate: float,
    td_time: float,
    out: float,
    yh: float,
    x2: float,
    x3: float,
    x4: float,
    u_prev: float,
    ff_prev: float,
    ref: float,
    q: float,
    e: float,
    y_last: float,
    started: bool,
    resolve: bool,
    sat: int,
    ab_sat: int,
    ab_wait: float,
    lo: float,
    hi: float,
    tuned: bool,
    order_prev: int,
    b0_prev: float,
    wc_prev: float,
    wo_prev: float,
    ts_prev: float,
    exact_prev: bool,
    rev_prev: bool,
    u_buf: list[float],
    d_idx: int,
    nd_prev: int,
    d_restart: bool,
    sp_f: float,
    pv_f: float,
    sp_w: float,
    scale_prev: bool,
    pv_lo_prev: float,
    pv_hi_prev: float,
    td1: float,
    td2: float,
    td3: float,
    td_time_prev: float,
) -> tuple[Any, ...]:
    """One cycle of the ADRC (:class:`~ctrlblocks.ADRC`, orders 1..3 in one body).

    The process data of the cycle -- scaling, the judgement of SP, PV, FF and the
    modes, the input stage, the tracking differentiator, reverse action, the law,
    the observer's restart, the output ramp, the status -- is the block's own
    function :func:`.adrc.adrc_compute`; this cycle adds what a PLC needs beyond the
    block: the changes of its configuration inputs, detected in the cycle (the block
    gets them through ``configure``), the coefficients every cycle, the delay line
    (restarted after a failed law, as the block's ``_resume`` restarts its history)
    and the commit of its own output.

    ``rst``, ``track``/``track_value`` and ``hold`` are the PID's RESET, TRACK and HOLD
    modes (priority RESET > TRACK > HOLD > MANUAL, :func:`.adrc.mode_output`: the output
    is ``u0`` at once, the tracking value, the last applied u, the manual value; the law
    tracks it as in MAN).  The PID's input stage runs first (:func:`.adrc.input_stage`):
    SP and PV scaled from ``pv_lo..pv_hi`` to 0..100 % (``scale_pv``; ``y_sat`` and
    ``y_sat_lo`` with them; a change of the range restarts the ESO at rest, x4 by (11)),
    the SP and PV filters and the setpoint ramp, then the tracking differentiator
    (:func:`.adrc.tracking_differentiator`, ``td_time``; states ``td1..td3``) whose
    ``r_eff`` is the law's reference.  ``ff`` is the feed-forward, added to the
    law's output before the limits;
    the ESO is fed the applied u less the ff of its cycle (``ff_prev``;
    :func:`~ctrlblocks.blocks.adrc.adrc_law`); a NaN/inf ``ff`` holds the output
    as a bad SP does (16#8101) and keeps the last one.  ``out_rate`` (0: off) is the
    PID's output ramp (:func:`~ctrlblocks.blocks.pid.pid_output`) after the limits.
    ``aw_rule`` 0 off, 1 freeze, 2 directional (section 4.1); ``exact`` the
    ZOH current observer instead of the Euler ESO (4a); ``u_real_on``: the
    measured actuator value ``u_real`` drives the ESO (section 5; a NaN falls
    back to u, 16#8101); ``anti_backoff`` (12a)/(12b) with ``y_sat``,
    ``y_sat_lo`` and ``tau_wait`` (0: 3.5/omega_o); ``reverse``: a reverse-acting
    process, the cycle runs on -sp and -y (``ADRCConfig.reverse``; ``y_sat`` and
    ``y_sat_lo`` stay in the units of y), and a change of ``reverse`` negates the
    states and re-solves x4 by (11), bumplessly.  The status
    ``WARN_DISCRETISATION`` (16#8301) when omega ts leaves the trusted range;
    a law that overflows REAL holds the output and restarts the ESO
    (16#8103, :func:`.adrc.adrc_compute`), as the block does.  ``nd``: the dead time of the
    process input in samples (``ADRCConfig.input_delay``): the ESO is fed the
    applied u of ``nd`` samples before the last one (Zhao & Gao 2014), from the
    line :func:`delay_line` (its array sized at export; a longer ``nd`` is
    refused with ``BAD_TIME_CONSTANT`` and the one in force stays).  Returns :data:`ADRC_RESULTS`.
    """
    lim_err = NO_ERROR
    if u_min <= u_max:
        lo = u_min
        hi = u_max
    else:
        lim_err = BAD_LIMITS
    out = clamp(out, lo, hi)  # new limits contain the last output (ADRC.set_limits)
    retuned = tuned and (
        order != order_prev
        or b0 != b0_prev
        or omega_c != wc_prev
        or omega_o != wo_prev
        or ts != ts_prev
        or exact != exact_prev
    )
    u_keep = 0.0
    if retuned:
        # bumpless retuning (ADRC._retune): the old law's value on the last states
        kp_o, kd1_o, kd2_o = law_gains(order_prev, b0_prev, wc_prev, wo_prev, ts_prev,
                                       exact_prev)  # fmt: skip
        u_keep = control_law(ref + q, yh, x2, x3, x4, b0_prev, kp_o, kd1_o, kd2_o)
        if order < 3:
            x3 = 0.0
        if order < 2:
            x2 = 0.0
    # the tracking differentiator (ADRC._td_retune): a new TD_TIME or ORDER restarts its
    # chain on its r_f and the derivatives its states carry (td_restart); a change of
    # r_eff's weights re-solves the handover offset (not TS: a jitter is no retune)
    td_retuned = False
    if tuned and (td_time > 0.0 or td_time_prev > 0.0):
        td_new = td_time != td_time_prev or order != order_prev
        if td_new:
            td1, td2, td3 = td_restart(order_prev, td_time_prev, order, td_time, sp_w, td1,
                                       td2, td3)  # fmt: skip
        td_retuned = (td_new or b0 != b0_prev or omega_c != wc_prev or omega_o != wo_prev
                      or exact != exact_prev)  # fmt: skip
    td_time_prev = td_time
    tuned = True
    order_prev = order
    b0_prev = b0
    wc_prev = omega_c
    wo_prev = omega_o
    ts_prev = ts
    exact_prev = exact
    # coefficients of this cycle (ADRC._coefficients)
    p1, p2, k1, k2, k3 = adrc_switches(order)
    l1, l2, l3, l4, kp, kd1, kd2 = bandwidth_gains(order, omega_c, omega_o)
    nsub = 1.0
    if not exact:
        nsub = euler_substeps(order, omega_o, ts)
    h_sub = ts
    if nsub > 1.0:
        h_sub = ts / nsub
    s_x3, s_x2, s_yh = euler_sensitivities(h_sub, p1, p2, k1, k2, k3)
    if exact:
        (f01, f02, f03, f12, f13, f23, g0, g1, g2, c0, c1, c2, c3, kp, kd1,
         kd2) = exact_coefficients(order, b0, omega_c, omega_o, ts)  # fmt: skip
        s_x3 = 0.0  # the current observer does not pass x4_i on
        s_x2 = 0.0
        s_yh = 0.0
    else:
        f01, f02, f03, f12, f13, f23 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        g0, g1, g2, c0, c1, c2, c3 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    s_u = -(1.0 + kp * s_yh + kd1 * s_x2 + kd2 * s_x3) / b0
    if retuned:
        # x4 so that the new law gives u_keep on them (retune_x4); (11) where it cannot
        x4_new = retune_x4(ref + q, yh, x2, x3, u_keep, b0, kp, kd1, kd2)
        if started and not resolve and is_real(x4_new):
            x4 = x4_new
        else:
            resolve = True
    if td_retuned:
        resolve = True
    a_ref = pt1_coefficient(t_ref, ts, "exact")
    a_q = handover_pole(omega_c, ts)
    prm = (ts, b0, l1, l2, l3, l4, p1, p2, k1, k2, k3, kp, kd1, kd2, s_yh, s_x2, s_x3, s_u,
           lo, hi, float(aw_rule), a_ref, a_q, nsub)  # fmt: skip
    ecoef = (f01, f02, f03, f12, f13, f23, g0, g1, g2, c0, c1, c2, c3)
    tau = tau_wait
    if tau_wait <= 0.0:
        tau = 3.5 / omega_o
        if not is_real(tau):
            tau = REAL_MAX  # omega_o of a subnormal: the wait saturates
    if reverse != rev_prev:
        # reverse changed (ADRC._reverse_states): the states in the units of y change sign,
        # x4 is re-solved by (11) in this cycle, so u continues from the last one
        yh = -yh
        x2 = -x2
        x3 = -x3
        x4 = -x4
        ref = -ref
        q = -q
        e = -e  # the held e and Y of Fig. 2 too (a bad SP or PV in this cycle keeps them)
        y_last = -y_last
        ab_sat = -ab_sat
        resolve = True
    rev_prev = reverse
    if scale_pv != scale_prev or (scale_pv and (pv_lo != pv_lo_prev or pv_hi != pv_hi_prev)):
        # the PV range changed (ADRC._restart_units): the states were in the old units; the
        # ESO restarts at rest on the next valid PV, x4 by (11), so u continues
        started = False
        resolve = True
    scale_prev = scale_pv
    pv_lo_prev = pv_lo
    pv_hi_prev = pv_hi
    sat_hi = y_sat
    sat_lo = y_sat_lo
    if scale_pv:
        # the sensor's saturation in % of the PV range, as SP and PV (adrc_compute); one at
        # +-REAL_MAX (or inf) is none and stays one: scaled, it would overflow REAL (a
        # floating-point exception on a PLC that traps them) on every cycle
        if abs(y_sat) < REAL_MAX:
            sat_hi = scale(y_sat, pv_lo, pv_hi, 0.0, 100.0)
        if abs(y_sat_lo) < REAL_MAX:
            sat_lo = scale(y_sat_lo, pv_lo, pv_hi, 0.0, 100.0)
    if reverse:
        # a reverse-acting process: the cycle runs on -sp and -y (ADRCConfig.reverse)
        sat_old = sat_hi
        sat_hi = -sat_lo
        sat_lo = -sat_old
    ab = (sat_hi, sat_lo, tau)
    # the ESO's input: the applied u less its feed-forward, of nd samples before the last
    # one (ADRC.input_delay)
    u_eso, u_buf, d_idx, nd_prev, delay_ok = delay_line(u_prev - ff_prev, nd, d_restart, u_buf,
                                                        d_idx, nd_prev)  # fmt: skip
    d_restart = False
    # the configuration's status, below the process data's (ADRC: limits, then the warning)
    status = lim_err
    if status == NO_ERROR and not delay_ok:
        status = BAD_TIME_CONSTANT  # a delay beyond the exported array: the one in force stays
    if status == NO_ERROR and not discretisation_ok(order, omega_c, omega_o, ts, exact):
        status = WARN_DISCRETISATION
    # the process data of the cycle around the law (adrc.adrc_compute), as the block runs it
    opt = (u0, u_sf, pv_lo, pv_hi, sp_filter, pv_filter, sp_rate, out_rate, td_time, REAL_MAX)
    (mv, u_raw, err, e, y_last, sp_td, _td_d1, _td_d2, _td_d3, yh, x2, x3, x4, ref, started,
     resolve, sat, ab_sat, ab_wait, q, ff, sp_f, pv_f, sp_w, td1, td2, td3,
     failed) = adrc_compute(
        sp, y, ff, y_ok, rst, track, hold, manual, awin, track_value, u_man, scale_pv, order,
        reverse, exact, anti_backoff, status, out, u_prev, ff_prev, u_eso, yh, x2, x3, x4, ref,
        q, started, resolve, sat, ab_sat, ab_wait, e, y_last, sp_f, pv_f, sp_w, td1, td2, td3,
        opt, prm, ecoef, ab,
    )  # fmt: skip
    if failed:
        d_restart = True  # the delay line restarts at the held output (ADRC._resume)
    u_prev = mv
    if u_real_on:
        if is_real(u_real):
            u_prev = u_real  # the measured actuator value drives the ESO (section 5)
        elif err in (NO_ERROR, WARN_DISCRETISATION):
            err = BAD_INPUT
    ff_prev = ff
    if not manual:
        u_man = u_prev  # In/Out: outside MAN the manual value follows the applied u
    out = mv
    # the outputs of Fig. 2 (Nowak et al. 2018, section 5) in the units of PV: e, Y, Y_ref
    # (the reference trajectory) and the ESO state (in the cycle's units)
    sgn = 1.0
    if reverse:
        sgn = -1.0
    return (
        mv, err, sat != 0, u_raw, u_man, x4, sgn * e, sgn * y_last, sgn * ref, yh, x2, x3, sp_td,
        out, yh, x2, x3, x4, u_prev, ff_prev, ref, q, e, y_last, started, resolve, sat, ab_sat,
        ab_wait, lo, hi,
        tuned, order_prev, b0_prev, wc_prev, wo_prev, ts_prev, exact_prev, rev_prev,
        u_buf, d_idx, nd_prev, d_restart, sp_f, pv_f, sp_w, scale_prev, pv_lo_prev, pv_hi_prev,
        td1, td2, td3, td_time_prev,
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
    out = clamp(out, lo, hi)  # new limits contain the last output (the block's configure)
    x_ok = is_real(x)
    if not x_ok:
        err = BAD_INPUT
    # the lead-lag's one cycle (leadlag.leadlag_law), as the block runs it
    b0, b1, a1 = leadlag_coefficients(k, t_lead, t_lag, ts, tustin)
    out, x_prev = leadlag_law(x, x_ok, enable, out, x_prev, b0, b1, a1, lo, hi)
    return out, err, x_prev, lo, hi


# ---------------------------------------------------------------------------
# float32 execution
# ---------------------------------------------------------------------------


_MATH32 = types.SimpleNamespace(
    exp=real_exp,
    sqrt=real_sqrt,
    log=real_ln,
    isfinite=lambda x: bool(np.isfinite(x)),
    inf=np.float32(np.inf),
    nan=np.float32(np.nan),
    pi=np.float32(math.pi),
)
"""The ``math`` functions the cycles use, as a PLC's REAL EXP, SQRT, LN: each DEFINED as the
float64 function rounded once to float32 (:func:`.precision.real_exp`)."""


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

_PID_AW = {"clamping": 0, "back_calc_model": 1, "back_calc_real": 2}
_BUMPLESS = ("integrator", "track_setpoint", "suppress_p_action")
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
        "velocity": config.algorithm == "velocity",
        **_input_stage(config), "out_rate": float(config.out_rate),
        "ff_k": float(config.ff_k), "ff_t_lead": float(config.ff_t_lead),
        "ff_t_lag": float(config.ff_t_lag),
        "bumpless": _BUMPLESS.index(config.bumpless), "dev_tol": float(config.dev_tol),
        "reset_value": float(config.reset_value),
        "safe_value": float(config.safe_value) if config.safe_value is not None else 0.0,
        "use_safe": config.safe_value is not None,
        "db_width": float(config.deadband), "t_stab": float(config.t_stab),
        "i_band": float(config.i_band),
    }  # fmt: skip


def _input_stage(config: Any) -> dict[str, Any]:
    """The inputs of the input stage (PV range, SP/PV filters, SP ramp): PID's and ADRC's."""
    rng = config.pv_range if config.pv_range is not None else (0.0, 100.0)
    return {
        "scale_pv": config.pv_range is not None, "pv_lo": float(rng[0]), "pv_hi": float(rng[1]),
        "sp_filter": float(config.sp_filter), "pv_filter": float(config.pv_filter),
        "sp_rate": float(config.sp_rate),
    }  # fmt: skip


def pid_state(config: Any) -> dict[str, Any]:
    """The state of :func:`pid_cycle` after a reset (PID.reset).

    The dead band's array holds the configured window ``round(t_stab/ts)``: the
    longest the PLC can retune to (:func:`deadband_window`).
    """
    lo, hi = float(config.u_min), float(config.u_max)
    u0 = clamp(float(config.reset_value), lo, hi)
    window = max(1, round(config.t_stab / config.ts))
    return {
        "out": u0, "p": 0.0, "i_term": float(config.reset_value), "i": float(config.reset_value),
        "d": 0.0, "w_prev": 0.0, "e_prev": 0.0, "x": u0, "bias": float(config.reset_value),
        "p_prev": 0.0, "d_prev": 0.0, "ff_prev": 0.0, "sp_f": 0.0, "pv_f": 0.0, "sp_w": 0.0,
        "ll_x": 0.0, "ll_out": 0.0, "suppressed": False, "ramp_out": u0,
        "lo": lo, "hi": hi, "mode_prev": NO_MODE,
        "cold": True, "reinit": False, "reinit_d": False, "k_prev": 0.0, "ti_prev": 0.0,
        "td_prev": 0.0, "n_prev": 0.0, "b_prev": 0.0, "c_prev": 0.0, "rev_prev": False,
        "vel_prev": False, "scale_prev": False, "pv_lo_prev": 0.0, "pv_hi_prev": 0.0,
        "db_active": False, "db_hold": u0, "db_win": window, "db_t": float(config.t_stab),
        "db_mean": 0.0, "db_buf": [0.0] * window, "ma_idx": 0, "ma_count": 0, "ma_since": 0,
        "ma_total": 0.0, "ma_spread": 0.0, "ma_mag": 0.0, "ma_n": 0, "st_anchor": 0.0,
        "st_elapsed": 0.0, "st_started": False,
    }  # fmt: skip


def adrc_inputs(config: Any) -> dict[str, Any]:
    """The tuning inputs of :func:`adrc_cycle` for an ADRCConfig."""
    return {
        "order": int(config.order), "b0": float(config.b0), "omega_c": float(config.omega_c),
        "omega_o": float(config.omega_o), "ts": float(config.ts),
        "u_min": float(config.u_min), "u_max": float(config.u_max),
        "t_ref": float(config.t_ref), "u_sf": float(config.u_sf),
        "aw_rule": _ADRC_AW[config.anti_windup], "exact": config.discretisation == "exact",
        "u_real_on": bool(config.u_real_on), "anti_backoff": bool(config.anti_backoff),
        "y_sat": float(config.y_sat), "y_sat_lo": float(config.y_sat_lo),
        "tau_wait": float(config.tau_wait), "reverse": bool(config.reverse),
        "nd": _adrc.delay_samples(config.input_delay, config.ts),
        "out_rate": float(config.out_rate), "u0": float(config.u0), **_input_stage(config),
        "td_time": float(config.td_time),
    }  # fmt: skip


def adrc_state(config: Any) -> dict[str, Any]:
    """The state of :func:`adrc_cycle` after a reset (ADRC.reset).

    The delay line's array holds the configured ``input_delay`` in samples and the
    last applied u: the longest delay the PLC can retune to.  The line starts empty
    (its instance's zeros); the first cycle fills it with the output, as ``reset``.
    """
    lo, hi = float(config.u_min), float(config.u_max)
    u0 = clamp(float(config.u0), lo, hi)
    nd = _adrc.delay_samples(config.input_delay, config.ts)
    stage = _input_stage(config)
    return {
        "out": u0, "yh": 0.0, "x2": 0.0, "x3": 0.0, "x4": 0.0, "u_prev": u0, "ff_prev": 0.0,
        "ref": 0.0,
        "q": 0.0, "e": 0.0, "y_last": 0.0, "started": False, "resolve": False, "sat": 0,
        "ab_sat": 0, "ab_wait": 0.0, "lo": lo, "hi": hi, "tuned": False, "order_prev": 0,
        "b0_prev": 0.0, "wc_prev": 0.0, "wo_prev": 0.0, "ts_prev": 0.0, "exact_prev": False,
        "rev_prev": bool(config.reverse), "u_buf": [0.0] * (nd + 1), "d_idx": 0, "nd_prev": 0,
        "d_restart": False, "sp_f": 0.0, "pv_f": 0.0, "sp_w": 0.0,
        "scale_prev": stage["scale_pv"], "pv_lo_prev": stage["pv_lo"],
        "pv_hi_prev": stage["pv_hi"], "td1": 0.0, "td2": 0.0, "td3": 0.0,
        "td_time_prev": float(config.td_time),
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
) -> dict[str, Any] | None:
    """One float32 cycle of ``block``: its state in ``block._plc_state`` (None after reset);
    None (nothing ran) when the sample time is no finite REAL > 0 (:func:`cycle_time_ok`)."""
    state = block.__dict__.get("_plc_state")
    if state is None:
        state = real_args(initial(block.config))
    # The block's edge (blocks/base.py): process values and the attribute inputs
    # (manual value) become floats once, anything unusable NaN; flags stay bools.
    process = {k: v if type(v) is bool else as_input(v) for k, v in inputs.items()}
    args = {**real_args(process), **real_args(config_inputs), **state}
    if not cycle_time_ok(args["ts"]):
        return None  # the sample time as a REAL is unusable: the FB's guard holds everything
    res = dict(zip(names, run_float32(fn, **args), strict=True))
    block._plc_state = {k: res[k] for k in state}
    return res


def _no_cycle(block: Any) -> float:
    """A cycle time beyond REAL's range (a PLC's TS cannot carry it): hold, ``NO_CYCLE``."""
    block.error_id = ErrorCode.NO_CYCLE
    return float(block.out)


def pid_float32(
    pid: Any, sp: float, pv: float, ff: float, pv_ok: bool, dt: float | None, dv: float = 0.0
) -> float:
    """The cycle of a PID with ``precision="float32"``: :func:`pid_cycle` in REAL."""
    prm = pid_inputs(pid.config)
    if dt is not None:
        if not float(dt) <= REAL_MAX:
            return _no_cycle(pid)
        prm["ts"] = float(dt)
    res = _lane(pid, pid_cycle, PID_RESULTS, {
        "sp": sp, "pv": pv, "ff": ff, "dv": dv, "pv_ok": bool(pv_ok), "manual": bool(pid.manual),
        "man_value": pid.manual_value, "rst": bool(pid.reset_active), "track": bool(pid.track),
        "track_value": pid.track_value, "hold": bool(pid.hold), "awin": bool(pid.awin),
        "actuator_pos": pid.actuator_pos}, prm, pid_state)  # fmt: skip
    if res is None:
        pid.error_id = ErrorCode.NO_CYCLE
        return pid.out  # type: ignore[no-any-return]
    pid.out = float(res["mv"])
    pid.error_id = ErrorCode(res["error_id"])
    pid.limits_active = bool(res["limits_active"])
    pid.manual_value = float(res["man_value"])
    pid.p, pid.i, pid.d = float(res["p"]), float(res["i_term"]), float(res["d_term"])
    return pid.out


def adrc_float32(
    adrc: Any, sp: float, y: float, y_ok: bool, dt: float | None, u_real: float | None = None,
    ff: float = 0.0,
) -> float:
    """The cycle of an ADRC with ``precision="float32"``: :func:`adrc_cycle` in REAL."""
    prm = adrc_inputs(adrc.config)
    prm["u_min"], prm["u_max"] = adrc.u_min, adrc.u_max  # as written by set_limits
    if dt is not None:
        if not float(dt) <= REAL_MAX:
            return _no_cycle(adrc)
        prm["ts"] = float(dt)
    res = _lane(adrc, adrc_cycle, ADRC_RESULTS, {
        "sp": sp, "y": y, "ff": ff, "y_ok": bool(y_ok), "manual": bool(adrc.manual),
        "track": bool(adrc.track), "track_value": adrc.track_value, "hold": bool(adrc.hold),
        "rst": bool(adrc.reset_active), "u_man": adrc.u_man, "awin": bool(adrc.awin),
        "u_real": math.nan if u_real is None else u_real}, prm, adrc_state)  # fmt: skip
    if res is None:
        adrc.error_id = ErrorCode.NO_CYCLE
        return adrc.out  # type: ignore[no-any-return]
    adrc.out = float(res["mv"])
    adrc.error_id = ErrorCode(res["error_id"])
    adrc.awout = bool(res["awout"])
    adrc.u_raw = float(res["u_raw"])
    adrc.u_man = float(res["u_man"])
    # the outputs of Fig. 2 as the exported FB has them (ADRC.e, y, y_ref, x)
    adrc.e, adrc.y, adrc.y_ref = float(res["e_out"]), float(res["y_out"]), float(res["y_ref"])
    adrc._yh, adrc._x2, adrc._x3 = (float(res[k]) for k in ("x1_out", "x2_out", "x3_out"))
    adrc._x4 = float(res["x4_out"])
    adrc.ff = adrc._ff_prev = float(res["ff_prev"])
    adrc.sp_w = float(res["sp_w"])
    adrc.sp_td = float(res["sp_td"])
    return adrc.out


def leadlag_float32(ll: Any, x: float, enable: bool, dt: float | None) -> float:
    """The sample of a LeadLag with ``precision="float32"``: :func:`leadlag_cycle` in REAL."""
    prm = leadlag_inputs(ll.config)
    if dt is not None:
        if not float(dt) <= REAL_MAX:
            return _no_cycle(ll)
        prm["ts"] = float(dt)
    res = _lane(
        ll, leadlag_cycle, LEADLAG_RESULTS, {"x": x, "enable": bool(enable)}, prm, leadlag_state
    )
    if res is None:
        ll.error_id = ErrorCode.NO_CYCLE
        return ll.out  # type: ignore[no-any-return]
    ll.out = float(res["out"])
    ll.error_id = ErrorCode(res["error_id"])
    ll.enabled = bool(enable)
    return ll.out


CYCLES.update(pid=pid_float32, adrc=adrc_float32, leadlag=leadlag_float32)
