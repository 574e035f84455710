"""The compiled lane: a structure's wiring run in a closed loop over arrays (numba).

:func:`lane_loop` runs a :class:`~ctrlblocks.loops.lane.LaneRun` -- what
``ctrlblocks.sim.simulate`` does for one controller entry in one case --
sample for sample and in the same order of floating point operations, over
arrays: the controllers' warm-up in manual (the plant held in its steady
state), then ``n`` recorded samples in Åström's computational order (Åström
1987, section 6, Listing 6.3)::

    y[k]  = plant.y + load_out[k]                       (Sensor.y_true)
    ym[k] = clamp(y[k] + noise[k], y_min, y_max)        (Sensor.y)
    u[k]  = the wiring's loops (sp[k], ym[k], y2[k], ...) (ComputeOutput, ShapeOutput)
            every loop commits with the value it applied (UpdateState)
    u_act[k] = clamp(clamp(u[k] + load_in[k], u_act[k-1] -+ rate ts), u_min, u_max)
    plant.step(u_act[k])                                (Actuator, then the model)

The structure is not written here: the lane runs the structure's own
description, its :class:`~ctrlblocks.loops.wiring.Wiring` (the one the Python
path runs), encoded as arrays (:func:`_codes`): per loop its setpoint (the
input, a number, an earlier loop's output), its measurement (``y``, ``y2``,
the Smith predictor's ``y_pred``), the quality flags it runs on, its
feed-forward input, the loop it follows (a cascade's primary tracks while
the inner loop is open) and the loop whose ``awout`` is its ``awin`` (the AW
handshake); the MV (a loop's output, or a min or max selector); and the
stages it has kernels for -- the lead-lag feed-forward
(:func:`~ctrlblocks.blocks.leadlag.leadlag_step`, Bonde et al. 2021, Fig. 10)
and the Smith predictor's two models (Nowak et al. 2018, section 3.1).
:func:`wiring_blockers` says what it cannot run (the other stages, an
output stage, a block without a kernel).  One kernel, :func:`_wired`, runs
every wiring; its controller side is :func:`_controllers`.

Series plants (an inner plant ``u -> y2``: cascade, override) are coupled
with a zero-order hold as in ``ProcessSide.step``: the outer plant receives
the inner plant's output of the start of the sample plus the load between
them.

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
quality flags per sample: while a loop's measurement is bad (flagged, or not
finite: ``ym`` is then recorded NaN) it runs its bad-measurement cycle
(:func:`_bad`, the blocks' rule with ``pv_ok`` false); a loop that follows
one whose measurement is bad holds.  ``limits`` events arrive as the limits
in force of every loop and sample (:func:`_set_limits`).  A sample whose true
measurement or controller output is not finite, or whose control law's
result before the limits is not (a PID's ``v_raw``, an ADRC's ``u_raw``:
the limited output may still be finite), is where the two paths could part
(the blocks' output guard, ``BAD_RESULT``): the loop stops there and
returns its index, and the caller runs the Python path instead.

The simulator finds this lane as the entry point ``compiled`` of the group
``ctrlblocks.lanes`` (:data:`LANE`, :mod:`ctrlblocks.loops.lane`): it
imports nothing of ``ctrlblocks.fast``, nor this module anything of it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np

from ..blocks.adrc import ADRC
from ..blocks.leadlag import LeadLag
from ..compiled import interpreted
from ..loops.feedforward import FeedForwardStage
from ..loops.lane import LaneResult, LaneRun
from ..loops.smith import SmithPredictor
from ._jit import HAVE_NUMBA, jit, jitable, python_function
from .kernels import UnsupportedConfig, adrc_step
from .loops import _controller_arrays, _plant_arrays, _plant_step

# the law functions as Python functions, for numba (ctrlblocks.compiled.interpreted)
_leadlag = interpreted("leadlag")
leadlag_coefficients = _leadlag.leadlag_coefficients
leadlag_step = _leadlag.leadlag_step
clamp = interpreted("signals").clamp
_pid = interpreted("pid")
NO_OPTIONS, pid_commit, pid_law = _pid.NO_OPTIONS, _pid.pid_commit, _pid.pid_law

__all__ = ["LANE", "CompiledLane", "lane_loop", "plant_blocker", "wiring_blockers"]

_PID, _ADRC = 0, 1
_N_PID, _N_ADRC, _N_STATE = 13, 24, 11

jitable(leadlag_step)


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



# ---------------------------------------------------------------------------
# one sample of the controller side: the loops of the wiring (loops.wiring)
# ---------------------------------------------------------------------------

# the columns of a loop's row of ``wire`` (:func:`_codes`)
_SP, _PV, _OK, _FFIN, _FOLLOWS, _AWIN, _MV = 0, 1, 2, 3, 4, 5, 6
_SP_INPUT, _SP_FIXED = -1, -2  # a setpoint that is not a loop's output
_MIN, _MAX = -1, -2  # the MV is selected
_SIG_FF, _SIG_PRED = -1, -2  # a recorded signal that is not a loop's output


@jitable
def _controllers(kinds, pprm, aprm, cst, wire, sp_fix, safe, mv_src, man, sp, pvs, oks, ffv,
                 awin, v, aw, good, track, cum, pend):  # fmt: skip
    """One sample of the controller side; returns ``(u, ok)``, commits every loop's state.

    ``wire`` has a row per loop (:func:`_codes`): its setpoint (the input,
    its own ``sp_fix``, or loop ``i``'s output), its measurement (index into
    ``pvs = (ym, y2, y_pred)``), the quality flags it runs on (bits of
    ``oks = (y_ok, y2_ok)``), its feed-forward input (``ffv``), the loop it
    follows (-1: none), the loop whose ``awout`` is its ``awin`` (-1: none),
    and whether it makes the MV.  ``man[j]``: loop ``j`` in manual.  In
    order, each loop computes (:func:`_compute`; while its measurement is
    bad, flagged or not finite, its bad-measurement cycle :func:`_bad`);
    a loop that follows another one whose loop is open (in manual, or its
    measurement bad) while it is in auto tracks that loop's measurement, or
    holds its last output while that measurement is bad (``Wiring.follow``);
    the MV is loop ``mv_src``'s output or the min (``_MIN``) or max
    (``_MAX``) of all; then every loop commits (:func:`_commit`, or
    :func:`_bad` again) with the MV if it makes it, else its own output
    (Åström 1987, section 6), and ``awin`` takes the ``awout`` of this sample
    for the next one.  ``ok`` is False when an output is not finite (the
    states are then not to be used).  ``v``, ``aw``, ``good``, ``track``,
    ``cum`` and ``pend`` are work arrays of one row per loop.
    """
    nb = kinds.shape[0]
    for j in range(nb):
        mask = wire[j, _OK]
        good[j] = ((mask & 1) == 0 or oks[0]) and ((mask & 2) == 0 or oks[1]) and math.isfinite(
            pvs[wire[j, _PV]])  # fmt: skip
    ok = True
    for j in range(nb):
        s = _row11(cst, j)
        f = wire[j, _FOLLOWS]
        tr = f >= 0 and not man[j] and (man[f] or not good[f])
        if tr:  # the loop it follows is open: track its measurement, or hold while it is bad
            s = _with_um(s, pvs[wire[f, _PV]] if good[f] else s[4])
        track[j], cum[j] = tr, s[9]
        src = wire[j, _SP]
        r = sp if src == _SP_INPUT else sp_fix[j] if src == _SP_FIXED else v[src]
        p, a, m = _row13(pprm, j), _row24(aprm, j), man[j] or tr
        if good[j]:
            ff = ffv if wire[j, _FFIN] != 0 else 0.0
            vj, awj, pd = _compute(kinds[j], p, a, s, r, pvs[wire[j, _PV]], ff, m, awin[j])
            for i in range(9):
                pend[j, i] = pd[i]
        else:  # committed below, with the value it applies
            vj, awj, _s = _bad(kinds[j], p, a, s, m, safe[j], math.nan, tr)
        v[j], aw[j] = vj, awj
        ok = ok and math.isfinite(vj)
    if mv_src >= 0:
        u = v[mv_src]
    else:  # a selector: the first of equal values (Python's min and max)
        u = v[0]
        for j in range(1, nb):
            if (v[j] > u) if mv_src == _MAX else (v[j] < u):
                u = v[j]
    for j in range(nb):
        applied = u if wire[j, _MV] != 0 else v[j]
        p, m = _row13(pprm, j), man[j] or track[j]
        if good[j]:
            s = _commit(kinds[j], p, _row11(cst, j), _row9(pend, j), m, applied, track[j])
        else:
            _v, _aw, s = _bad(kinds[j], p, _row24(aprm, j), _with_um(_row11(cst, j), cum[j]), m,
                              safe[j], applied, track[j])  # fmt: skip
        for i in range(11):
            cst[j, i] = s[i]
    for j in range(nb):
        if wire[j, _AWIN] >= 0:
            awin[j] = aw[wire[j, _AWIN]]
    return u, ok


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


# ---------------------------------------------------------------------------
# the loop
# ---------------------------------------------------------------------------


@jit
def _wired(kinds, pprm, aprm, cst, wire, sp_fix, safe, sigsrc, cfg, pk, pp, ps, pos, buf0, buf1,
           buf2, buf3, ffp, act, sig, man, noise, out, lim):  # fmt: skip
    """The loop of :func:`lane_loop`: warm-up, then the recorded samples (module docstring).

    Returns the first sample that is not finite, or -1.  ``cfg = (MV source,
    Smith predictor, lead-lag feed-forward, series plants, warm-up samples,
    sp, y, y2 and dv of the warm-up)``; plants: 0 the measured one, 1 the
    inner one (series), 2 and 3 the Smith predictor's models (with and
    without the dead time); ``ffp = (b0, b1, a1, lo, hi, x_prev, out)`` of
    the lead-lag; ``sig`` rows: sp, load_in, load_out, u_man (NaN:
    unchanged), outlet g3o, load between the plants, the quality of ``y2``
    (0: bad), the quality of ``y`` (0: bad, flagged or NaN), ``y`` replaced
    by NaN (1), a ``limits`` event (1: the limits in force ``lim[j, 0 or 1,
    k]`` of loop ``j`` are set, its held output limited to ``lim[j, 2 or 3,
    k]``, :func:`_set_limits`); ``man[j, k]``: loop ``j`` in manual;
    ``sigsrc``: the recorded signals (a loop's output, ``_SIG_FF`` or
    ``_SIG_PRED``); ``out`` rows: y, ym, u, u_act, y2, the signals.
    """
    nb = kinds.shape[0]
    mv_src, smith, use_ff, series = int(cfg[0]), cfg[1] != 0.0, cfg[2] != 0.0, cfg[3] != 0.0
    nw = int(cfg[4])
    fx0, st0 = _plant(pk, pp, ps, pos, buf0, 0)
    fx1, st1 = _plant(pk, pp, ps, pos, buf1, 1)
    fx2, st2 = _plant(pk, pp, ps, pos, buf2, 2)
    fx3, st3 = _plant(pk, pp, ps, pos, buf3, 3)
    ff, x_prev = ffp[6], ffp[5]
    ua = act[3]
    v, aw = np.empty(nb), np.zeros(nb, dtype=np.bool_)
    awin, good, track = np.zeros(nb, dtype=np.bool_), np.empty(nb, dtype=np.bool_), np.empty(
        nb, dtype=np.bool_)  # fmt: skip
    cum, pend, mk = np.empty(nb), np.zeros((nb, 9)), np.empty(nb, dtype=np.bool_)
    # the warm-up (k < 0): every loop in manual, the plants held in their steady state and
    # measured without noise; then the n recorded samples
    for k in range(-nw, out.shape[1]):
        if k < 0:
            sp, y, ym, y2, dv, oky, ok2 = cfg[5], cfg[6], cfg[6], cfg[7], cfg[8], True, True
            mk[:] = True
        else:
            sp, dv, y2 = sig[0, k], sig[1, k], st1[4] if series else math.nan
            y = st0[4] + sig[2, k]
            ym = clamp(y + noise[k], act[4], act[5])
            if not math.isfinite(ym):
                return k
            oky, ok2 = sig[7, k] != 0.0, sig[6, k] != 0.0
            if sig[8, k] != 0.0:  # a sensor fault: the measurement is NaN (Sensor.fault)
                ym = math.nan
            for j in range(nb):
                mk[j] = man[j, k] != 0.0
                if not math.isnan(sig[3, k]) and wire[j, _MV] != 0:  # a manual-value event
                    cst[j, 9] = sig[3, k]
            if sig[9, k] != 0.0:  # a limits event: the limits in force from this sample on
                for j in range(nb):
                    p, a, s = _set_limits(kinds[j], _row13(pprm, j), _row24(aprm, j),
                                          _row11(cst, j), lim[j, 0, k], lim[j, 1, k],
                                          lim[j, 2, k], lim[j, 3, k])  # fmt: skip
                    for i in range(13):
                        pprm[j, i] = p[i]
                    for i in range(24):
                        aprm[j, i] = a[i]
                    for i in range(11):
                        cst[j, i] = s[i]
        # the stages: the Smith predictor's y + y_model_fast - y_model, the lead-lag on dv
        yp = ym + st3[4] - st2[4] if smith else math.nan
        if use_ff and math.isfinite(dv):
            ff = leadlag_step(dv, x_prev, ff, ffp[0], ffp[1], ffp[2], ffp[3], ffp[4])
            x_prev = dv
        u, ok = _controllers(kinds, pprm, aprm, cst, wire, sp_fix, safe, mv_src, mk, sp,
                             (ym, y2, yp), (oky, ok2), ff, awin, v, aw, good, track, cum,
                             pend)  # fmt: skip
        if k < 0:
            continue
        if not ok:
            return k
        ua = _actuate(u, sig[1, k], ua, act[2], act[0], act[1])
        out[0, k] = y
        out[1, k] = ym
        out[2, k] = u
        out[3, k] = ua
        out[4, k] = y2
        for i in range(sigsrc.shape[0]):
            src = sigsrc[i]
            out[5 + i, k] = v[src] if src >= 0 else ff if src == _SIG_FF else yp
        if series:  # the inner plant from the actuator, the outer one from y2 (zero-order hold)
            st1 = _advance(fx1, st1, buf1, ua, fx1[3][5])
            st0 = _advance(fx0, st0, buf0, y2 + sig[5, k], sig[4, k])
        else:
            st0 = _advance(fx0, st0, buf0, ua, sig[4, k])
        if smith:  # the models advance with the controller output
            st2 = _advance(fx2, st2, buf2, u, fx2[3][5])
            st3 = _advance(fx3, st3, buf3, u, fx3[3][5])
    return -1


# ---------------------------------------------------------------------------
# the lane: a wiring encoded as arrays, the blockers, the run
# ---------------------------------------------------------------------------


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


def plant_blocker(model: Any) -> str | None:
    """Why the lane cannot run the process model ``model`` (None: it can)."""
    try:
        _plant_arrays(model)
    except UnsupportedConfig as exc:
        return str(exc)
    return None


@runtime_checkable
class _KernelSeam(Protocol):
    """The compiled paths' seam of a controller block (``PID``, ``ADRC``)."""

    def fast_path_blockers(self, *, manual_ok: bool = True) -> list[str]: ...


