"""Robustness margins of a tuned loop: the exact discrete loop at the controller's ts.

What is computed
----------------
For a process model and a configured :class:`ctrlblocks.PID` or
:class:`ctrlblocks.ADRC`, the loop is the one the simulator runs: at sample
``k`` the block reads ``y[k]`` and the set point ``r[k]``, computes ``u[k]``,
and the process advances by ``ts`` with ``u[k]`` held (zero-order hold).

* **Process**: the exact ZOH sampling of the model with its dead time
  (Åström & Wittenmark 1997, section 2.3),
  through :class:`ctrlblocks.plants.linear.LinearPlant`: a dead time
  ``L = d ts + eps`` that is not a multiple of ``ts`` is exact as well (the
  modified z-transform, the two input matrices ``Gamma0``/``Gamma1`` of that
  module), so ``P(z) = C (zI - Phi)^-1 (Gamma0 + Gamma1 z^-1) z^-d``; no Padé
  approximation anywhere.
* **Controller**: the block itself, linear inside its limits.  Its state
  update and output are linear in (state, ``r``, ``y``); the matrices of the
  discrete 2-DOF controller ``x+ = A x + B [r; y]``, ``u = C x + D [r; y]``
  are read off the real block by running one cycle from unit states and unit
  inputs (:meth:`Block.snapshot`/:meth:`Block.restore`), so the equivalent of
  the ESO (4a) and the law (4b) of Nowak et al. 2018 (both discretisations,
  orders 1..3) and of the PID's own discretisation (integral and derivative
  methods, filter ``Td/N``, set-point weights ``b``, ``c``) is exactly the
  code that runs, not a second implementation.  States the inputs cannot
  reach (the integrator of a PID without integral action, the x2/x3 of a
  lower ADRC order) are left out.  A PID is analysed as a plant runs it
  (controltheplant 2024: PV and setpoint filters, scaling of SP and PV to
  0..100 %, the velocity form): every memory of its cycle is a state (the
  ones its configuration does not use drop out), and the cycle's value at
  rest is subtracted (scaling makes it affine).  Ramps and the dead band are
  not linear and are refused.  :attr:`Margins.warnings` notes a Tustin
  derivative that rings (``Td/N < ts/2``, :func:`derivative_rings`).
* **Loop**: the feedback part ``C_y(z) = -(C (zI - A)^-1 B_y + D_y)`` gives
  the loop transfer function ``L = C_y P``, the sensitivity ``S = 1/(1 + L)``
  and the complementary sensitivity ``T = L/(1 + L)`` on ``z = e^{j w ts}``,
  ``0 < w <= pi/ts``.

Margins (Åström & Hägglund 2006, section 4.4):
``ms = max |S|`` (the inverse of the shortest distance from ``L`` to -1),
``gm`` the gain margin (ratio, ``inf`` when ``L`` never crosses the negative
real axis), ``pm`` the phase margin [deg], ``wc_crossover`` the gain
crossover frequency [rad/s] (``|L| = 1``; the crossing with the smallest phase
margin).  **Stability** is decided by the closed-loop poles (the eigenvalues
of the loop's state matrix, dead-time shift register included): ``stable``
means all of them strictly inside the unit circle.  The margins of an
unstable loop mean nothing; ``ms`` is then reported as ``inf``.

Margin targets used by the tuning tools: ``ms <= 1.4`` robust, ``1.4..2``
the usual range (Åström & Hägglund 2006, section 4.4: ``ms = 1.4`` and
``2`` bracket good designs; ``ms = 2`` guarantees ``gm >= 2`` and
``pm >= 29 deg``), above 2 fragile.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import optimize

from ..blocks.adrc import ADRC
from ..blocks.base import ErrorCode, ParameterError
from ..blocks.pid import PID
from ..plants.linear import LinearPlant
from .identify import FOPDT, SOPDT, Integrating

__all__ = [
    "MS_FRAGILE",
    "DiscreteSS",
    "Loop",
    "Margins",
    "SmithSS",
    "controller_ss",
    "derivative_rings",
    "loop",
    "margins",
    "model_plant",
    "plant_response",
    "plant_ss",
    "smith_ss",
]

MS_FRAGILE = 2.0
"""Above this maximum sensitivity a tuning is called fragile (refused by default)."""

_POLE_TOL = 1e-10  # a closed-loop pole with |z| > 1 - _POLE_TOL counts as unstable
_GRID = 2000  # log-spaced frequencies over _DECADES below the Nyquist frequency
_DECADES = 6.0


@dataclass(frozen=True)
class DiscreteSS:
    """A discrete state space ``x+ = a x + b w``, ``v = c x + d w`` with sample time ``ts`` [s]."""

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    d: np.ndarray
    ts: float
    mv_states: tuple[bool, ...] = ()
    """Which states hold MV values (a controller's integrator, its last output; the
    rest hold PV values and their rates): :meth:`Loop.poles` scales them with the
    process gain.  Empty: none does."""
    delay: tuple[int, int] | None = None
    """``(source, m)``: the last states from ``m`` on are a shift register of the state
    ``source`` (the ADRC's ``input_delay`` history of its last u, oldest first: state
    ``m + j`` is ``source`` delayed by ``n - m - j`` samples).  :meth:`response` then
    solves the ``m`` other states only (a register of 200 samples makes the full
    matrix ill-conditioned for a transfer function, and slow to solve)."""

    def response(self, w: np.ndarray) -> np.ndarray:
        """Frequency response at ``w`` [rad/s]: array (len(w), outputs, inputs), complex."""
        z = np.exp(1j * np.asarray(w, float) * self.ts)
        n = self.a.shape[0]
        if n == 0:
            return np.broadcast_to(self.d, (len(z), *self.d.shape)).astype(complex)
        if self.delay is not None:
            return self._delayed_response(z)
        m = z[:, None, None] * np.eye(n) - self.a
        x = np.linalg.solve(m, np.broadcast_to(self.b, (len(z), *self.b.shape)))
        return self.c @ x + self.d

    def _delayed_response(self, z: np.ndarray) -> np.ndarray:
        """:meth:`response` with the register states written as delays of their source."""
        assert self.delay is not None
        src, m = self.delay
        n = self.a.shape[0]
        # the register's states that act on the rest (the oldest one, for the ADRC)
        used = np.flatnonzero(np.any(self.a[:m, m:] != 0.0, axis=0)
                              | np.any(self.c[:, m:] != 0.0, axis=0))  # fmt: skip
        lags = (n - m - used).astype(float)  # state m + j is the source delayed by n - m - j
        zd = np.exp(-1j * np.log(z)[:, None].imag * lags[None, :])  # z^-lag on |z| = 1
        # x_reg = zd * x_src: fold the register's columns into the source's column
        a_eff = np.broadcast_to(self.a[:m, :m], (len(z), m, m)).astype(complex).copy()
        a_eff[:, :, src] += zd @ self.a[:m, m + used].T
        c_eff = np.broadcast_to(self.c[:, :m], (len(z), *self.c[:, :m].shape)).astype(complex)
        c_eff = c_eff.copy()
        c_eff[:, :, src] += zd @ self.c[:, m + used].T
        lhs = z[:, None, None] * np.eye(m) - a_eff
        x = np.linalg.solve(lhs, np.broadcast_to(self.b[:m], (len(z), m, self.b.shape[1])))
        return c_eff @ x + self.d


# ---------------------------------------------------------------------------
# The process
# ---------------------------------------------------------------------------


def model_plant(model: Any, ts: float) -> LinearPlant:
    """The :class:`LinearPlant` of a tuning model at the sample time ``ts`` [s].

    ``model`` is a :class:`~ctrlblocks.tuning.identify.FOPDT`, ``SOPDT`` or
    ``Integrating`` (``k e^{-L s}/s``), or already a ``LinearPlant`` (any of
    :mod:`ctrlblocks.plants.linear`, whose own ``ts`` must equal ``ts``).
    """
    from ..plants.linear import FOPDT as PlantFOPDT
    from ..plants.linear import PT2

    if isinstance(model, LinearPlant):
        if not math.isclose(model.ts, ts, rel_tol=1e-12):
            raise ParameterError(
                ErrorCode.NO_CYCLE, "ts", f"the plant has ts = {model.ts:g} s, the block {ts:g} s"
            )
        return model
    if isinstance(model, SOPDT):
        return PT2(model.gain, model.time_constant, model.time_constant_2, ts, model.dead_time)
    if isinstance(model, FOPDT):
        return PlantFOPDT(model.gain, model.time_constant, model.dead_time, ts)
    if isinstance(model, Integrating):
        # k/s as (A, B, C) = (0, 1, k): the realisation tf2ss gives, without scipy.signal's
        # "badly conditioned" warning for a gain of 1e-100
        return LinearPlant(A=[[0.0]], B=[[1.0]], C=[[model.gain]], ts=ts, dead_time=model.dead_time)
    raise TypeError(f"no process model: {model!r}")


def plant_ss(plant: LinearPlant) -> DiscreteSS:
    """Input ``u[k]``, output ``y[k]``: the ZOH sampling with the dead time as a shift register.

    States: the plant's ``x`` and the past inputs ``u[k-1] .. u[k-d-1]``
    (Åström & Wittenmark 1997, section 2.3, "Time delay"; the update (2)
    of :mod:`ctrlblocks.plants.linear`).
    """
    nx, d = plant.n_states, plant.dead_samples
    m = d + 1  # u[k-1] .. u[k-d-1]
    a = np.zeros((nx + m, nx + m))
    b = np.zeros((nx + m, 1))
    a[:nx, :nx] = plant.phi
    g0, g1 = plant.gamma0, plant.gamma1
    if d == 0:
        b[:nx, 0] = g0
    else:
        a[:nx, nx + d - 1] = g0
    a[:nx, nx + d] += g1
    b[nx, 0] = 1.0
    for j in range(1, m):
        a[nx + j, nx + j - 1] = 1.0
    c = np.zeros((1, nx + m))
    c[0, :nx] = plant.c
    return DiscreteSS(a, b, c, np.zeros((1, 1)), plant.ts)


# ---------------------------------------------------------------------------
# The controller: matrices read off the real block
# ---------------------------------------------------------------------------

# the controller states that hold MV values (ADRC: the last output; PID: the integral and
# derivative terms); the others hold PV values, their rates or the ESO's total disturbance
_MV_STATES = frozenset({"_u_prev", "_i", "_d", "_x", "_bias", "_p_prev", "_d_prev", "_ff_prev"})

_ADRC_STATES = {
    1: ("_yh", "_x4", "_u_prev", "_ref"),
    2: ("_yh", "_x2", "_x4", "_u_prev", "_ref"),
    3: ("_yh", "_x2", "_x3", "_x4", "_u_prev", "_ref"),
}


def controller_ss(block: PID | ADRC, *, direct: bool = False) -> DiscreteSS:
    """The discrete 2-DOF controller of ``block`` inside its limits: inputs ``[r, y]``, output u.

    An ADRC with an ``input_delay`` of ``d > 1`` samples is read with a delay of
    one sample and its history extended to ``d`` samples (only the oldest value
    feeds the ESO; the others shift): the same matrices as reading all ``d``
    history states one by one (``direct=True``, a test compares them), without
    ``d`` cycles of the block.

    The block's configuration is copied with infinite output limits (the
    margins are those of the linear loop); the matrices come from one cycle of
    that block per unit state and unit input (module docstring).  SP/PV filters,
    the ADRC's tracking differentiator (its reference path ``C_r``) and PV scaling
    are part of the controller (as a plant runs it); a ramp of the
    setpoint or the output, or a dead band, is refused (the law is then not
    linear).
    """
    cfg = block.config
    nd = round(float(getattr(cfg, "input_delay", 0.0)) / float(cfg.ts))
    if isinstance(block, ADRC) and nd > 1 and not direct:
        one = ADRC(cfg, input_delay=float(cfg.ts), u_min=-math.inf, u_max=math.inf)
        return _extend_history(controller_ss(one), nd)
    if isinstance(block, PID | ADRC):
        nonlinear = [name for name in ("sp_rate", "out_rate", "deadband")
                     if getattr(cfg, name, 0.0) != 0.0]  # fmt: skip
        if nonlinear:
            kind = type(block).__name__
            raise ParameterError(
                ErrorCode.BAD_PARAMETER,
                kind,
                f"margins need a linear law; {', '.join(nonlinear)} is not (a ramp limits a "
                f"rate, the dead band holds the output): analyse the {kind} without it",
            )
    if isinstance(block, ADRC):
        probe: PID | ADRC = ADRC(cfg, u_min=-math.inf, u_max=math.inf, anti_backoff=False)
        fields = _ADRC_STATES[int(cfg.order)]  # x2, x3 unused below order 2, 3
        # the input stage's filters are part of the loop (PV) and of the reference path
        # (SP); PV scaling is static (the affine part is subtracted below)
        fields += tuple(f for f, t in (("_sp_f", cfg.sp_filter), ("_pv_f", cfg.pv_filter))
                        if t > 0.0)  # fmt: skip
        # the tracking differentiator's chain: the reference path only (r_eff)
        if getattr(cfg, "td_time", 0.0) > 0.0:
            fields += ("_td1", "_td2", "_td3")[: int(cfg.order)]
    elif isinstance(block, PID):
        probe = PID(cfg, u_min=-math.inf, u_max=math.inf, bumpless="integrator")
        plain = (
            cfg.algorithm == "positional"
            and cfg.pv_range is None
            and cfg.sp_filter == cfg.pv_filter == 0.0
        )
        if plain:
            # without integral action the integrator is a constant (unreachable) state
            fields = ("_i", "_d", "_w_prev", "_e_prev")[0 if cfg.ti > 0.0 else 1 :]
        else:
            # as a plant runs it (controltheplant 2024): PV and SP filters, scaling to
            # 0..100 %, the velocity form -- every memory of the cycle is a state
            fields = _PID_STATES
    else:
        raise TypeError(f"margins are defined for PID and ADRC blocks, not {type(block).__name__}")
    probe(0.0, 0.0)  # leave the first-cycle start-up (ESO start, PID cold start)
    probe(0.0, 0.0)
    template = probe.snapshot()
    # the ADRC's input_delay: the history of applied u the ESO is fed from, oldest first
    n_hist = len(template.get("_u_hist", ()))
    n = len(fields) + n_hist

    def cycle(x: Sequence[float], r: float, y: float) -> tuple[np.ndarray, float]:
        snap = copy.deepcopy(template)
        for f, v in zip(fields, x[: len(fields)], strict=True):
            _set_field(snap, f, float(v))
        if n_hist:
            snap["_u_hist"] = tuple(float(v) for v in x[len(fields) :])
        probe.restore(snap)
        u = float(probe(r, y))
        new = probe.snapshot()
        hist = [float(v) for v in new["_u_hist"]] if n_hist else []
        return np.array([float(_get_field(new, f)) for f in fields] + hist), u

    a = np.zeros((n, n))
    b = np.zeros((n, 2))
    c = np.zeros((1, n))
    d = np.zeros((1, 2))
    zero = np.zeros(n)
    # the cycle is affine (scaling to 0..100 % shifts r and y): its value at rest is
    # subtracted, so that the columns are the linear part (0 for the plain laws)
    x0, u0 = cycle(zero, 0.0, 0.0)
    for j in range(n):
        e = zero.copy()
        e[j] = 1.0
        a[:, j], c[0, j] = cycle(e, 0.0, 0.0)
        a[:, j] -= x0
        c[0, j] -= u0
    b[:, 0], d[0, 0] = cycle(zero, 1.0, 0.0)
    b[:, 1], d[0, 1] = cycle(zero, 0.0, 1.0)
    b -= x0[:, None]
    d -= u0
    mv = tuple(f in _MV_STATES for f in fields) + (True,) * n_hist
    delay = (fields.index("_u_prev"), len(fields)) if n_hist else None
    if isinstance(block, PID) and fields is _PID_STATES:
        return _minimal(DiscreteSS(a, b, c, d, float(cfg.ts), mv, delay))
    return DiscreteSS(a, b, c, d, float(cfg.ts), mv, delay)


_PID_STATES = (
    "_i", "_d", "_w_prev", "_e_prev", "_x", "_bias", "_p_prev", "_d_prev", "_ff_prev",
    "_subs._sp_filter.out", "_subs._pv_filter.out",
)  # fmt: skip
"""The memories of a PID's cycle with filters, scaling or the velocity form (those its
configuration does not use are dropped by :func:`_minimal`)."""


def _get_field(snap: dict[str, Any], name: str) -> Any:
    """A snapshot's value at a dotted path (``"_subs._pv_filter.out"``)."""
    for part in name.split("."):
        snap = snap[part]
    return snap


