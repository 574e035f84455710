"""Banks of many independent loops: each with its own tunings and its own plant.

A Monte Carlo robustness study, a tuning study or a fleet of similar loops
runs the *same* control law for N independent loops.  :class:`PIDBank` holds
the N parameter sets and states in numpy arrays (one row per loop) and steps
every loop with :func:`~ctrlblocks.fast.kernels.pid_step` -- the blocks' own
functions, compiled by numba when it is installed -- so there is no
vectorised second copy of the law (one implementation of each law).

Why not "vectorised numpy over the arrays"?  That would be a second,
array-shaped implementation of the PID (and numpy's temporaries make it slower
than the compiled bank: one pass over memory per operation).  Instead the bank
runs four loops at a time for the whole run, their states and parameters in
local variables, so that the processor overlaps four independent chains (a
single loop is limited by the latency of its own chain of dependent
operations).  The ADRC bank runs chunks of loops that stay in the L1 cache,
time outside and loops inside.

State per loop: the PID's ``(i, d, w_prev, e_prev, out, cold)`` and the plant's
``x`` and ``y``: 80 bytes (10 floats, :attr:`PIDBank.state_bytes`); the
parameters are 13 PID and 15 plant floats per loop, 224 bytes
(:attr:`PIDBank.param_bytes`), of which the bank stores once what all loops
share: a parameter that has the same value (the same bits) in every loop is
one number, not a column -- the limits, weights and methods of a study that
varies only the tunings, the zero upper triangle and the output vector of the
lag chains.  :attr:`PIDBank.stored_bytes` is what a loop then costs (192
bytes for varied ``kp, ti, td`` and plants).  Exact: the kernel reads the very
same numbers.

Example
-------
>>> import numpy as np
>>> from ctrlblocks.fast import PIDBank
>>> rng = np.random.default_rng(1)
>>> n = 1000
>>> bank = PIDBank.from_arrays(
...     kp=rng.uniform(1.0, 3.0, n), ti=rng.uniform(5.0, 10.0, n), td=np.full(n, 1.0),
...     ts=0.1, u_min=0.0, u_max=100.0,
...     plant_k=rng.uniform(0.5, 1.0, n), plant_t=rng.uniform(1.0, 5.0, (n, 3)))
>>> res = bank.run(sp=1.0, n_steps=2000)
>>> bool(np.all(np.abs(res.y - 1.0) < 1e-2))
True
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..compiled import interpreted
from ._jit import HAVE_NUMBA, jit, jit_parallel, jitable, prange, python_function
from .kernels import (
    UnsupportedConfig,
    adrc_params,
    adrc_step,
    lti3_params,
    lti3_step,
    pid_params,
    pid_step,
)

_pid = interpreted("pid")  # the law functions as Python functions (ctrlblocks.compiled)

__all__ = ["ADRCBank", "BankResult", "PIDBank"]

_N_PID = 13
_N_PLANT = 15  # phi (9), gamma0 (3), c (3): no dead time in a bank
_CHUNK = 1 << 16
"""Rows made at a time while a bank is built (a small buffer, not a full-width table)."""

Columns = tuple[np.ndarray, np.ndarray, np.ndarray]
"""A parameter table stored by columns: ``(table, shared, where)``.

``where[m] >= 0``: parameter ``m`` of loop ``j`` is ``table[j, where[m]]``; else
every loop has ``shared[m]``.  See :func:`_columns` and :func:`_at`.
"""


@dataclasses.dataclass
class BankResult:
    """Per-loop results of :meth:`PIDBank.run` (arrays of length N)."""

    y: np.ndarray
    """Plant output after the last sample."""
    u: np.ndarray
    """Controller output of the last sample."""
    iae: np.ndarray
    """Integral of the absolute error ``sum |sp - y| ts`` over the run."""


@jitable
def _pid_row(k, ti, td, n, b, c, h, lo, hi, reverse, dmeth, imeth, aw, tt):
    """The :func:`pid_params` tuple from ISA parameters: the block's own :func:`pid_parameters`."""
    return _pid.pid_parameters(k, ti, td, n, b, c, h, lo, hi, reverse, dmeth, imeth, aw,
                               _pid.tracking_time(tt, ti, h))  # fmt: skip


