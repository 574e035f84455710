"""The simulator's loops on the compiled lane: controllers, actuator, plant(s), sensor.

:func:`lane_loop` runs what :func:`ctrlblocks.sim.simulate` does for one of
the structures it has a *wiring* for (:data:`WIRINGS`), sample for sample and
in the same order of floating point operations, over arrays: the
controllers' warm-up in manual (the plant held in its steady state), then
``n`` recorded samples in Åström's computational order (Åström 1987,
section 6, Listing 6.3)::

    y[k]  = plant.y + load_out[k]                       (Sensor.y_true)
    ym[k] = clamp(y[k] + noise[k], y_min, y_max)        (Sensor.y)
    u[k]  = controllers(sp[k], ym[k], y2[k], ...)        (ComputeOutput, ShapeOutput)
            every controller commits with its applied value (UpdateState)
    u_act[k] = clamp(clamp(u[k] + load_in[k], u_act[k-1] -+ rate ts), u_min, u_max)
    plant.step(u_act[k])                                (Actuator, then the model)

The wirings (``ctrlblocks.loops.structures``, ``Structure.compiled_lane``):

``single``
    one PID or ADRC.
``feedforward``
    the input load (the measured disturbance) through a lead-lag
    (:func:`~ctrlblocks.blocks.leadlag.leadlag_step`, Bonde et al. 2021,
    Fig. 10) into the PID's ``ff``.
``smith``
    the controller sees ``ym + y_model_fast - y_model`` (Nowak et al. 2018,
    section 3.1); both models advance with the controller output.
``cascade``
    the primary's output is the secondary's setpoint; the secondary (on
    ``y2``, the inner plant's output) writes the MV; its ``awout`` freezes
    the primary's integrator in the next sample (``awin``, Åström 1987,
    section 3 "Cascade Control"); while the secondary is in manual the
    primary (in auto) tracks ``y2``; while ``y2`` is bad (its quality flag
    false or NaN: the scenario's ``sensor`` events on ``y2``) it holds its
    last output (``Cascade.follow_value``) and the secondary runs its
    bad-measurement cycle (:func:`_bad`: the safe value, or the last
    output held; the manual value in manual), as the blocks do.
``override``
    two controllers (each on ``y`` or ``y2``, on ``sp`` or a fixed setpoint);
    a min or max selector picks the MV and both track it (Åström 1987,
    Figs. 3.8/3.9).

Series plants (cascade, override) are coupled with a zero-order hold as in
``ProcessSide.step``: the outer plant receives the inner plant's output of
the start of the sample plus the load between them.

The controllers are the blocks' own kernels (:func:`~ctrlblocks.fast.kernels.pid_step`,
:func:`~ctrlblocks.fast.kernels.adrc_step`), the plants the kernels of
:mod:`.loops` (a linear plant of order <= 3 with any dead time, or the
three-tank process).  A controller whose applied value is not its own
output (an override's tracking) commits with :func:`_commit`: the
integrator tracks the applied value as ``PID.update_state`` does (Åström
1987, Fig. 3.6), the ADRC's ESO takes it as its input (``ADRC.update_state``).
The caller (``ctrlblocks.sim.dispatch``) turns the scenario's events into
the per-sample arrays and draws the noise with the scenario's own
generator, so the traces equal the Python path's.

The scenario's faults of the measurements (``sensor`` events) arrive as
quality flags per sample: while ``y`` is bad (flagged, or NaN: ``ym`` is
then recorded NaN) every controller on it runs its bad-measurement cycle
(:func:`_bad`, the blocks' rule with ``pv_ok`` false), an override's blocks
all of them while ``y`` or ``y2`` is bad; the cascade's bad ``y2`` makes
the primary hold.  ``limits`` events arrive as the limits in force of every
controller and sample (:func:`_set_limits`).  A sample whose true
measurement or controller output is not finite, or whose control law's
result before the limits is not (a PID's ``v_raw``, an ADRC's ``u_raw``:
the limited output may still be finite), is where the two paths could part
(the blocks' output guard, ``BAD_RESULT``): the loop stops there and
returns its index, and the caller runs the Python path instead.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..compiled import interpreted
from ._jit import HAVE_NUMBA, jit, jitable, python_function
from .kernels import UnsupportedConfig, adrc_step, pid_step
from .loops import _controller_arrays, _plant_arrays, _plant_step

# the law functions as Python functions, for numba (ctrlblocks.compiled.interpreted)
_leadlag = interpreted("leadlag")
leadlag_coefficients = _leadlag.leadlag_coefficients
leadlag_step = _leadlag.leadlag_step
clamp = interpreted("signals").clamp
_pid = interpreted("pid")
NO_OPTIONS, pid_commit, pid_law = _pid.NO_OPTIONS, _pid.pid_commit, _pid.pid_law

__all__ = ["WIRINGS", "LaneResult", "lane_loop", "plant_blocker"]

WIRINGS = ("single", "feedforward", "smith", "cascade", "override")
"""The structures' wirings :func:`lane_loop` runs (index = the kernel's code)."""

_FF, _SMITH, _CASCADE, _OVERRIDE = 1, 2, 3, 4
_PID, _ADRC = 0, 1
_N_PID, _N_ADRC, _N_STATE = 13, 24, 11

jitable(leadlag_step)


# ---------------------------------------------------------------------------
# rows of arrays as tuples (numba keeps tuples in registers, arrays in memory)
# ---------------------------------------------------------------------------


@jitable
def _row8(a, j):
    return (a[j, 0], a[j, 1], a[j, 2], a[j, 3], a[j, 4], a[j, 5], a[j, 6], a[j, 7])


@jitable
def _row10(a, j):
    return (a[j, 0], a[j, 1], a[j, 2], a[j, 3], a[j, 4], a[j, 5], a[j, 6], a[j, 7],
            a[j, 8], a[j, 9])  # fmt: skip


@jitable
def _row11(a, j):
    return (a[j, 0], a[j, 1], a[j, 2], a[j, 3], a[j, 4], a[j, 5], a[j, 6], a[j, 7],
            a[j, 8], a[j, 9], a[j, 10])  # fmt: skip


@jitable
def _row9(a, j):
    return (a[j, 0], a[j, 1], a[j, 2], a[j, 3], a[j, 4], a[j, 5], a[j, 6], a[j, 7], a[j, 8])


@jitable
def _row13(a, j):
    return (a[j, 0], a[j, 1], a[j, 2], a[j, 3], a[j, 4], a[j, 5], a[j, 6], a[j, 7],
            a[j, 8], a[j, 9], a[j, 10], a[j, 11], a[j, 12])  # fmt: skip


@jitable
def _row18(a, j):
    return (a[j, 0], a[j, 1], a[j, 2], a[j, 3], a[j, 4], a[j, 5], a[j, 6], a[j, 7],
            a[j, 8], a[j, 9], a[j, 10], a[j, 11], a[j, 12], a[j, 13], a[j, 14],
            a[j, 15], a[j, 16], a[j, 17])  # fmt: skip


@jitable
def _row24(a, j):
    return (a[j, 0], a[j, 1], a[j, 2], a[j, 3], a[j, 4], a[j, 5], a[j, 6], a[j, 7],
            a[j, 8], a[j, 9], a[j, 10], a[j, 11], a[j, 12], a[j, 13], a[j, 14],
            a[j, 15], a[j, 16], a[j, 17], a[j, 18], a[j, 19], a[j, 20], a[j, 21],
            a[j, 22], a[j, 23])  # fmt: skip


@jitable
def _with_um(s, um):
    """The controller state ``s`` with the manual value ``um``."""
    return (s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7], s[8], um, s[10])


@jitable
def _pid_limits(p, lo, hi):
    """The PID parameters ``p`` (:func:`pid_step`'s) with the limits ``lo``, ``hi``."""
    return (p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], lo, hi, p[11], p[12])