def _set_field(snap: dict[str, Any], name: str, value: float) -> None:
    *path, last = name.split(".")
    for part in path:
        snap = snap[part]
    snap[last] = value


def _minimal(ss: DiscreteSS) -> DiscreteSS:
    """``ss`` without the states the inputs cannot reach or the output cannot see.

    Structurally: a state is kept when a chain of non-zero entries leads to it
    from ``b`` and from it to ``c`` -- a memory the configuration does not use
    (the velocity form's output integrator in the positional law, an integrator
    without integral action) would otherwise add a pole at 0 or 1 that the loop
    does not have.
    """
    a, b, c = ss.a, ss.b, ss.c
    n = a.shape[0]
    reach = set(np.flatnonzero(np.any(b != 0.0, axis=1)))
    grow = True
    while grow:
        new = {i for i in range(n) for j in reach if a[i, j] != 0.0}
        grow = not new <= reach
        reach |= new
    seen = set(np.flatnonzero(c[0] != 0.0))
    grow = True
    while grow:
        new = {j for j in range(n) for i in seen if a[i, j] != 0.0}
        grow = not new <= seen
        seen |= new
    keep = sorted(reach & seen)
    mv = tuple(ss.mv_states[i] for i in keep) if ss.mv_states else ()
    return DiscreteSS(a[np.ix_(keep, keep)], b[keep], c[:, keep], ss.d, ss.ts, mv, None)