for _f in (_pid.derivative_coefficients, _pid.integral_weights, _pid.tracking_time,
           _pid.pid_parameters):  # fmt: skip
    jitable(_f)


@jit
def _fill_rows(out, k, ti, td, n, b, c, h, lo, hi, reverse, dmeth, imeth, aw, tt):
    for j in range(out.shape[0]):
        row = _pid_row(k[j], ti[j], td[j], n[j], b[j], c[j], h, lo[j], hi[j], reverse[j],
                       dmeth, imeth, aw, tt[j])  # fmt: skip
        for m in range(_N_PID):
            out[j, m] = row[m]


@jitable
def _row(cols, j, out, o):
    """``out[o:]`` = the parameters of loop ``j`` in the :data:`Columns` ``cols``."""
    table, shared, where = cols
    for m in range(where.shape[0]):
        c = where[m]
        out[o + m] = table[j, c] if c >= 0 else shared[m]


@jitable
def _load(prm, pp, st, x, j):
    """Parameters and state of loop ``j`` as locals (once per run: the loop runs on them)."""
    a = np.empty(_N_PID + _N_PLANT)  # one small buffer: few calls that pass arrays
    _row(prm, j, a, 0)
    _row(pp, j, a, _N_PID)
    r = (a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11],
         a[12])  # fmt: skip
    q = (a[13], a[14], a[15], a[16], a[17], a[18], a[19], a[20], a[21], a[22], a[23], a[24],
         0.0, 0.0, 0.0, a[25], a[26], a[27])  # fmt: skip
    return (r, q, st[j, 0], st[j, 1], st[j, 2], st[j, 3], st[j, 4], st[j, 5] != 0.0,
            x[j, 0], x[j, 1], x[j, 2], x[j, 3])  # fmt: skip


@jitable
def _store(st, x, iae, j, i, d, w, e, out, x0, x1, x2, y, s):
    """Write the locals of loop ``j`` back (the history is warm now)."""
    st[j, 0] = i
    st[j, 1] = d
    st[j, 2] = w
    st[j, 3] = e
    st[j, 4] = out
    st[j, 5] = 0.0
    x[j, 0] = x0
    x[j, 1] = x1
    x[j, 2] = x2
    x[j, 3] = y
    iae[j] += s


@jitable
def _sample(sp, r, q, i, d, w, e, out, cold, x0, x1, x2, y, s, h):
    """One sample of one loop: the PID (:func:`pid_step`), the IAE sum, the plant."""
    out, _vr, _p, _ish, i, d, w, e = pid_step(sp, y, 0.0, False, 0.0, cold, False,
                                              i, d, w, e, out, r)  # fmt: skip
    s += abs(sp - y) * h
    x0, x1, x2, y = lti3_step(x0, x1, x2, out, 0.0, q)
    return i, d, w, e, out, x0, x1, x2, y, s


@jitable
def _run_one(prm, pp, st, x, sp, n_steps, j, iae, h):
    """``n_steps`` samples of loop ``j``, its state in local variables."""
    r, q, i, d, w, e, out, cold, x0, x1, x2, y = _load(prm, pp, st, x, j)
    s = 0.0
    for _k in range(n_steps):
        i, d, w, e, out, x0, x1, x2, y, s = _sample(sp[j], r, q, i, d, w, e, out, cold,
                                                    x0, x1, x2, y, s, h)  # fmt: skip
        cold = False
    _store(st, x, iae, j, i, d, w, e, out, x0, x1, x2, y, s)