_PVS = {"y": 0, "y2": 1, "y_pred": 2}  # the measurements a loop of the lane may read


def wiring_blockers(side: Any) -> list[str]:
    """Why the lane cannot run the wiring of the controller side ``side`` (empty: it can).

    The lane runs a wiring of PID and ADRC loops (the blocks decide which
    configurations its kernels cover: ``fast_path_blockers``) on ``y``,
    ``y2`` or the Smith predictor's ``y_pred``, with setpoints from the input,
    a number or an earlier loop, an MV from a loop or a min/max selector,
    the AW handshake and tracking, and the stages
    :class:`~ctrlblocks.loops.feedforward.FeedForwardStage` (a float64
    :class:`~ctrlblocks.LeadLag`) and
    :class:`~ctrlblocks.loops.smith.SmithPredictor`; no output stage.
    """
    w = side.wiring
    where = f"structure {side.structure!r} has no compiled loop"
    if w is None:
        return [where]
    bad: list[str] = []
    if w.output is not None:
        bad.append(f"{where} (its output stage)")
    signals: set[str] = set()
    for st in w.stages:
        if isinstance(st, FeedForwardStage):
            ll = st.block(side)
            if not isinstance(ll, LeadLag):
                bad.append(f"feedforward: {type(ll).__name__} has no compiled kernel (LeadLag has)")
            elif ll.config.precision != "float64":
                bad.append(f"feedforward: precision {ll.config.precision!r}")
        elif isinstance(st, SmithPredictor):
            bad += [why for m in st.models(side) if (why := plant_blocker(m)) is not None]
        else:
            bad.append(f"{where} (its stage {st.name!r})")
        signals.update(st.signals)
    before: list[str] = []
    for lp in w.loops:
        if isinstance(lp.sp, str) and lp.sp != "sp" and lp.sp not in before:
            bad.append(f"{lp.role}: a setpoint from {lp.sp!r}")
        if lp.pv not in _PVS or (lp.pv == "y_pred" and "y_pred" not in signals):
            bad.append(f"{lp.role}: a measurement {lp.pv!r}")
        if lp.ff not in (None, "ff") or (lp.ff == "ff" and "ff" not in signals):
            bad.append(f"{lp.role}: a feed-forward {lp.ff!r}")
        block = side.blocks[lp.role]
        if lp.ff is not None and isinstance(block, ADRC):
            # adrc_step has no ff: its ESO would be fed the whole applied u (the Python
            # path feeds it the applied u less ff, ADRC.compute_output)
            bad.append(f"{lp.role}: an ADRC's feed-forward (the kernel has none)")
        if not isinstance(block, _KernelSeam):
            bad.append(f"{lp.role}: {type(block).__name__} has no compiled kernel")
        else:
            why = block.fast_path_blockers(manual_ok=True)
            if not why:
                try:
                    _controller_arrays(block)
                except UnsupportedConfig as exc:
                    why = [str(exc)]
            bad += [f"{lp.role}: {x}" for x in why]
        before.append(lp.role)
    return bad