def derivative_rings(block: Any) -> str | None:
    """A warning when a PID's Tustin derivative rings: ``Td/N < ts/2``, else None.

    The Tustin image of the filtered derivative ``Td s/(1 + s Td/N)`` has its pole
    at ``z = (2 Td/N - h)/(2 Td/N + h)`` (Åström 1987, (2.13)): negative, an
    oscillation at the Nyquist frequency, when the filter time ``Td/N`` is
    shorter than half the sample time ``h``.
    """
    if not isinstance(block, PID):
        return None
    cfg = block.config
    _k, _ti, td = cfg.isa()
    if cfg.derivative_method != "tustin" or td <= 0.0:
        return None
    tf, h = td / cfg.n, float(cfg.ts)
    if tf >= 0.5 * h:
        return None
    pole = (2.0 * tf - h) / (2.0 * tf + h)
    return (
        f"the Tustin derivative rings: Td/N = {tf:.4g} s < ts/2 = {0.5 * h:.4g} s puts its "
        f"pole at z = {pole:.3f} (an oscillation at the Nyquist frequency); use the "
        "backward derivative or N <= 2 Td/ts"
    )


def plant_response(p: LinearPlant, w: np.ndarray) -> np.ndarray:
    """``P(e^{j w ts})`` of a sampled plant from its own matrices (dead time as ``z^-d``)."""
    z = np.exp(1j * np.asarray(w, float) * p.ts)
    n = p.n_states
    m = z[:, None, None] * np.eye(n) - p.phi
    g = p.gamma0[None, :] + p.gamma1[None, :] / z[:, None]
    x = np.linalg.solve(m, g[:, :, None])[:, :, 0]
    return (x @ p.c) * z ** (-p.dead_samples)