@jitable
def _adrc_limits(a, lo, hi):
    """The ADRC parameters ``a`` (:func:`adrc_step`'s) with the limits ``lo``, ``hi``."""
    return (a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11], a[12],
            a[13], a[14], a[15], a[16], a[17], lo, hi, a[20], a[21], a[22], a[23])  # fmt: skip


@jitable
def _set_limits(kind, p, a, s, lo, hi, out_lo, out_hi):
    """``set_limits(lo, hi)`` of one controller: ``(p, a, s)`` with the limits in force.

    ``lo``, ``hi`` are the limits in force after the sample's events (a
    refused pair: the old ones, found by the caller with the block's own
    ``set_limits``).  The PID's output is limited at once
    (``Block._relimit``: its next cycle holds or continues from it) to
    ``out_lo``, ``out_hi``: the limits in force after one event, the
    limitations of all of them one after the other after several (the
    caller's ``limits[j, 2:]``).  The ADRC's input of the ESO, the last
    applied value, stays (``ADRC.set_limits`` limits ``out`` only, which
    the ESO does not read).
    """
    if kind == _PID:
        s = (s[0], s[1], s[2], s[3], clamp(s[4], out_lo, out_hi), s[5], s[6], s[7], s[8], s[9],
             s[10])  # fmt: skip
    return _pid_limits(p, lo, hi), _adrc_limits(a, lo, hi), s


# ---------------------------------------------------------------------------
# one controller: ComputeOutput, then UpdateState with the applied value
# ---------------------------------------------------------------------------


@jitable
def _compute(kind, p, a, s, sp, y, ff, man, awin):
    """ComputeOutput of one controller in state ``s``; returns ``(out, awout, pending)``.

    PID (the one law, :func:`~ctrlblocks.blocks.pid.pid_law`) state ``s = (i, d,
    w_prev, e_prev, out, cold, was_manual, -, -, u_man)``; ``awin`` freezes the
    integrator as ``PID.compute_output`` does.  ADRC state ``s = (yh, x2, x3, x4,
    u_prev, ref, started, track, sat, u_man, q)`` (``q``: handover offset); ``awin`` freezes x4 as
    ``ADRC.compute_output`` does (``adrc_step``'s own ``awin`` input,
    Nowak et al. 2018, section 5).
    """
    if kind == _PID:
        out, v_raw, _lim, pt, i_k, dn, w, e, _bias, _sup, _db = pid_law(
            sp, y, ff, man, s[9], s[5] != 0.0, (not man) and s[6] != 0.0, False, awin, False,
            0.0, s[0], s[1], s[2], s[3], 0.0, 0.0, 0.0, 0.0, 0.0, s[4], s[4], p, NO_OPTIONS,
        )  # fmt: skip
        awout = v_raw > p[10] or v_raw < p[9]  # limits_active (PID.compute_output)
        if not math.isfinite(v_raw):  # the block's output guard (BAD_RESULT): not here
            out = math.nan
        return out, awout, (out, v_raw, pt, i_k, dn, w, e, ff, 0.0)
    u, u_raw, yh, x2, x3, x4, ref, q, track, sat = adrc_step(
        sp, y, man, s[9], s[6] != 0.0, s[7] != 0.0, int(s[8]), s[0], s[1], s[2], s[3],
        s[4], s[5], s[10], a, awin,
    )  # fmt: skip
    if not math.isfinite(u_raw):  # the block's output guard (BAD_RESULT): not here
        u = math.nan
    return u, sat != 0, (u, yh, x2, x3, x4, ref, 1.0 if track else 0.0, sat * 1.0, q)