@jitable
def _run_four(prm, pp, st, x, sp, n_steps, j, iae, h):
    """Loops ``j .. j+3`` together, all in local variables.

    One loop is limited by the latency of its own chain of dependent
    operations; four independent chains side by side let the processor
    overlap them (about 2.5x the throughput of one loop at a time).
    """
    ra, qa, ia, da, wa, ea, oa, ca, xa0, xa1, xa2, ya = _load(prm, pp, st, x, j)
    rb, qb, ib, db, wb, eb, ob, cb, xb0, xb1, xb2, yb = _load(prm, pp, st, x, j + 1)
    rc, qc, ic, dc, wc, ec, oc, cc, xc0, xc1, xc2, yc = _load(prm, pp, st, x, j + 2)
    rd, qd, id_, dd, wd, ed, od, cd, xd0, xd1, xd2, yd = _load(prm, pp, st, x, j + 3)
    spa, spb, spc, spd = sp[j], sp[j + 1], sp[j + 2], sp[j + 3]
    sa = sb = sc = sd = 0.0
    for _k in range(n_steps):
        ia, da, wa, ea, oa, xa0, xa1, xa2, ya, sa = _sample(
            spa, ra, qa, ia, da, wa, ea, oa, ca, xa0, xa1, xa2, ya, sa, h)  # fmt: skip
        ib, db, wb, eb, ob, xb0, xb1, xb2, yb, sb = _sample(
            spb, rb, qb, ib, db, wb, eb, ob, cb, xb0, xb1, xb2, yb, sb, h)  # fmt: skip
        ic, dc, wc, ec, oc, xc0, xc1, xc2, yc, sc = _sample(
            spc, rc, qc, ic, dc, wc, ec, oc, cc, xc0, xc1, xc2, yc, sc, h)  # fmt: skip
        id_, dd, wd, ed, od, xd0, xd1, xd2, yd, sd = _sample(
            spd, rd, qd, id_, dd, wd, ed, od, cd, xd0, xd1, xd2, yd, sd, h)  # fmt: skip
        ca = cb = cc = cd = False
    _store(st, x, iae, j, ia, da, wa, ea, oa, xa0, xa1, xa2, ya, sa)
    _store(st, x, iae, j + 1, ib, db, wb, eb, ob, xb0, xb1, xb2, yb, sb)
    _store(st, x, iae, j + 2, ic, dc, wc, ec, oc, xc0, xc1, xc2, yc, sc)
    _store(st, x, iae, j + 3, id_, dd, wd, ed, od, xd0, xd1, xd2, yd, sd)


@jit
def _run(prm, pp, st, x, sp, n_steps, iae, h):
    """Every loop for ``n_steps`` samples, four at a time, on one core."""
    n_loops = st.shape[0]
    n4 = n_loops - n_loops % 4
    for j in range(0, n4, 4):
        _run_four(prm, pp, st, x, sp, n_steps, j, iae, h)
    for j in range(n4, n_loops):
        _run_one(prm, pp, st, x, sp, n_steps, j, iae, h)