@dataclass(frozen=True)
class SmithSS(DiscreteSS):
    """The state space of :func:`smith_ss`, with its frequency response from the parts.

    ``inner`` is the block's controller, ``models`` the predictor's plants
    ``(M0, M)``: ``[C_r, -C_y] / (1 + C_y (M0 - M))`` (the matrices of the
    whole controller, with both models' states and the dead-time register, are
    for the poles; their response would need a solve of that size per frequency).
    """

    inner: DiscreteSS | None = None
    models: tuple[LinearPlant, LinearPlant] | None = None

    def response(self, w: np.ndarray) -> np.ndarray:
        assert self.inner is not None and self.models is not None
        g = self.inner.response(w).copy()
        dm = plant_response(self.models[0], w) - plant_response(self.models[1], w)
        cy = -g[:, 0, 1]
        den = 1.0 + cy * dm
        g[:, 0, 0] /= den
        g[:, 0, 1] /= den
        return g


def _extend_history(one: DiscreteSS, nd: int) -> DiscreteSS:
    """The controller of a one-sample ``input_delay`` with its history made ``nd`` samples long."""
    assert one.delay is not None
    src, m = one.delay
    n = m + nd
    a = np.zeros((n, n))
    a[:m, :m] = one.a[:m, :m]
    a[:m, m] = one.a[:m, m]  # the oldest value feeds the ESO
    for j in range(nd - 1):
        a[m + j, m + j + 1] = 1.0  # the history shifts
    a[n - 1, :m] = one.a[m, :m]  # the newest value: the last u (the source state)
    b = np.zeros((n, one.b.shape[1]))
    b[:m] = one.b[:m]
    c = np.zeros((1, n))
    c[0, :m] = one.c[0, :m]
    c[0, m] = one.c[0, m]
    mv = tuple(one.mv_states[:m]) + (True,) * nd
    return DiscreteSS(a, b, c, one.d.copy(), one.ts, mv, (src, m))