@jitable
def _commit(kind, p, s, pend, man, applied, track):
    """UpdateState of one controller with ``applied`` (its own output or the selected MV).

    PID (``PID.update_state``: :func:`~ctrlblocks.blocks.pid.pid_commit`): in
    auto the integrator tracks ``applied`` (Åström 1987, Fig. 3.6), in manual
    it is set so that ``P + I + D + FF = applied``; ADRC (``ADRC.update_state``): ``applied``
    is the ESO's input of the next sample.  In auto the manual value follows
    ``applied`` (In/Out).  A non-finite ``applied`` counts as the output.
    ``track``: the cycle was computed in manual (``man``) to track a value
    the user did not set (the cascade's primary, :func:`_control`): held as
    in manual, but the manual value follows ``applied`` as in the PID's
    TRACK mode and the ADRC's auto.
    """
    out = pend[0]
    u = applied if math.isfinite(applied) else out
    um = s[9] if man and not track else u
    if kind == _PID:  # the one law's commit (pid_commit)
        v_raw, pt, i_k, dn, w, e, ff = pend[1], pend[2], pend[3], pend[4], pend[5], pend[6], pend[7]
        i, _x = pid_commit(u, out, v_raw, pt, i_k, dn, ff, man, False, 0.0, p[6], p[11], p[12],
                           0.0)  # fmt: skip
        return (i, dn, w, e, out, 0.0, 1.0 if man else 0.0, 0.0, 0.0, um, 0.0)
    return (pend[1], pend[2], pend[3], pend[4], u, pend[5], 1.0, pend[6], pend[7], um, pend[8])


@jitable
def _bad_pid(p, s, man, safe, applied, track):
    """:func:`_bad` of a PID (parameters ``p``)."""
    lo, hi = p[9], p[10]
    # in manual the manual (or track) value, a non-finite one holding; in auto safe_value
    held = s[4] if math.isnan(safe) else safe
    target = (s[9] if math.isfinite(s[9]) else s[4]) if man else held
    out = clamp(target, lo, hi)
    u = applied if math.isfinite(applied) else out
    um = s[9] if man and not track else u
    return out, target > hi or target < lo, (s[0], s[1], s[2], s[3], out, 1.0, 1.0, 0.0, 0.0,
                                             um, 0.0)  # fmt: skip


@jitable
def _bad_adrc(a, s, man, safe, applied, track):
    """:func:`_bad` of an ADRC (parameters ``a``)."""
    lo, hi = a[18], a[19]
    target = (s[9] if math.isfinite(s[9]) else s[4]) if man else safe
    u = clamp(target, lo, hi)
    ua = applied if math.isfinite(applied) else u
    um = s[9] if man and not track else ua
    return u, False, (s[0], s[1], s[2], s[3], ua, s[5], s[6], 1.0, 0.0, um, s[10])


@jitable
def _bad(kind, p, a, s, man, safe, applied, track):
    """A cycle of one controller on a bad measurement, committed with ``applied``.

    Returns ``(out, awout, state)``.  PID (``PID.compute_output``'s
    bad-input branch, ``PID.update_state`` of that cycle): the output is the
    manual value in manual (the track value while ``track``), else ``safe``
    (its ``safe_value``; NaN: hold the last output), limited; the integrator
    and the histories stay, and the first good cycle starts the histories
    afresh (``cold``) and continues from this output (``transfer``:
    ``PID._reinit``); ``awout`` is the target beyond a limit.  ADRC
    (``ADRC.compute_output``, ``y_ok`` false): the manual value in manual,
    else ``safe`` (its ``u_sf``), limited; the ESO frozen, x4 re-solved by
    (11) of Nowak et al. 2018 at the first good cycle (``track``); not at a
    limit; ``applied`` is the ESO's input of the next sample.  The manual
    value follows ``applied`` (NaN: the block's own output) in auto and while
    ``track`` (In/Out, as :func:`_commit`).
    """
    if kind == _PID:
        return _bad_pid(p, s, man, safe, applied, track)
    return _bad_adrc(a, s, man, safe, applied, track)