def _codes(side: Any) -> tuple[np.ndarray, np.ndarray, int, np.ndarray, tuple[str, ...]]:
    """The wiring of ``side`` as arrays: ``(wire, sp_fix, mv_src, sigsrc, signal names)``
    (:func:`_controllers`, :func:`_wired`)."""
    w = side.wiring
    roles = list(w.roles)
    wire = np.zeros((len(roles), 7), dtype=np.int64)
    sp_fix = np.full(len(roles), math.nan)
    for j, lp in enumerate(w.loops):
        if isinstance(lp.sp, str):
            wire[j, _SP] = _SP_INPUT if lp.sp == "sp" else roles.index(lp.sp)
        else:
            wire[j, _SP], sp_fix[j] = _SP_FIXED, float(lp.sp)
        wire[j, _PV] = _PVS[lp.pv]
        wire[j, _OK] = ("y" in lp.ok) + 2 * ("y2" in lp.ok)
        wire[j, _FFIN] = lp.ff is not None
        wire[j, _FOLLOWS] = -1 if lp.follows is None else roles.index(lp.follows)
        wire[j, _AWIN] = -1 if lp.awin is None else roles.index(lp.awin)
        wire[j, _MV] = lp.role in w.mv_roles
    mv_src = {"min": _MIN, "max": _MAX}.get(w.mv)
    if mv_src is None:
        mv_src = roles.index(w.mv)
    src = {"ff": _SIG_FF, "y_pred": _SIG_PRED}
    src |= {lp.signal: j for j, lp in enumerate(w.loops) if lp.signal is not None}
    names = w.signals
    return wire, sp_fix, mv_src, np.array([src[s] for s in names], dtype=np.int64), names


