"""One cycle of a block or a plant over plain floats, built from the blocks' own functions.

Each kernel here is the per-cycle *sequence* of one block in its plain
configuration (what ``PID.__call__`` / ``ADRC.__call__`` do for it), written
only with the module-level pure functions of the blocks -- the single
implementation of each control law (one implementation of each law):

* :func:`pid_step` is :func:`ctrlblocks.blocks.pid.pid_step` (the PID's own
  fast lane), which calls :func:`ctrlblocks.blocks.pid.derivative_step`
  (Åström 1987, (2.13)), ``integral_increment`` ((2.8)/Tustin), ``clamp``,
  ``clamping_blocks`` and ``clamping_integral`` (controltheplant 2024 CLAMPING)
  and the back-calculation gain that the block precomputes with
  ``tracking_gain`` (Åström 1987, Fig. 3.6);
* :func:`adrc_step` is :func:`ctrlblocks.blocks.adrc.adrc_step` (the ADRC's
  own fast lane), which calls :func:`ctrlblocks.blocks.adrc.eso_euler` (Nowak et al. 2018
  (4a)), ``control_law`` ((4b)), ``x4_update_allowed`` (section 4.1) and
  ``solve_x4`` ((11));
* :func:`lti3_step` is the exact ZOH update (2) of
  :class:`ctrlblocks.plants.LinearPlant` for up to three states held in local
  variables (``plants.linear.lti_step`` works on lists, which compiled code
  would allocate every sample); the plant ``ThreeTank`` is stepped by its own
  ``threetank_rk4``.

The kernels take and return floats only, so numba compiles them (they are
registered with :func:`~ctrlblocks.fast._jit.jitable`) and inlines them into
the time loops of :mod:`.loops` and :mod:`.bank`, with the state in local
variables; without numba the same kernels run interpreted.  The tests check
every kernel against the blocks sample by sample (to 1e-12), including
limits, manual mode, bumpless transfer and both anti-windup methods.

Parameter tuples are built from a configured block by :func:`pid_params` and
:func:`adrc_params` (which refuse configurations the kernels do not cover).
"""

from __future__ import annotations

from typing import Any

from ..compiled import interpreted
from ..plants import threetank as _tt
from ._jit import jitable

# the blocks' law functions as Python functions (numba compiles those, not a compiled build's)
_adrc = interpreted("adrc")
_pid = interpreted("pid")

__all__ = [
    "ADRC_PARAMS",
    "PID_PARAMS",
    "UnsupportedConfig",
    "adrc_params",
    "adrc_step",
    "lti3_params",
    "lti3_step",
    "pid_params",
    "pid_step",
]

# the blocks' pure functions, callable (and inlined) from compiled code
for _f in (
    _pid.derivative_step,
    _pid.integral_increment,
    _pid.clamp,
    _pid.clamping_blocks,
    _pid.clamping_integral,
    _pid.tracking_gain,
    _pid.ramp_blocks,
    _pid.deadband,
    _pid.rate_limit_step,
    _pid.pid_output,
    _pid.pid_law,
    _pid.pid_commit,
    _adrc.eso_euler,
    _adrc.eso_exact,
    _adrc.control_law,
    _adrc.x4_update_allowed,
    _adrc.solve_x4,
    _adrc.anti_backoff_states,
    _adrc.eso_euler_substeps,
    _adrc.handover_offset,
    _adrc.adrc_law,
    _tt.threetank_rk4,
    _pid.pid_step,
    _adrc.adrc_step,
):
    jitable(_f)


class UnsupportedConfig(ValueError):
    """The block's configuration uses a feature the compiled kernels do not cover."""


# ---------------------------------------------------------------------------
# PID
# ---------------------------------------------------------------------------

PID_PARAMS = _pid.PIDKernelParams._fields
"""Names of the entries of the PID parameter tuple (all floats)."""