@jitable
def _control(cascade, hs, kinds, p0, a0, s0, p1, a1, s1, sp, yc, y2, ok2, safe1, ff, m0, m1,
             awin, ok0, safe0):  # fmt: skip
    """One sample of the controller side: ``(u, v1, ok, s0, s1, awin)``.

    ``v1`` is the first controller's output (cascade: the secondary's
    setpoint); ``ok`` is False when an output is not finite (the states are
    then not to be used).  ``ok2``: the quality flag of ``y2`` (a cascade),
    ``safe1`` the secondary's safe value (:func:`_bad`); ``ok0``: the
    quality flag of ``y`` (False: flagged bad or NaN, the scenario's
    ``sensor`` events), ``safe0`` the first controller's safe value: on a
    bad ``y`` it runs its bad-measurement cycle (:func:`_bad`), as the
    blocks do with ``pv_ok`` false.  Each controller is computed and
    committed at one place (the compiled code inlines each kernel once per
    controller).
    """
    # the inner loop is open (the secondary in manual, or y2 bad: flagged or not finite)
    # and the primary in auto: the primary tracks y2, or holds its last output while y2
    # is bad (Cascade.follow_value); the secondary then runs its bad-measurement cycle
    good2 = ok2 and math.isfinite(y2)
    track = cascade and not m0 and (m1 or not good2)
    c0 = s0
    if track:
        c0 = _with_um(s0, y2 if good2 else s0[4])
    if ok0:
        v1, _aw0, pd0 = _compute(kinds[0], p0, a0, c0, sp, yc, ff, m0 or track, awin)
        b0 = s0
    else:  # committed with its own output (v1 is what the structure applies of it)
        v1, _aw0, b0 = _bad(kinds[0], p0, a0, c0, m0 or track, safe0, math.nan, track)
        pd0 = (v1, v1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    u, ok = v1, math.isfinite(v1)
    if cascade:  # the secondary on y2, its setpoint the primary's output, writes the MV
        if good2:
            u, aw1, pd1 = _compute(kinds[1], p1, a1, s1, v1, y2, 0.0, m1, False)
            s1 = _commit(kinds[1], p1, s1, pd1, m1, u, False)
        else:
            u, aw1, s1 = _bad(kinds[1], p1, a1, s1, m1, safe1, math.nan, False)
        ok = ok and math.isfinite(u)
        if hs:
            awin = aw1  # the secondary's awout, read by the primary in the next sample
    s0 = _commit(kinds[0], p0, s0, pd0, m0 or track, v1, track) if ok0 else b0
    return u, v1, ok, s0, s1, awin


# ---------------------------------------------------------------------------
# the process
# ---------------------------------------------------------------------------


@jitable
def _actuate(u, load, u_prev, du, lo, hi):
    """Actuator._shape: ``clamp(clamp(u + load, u_prev - du, u_prev + du), lo, hi)``."""
    v = u + load
    if du < math.inf:
        v = clamp(v, u_prev - du, u_prev + du)
    return clamp(v, lo, hi)


@jitable
def _plant(pk, pp, ps, pos, buf, j):
    """Plant ``j`` of the arrays: ``(fixed, state)`` for :func:`_advance`."""
    fixed = (pk[j], int(ps[j, 3]), buf.shape[0], _row18(pp, j), pp[j, 6], int(pp[j, 7]),
             pp[j, 8], pp[j, 9])  # fmt: skip
    return fixed, (ps[j, 0], ps[j, 1], ps[j, 2], ps[j, 4], ps[j, 5], pos[j])


@jitable
def _advance(fixed, st, buf, u, g5):
    """One sample of a plant (``_plant_step``) from ``u``; ``g5``: the three-tank's outlet."""
    kind, dsamp, nbuf, lti, hsub, nsub, lo, hi = fixed
    x0, x1, x2, py, u_hold, pos = _plant_step(
        kind, st[0], st[1], st[2], st[3], u, buf, st[5], dsamp, nbuf, lti,
        (lti[0], lti[1], lti[2], lti[3], lti[4], g5), hsub, nsub, lo, hi,
    )  # fmt: skip
    return (x0, x1, x2, u_hold, py, pos)


@jit
def _lane(cfg, kinds, pprm, aprm, cst, pk, pp, ps, pos, buf0, buf1, buf2, buf3, ffp,
          act, sig, noise, out, lim):  # fmt: skip
    """The loop of :func:`lane_loop` for the feed-forward, Smith and cascade wirings.

    Returns the first sample that is not finite, or -1.  ``cfg = (wiring,
    handshake, warm-up samples, sp, y, y2, dv of the warm-up, mv[0], mv[1], the
    secondary's safe value, the first controller's safe value)``;
    plants: 0 the measured one, 1 the inner one (series), 2 and 3 the Smith
    predictor's models (with and without the dead time); ``ffp = (b0, b1, a1,
    lo, hi, x_prev, out)`` of the lead-lag; ``sig`` rows: sp, load_in,
    load_out, manual[0], manual[1], u_man (NaN: unchanged), outlet g3o, load
    between the plants, the quality of ``y2`` (0: bad), the quality of ``y`` (0: bad,
    flagged or NaN), ``y`` replaced by NaN (1), a ``limits`` event (1: the
    limits in force ``lim[j, 0 or 1, k]`` of controller ``j`` are set, its
    held output limited to ``lim[j, 2 or 3, k]``); ``out`` rows: y, ym, u,
    u_act, y2 (the inner plant's output), the wiring's signal.
    """
    wiring = int(cfg[0])
    cascade = wiring == _CASCADE
    hs = cfg[1] != 0.0
    mv0, mv1 = cfg[7] != 0.0, cfg[8] != 0.0
    p0, p1 = _row13(pprm, 0), _row13(pprm, 1)
    a0, a1 = _row24(aprm, 0), _row24(aprm, 1)
    s0, s1 = _row11(cst, 0), _row11(cst, 1)
    awin = False
    smith = wiring == _SMITH
    fx0, st0 = _plant(pk, pp, ps, pos, buf0, 0)
    fx1, st1 = _plant(pk, pp, ps, pos, buf1, 1)
    fx2, st2 = _plant(pk, pp, ps, pos, buf2, 2)
    fx3, st3 = _plant(pk, pp, ps, pos, buf3, 3)
    ff, x_prev = ffp[6], ffp[5]
    a_lo, a_hi, du, ua, y_lo, y_hi = act[0], act[1], act[2], act[3], act[4], act[5]
    sp_a, ld_in, ld_out, man0, man1 = sig[0], sig[1], sig[2], sig[3], sig[4]
    um_a, g3o, ld_mid, ok2_a, ok_a, nan_a = sig[5], sig[6], sig[7], sig[8], sig[9], sig[10]
    safe1, safe0 = cfg[9], cfg[10]
    nw = int(cfg[2])
    # the warm-up (k < 0): every controller in manual, the plant held in its steady state
    # and measured without noise; then the n recorded samples
    for k in range(-nw, out.shape[1]):
        if k < 0:
            sp, y, dv, m0, m1, yc = cfg[3], cfg[4], cfg[6], True, True, cfg[4]
            y2, ok2, ok0 = cfg[5], True, True
        else:
            sp, dv, m0, m1, y2 = sp_a[k], ld_in[k], man0[k] != 0.0, man1[k] != 0.0, st1[4]
            ok2, ok0 = ok2_a[k] != 0.0, ok_a[k] != 0.0
            y = st0[4] + ld_out[k]
            yc = clamp(y + noise[k], y_lo, y_hi)
            if not math.isfinite(yc):
                return k
            if nan_a[k] != 0.0:  # a sensor fault: the measurement is NaN (Sensor.fault)
                yc = math.nan
            if not math.isnan(um_a[k]):  # a manual-value event acts on the MV blocks
                if mv0:
                    s0 = _with_um(s0, um_a[k])
                if mv1:
                    s1 = _with_um(s1, um_a[k])
            if sig[11, k] != 0.0:  # a limits event: the limits in force from this sample on
                p0, a0, s0 = _set_limits(kinds[0], p0, a0, s0, lim[0, 0, k], lim[0, 1, k],
                                         lim[0, 2, k], lim[0, 3, k])  # fmt: skip
                p1, a1, s1 = _set_limits(kinds[1], p1, a1, s1, lim[1, 0, k], lim[1, 1, k],
                                         lim[1, 2, k], lim[1, 3, k])  # fmt: skip
        ym = yc
        if smith:
            yc = yc + st3[4] - st2[4]  # ym + y_model_fast - y_model
        if wiring == _FF:
            ff = leadlag_step(dv, x_prev, ff, ffp[0], ffp[1], ffp[2], ffp[3], ffp[4])
            x_prev = dv
        u, v1, ok, s0, s1, awin = _control(
            cascade, hs, kinds, p0, a0, s0, p1, a1, s1, sp, yc, y2, ok2, safe1, ff, m0, m1, awin,
            ok0, safe0,
        )  # fmt: skip
        if k < 0:
            continue
        if not ok:
            return k
        ua = _actuate(u, ld_in[k], ua, du, a_lo, a_hi)
        out[0, k] = y
        out[1, k] = ym
        out[2, k] = u
        out[3, k] = ua
        if cascade:
            out[4, k] = y2
            out[5, k] = v1
            st1 = _advance(fx1, st1, buf1, ua, fx1[3][5])
            st0 = _advance(fx0, st0, buf0, y2 + ld_mid[k], g3o[k])
        else:
            if wiring == _FF:
                out[5, k] = ff
            elif smith:
                out[5, k] = yc
            st0 = _advance(fx0, st0, buf0, ua, g3o[k])
        if smith:
            st2 = _advance(fx2, st2, buf2, u, fx2[3][5])
            st3 = _advance(fx3, st3, buf3, u, fx3[3][5])
    return -1


@jitable
def _sense(st, sig, noise, k, act, um):
    """``(y, ym, manual, u_man)`` of sample ``k``: ``Sensor.y_true``, the measurement
    ``Sensor.y``, the mode and the manual value (changed by a manual-value event)."""
    y = st[4] + sig[2, k]
    um = um if math.isnan(sig[5, k]) else sig[5, k]
    return y, clamp(y + noise[k], act[4], act[5]), sig[3, k] != 0.0, um


@jitable
def _drive(fx, st, buf, out, k, y, ym, u, ld_in, ua, act, g5):
    """Record sample ``k``, shape ``u`` by the actuator and step the plant; ``(ua, st)``."""
    ua = _actuate(u, ld_in, ua, act[2], act[0], act[1])
    out[0, k] = y
    out[1, k] = ym
    out[2, k] = u
    out[3, k] = ua
    return ua, _advance(fx, st, buf, ua, g5)


@jit
def _single(p, a, cs, um, nw, sp_w, y_w, pk, pp, ps, pos, buf, act, sig, noise, out, safe,
            lim):  # fmt: skip
    """The ``single`` wiring: one PID (parameters ``p``, ``a`` None) or ADRC (``a``, ``p`` None).

    The loop of the structures of :func:`_lane` without their branches and
    states: most runs are single loops.  numba compiles one version for each
    controller (the types of ``p`` and ``a`` differ) and prunes the other's
    branch, so each runs as lean as a loop written for it alone.  While ``y``
    is bad (``sig`` rows 9 and 10, the scenario's ``sensor`` events) the
    controller runs its bad-measurement cycle (:func:`_bad`, ``safe``: its
    safe value); from a ``limits`` event on (``sig`` row 11) the limits in
    force are ``lim[0, :2, k]``, the held output limited to ``lim[0, 2:, k]``
    (:func:`_set_limits`).
    """
    fx, st = _plant(pk, pp, ps, pos, buf, 0)
    # PID: i, d, w_prev, e_prev, cold, was_manual; ADRC: yh, x2, x3, x4, ref, started,
    # track, sat; both: the last output u
    c0, c1, c2, c3, u, c5 = cs[0], cs[1], cs[2], cs[3], cs[4], cs[5]
    on, track, sat = cs[6] != 0.0, cs[7] != 0.0, int(cs[8])
    cq = cs[10]  # ADRC: the handover offset of the reference
    cold = c5 != 0.0
    ua = act[3]
    pl, al = p, a  # the parameters with the limits in force (p and a stay for the pruning)
    for k in range(-nw, out.shape[1]):  # k < 0: the warm-up, manual at um, plant held
        if k < 0:
            sp, y, ym, m = sp_w, y_w, y_w, True
        else:
            sp = sig[0, k]
            y, ym, m, um = _sense(st, sig, noise, k, act, um)
            if not math.isfinite(ym):
                return k
            good = sig[9, k] != 0.0
            if sig[10, k] != 0.0:  # a sensor fault: the measurement is NaN (Sensor.fault)
                ym = math.nan
            if sig[11, k] != 0.0:  # a limits event (_set_limits)
                if p is not None:
                    pl = _pid_limits(pl, lim[0, 0, k], lim[0, 1, k])
                    u = clamp(u, lim[0, 2, k], lim[0, 3, k])
                if a is not None:
                    al = _adrc_limits(al, lim[0, 0, k], lim[0, 1, k])
        # numba prunes the branch whose parameters are None (checked on a None-typed value)
        if p is not None:
            if k < 0 or good:
                u, v_raw, _p, _ish, c0, c1, c2, c3 = pid_step(
                    sp, ym, 0.0, m, um, cold, (not m) and on, c0, c1, c2, c3, u, pl
                )
                if not math.isfinite(v_raw):  # the block's output guard: not on the lane
                    u = math.nan
                cold = False
                on = m  # the mode of the last cycle (bumpless return to auto)
            else:  # the integrator and histories stay; the next good cycle re-initialises
                u, _aw, _s = _bad_pid(pl, (c0, c1, c2, c3, u, 1.0, 1.0, 0.0, 0.0, um, 0.0), m,
                                      safe, math.nan, False)  # fmt: skip
                cold = on = True
        if a is not None:
            if k < 0 or good:
                u, u_raw, c0, c1, c2, c3, c5, cq, track, sat = adrc_step(
                    sp, ym, m, um, on, track, sat, c0, c1, c2, c3, u, c5, cq, al
                )
                if not math.isfinite(u_raw):  # the block's output guard: not on the lane
                    u = math.nan
                on = True  # started
            else:  # the ESO frozen; x4 re-solved at the next good cycle
                u, _aw, _s = _bad_adrc(al, (c0, c1, c2, c3, u, c5, 1.0, 0.0, 0.0, um, cq), m,
                                       safe, math.nan, False)  # fmt: skip
                track, sat = True, 0
        if k < 0:
            continue
        if not math.isfinite(u):
            return k
        if not m:
            um = u  # the manual value is In/Out: in auto it follows the output
        ua, st = _drive(fx, st, buf, out, k, y, ym, u, sig[1, k], ua, act, sig[6, k])
    return -1


@jit
def _override(kinds, pprm, aprm, cst, on_y2, sp_fix, sel_max, nw, sp_w, y_w, y2_w, pk, pp, ps,
              pos, buf0, buf1, act, sig, man, noise, out, safe, lim):  # fmt: skip
    """The ``override`` wiring: any number of controllers, a min or max selector.

    Every controller ``j`` (parameters and state: row ``j`` of ``pprm``,
    ``aprm``, ``cst``; mode: ``man[j]``) computes on ``y`` or ``y2``
    (``on_y2[j]``) with ``sp`` or its own setpoint (``sp_fix[j]``, NaN: ``sp``);
    the selector picks the MV as Python's ``min``/``max`` (the first of equal
    values) and every controller commits with it (Åström 1987, Figs.
    3.8/3.9).  While ``y`` or ``y2`` is bad (``sig`` rows 8 to 10, the
    scenario's ``sensor`` events) every controller runs its bad-measurement
    cycle (:func:`_bad`, ``safe[j]``: its safe value), as
    ``Override.compute`` calls each block with ``y_ok and y2_ok``, and
    commits with the selected MV.  A ``limits`` event (``sig`` row 11) sets
    the limits in force ``lim[j, :, k]`` (:func:`_set_limits`).  The process is the series of
    :func:`_lane` (plants 0 and 1); ``out`` rows: y, ym, u, u_act, y2, then
    each controller's output.
    """
    nb = kinds.shape[0]
    fx0, st0 = _plant(pk, pp, ps, pos, buf0, 0)
    fx1, st1 = _plant(pk, pp, ps, pos, buf1, 1)
    pend = np.empty((nb, 9))
    v = np.empty(nb)
    ua, um = act[3], math.nan
    for k in range(-nw, out.shape[1]):  # k < 0: the warm-up, manual, plants held
        if k < 0:
            sp, y, ym, y2, good = sp_w, y_w, y_w, y2_w, True
        else:
            sp, y2 = sig[0, k], st1[4]
            y, ym, _m, um = _sense(st0, sig, noise, k, act, math.nan)
            if not math.isfinite(ym):
                return k
            good = sig[8, k] != 0.0 and sig[9, k] != 0.0  # y_ok and y2_ok (Override.compute)
            if sig[10, k] != 0.0:  # a sensor fault: the measurement is NaN (Sensor.fault)
                ym = math.nan
            if sig[11, k] != 0.0:  # a limits event (_set_limits)
                for j in range(nb):
                    lo, hi = lim[j, 0, k], lim[j, 1, k]
                    pprm[j, 9], pprm[j, 10], aprm[j, 18], aprm[j, 19] = lo, hi, lo, hi
                    if kinds[j] == _PID:
                        cst[j, 4] = clamp(cst[j, 4], lim[j, 2, k], lim[j, 3, k])
        u, ok = math.nan, True
        for j in range(nb):
            if not math.isnan(um):  # a manual-value event acts on every block (the MV's)
                cst[j, 9] = um
            m = k < 0 or man[j, k] != 0.0
            r = sp if math.isnan(sp_fix[j]) else sp_fix[j]
            if good:
                vj, _aw, pd = _compute(kinds[j], _row13(pprm, j), _row24(aprm, j),
                                       _row11(cst, j), r, y2 if on_y2[j] else ym, 0.0, m,
                                       False)  # fmt: skip
                for i in range(9):
                    pend[j, i] = pd[i]
            else:  # committed below with the selected MV
                vj, _aw, _s = _bad(kinds[j], _row13(pprm, j), _row24(aprm, j), _row11(cst, j),
                                   m, safe[j], math.nan, False)  # fmt: skip
            v[j] = vj
            ok = ok and math.isfinite(vj)
            if j == 0 or (vj > u if sel_max else vj < u):
                u = vj
        for j in range(nb):
            m = k < 0 or man[j, k] != 0.0
            if good:
                s = _commit(kinds[j], _row13(pprm, j), _row11(cst, j), _row9(pend, j), m, u,
                            False)  # fmt: skip
            else:
                _v, _aw, s = _bad(kinds[j], _row13(pprm, j), _row24(aprm, j), _row11(cst, j), m,
                                  safe[j], u, False)  # fmt: skip
            for i in range(11):
                cst[j, i] = s[i]
        if k < 0:
            continue
        if not ok:
            return k
        ua, st1 = _drive(fx1, st1, buf1, out, k, y, ym, u, sig[1, k], ua, act, fx1[3][5])
        st0 = _advance(fx0, st0, buf0, y2 + sig[7, k], sig[6, k])
        out[4, k] = y2
        for j in range(nb):
            out[5 + j, k] = v[j]
    return -1


# ---------------------------------------------------------------------------
# the public function
# ---------------------------------------------------------------------------


def plant_blocker(model: Any) -> str | None:
    """Why :func:`lane_loop` cannot run the process model ``model`` (None: it can)."""
    try:
        _plant_arrays(model)
    except UnsupportedConfig as exc:
        return str(exc)
    return None


class LaneResult:
    """Traces of :func:`lane_loop` (arrays of ``n`` samples), or where it stopped."""

    __slots__ = ("compiled", "signals", "stopped", "u", "u_act", "y", "y2", "ym")

    def __init__(self, traces: np.ndarray, stopped: int, compiled: bool) -> None:
        self.y, self.ym, self.u, self.u_act, self.y2 = traces[:5]
        self.signals = list(traces[5:])
        """The wiring's signals (``Structure.lane_signals``): cascade ``sp2``,
        override each block's output, feed-forward ``ff``, Smith ``y_pred``."""
        self.stopped = stopped
        """The first sample that was not finite (the traces stop there), or -1."""
        self.compiled = compiled


def _slot(block: Any, u_man: float) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """``(kind, PID parameters, ADRC parameters, state)`` of one controller."""
    _loop, prm, cs = _controller_arrays(block)
    pid = np.zeros(_N_PID)
    adrc = np.zeros(_N_ADRC)
    st = np.zeros(_N_STATE)
    st[: min(cs.shape[0], 9)] = cs[:9]
    if cs.shape[0] > 9:
        st[10] = cs[9]  # the ADRC's handover offset
    st[9] = u_man
    if len(prm) == _N_PID:
        pid[:] = prm
        return _PID, pid, adrc, st
    adrc[:] = prm
    return _ADRC, pid, adrc, st


def _safe_value(block: Any, kind: int) -> float:
    """The output of ``block`` on a bad measurement in auto (:func:`_bad`): the PID's
    ``safe_value`` (NaN for None: hold the last output), the ADRC's ``u_sf``."""
    v = block.config.u_sf if kind == _ADRC else block.config.safe_value
    return math.nan if v is None else float(v)


def lane_loop(
    wiring: str,
    controllers: Sequence[Any],
    model: Any,
    *,
    u_man: Sequence[float],
    mv: Sequence[bool],
    warmup: int,
    sp_warmup: float,
    y_warmup: float,
    actuator: tuple[float, float, float, float],
    sensor: tuple[float, float],
    signals: dict[str, Any],
    noise: np.ndarray,
    inner_model: Any = None,
    models: Sequence[Any] = (),
    lead_lag: Any = None,
    on_y2: Sequence[bool] | None = None,
    sp_fixed: Sequence[float] | None = None,
    selector_max: bool = False,
    handshake: bool = True,
    y2_warmup: float = math.nan,
    dv_warmup: float = 0.0,
    compiled: bool = True,
) -> LaneResult:
    """Run the warm-up and ``n`` samples of one loop structure (module docstring).

    Parameters
    ----------
    wiring : str
        One of :data:`WIRINGS`.
    controllers : sequence of PID or ADRC
        One block (two for ``cascade``: primary, secondary; ``override``: its
        blocks, two or more), each in its state before the warm-up (not advanced).
    model : LinearPlant (order <= 3) or ThreeTank
        The measured process model in its initial state (not advanced).
    u_man : sequence
        Per controller: its manual value (the warm-up runs every controller
        in manual at it; its mode of every sample is ``signals["manual"]``).
    mv : sequence of bool
        Per controller: mode and manual-value events act on it (the MV blocks).
    warmup : int
        Samples of the warm-up: setpoint ``sp_warmup``, measurements
        ``y_warmup``, ``y2_warmup`` and ``dv_warmup`` (the plant stays in its
        steady state).
    actuator : tuple
        ``(u_min, u_max, rate * ts, u)``: range, largest step per sample and
        the input applied before the first sample.
    sensor : tuple
        ``(y_min, y_max)``, the measuring range.
    signals : dict
        Per sample: ``sp``, ``load_in``, ``load_out``, ``u_man`` (NaN:
        unchanged), ``g3o`` (three-tank outlet coefficient; anything for a
        linear plant), ``load_mid`` (between series plants; optional),
        ``y2_ok`` (``cascade``, ``override``: 0 while ``y2`` is bad, flagged
        or NaN; optional, default good), ``y_ok`` (0 while ``y`` is bad,
        flagged or NaN; optional, default good), ``y_nan`` (1 while the
        measurement ``ym`` is NaN, a ``sensor`` event's ``nan``; optional,
        default 0), ``limits_event`` (1 where a ``limits`` event is due;
        optional) with ``limits``, an array ``(controller, lo/hi, sample)``
        of the limits in force (optional: those of the blocks throughout),
        or ``(controller, 4, sample)`` whose rows 2 and 3 are the bounds the
        PID's held output is limited to at an event's sample (several events
        in one sample: their limitations one after the other; default: the
        limits in force),
        and ``manual``: a sequence of one 0/1 array per controller.
    noise : array
        The measurement noise of every sample.
    inner_model : plant, optional
        The inner plant (``u -> y2``) of ``cascade`` and ``override``.
    models : pair of plants, optional
        The Smith predictor's models, with and without the dead time.
    lead_lag : LeadLag, optional
        The feed-forward block (``feedforward``).
    on_y2, sp_fixed, selector_max : optional
        ``override``: per block whether it measures ``y2`` and its own
        setpoint (NaN: ``sp``; default: ``y`` and ``sp`` for every block); a
        max selector instead of min.
    handshake : bool
        ``cascade``: the secondary's ``awout`` goes to the primary's ``awin``.
    compiled : bool
        False runs the same loop interpreted (tests of the lane itself).

    Raises
    ------
    UnsupportedConfig
        For a controller or a plant the kernels do not cover.
    """
    code = WIRINGS.index(wiring)
    slots = [_slot(b, float(um)) for b, um in zip(controllers, u_man, strict=True)]
    if len(slots) == 1:
        slots.append(slots[0])
    kinds = np.array([s[0] for s in slots], dtype=np.int64)
    pprm, aprm, cst = (np.array([s[i] for s in slots]) for i in (1, 2, 3))
    plants = [model] if code == 0 else [model, inner_model or model, *(models or (model, model))]
    arrays = [_plant_arrays(p) for p in plants]
    pk = np.array([a[0] for a in arrays], dtype=np.int64)
    pp = np.array([a[1] for a in arrays])
    ps = np.array([a[2] for a in arrays])
    pos = np.array([a[4] for a in arrays], dtype=np.int64)
    ffp = np.zeros(7)
    if lead_lag is not None:  # its coefficients at ts (LeadLag._set_h), limits and memory
        c, snap = lead_lag.config, lead_lag.snapshot()
        b0, b1, a1 = leadlag_coefficients(float(c.k), float(c.t_lead), float(c.t_lag),
                                          float(c.ts), c.method == "tustin")  # fmt: skip
        ffp[:] = (b0, b1, a1, *lead_lag.output_limits(), snap["_x_prev"], lead_lag.out)
    n = signals["sp"].shape[0]
    man = list(signals["manual"])
    nb = len(controllers)
    cfg = np.array([
        code, handshake, warmup, sp_warmup, y_warmup, y2_warmup, dv_warmup, mv[0],
        mv[-1] if len(mv) > 1 else 0, _safe_value(controllers[-1], slots[-1][0]),
        _safe_value(controllers[0], slots[0][0]),
    ], dtype=float)  # fmt: skip
    safe = np.array([_safe_value(b, sl[0]) for b, sl in zip(controllers, slots[:nb], strict=True)])
    sig = np.stack([
        signals["sp"], signals["load_in"], signals["load_out"], man[0], man[-1],
        signals["u_man"], signals["g3o"], signals.get("load_mid", np.zeros(n)),
        signals.get("y2_ok", np.ones(n)), signals.get("y_ok", np.ones(n)),
        signals.get("y_nan", np.zeros(n)), signals.get("limits_event", np.zeros(n)),
    ])  # fmt: skip
    # the limits in force of every controller and sample (a single controller's twice)
    lim = np.empty((len(slots), 4, n))
    given = signals.get("limits")
    for j, (kind, pid, adrc, _st) in enumerate(slots):
        if given is not None:
            g = given[min(j, nb - 1)]
            lim[j, :2] = g[:2]
            lim[j, 2:] = g[2:] if g.shape[0] == 4 else g[:2]
        else:
            lim[j, 0], lim[j, 1] = (pid[9], pid[10]) if kind == _PID else (adrc[18], adrc[19])
            lim[j, 2:] = lim[j, :2]
    traces = np.zeros((5 + (nb if code == _OVERRIDE else 1), n))
    traces[5:] = math.nan
    act = np.array([*actuator, *sensor], dtype=float)
    run = compiled and HAVE_NUMBA
    bufs = [a[3].copy() for a in arrays]
    if code == _OVERRIDE:  # any number of blocks, their states in arrays
        stopped = (_override if run else python_function(_override))(
            kinds, pprm, aprm, cst,
            np.array(on_y2 if on_y2 is not None else [False] * nb, dtype=np.bool_),
            np.array(sp_fixed if sp_fixed is not None else [math.nan] * nb, dtype=float),
            bool(selector_max), int(warmup), float(sp_warmup), float(y_warmup),
            float(y2_warmup), pk, pp, ps, pos, bufs[0], bufs[1], act, sig,
            np.array(man, dtype=float), noise, traces, safe, lim,
        )  # fmt: skip
    elif code == 0:  # the single loop (the most common runs) has its own, leaner kernel
        pid = kinds[0] == _PID
        stopped = (_single if run else python_function(_single))(
            tuple(pprm[0].tolist()) if pid else None, None if pid else tuple(aprm[0].tolist()),
            cst[0], float(u_man[0]), int(warmup), float(sp_warmup), float(y_warmup), pk, pp, ps,
            pos, bufs[0], act, sig, noise, traces, float(safe[0]), lim,
        )  # fmt: skip
    else:
        stopped = (_lane if run else python_function(_lane))(
            cfg, kinds, pprm, aprm, cst, pk, pp, ps, pos, *bufs, ffp, act, sig, noise, traces, lim
        )
    return LaneResult(traces, stopped=int(stopped), compiled=run)