def smith_ss(ctrl: DiscreteSS, model: Any) -> DiscreteSS:
    """The controller ``ctrl`` inside a Smith predictor on ``model``: inputs ``[r, y]``, output u.

    The structure of :class:`ctrlblocks.loops.structures.Smith` (Nowak et al.
    2018, section 3.1), in the simulator's order: the block reads
    ``y_f = y + y_M0 - y_M`` (``M`` the model sampled at the controller's
    ``ts`` with its dead time, ``M0`` the same without the dead time; both
    strictly proper, their outputs of this cycle from their states), computes
    ``u``, then both models advance with ``u``.  States: the block's, then
    ``M0``'s, then ``M``'s (with its input shift register).  ``model`` is the
    predictor's model, which need not be the process the loop runs on.
    """
    import dataclasses

    ts = ctrl.ts
    fast_plant, fast = _sampled(dataclasses.replace(model, dead_time=0.0), ts)
    slow_plant, slow = _sampled(model, ts)
    nc, n0, nm = ctrl.a.shape[0], fast.a.shape[0], slow.a.shape[0]
    n = nc + n0 + nm
    # y_f = y + H x_models, H = [c0, -cm]
    h = np.zeros((1, n))
    h[0, nc : nc + n0] = fast.c[0]
    h[0, nc + n0 :] = -slow.c[0]
    ex = np.zeros((nc, n))
    ex[:, :nc] = np.eye(nc)
    by, dy = ctrl.b[:, 1:2], ctrl.d[0, 1]
    c_u = ctrl.c[0] @ ex + dy * h[0]  # u = c_u X + d_r r + d_y y
    d_u = ctrl.d[0].copy()
    a = np.zeros((n, n))
    b = np.zeros((n, 2))
    a[:nc] = ctrl.a @ ex + by @ h
    b[:nc] = ctrl.b
    for lo, ss in ((nc, fast), (nc + n0, slow)):
        k = ss.a.shape[0]
        a[lo : lo + k, lo : lo + k] += ss.a
        a[lo : lo + k] += ss.b @ c_u[None, :]
        b[lo : lo + k] += ss.b @ d_u[None, :]
    mv = list(ctrl.mv_states) + [False] * (nc - len(ctrl.mv_states))
    mv += _register_flags(fast, fast_plant)
    mv += _register_flags(slow, slow_plant)
    return SmithSS(a, b, c_u[None, :], d_u[None, :], ts, tuple(mv), None, ctrl,
                   (fast_plant, slow_plant))  # fmt: skip


def _register_flags(ss: DiscreteSS, plant: LinearPlant) -> list[bool]:
    """Which states of :func:`plant_ss` hold past MVs (the input shift register)."""
    return [False] * plant.n_states + [True] * (ss.a.shape[0] - plant.n_states)


# ---------------------------------------------------------------------------
# The loop and its margins
# ---------------------------------------------------------------------------