def pid_params(pid: Any, *, manual_ok: bool = True) -> tuple[float, ...]:
    """The parameter tuple of :func:`pid_step` for a configured :class:`~ctrlblocks.PID`.

    The block decides what the kernel can run (:meth:`~ctrlblocks.PID.fast_path_blockers`)
    and gives its parameters (:meth:`~ctrlblocks.PID.kernel_params`).

    Raises
    ------
    UnsupportedConfig
        For the velocity algorithm, PV scaling, SP/PV filters, SP or output
        ramps, the lead-lag feed-forward, the adaptive dead band, bumpless
        methods other than ``"integrator"``, anti-windup ``back_calc_real``,
        the inputs track/hold/reset_active/awin and a re-initialisation in
        progress (and, ``manual_ok`` False, a block that last ran in manual).
    """
    bad = pid.fast_path_blockers(manual_ok=manual_ok)
    if bad:
        raise UnsupportedConfig(f"PID options not covered by the compiled kernel: {bad}")
    return tuple(float(v) for v in pid.kernel_params())


pid_step = _pid.pid_step


# ---------------------------------------------------------------------------
# ADRC
# ---------------------------------------------------------------------------

ADRC_PARAMS = _adrc.ADRCKernelParams._fields
"""Names of the entries of the ADRC parameter tuple (all floats)."""


def adrc_params(adrc: Any, *, manual_ok: bool = True) -> tuple[float, ...]:
    """The parameter tuple of :func:`adrc_step` for a configured :class:`~ctrlblocks.ADRC`.

    The block decides (:meth:`~ctrlblocks.ADRC.fast_path_blockers`) and gives
    the parameters (:meth:`~ctrlblocks.ADRC.kernel_params`).

    Raises
    ------
    UnsupportedConfig
        For ``discretisation="exact"``, ``u_real_on``, ``anti_backoff``, the
        ``awin`` input (and, ``manual_ok`` False, manual).
    """
    bad = adrc.fast_path_blockers(manual_ok=manual_ok)
    if bad:
        raise UnsupportedConfig(f"ADRC options not covered by the compiled kernel: {bad}")
    return tuple(float(v) for v in adrc.kernel_params())


adrc_step = _adrc.adrc_step


# ---------------------------------------------------------------------------
# Plants
# ---------------------------------------------------------------------------


def lti3_params(plant: Any) -> tuple[float, ...]:
    """``(phi (9, row-major), gamma0 (3), gamma1 (3), c (3))`` of a LinearPlant of order <= 3.

    Lower orders are padded with zeros (which leave the update exact).
    """
    n = plant.n_states
    if n > 3:
        raise UnsupportedConfig(f"compiled loops cover linear plants up to order 3, got {n}")
    phi = [[0.0] * 3 for _ in range(3)]
    g0, g1, cc = [0.0] * 3, [0.0] * 3, [0.0] * 3
    for i in range(n):
        for j in range(n):
            phi[i][j] = float(plant.phi[i, j])
        g0[i], g1[i], cc[i] = float(plant.gamma0[i]), float(plant.gamma1[i]), float(plant.c[i])
    return (*phi[0], *phi[1], *phi[2], *g0, *g1, *cc)


def lti3_step(
    x0: float, x1: float, x2: float, u0: float, u1: float, pp: tuple[float, ...]
) -> tuple[float, float, float, float]:
    """``x = Phi x + Gamma0 u0 + Gamma1 u1``, ``y = C x`` (LinearPlant (2)); returns ``(x, y)``.

    Same order of operations as ``plants.linear.lti_step``/``lti_output``.
    """
    (f00, f01, f02, f10, f11, f12, f20, f21, f22,
     a0, a1, a2, b0, b1, b2, c0, c1, c2) = pp  # fmt: skip
    n0 = a0 * u0 + b0 * u1
    n0 += f00 * x0
    n0 += f01 * x1
    n0 += f02 * x2
    n1 = a1 * u0 + b1 * u1
    n1 += f10 * x0
    n1 += f11 * x1
    n1 += f12 * x2
    n2 = a2 * u0 + b2 * u1
    n2 += f20 * x0
    n2 += f21 * x1
    n2 += f22 * x2
    y = 0.0
    y += c0 * n0
    y += c1 * n1
    y += c2 * n2
    return n0, n1, n2, y


jitable(lti3_step)