@jit_parallel
def _run_parallel(prm, pp, st, x, sp, n_steps, iae, h):
    """The groups of four spread over all cores (they share nothing)."""
    n_loops = st.shape[0]
    n4 = n_loops - n_loops % 4
    for m in prange(n4 // 4):
        _run_four(prm, pp, st, x, sp, n_steps, 4 * m, iae, h)
    for j in range(n4, n_loops):
        _run_one(prm, pp, st, x, sp, n_steps, j, iae, h)


class PIDBank:
    """N independent loops PID + linear plant (order <= 3, no dead time), one row each.

    Build it from block objects (``PIDBank(pids, plants)``; any PID the
    compiled kernel covers, see :func:`~ctrlblocks.fast.kernels.pid_params`)
    or, for very many loops, from arrays with :meth:`from_arrays`.

    Attributes
    ----------
    n : int
        Number of loops.
    ts : float
        Common sample time [s].
    compiled : bool
        True when numba compiles the bank.
    """

    def __init__(self, pids: Sequence[Any], plants: Sequence[Any]) -> None:
        ts = _check_ts(pids, plants)
        # bank loops start in auto (a block that ran in manual: run one auto cycle first)
        prm = np.array([pid_params(p, manual_ok=False) for p in pids], dtype=float)
        pp, x = _plant_rows(plants)
        st = np.zeros((len(pids), 6))
        for j, p in enumerate(pids):
            s = p.kernel_state()
            st[j] = (s.i, s.d, s.w_prev, s.e_prev, s.out, float(s.cold))
        self._init(_columns_of(prm), _columns_of(pp), st, x, ts)

    def _init(self, prm: Columns, pp: Columns, st: np.ndarray, x: np.ndarray, ts: float):
        self._prm, self._pp, self.st, self.x = prm, pp, st, x
        self.n = st.shape[0]
        self.ts = ts
        self.compiled = HAVE_NUMBA

    @classmethod
    def from_arrays(
        cls,
        *,
        kp: Any,
        ti: Any,
        td: Any,
        ts: float,
        plant_k: Any,
        plant_t: Any,
        n: Any = 10.0,
        b: Any = 1.0,
        c: Any = 0.0,
        u_min: Any = 0.0,
        u_max: Any = 100.0,
        tt: Any = 0.0,
        derivative_method: str = "backward",
        integral_method: str = "tustin",
        anti_windup: str = "clamping",
        reverse: Any = False,
    ) -> PIDBank:
        """A bank of ISA PIDs (as ``PID(kp=..., ti=..., td=...)``) on lag chains ``PTn``.

        Every argument but ``ts`` and the method names may be a scalar or an
        array of length N.  Loop ``j`` is ``PID(kp=kp[j], ti=ti[j], td=td[j],
        n=n[j], b=b[j], c=c[j], ts=ts, u_min=u_min[j], u_max=u_max[j],
        tt=tt[j] or None, ...)`` on ``PTn(k=plant_k[j], t=plant_t[j], ts=ts)``
        (``plant_t`` of shape (N, m), m = 1..3 lags), both at rest at zero.
        """
        t = np.atleast_2d(np.asarray(plant_t, dtype=float))
        n_loops, m = t.shape
        if not 1 <= m <= 3:
            raise UnsupportedConfig("plant_t must have 1..3 lags per loop")

        def arr(v: Any, dtype: Any = float) -> np.ndarray:
            # length N, or length 1 for a value shared by all loops (never copied N times)
            a = np.asarray(v, dtype=dtype)
            np.broadcast_shapes(a.shape, (n_loops,))
            return np.ascontiguousarray(a.reshape(-1) if a.ndim else a.reshape(1))

        kp_a, ti_a, td_a, n_a = arr(kp), arr(ti), arr(td), arr(n)
        lo, hi = arr(u_min), arr(u_max)
        if np.any(kp_a <= 0) or np.any(ti_a < 0) or np.any(td_a < 0) or np.any(n_a <= 0):
            raise ValueError("need kp > 0, ti >= 0, td >= 0, n > 0 (as PIDConfig)")
        if np.any(lo > hi) or np.any(t <= 0):
            raise ValueError("need u_min <= u_max and positive lags")
        for name in (derivative_method, integral_method):
            if name not in _pid.METHODS:
                raise ValueError(f"method must be one of {_pid.METHODS}, got {name!r}")
        aw = {"clamping": 0.0, "back_calc_model": 1.0}.get(anti_windup)
        if aw is None:
            raise UnsupportedConfig("bank anti_windup: 'clamping' or 'back_calc_model'")
        h, dmeth = float(ts), _pid.METHODS.index(derivative_method)
        imeth = _pid.METHODS.index(integral_method)
        b_a, c_a, rev_a, tt_a, k_a = arr(b), arr(c), arr(reverse, np.bool_), arr(tt), arr(plant_k)
        t = np.ascontiguousarray(t)

        def pid_rows(out: np.ndarray, j0: int, j1: int) -> None:
            _fill_rows(out, *(_part(v, j0, j1) for v in (kp_a, ti_a, td_a, n_a, b_a, c_a)), h,
                       _part(lo, j0, j1), _part(hi, j0, j1), _part(rev_a, j0, j1), dmeth,
                       imeth, aw, _part(tt_a, j0, j1))  # fmt: skip

        def plant_rows(out: np.ndarray, j0: int, j1: int) -> None:
            _chain_zoh(out, _part(k_a, j0, j1), t[j0:j1], h)

        prm = _columns(pid_rows, n_loops, _N_PID)
        pp = _columns(plant_rows, n_loops, _N_PLANT)
        st = np.zeros((n_loops, 6))
        st[:, 5] = 1.0  # cold: the first cycle starts the histories
        x = np.zeros((n_loops, 4))
        bank = cls.__new__(cls)
        bank._init(prm, pp, st, x, float(ts))
        return bank

    @property
    def state_bytes(self) -> int:
        """Bytes of state per loop: PID ``(i, d, w_prev, e_prev, out, cold)`` + plant x, y."""
        return int(self.st.itemsize * self.st.shape[1] + self.x.itemsize * self.x.shape[1])

    @property
    def param_bytes(self) -> int:
        """Bytes of one loop's parameter set (13 PID + 15 plant floats)."""
        return 8 * (_N_PID + _N_PLANT)

    @property
    def stored_bytes(self) -> int:
        """Bytes the bank holds per loop: the state and the parameters not shared by all loops."""
        return self.state_bytes + 8 * (self._prm[0].shape[1] + self._pp[0].shape[1])

    @property
    def prm(self) -> np.ndarray:
        """The PID parameter rows, ``(N, 13)`` (a copy, made from the columns; see ``pid_step``)."""
        return _rows(self._prm, self.n)

    @property
    def pp(self) -> np.ndarray:
        """The plant rows ``(phi, gamma0, c)``, ``(N, 15)`` (a copy, made from the columns)."""
        return _rows(self._pp, self.n)

    @property
    def y(self) -> np.ndarray:
        """Current plant outputs (length N)."""
        return self.x[:, 3].copy()

    def run(
        self, sp: Any, n_steps: int, *, engine: str = "auto", parallel: bool = False
    ) -> BankResult:
        """Run every loop for ``n_steps`` samples with setpoint ``sp`` (scalar or per loop).

        Continues from the current states (call again to go on).  Loops run
        four at a time with their states in local variables; ``parallel``
        spreads them over all cores; ``engine="python"`` runs the same code
        interpreted (as without numba).
        """
        fn = _run_parallel if parallel else _run
        if engine != "auto":
            fn = python_function(fn)
        spa = np.ascontiguousarray(np.broadcast_to(np.asarray(sp, dtype=float), (self.n,)))
        iae = np.zeros(self.n)
        fn(self._prm, self._pp, self.st, self.x, spa, int(n_steps), iae, self.ts)
        return BankResult(self.x[:, 3].copy(), self.st[:, 4].copy(), iae)


def _part(v: np.ndarray, j0: int, j1: int) -> np.ndarray:
    """Rows ``j0:j1`` of an input of length N, or a value shared by all loops, repeated."""
    return v[j0:j1] if v.shape[0] > 1 else np.full(j1 - j0, v[0], dtype=v.dtype)


def _columns(fill: Any, n: int, width: int) -> Columns:
    """The :data:`Columns` of ``n`` rows that ``fill(out, j0, j1)`` writes into ``out``.

    Two passes over chunks of :data:`_CHUNK` rows (the rows are cheap to make,
    a full-width table of N rows is not): the first finds the parameters whose
    bits differ between loops, the second stores only those.  Bits, not
    values: ``-0.0`` and ``0.0`` stay apart, so every loop reads exactly the
    number its row had.
    """
    chunks = [(j0, min(j0 + _CHUNK, n)) for j0 in range(0, n, _CHUNK)]
    buf = np.empty((chunks[0][1], width))
    fill(buf, 0, chunks[0][1])
    shared = buf[0].copy()
    varies = np.zeros(width, dtype=bool)
    for j0, j1 in chunks:
        if j0:
            fill(buf[: j1 - j0], j0, j1)
        varies |= np.any(buf[: j1 - j0].view(np.int64) != shared.view(np.int64), axis=0)
    where = np.full(width, -1, dtype=np.int64)
    where[varies] = np.arange(int(varies.sum()))
    table = np.empty((n, int(varies.sum())))
    for j0, j1 in chunks:
        if j0 or len(chunks) > 1:
            fill(buf[: j1 - j0], j0, j1)
        table[j0:j1] = buf[: j1 - j0][:, varies]
    return table, shared, where


def _columns_of(rows: np.ndarray) -> Columns:
    """The :data:`Columns` of a full table of rows."""

    def fill(out: np.ndarray, j0: int, j1: int) -> None:
        out[:] = rows[j0:j1]

    return _columns(fill, rows.shape[0], rows.shape[1])


def _rows(cols: Columns, n: int) -> np.ndarray:
    """The full ``(n, width)`` table of :data:`Columns` ``cols``."""
    table, shared, where = cols
    out = np.empty((n, shared.shape[0]))
    out[:] = shared
    out[:, where >= 0] = table
    return out


def _plant_rows(plants: Sequence[Any]) -> tuple[np.ndarray, np.ndarray]:
    """Parameter rows ``(phi, gamma0, c)`` and states ``(x0, x1, x2, y)`` of LinearPlants."""
    pp = np.empty((len(plants), _N_PLANT))
    x = np.zeros((len(plants), 4))
    for j, pl in enumerate(plants):
        if getattr(pl, "dead_time", None) != 0.0:
            raise UnsupportedConfig("plants in a bank are LinearPlants without dead time")
        q = lti3_params(pl)
        pp[j] = (*q[:12], *q[15:18])
        x[j, : pl.n_states] = pl.state
        x[j, 3] = pl.y
    return pp, x


def _check_ts(blocks: Sequence[Any], plants: Sequence[Any]) -> float:
    if len(blocks) != len(plants) or not blocks:
        raise ValueError("give one plant per controller (and at least one loop)")
    ts = {float(b.config.ts) for b in blocks} | {float(p.ts) for p in plants}
    if len(ts) != 1:
        raise UnsupportedConfig(f"all loops of a bank share one sample time, got {ts}")
    return ts.pop()


# ---------------------------------------------------------------------------
# ADRC bank
# ---------------------------------------------------------------------------


@jitable
def _run_adrc_chunk(prm, pp, st, x, sp, n_steps, c0, c1, iae, h):
    """``n_steps`` samples of ADRC loops ``c0 .. c1-1`` (time outside, loops inside)."""
    for _k in range(n_steps):
        for j in range(c0, c1):
            r = (prm[j, 0], prm[j, 1], prm[j, 2], prm[j, 3], prm[j, 4], prm[j, 5],
                 prm[j, 6], prm[j, 7], prm[j, 8], prm[j, 9], prm[j, 10], prm[j, 11],
                 prm[j, 12], prm[j, 13], prm[j, 14], prm[j, 15], prm[j, 16], prm[j, 17],
                 prm[j, 18], prm[j, 19], prm[j, 20], prm[j, 21], prm[j, 22],
                 prm[j, 23])  # fmt: skip
            q = (pp[j, 0], pp[j, 1], pp[j, 2], pp[j, 3], pp[j, 4], pp[j, 5], pp[j, 6],
                 pp[j, 7], pp[j, 8], pp[j, 9], pp[j, 10], pp[j, 11], 0.0, 0.0, 0.0,
                 pp[j, 12], pp[j, 13], pp[j, 14])  # fmt: skip
            y = x[j, 3]
            u, _ur, yh, e2, e3, e4, ref, q_ref, track, sat = adrc_step(
                sp[j], y, False, 0.0, st[j, 6] != 0.0, st[j, 7] != 0.0, int(st[j, 8]),
                st[j, 0], st[j, 1], st[j, 2], st[j, 3], st[j, 4], st[j, 5], st[j, 9], r,
            )  # fmt: skip
            st[j, 0] = yh
            st[j, 1] = e2
            st[j, 2] = e3
            st[j, 3] = e4
            st[j, 4] = u
            st[j, 5] = ref
            st[j, 6] = 1.0
            st[j, 7] = 1.0 if track else 0.0
            st[j, 8] = sat
            st[j, 9] = q_ref
            iae[j] += abs(sp[j] - y) * h
            x0, x1, x2, yn = lti3_step(x[j, 0], x[j, 1], x[j, 2], u, 0.0, q)
            x[j, 0] = x0
            x[j, 1] = x1
            x[j, 2] = x2
            x[j, 3] = yn


@jit
def _run_adrc(prm, pp, st, x, sp, n_steps, chunk, iae, h):
    n_loops = prm.shape[0]
    for c0 in range(0, n_loops, chunk):
        _run_adrc_chunk(prm, pp, st, x, sp, n_steps, c0, min(c0 + chunk, n_loops), iae, h)


class ADRCBank:
    """N independent loops ADRC (Euler, auto) + linear plant, built from block objects.

    Each loop has its own order, b0, bandwidths, limits and plant; the state
    per loop is ``(Y_hat, x2, x3, x4, u_prev, ref, started, track, sat, q)`` (``q``: the
    handover offset of the reference) and the plant's ``(x0, x1, x2, y)``: 112 bytes.  The kernel is
    :func:`ctrlblocks.blocks.adrc.adrc_step`, the ADRC's own fast lane.
    """

    def __init__(self, adrcs: Sequence[Any], plants: Sequence[Any]) -> None:
        self.ts = _check_ts(adrcs, plants)
        # bank loops run in auto without awin
        self.prm = np.array([adrc_params(a, manual_ok=False) for a in adrcs], dtype=float)
        self.pp, self.x = _plant_rows(plants)
        self.st = np.array([[float(v) for v in a.kernel_state()] for a in adrcs])
        self.n = len(adrcs)
        self.compiled = HAVE_NUMBA

    @property
    def state_bytes(self) -> int:
        """Bytes of state per loop (ADRC + plant)."""
        return int(self.st.itemsize * self.st.shape[1] + self.x.itemsize * self.x.shape[1])

    def run(self, sp: Any, n_steps: int, *, chunk: int = 64, engine: str = "auto") -> BankResult:
        """Run every loop for ``n_steps`` samples (continues from the current states)."""
        fn = _run_adrc if engine == "auto" else python_function(_run_adrc)
        spa = np.ascontiguousarray(np.broadcast_to(np.asarray(sp, dtype=float), (self.n,)))
        iae = np.zeros(self.n)
        fn(self.prm, self.pp, self.st, self.x, spa, int(n_steps), int(chunk), iae, self.ts)
        return BankResult(self.x[:, 3].copy(), self.st[:, 4].copy(), iae)


_TAYLOR_DEGREE = 14
"""Taylor degree of :func:`_chain_zoh` (norm <= 1/2: truncation 0.5^15/15! < 3e-17)."""


@jit
def _chain_zoh(pp, k, t, ts):
    """Fill ``pp[j]`` with the exact ZOH of the lag chain ``k / prod(t[j, i] s + 1)``.

    The ZOH of ``(A, B)`` over ``ts`` is the exponential of the augmented
    matrix ``[[A, B], [0, 0]] ts`` (Åström and Wittenmark, section 2.3; what
    ``LinearPlant`` computes with scipy).  Ordered with the input first, the
    augmented matrix of a lag chain is *lower bidiagonal*: diagonal
    ``(0, -ts/t1, -ts/t2, -ts/t3)``, sub-diagonal ``(k ts/t1, ts/t2, ts/t3)``,
    so its exponential is lower triangular with 10 entries, and
    ``Phi = E[1:, 1:]``, ``Gamma = E[1:, 0]``.  Here it is evaluated by scaling
    and squaring (infinity-norm <= 1/2) with a Taylor polynomial of degree
    :data:`_TAYLOR_DEGREE` in Horner form, only on those entries, in local
    variables.  Agrees with ``LinearPlant`` to ~1e-14 for ordinary sample
    times and lags (tested to 1e-12).
    """
    m = t.shape[1]
    for j in range(t.shape[0]):
        d1 = -ts / t[j, 0]
        s1 = k[j] * ts / t[j, 0]
        d2 = -ts / t[j, 1] if m > 1 else 0.0
        s2 = ts / t[j, 1] if m > 1 else 0.0
        d3 = -ts / t[j, 2] if m > 2 else 0.0
        s3 = ts / t[j, 2] if m > 2 else 0.0
        # infinity-norm (largest row sum) and the squarings that bring it to <= 1/2
        norm = max(abs(s1) + abs(d1), abs(s2) + abs(d2), abs(s3) + abs(d3))
        n_sq = 0
        while norm > 0.5:
            norm *= 0.5
            n_sq += 1
        f = 0.5**n_sq
        d1 *= f
        d2 *= f
        d3 *= f
        s1 *= f
        s2 *= f
        s3 *= f
        # E = I + X E / q for q = degree .. 1 (row i of X: s_i at column i-1, d_i at i)
        e10 = e20 = e21 = e30 = e31 = e32 = 0.0
        e11 = e22 = e33 = 1.0
        for q in range(_TAYLOR_DEGREE, 0, -1):
            r = 1.0 / q
            n10 = (s1 + d1 * e10) * r
            n20 = (s2 * e10 + d2 * e20) * r
            n21 = (s2 * e11 + d2 * e21) * r
            n30 = (s3 * e20 + d3 * e30) * r
            n31 = (s3 * e21 + d3 * e31) * r
            n32 = (s3 * e22 + d3 * e32) * r
            e11 = 1.0 + d1 * e11 * r
            e22 = 1.0 + d2 * e22 * r
            e33 = 1.0 + d3 * e33 * r
            e10, e20, e21, e30, e31, e32 = n10, n20, n21, n30, n31, n32
        for _ in range(n_sq):  # E = E E (E[0, 0] = 1 throughout)
            a10 = e10 + e11 * e10
            a20 = e20 + e21 * e10 + e22 * e20
            a21 = e21 * e11 + e22 * e21
            a30 = e30 + e31 * e10 + e32 * e20 + e33 * e30
            a31 = e31 * e11 + e32 * e21 + e33 * e31
            a32 = e32 * e22 + e33 * e32
            e11 *= e11
            e22 *= e22
            e33 *= e33
            e10, e20, e21, e30, e31, e32 = a10, a20, a21, a30, a31, a32
        for c in range(_N_PLANT):
            pp[j, c] = 0.0
        pp[j, 0] = e11  # phi, row major; unused lags stay 0
        pp[j, 3] = e21
        pp[j, 6] = e31
        if m > 1:
            pp[j, 4] = e22
            pp[j, 7] = e32
        if m > 2:
            pp[j, 8] = e33
        pp[j, 9] = e10  # gamma0
        pp[j, 10] = e20
        pp[j, 11] = e30
        pp[j, 12 + m - 1] = 1.0  # c: y = the last lag