def lane_loop(run: LaneRun, *, compiled: bool = True) -> LaneResult:
    """Run the warm-up and the ``n`` samples of ``run`` (module docstring).

    ``compiled`` False runs the same loop interpreted (tests of the lane
    itself).  Raises :class:`~ctrlblocks.fast.kernels.UnsupportedConfig` for
    a controller or a plant the kernels do not cover (:meth:`CompiledLane.
    controller_blockers` and :meth:`~CompiledLane.process_blockers` say so first).
    """
    side = run.side
    w = side.wiring
    wire, sp_fix, mv_src, sigsrc, names = _codes(side)
    blocks = [side.blocks[r] for r in w.roles]
    slots = [_slot(b, float(um)) for b, um in zip(blocks, run.u_man, strict=True)]
    kinds = np.array([s[0] for s in slots], dtype=np.int64)
    pprm, aprm, cst = (np.array([s[i] for s in slots]) for i in (1, 2, 3))
    safe = np.array([_safe_value(b, s[0]) for b, s in zip(blocks, slots, strict=True)])
    smith = next((st for st in w.stages if isinstance(st, SmithPredictor)), None)
    ffs = next((st for st in w.stages if isinstance(st, FeedForwardStage)), None)
    model = run.model
    models = smith.models(side) if smith is not None else (model, model)
    plants = [model, run.inner_model or model, *models]
    arrays = [_plant_arrays(p) for p in plants]
    pk = np.array([a[0] for a in arrays], dtype=np.int64)
    pp = np.array([a[1] for a in arrays])
    ps = np.array([a[2] for a in arrays])
    pos = np.array([a[4] for a in arrays], dtype=np.int64)
    ffp = np.zeros(7)
    if ffs is not None:  # its coefficients at ts (LeadLag._set_h), limits and memory
        ll = ffs.block(side)
        c, snap = ll.config, ll.snapshot()
        b0, b1, a1 = leadlag_coefficients(float(c.k), float(c.t_lead), float(c.t_lag),
                                          float(c.ts), c.method == "tustin")  # fmt: skip
        ffp[:] = (b0, b1, a1, *ll.output_limits(), snap["_x_prev"], ll.out)
    sg = run.signals
    n = sg["sp"].shape[0]
    sig = np.stack([
        sg["sp"], sg["load_in"], sg["load_out"], sg["u_man"], sg["g3o"],
        sg.get("load_mid", np.zeros(n)), sg.get("y2_ok", np.ones(n)), sg.get("y_ok", np.ones(n)),
        sg.get("y_nan", np.zeros(n)), sg.get("limits_event", np.zeros(n)),
    ])  # fmt: skip
    lim = np.empty((len(slots), 4, n))
    for j, (kind, pid, adrc, _st) in enumerate(slots):
        if run.limits is not None:
            g = run.limits[j]
            lim[j, :2] = g[:2]
            lim[j, 2:] = g[2:] if g.shape[0] == 4 else g[:2]
        else:
            lim[j, 0], lim[j, 1] = (pid[9], pid[10]) if kind == _PID else (adrc[18], adrc[19])
            lim[j, 2:] = lim[j, :2]
    cfg = np.array([
        mv_src, smith is not None, ffs is not None, run.inner_model is not None, run.warmup,
        run.sp_warmup, run.y_warmup, run.y2_warmup, run.dv_warmup,
    ], dtype=float)  # fmt: skip
    traces = np.zeros((5 + len(names), n))
    act = np.array([*run.actuator, *run.sensor], dtype=float)
    man = np.array([np.asarray(m, dtype=float) for m in run.manual]).reshape(len(slots), n)
    go = compiled and HAVE_NUMBA
    bufs = [a[3].copy() for a in arrays]
    stopped = (_wired if go else python_function(_wired))(
        kinds, pprm, aprm, cst, wire, sp_fix, safe, sigsrc, cfg, pk, pp, ps, pos, *bufs, ffp,
        act, sig, man, np.ascontiguousarray(run.noise, dtype=float), traces, lim,
    )  # fmt: skip
    y, ym, u, u_act, y2 = traces[:5]
    return LaneResult(y, ym, u, u_act, y2, dict(zip(names, traces[5:], strict=True)),
                      int(stopped), go)  # fmt: skip


class CompiledLane:
    """The compiled lane as a :class:`~ctrlblocks.loops.lane.Lane` (entry point ``compiled``)."""

    def controller_blockers(self, side: Any) -> list[str]:
        return wiring_blockers(side)

    def process_blockers(self, models: Sequence[Any]) -> list[str]:
        bad = [] if HAVE_NUMBA else ["numba is not installed"]
        return bad + [why for m in models if m is not None and (why := plant_blocker(m))]

    def run(self, run: LaneRun) -> LaneResult:
        return lane_loop(run)


LANE = CompiledLane()
"""The lane the simulator finds (``pyproject.toml``: entry point group ``ctrlblocks.lanes``)."""