@dataclass(frozen=True)
class Margins:
    """Robustness of one loop (module docstring).

    Attributes
    ----------
    ms : float
        Maximum sensitivity ``max |S|`` (``inf`` when the loop is unstable).
    gm : float
        Gain margin (ratio; ``inf`` when there is no phase crossover).
    pm : float
        Phase margin [deg] (``inf`` when ``|L|`` never reaches 1).
    wc_crossover : float
        Gain-crossover frequency [rad/s] (NaN without crossover).
    w_gm : float
        Phase-crossover frequency of the gain margin [rad/s] (NaN without).
    w_ms : float
        Frequency of the sensitivity peak [rad/s].
    stable : bool
        All closed-loop poles strictly inside the unit circle.
    radius : float
        Largest closed-loop pole modulus.
    ts : float
        Sample time of the analysed loop [s].
    """

    ms: float
    gm: float
    pm: float
    wc_crossover: float
    w_gm: float
    w_ms: float
    stable: bool
    radius: float
    ts: float
    warnings: tuple[str, ...] = ()
    """Notes on the analysed controller (a ringing Tustin derivative, :func:`derivative_rings`)."""

    def as_dict(self) -> dict[str, float | bool]:
        """The keys of ``ctrlblocks tune ... --json``: ``ms, gm, pm, wc_crossover, stable``."""
        return {
            "ms": self.ms,
            "gm": self.gm,
            "pm": self.pm,
            "wc_crossover": self.wc_crossover,
            "stable": self.stable,
        }

    def summary(self) -> str:
        """One line, e.g. ``Ms 1.60, GM 3.1 (9.8 dB), PM 52 deg at 0.12 rad/s, stable``."""
        if not self.stable:
            return f"UNSTABLE closed loop (largest pole |z| = {self.radius:.4g})"
        gm = "inf" if math.isinf(self.gm) else f"{self.gm:.3g} ({20 * math.log10(self.gm):.1f} dB)"
        pm = "inf" if math.isinf(self.pm) else f"{self.pm:.1f} deg"
        wc = "" if math.isnan(self.wc_crossover) else f" at {self.wc_crossover:.4g} rad/s"
        return f"Ms {self.ms:.3f}, GM {gm}, PM {pm}{wc}, stable"


_SAMPLED: dict[tuple[Any, ...], tuple[LinearPlant, DiscreteSS]] = {}


def _sampled(model: Any, ts: float) -> tuple[LinearPlant, DiscreteSS]:
    """The plant of ``model`` at ``ts`` and its state space (cached for the tuning models)."""
    if isinstance(model, LinearPlant):
        plant = model_plant(model, ts)
        return plant, plant_ss(plant)
    names = ("gain", "time_constant", "time_constant_2", "dead_time")
    key = (type(model).__name__, *(getattr(model, f, None) for f in names), ts)
    hit = _SAMPLED.get(key)
    if hit is None:
        plant = model_plant(model, ts)
        hit = (plant, plant_ss(plant))
        if len(_SAMPLED) > 256:
            _SAMPLED.clear()
        _SAMPLED[key] = hit
    return hit


