"""The simulator's single loop on the compiled lane: a PID or ADRC, actuator, plant, sensor.

:func:`single_loop` runs what :func:`ctrlblocks.sim.simulate` does for the
``single`` structure, sample for sample and in the same order of floating
point operations, over arrays: the controller's warm-up in manual (the plant
held in its steady state), then ``n`` recorded samples in Åström's
computational order (Åström 1987, section 6, Listing 6.3)::

    y[k]  = plant.y + load_out[k]                       (Sensor.y_true)
    ym[k] = clamp(y[k] + noise[k], y_min, y_max)        (Sensor.y)
    u[k]  = controller(sp[k], ym[k])                    (compute_output + update_state)
    u_act[k] = clamp(clamp(u[k] + load_in[k], u_act[k-1] -+ rate ts), u_min, u_max)
    plant.step(u_act[k])                                (Actuator, then the model)

The controller is the blocks' own fast lane (:func:`~ctrlblocks.fast.kernels.pid_step`,
:func:`~ctrlblocks.fast.kernels.adrc_step`), the plant the kernels of
:mod:`.loops` (a linear plant of order <= 3 with any dead time, or the
three-tank process).  The caller (``ctrlblocks.sim.dispatch``) turns the
scenario's events into the per-sample arrays and draws the noise with the
scenario's own generator, so the traces equal the Python path's.

A sample whose measurement or controller output is not finite is where the
two paths could part (quality flags, held commands): the loop stops there
and returns its index, and the caller runs the Python path instead.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..blocks.signals import clamp
from ._jit import HAVE_NUMBA, jit, jitable, python_function
from .kernels import UnsupportedConfig, adrc_step, pid_step
from .loops import _controller_arrays, _plant_arrays, _plant_step

__all__ = ["LaneResult", "plant_blocker", "single_loop"]


@jitable
def _actuate(u, load, u_prev, du, lo, hi):
    """Actuator._shape: ``clamp(clamp(u + load, u_prev - du, u_prev + du), lo, hi)``."""
    v = u + load
    if du < math.inf:
        v = clamp(v, u_prev - du, u_prev + du)
    return clamp(v, lo, hi)


@jit
def _pid_lane(prm, cs, um, nw, sp_w, y_w, kind, pp, ps, buf, pos, act,
              sp, ld_in, ld_out, man_a, um_a, g3o_a, noise, y_o, ym_o, u_o, ua_o):  # fmt: skip
    """PID + process; returns the first sample that is not finite, or -1."""
    i, d, w_prev, e_prev, out = cs[0], cs[1], cs[2], cs[3], cs[4]
    cold = cs[5] != 0.0
    was_manual = cs[6] != 0.0
    for _ in range(nw):  # warm-up: manual at um, plant held in steady state
        out, _vr, _p, _ish, i, d, w_prev, e_prev = pid_step(
            sp_w, y_w, 0.0, True, um, cold, False, i, d, w_prev, e_prev, out, prm
        )
        cold = False
        was_manual = True
    x0, x1, x2, u_hold, py = ps[0], ps[1], ps[2], ps[4], ps[5]
    dsamp = int(ps[3])
    nbuf = buf.shape[0]
    lti = (pp[0], pp[1], pp[2], pp[3], pp[4], pp[5], pp[6], pp[7], pp[8], pp[9],
           pp[10], pp[11], pp[12], pp[13], pp[14], pp[15], pp[16], pp[17])  # fmt: skip
    hsub, nsub, lo, hi = pp[6], int(pp[7]), pp[8], pp[9]
    a_lo, a_hi, du, ua, y_lo, y_hi = act[0], act[1], act[2], act[3], act[4], act[5]
    for k in range(y_o.shape[0]):
        y = py + ld_out[k]
        ym = clamp(y + noise[k], y_lo, y_hi)
        if not math.isfinite(ym):
            return k
        m = man_a[k] != 0.0
        if not math.isnan(um_a[k]):
            um = um_a[k]
        transfer = (not m) and was_manual
        out, _vr, _p, _ish, i, d, w_prev, e_prev = pid_step(
            sp[k], ym, 0.0, m, um, cold, transfer, i, d, w_prev, e_prev, out, prm
        )
        if not math.isfinite(out):
            return k
        cold = False
        was_manual = m
        if not m:
            um = out  # manual_value is In/Out: in auto it follows the output
        ua = _actuate(out, ld_in[k], ua, du, a_lo, a_hi)
        y_o[k] = y
        ym_o[k] = ym
        u_o[k] = out
        ua_o[k] = ua
        x0, x1, x2, py, u_hold, pos = _plant_step(
            kind, x0, x1, x2, u_hold, ua, buf, pos, dsamp, nbuf, lti,
            (pp[0], pp[1], pp[2], pp[3], pp[4], g3o_a[k]), hsub, nsub, lo, hi,
        )  # fmt: skip
    return -1


@jit
def _adrc_lane(prm, cs, um, nw, sp_w, y_w, kind, pp, ps, buf, pos, act,
               sp, ld_in, ld_out, man_a, um_a, g3o_a, noise, y_o, ym_o, u_o, ua_o):  # fmt: skip
    """ADRC + process; returns the first sample that is not finite, or -1."""
    yh, e2, e3, e4, u_prev, ref = cs[0], cs[1], cs[2], cs[3], cs[4], cs[5]
    started = cs[6] != 0.0
    track = cs[7] != 0.0
    sat = int(cs[8])
    for _ in range(nw):  # warm-up: manual at um, plant held in steady state
        u, _ur, yh, e2, e3, e4, ref, track, sat = adrc_step(
            sp_w, y_w, True, um, started, track, sat, yh, e2, e3, e4, u_prev, ref, prm
        )
        started = True
        u_prev = u
    x0, x1, x2, u_hold, py = ps[0], ps[1], ps[2], ps[4], ps[5]
    dsamp = int(ps[3])
    nbuf = buf.shape[0]
    lti = (pp[0], pp[1], pp[2], pp[3], pp[4], pp[5], pp[6], pp[7], pp[8], pp[9],
           pp[10], pp[11], pp[12], pp[13], pp[14], pp[15], pp[16], pp[17])  # fmt: skip
    hsub, nsub, lo, hi = pp[6], int(pp[7]), pp[8], pp[9]
    a_lo, a_hi, du, ua, y_lo, y_hi = act[0], act[1], act[2], act[3], act[4], act[5]
    for k in range(y_o.shape[0]):
        y = py + ld_out[k]
        ym = clamp(y + noise[k], y_lo, y_hi)
        if not math.isfinite(ym):
            return k
        m = man_a[k] != 0.0
        if not math.isnan(um_a[k]):
            um = um_a[k]
        u, _ur, yh, e2, e3, e4, ref, track, sat = adrc_step(
            sp[k], ym, m, um, started, track, sat, yh, e2, e3, e4, u_prev, ref, prm
        )
        if not math.isfinite(u):
            return k
        started = True
        u_prev = u
        if not m:
            um = u  # u_man is In/Out: in auto it follows the output
        ua = _actuate(u, ld_in[k], ua, du, a_lo, a_hi)
        y_o[k] = y
        ym_o[k] = ym
        u_o[k] = u
        ua_o[k] = ua
        x0, x1, x2, py, u_hold, pos = _plant_step(
            kind, x0, x1, x2, u_hold, ua, buf, pos, dsamp, nbuf, lti,
            (pp[0], pp[1], pp[2], pp[3], pp[4], g3o_a[k]), hsub, nsub, lo, hi,
        )  # fmt: skip
    return -1


def plant_blocker(model: Any) -> str | None:
    """Why :func:`single_loop` cannot run the process model ``model`` (None: it can)."""
    try:
        _plant_arrays(model)
    except UnsupportedConfig as exc:
        return str(exc)
    return None


class LaneResult:
    """Traces of :func:`single_loop` (arrays of ``n`` samples), or where it stopped."""

    __slots__ = ("compiled", "stopped", "u", "u_act", "y", "ym")

    def __init__(self, y: np.ndarray, ym: np.ndarray, u: np.ndarray, u_act: np.ndarray,
                 stopped: int, compiled: bool) -> None:  # fmt: skip
        self.y, self.ym, self.u, self.u_act = y, ym, u, u_act
        self.stopped = stopped
        """The first sample that was not finite (the traces stop there), or -1."""
        self.compiled = compiled


def single_loop(
    controller: Any,
    model: Any,
    *,
    warmup: int,
    sp_warmup: float,
    y_warmup: float,
    u_man: float,
    actuator: tuple[float, float, float, float],
    sensor: tuple[float, float],
    signals: dict[str, np.ndarray],
    noise: np.ndarray,
    compiled: bool = True,
) -> LaneResult:
    """Run the warm-up and ``n`` samples of one single loop (module docstring).

    Parameters
    ----------
    controller : PID or ADRC
        The block in its state before the warm-up (not advanced).
    model : LinearPlant (order <= 3) or ThreeTank
        The bare process model in its initial state (not advanced).
    warmup : int
        Samples of the warm-up: manual at ``u_man``, setpoint ``sp_warmup``,
        measurement ``y_warmup`` (the plant stays in its steady state).
    u_man : float
        The manual value at the end of the warm-up (the mode of every sample is
        ``signals["manual"]``).
    actuator : tuple
        ``(u_min, u_max, rate * ts, u)``: range, largest step per sample and
        the input applied before the first sample.
    sensor : tuple
        ``(y_min, y_max)``, the measuring range.
    signals : dict of arrays
        Per sample: ``sp``, ``load_in``, ``load_out``, ``manual`` (0/1),
        ``u_man`` (NaN: unchanged), ``g3o`` (three-tank outlet coefficient;
        anything for a linear plant).
    noise : array
        The measurement noise of every sample.
    compiled : bool
        False runs the same loop interpreted (tests of the lane itself).

    Raises
    ------
    UnsupportedConfig
        For a controller or a plant the kernels do not cover.
    """
    loop, prm, cs = _controller_arrays(controller)
    kind, pp, ps, buf, pos = _plant_arrays(model)
    lane = _pid_lane if loop.__name__ == "_pid_loop" else _adrc_lane
    if not (compiled and HAVE_NUMBA):
        lane = python_function(lane)
    n = signals["sp"].shape[0]
    out = [np.empty(n) for _ in range(4)]
    act = np.array([*actuator, *sensor], dtype=float)
    stopped = lane(
        prm, cs, float(u_man), int(warmup), float(sp_warmup), float(y_warmup),
        kind, pp, ps, buf.copy(), pos, act, signals["sp"], signals["load_in"],
        signals["load_out"], signals["manual"], signals["u_man"], signals["g3o"], noise, *out,
    )  # fmt: skip
    return LaneResult(*out, stopped=int(stopped), compiled=compiled and HAVE_NUMBA)