class Loop:
    """The sampled loop of a process model and a block (module docstring).

    Parameters
    ----------
    model : FOPDT, SOPDT, Integrating or LinearPlant
        The process model (dead time exact).
    block : PID, ADRC or DiscreteSS
        The configured controller; its ``ts`` is the loop's sample time.  A
        :class:`DiscreteSS` with inputs ``[r, y]`` is a whole controller
        already (e.g. a block inside a Smith predictor, :func:`smith_ss`).
    """

    def __init__(self, model: Any, block: PID | ADRC | DiscreteSS) -> None:
        self.ctrl = block if isinstance(block, DiscreteSS) else controller_ss(block)
        ring = derivative_rings(block)
        self.warnings: tuple[str, ...] = () if ring is None else (ring,)
        self.ts = self.ctrl.ts
        self.plant, self.pss = _sampled(model, self.ts)

    # -- frequency responses -------------------------------------------------

    def process(self, w: np.ndarray) -> np.ndarray:
        """``P(e^{j w ts})`` from the plant's own matrices (dead time as ``z^-d``)."""
        return plant_response(self.plant, w)

    def controller(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(C_r, C_y)`` at ``w``: ``u = C_r r - C_y y`` (``C_y`` the feedback part)."""
        g = self.ctrl.response(w)
        return g[:, 0, 0], -g[:, 0, 1]

    def loop_gain(self, w: np.ndarray) -> np.ndarray:
        """``L = C_y P`` at ``w`` [rad/s]."""
        return self.controller(w)[1] * self.process(w)

    def sensitivity(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(S, T)`` at ``w``."""
        L = self.loop_gain(w)
        return 1.0 / (1.0 + L), L / (1.0 + L)

    # -- poles ---------------------------------------------------------------

    def closed_loop_a(self) -> np.ndarray:
        """State matrix of the closed loop (process with its shift register, then controller)."""
        p, c = self.pss, self.ctrl
        np_, nc = p.a.shape[0], c.a.shape[0]
        by = c.b[:, 1:]
        dy = c.d[0, 1]
        a = np.zeros((np_ + nc, np_ + nc))
        a[:np_, :np_] = p.a + dy * p.b @ p.c
        a[:np_, np_:] = p.b @ c.c
        a[np_:, :np_] = by @ p.c
        a[np_:, np_:] = c.a
        return a

    def poles(self) -> np.ndarray:
        """Closed-loop poles: eigenvalues of :meth:`closed_loop_a`, MV states scaled to the process.

        The loop is the same in any units, its state matrix is not: with a
        process gain of ``1e30`` the past MVs of the dead-time register and the
        controller's MV states are ``1e30`` times smaller than the PV states,
        and the eigenvalues of such a matrix are wrong in the 5th digit (a
        loop of ``|z| = 0.999999`` came out at ``1.00001``; LAPACK's own
        balancing does not undo it).  So the poles are those of
        ``T A T^-1`` (the same eigenvalues), ``T`` scaling every state that
        holds an MV by a power of two near the process gain ``|P|`` (at a
        hundredth of the Nyquist frequency), and the plant's states by one
        near its largest output coefficient: the loop as it is in units in
        which the process gain is about 1.
        """
        a = self.closed_loop_a()
        t = self._state_scales()
        return np.linalg.eigvals(a * t[:, None] / t[None, :])

    def _state_scales(self) -> np.ndarray:
        """The diagonal of ``T`` in :meth:`poles` (powers of two: no rounding)."""
        with np.errstate(all="ignore"):
            gain = float(np.abs(self.process(np.array([0.01 * math.pi / self.ts])))[0])
            c_max = float(np.max(np.abs(self.plant.c)))
        nx, n_reg = self.plant.n_states, self.pss.a.shape[0] - self.plant.n_states
        mv = _power_of_two(gain)
        ctrl = [mv if is_mv else 1.0 for is_mv in self.ctrl.mv_states]
        ctrl += [1.0] * (self.ctrl.a.shape[0] - len(ctrl))
        return np.array([_power_of_two(c_max)] * nx + [mv] * n_reg + ctrl)

    def integral_gain(self) -> float:
        """The controller's integral gain ``ki`` [MV/(PV s)]: ``(z - 1)/ts C_y(z)`` at ``z -> 1``.

        For a PID ``kp/ti``; for an ADRC that of its equivalent feedback
        controller (the ESO's disturbance estimate integrates).  With a
        stable loop and a unit step load at the process input the integrated
        error is ``IE = -1/ki``, the PV's integrated deviation ``1/ki``
        (final-value theorem, checked against a simulation in the tests);
        the MIGO design of Åström & Hägglund 2006, chapter 7, maximises ``ki``
        under an Ms constraint for that reason.  Evaluated at
        ``w = 1e-7 pi/ts`` (relative error of order ``1e-7``); 0 without
        integral action.
        """
        w = np.array([1e-7 * math.pi / self.ts])
        z = np.exp(1j * w[0] * self.ts)
        return float(((z - 1.0) / self.ts * self.controller(w)[1][0]).real)

    # -- margins -------------------------------------------------------------

    def grid(self) -> np.ndarray:
        """The frequency grid [rad/s]: log-spaced up to the Nyquist frequency ``pi/ts``."""
        wn = math.pi / self.ts
        return wn * np.logspace(-_DECADES, 0.0, _GRID)

    def stable(self) -> bool:
        """All closed-loop poles strictly inside the unit circle (module docstring)."""
        return float(np.max(np.abs(self.poles()))) < 1.0 - _POLE_TOL

    def peak_sensitivity(self, points: int = 400) -> float:
        """Quick ``max |S|`` on a coarse grid plus a local refinement; ``inf`` if unstable.

        For searches (:func:`ctrlblocks.tuning.adrc.adrc_tuning`); the final
        numbers come from :meth:`margins`.
        """
        if not self.stable():
            return math.inf
        w = math.pi / self.ts * np.logspace(-_DECADES, 0.0, points)
        s = np.abs(1.0 / (1.0 + self.loop_gain(w)))
        return self._refine_peak(w, int(np.argmax(s)))[0]

    def margins(self) -> Margins:
        """Ms, GM, PM, crossover and stability (module docstring)."""
        radius = float(np.max(np.abs(self.poles())))
        stable = radius < 1.0 - _POLE_TOL
        w = self.grid()
        with np.errstate(all="ignore"):  # an overflow is refused below, with its cause
            L = self.loop_gain(w)
        if not (math.isfinite(radius) and np.all(np.isfinite(L))):
            raise ParameterError(
                ErrorCode.BAD_PARAMETER,
                "model/tuning",
                "the loop's frequency response or poles are not finite: the model's or the "
                "controller's numbers are too extreme to analyse (a time constant of 1e308 s?)",
            )
        # a finite but extreme loop may overflow a margin to inf (an infinite gain margin):
        # that is its value, not an error
        with np.errstate(over="ignore", divide="ignore", under="ignore"):
            s = np.abs(1.0 / (1.0 + L))
            i = int(np.argmax(s))
            ms, w_ms = self._refine_peak(w, i)
            gm, w_gm = self._gain_margin(w, L)
            pm, wc = self._phase_margin(w, L)
        return Margins(ms if stable else math.inf, gm, pm, wc, w_gm, w_ms, stable, radius, self.ts,
                       self.warnings)  # fmt: skip

    def _refine_peak(self, w: np.ndarray, i: int) -> tuple[float, float]:
        lo, hi = w[max(i - 1, 0)], w[min(i + 1, len(w) - 1)]

        def neg(x: float) -> float:
            return -float(np.abs(1.0 / (1.0 + self.loop_gain(np.array([x]))[0])))

        best = (-neg(w[i]), float(w[i]))
        if hi > lo:
            r = optimize.minimize_scalar(neg, bounds=(lo, hi), method="bounded",
                                         options={"xatol": 1e-7 * hi})  # fmt: skip
            if -r.fun > best[0]:
                best = (-float(r.fun), float(r.x))
        return best

    def _gain_margin(self, w: np.ndarray, L: np.ndarray) -> tuple[float, float]:
        im = L.imag
        best = (math.inf, math.nan)
        for k in np.nonzero(np.sign(im[:-1]) * np.sign(im[1:]) <= 0)[0]:
            if im[k] == im[k + 1]:
                wk = float(w[k])
            else:
                wk = optimize.brentq(
                    lambda x: float(self.loop_gain(np.array([x]))[0].imag), w[k], w[k + 1],
                    xtol=1e-12 * w[k + 1],
                )  # fmt: skip
            lk = self.loop_gain(np.array([wk]))[0]
            if lk.real < 0.0 and -1.0 / lk.real < best[0]:
                best = (-1.0 / lk.real, wk)
        real_end = L[-1].real < 0.0 and abs(L[-1].imag) < 1e-9 * max(1.0, abs(L[-1]))
        if real_end and -1.0 / L[-1].real < best[0]:  # the Nyquist frequency: L is real there
            best = (-1.0 / L[-1].real, float(w[-1]))
        return float(best[0]), best[1]

    def _phase_margin(self, w: np.ndarray, L: np.ndarray) -> tuple[float, float]:
        lg = np.log(np.abs(L))
        best = (math.inf, math.nan)
        for k in np.nonzero(np.sign(lg[:-1]) * np.sign(lg[1:]) <= 0)[0]:
            if lg[k] == lg[k + 1]:
                wk = w[k]
            else:
                wk = optimize.brentq(
                    lambda x: float(np.log(np.abs(self.loop_gain(np.array([x]))[0]))),
                    w[k], w[k + 1], xtol=1e-12 * w[k + 1],
                )  # fmt: skip
            pm = math.degrees(float(np.angle(-self.loop_gain(np.array([wk]))[0])))
            if pm < best[0]:
                best = (pm, float(wk))
        return best

    # -- time responses on the model -------------------------------------------

    def simulate(
        self, t_end: float, *, r: float = 1.0, load: float = 0.0, t_load: float = 0.0
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(t, y, u)`` [s, PV, MV] of the linear loop on the model, from rest.

        Set-point step ``r`` at ``t = 0`` and a step ``load`` added to the
        process input from ``t_load`` [s] on; the simulator's order (``u[k]``
        from ``y[k]``, then the process advances), no limits.
        """
        n = round(t_end / self.ts) + 1
        p, c = self.pss, self.ctrl
        a = self.closed_loop_a()
        b_r = np.concatenate([p.b[:, 0] * c.d[0, 0], c.b[:, 0]])
        b_l = np.concatenate([p.b[:, 0], np.zeros(c.a.shape[0])])
        c_y = np.concatenate([p.c[0], np.zeros(c.a.shape[0])])
        c_u = np.concatenate([c.d[0, 1] * p.c[0], c.c[0]])
        x = np.zeros(a.shape[0])
        t = np.arange(n) * self.ts
        ys, us = np.zeros(n), np.zeros(n)
        for k in range(n):
            ys[k] = c_y @ x
            us[k] = c_u @ x + c.d[0, 0] * r
            x = a @ x + b_r * r + (b_l * load if t[k] >= t_load else 0.0)
        return t, ys, us

    def response_time(self) -> float:
        """A time [s] after which the step response has surely settled: 10 times the
        slowest closed-loop time constant, plus the dead time (at most 200000 samples)."""
        r = float(np.max(np.abs(self.poles())))
        tau = -self.ts / math.log(r) if 0.0 < r < 1.0 else 0.0
        return min(10.0 * tau + self.plant.dead_time + 10.0 * self.ts, 200000 * self.ts)

    def settling_time(self, t_end: float | None = None, band: float = 0.02) -> float:
        """2 % settling time [s] of the set-point step response on the model (NaN: not settled).

        ``t_end`` defaults to :meth:`response_time`.
        """
        t, y, _u = self.simulate(self.response_time() if t_end is None else t_end)
        outside = np.flatnonzero(np.abs(y - 1.0) > band)
        if len(outside) == 0:
            return 0.0
        return math.nan if outside[-1] == len(y) - 1 else float(t[outside[-1] + 1])


def _power_of_two(x: float) -> float:
    """The power of two nearest ``x`` in log scale (2**-1000 .. 2**1000; 1 for 0, inf, NaN)."""
    if not (math.isfinite(x) and x > 0.0):
        return 1.0
    return math.ldexp(1.0, max(-1000, min(1000, round(math.log2(x)))))


def loop(model: Any, block: PID | ADRC) -> Loop:
    """Shorthand for :class:`Loop`."""
    return Loop(model, block)


def margins(model: Any, block: PID | ADRC) -> Margins:
    """Margins of ``block`` on ``model`` (module docstring); see :class:`Margins`."""
    return Loop(model, block).margins()
