"""The oracle of the compare tests: each family's best on the TRUE process, by brute force.

Independent of :mod:`ctrlblocks.tuning.design` (which designs on the
*identified* model by following the Ms boundary from a rule's start): here
each family's parameters are searched by a plain grid over their whole range
and a zoom around the best grid points, on the true process, for each
experiment separately (the set-point step and the load: each family at its
best on each), at the same Ms and MV-noise budget.

Two stages, each checking the other:

* **the search** screens thousands of controllers at once from frequency
  responses: the real block's 2-DOF matrices (:func:`controller_ss`) give its
  ``C_r`` and ``C_y`` on two grids -- a dense log grid (4000 points up to the
  Nyquist frequency: Ms) and the ``N/2 + 1`` frequencies of a real FFT of
  length ``N`` covering 30 times the process's lags and dead time (the
  MV-noise standard deviation by Parseval's relation for the length-``N``
  DFT, and the load and set-point responses: the transform of the
  increments of the PV, ``P S``, resp. of the error, ``1 - P C_r S``,
  inverted and summed).  A response that has not died out at the window's
  end (not settled, or an unstable loop, whose inverse transform is not
  causal) scores infinite.  The PID's ``C_y = kp C_PD + ki C_I`` and
  ``C_r = b kp + ki C_I`` are linear in ``kp``, ``ki`` and ``b kp`` for a
  fixed ``(td, N)``, the ADRC's ``C_y`` and ``C_r`` proportional to ``1/b0``
  (``u = (kp (r - z1) - .. - z_{n+1})/b0`` with the observer fed ``b0 u``),
  so the matrices are read once per ``(td, N)`` resp. ``(order, omega_c,
  ratio)`` (tests/sim/test_compare_truth.py checks both against the block);
* **the judgement** of the best screened candidates, one by one until one
  passes, with the real block: stability by the closed-loop poles, Ms on the
  dense grid, the MV noise by the discrete Lyapunov equation of the closed
  loop (scipy, not a frequency integral) and the IAE by the linear loop
  simulated in time (:func:`response`).  The judged IAE is the oracle's answer.

The PID family is PI and PID (``td`` 0.01..0.5 times the lags and dead
time, filter ``N`` of 2.5, 5, 10), each also in a Smith predictor on the true
process (a perfect predictor: the family at its best), with the set-point
weight ``b`` of 0, 0.1, .., 1 for the set-point step; the ADRC family the
orders 1..3 with the observer ratio 3, 5, 10 (``omega_o ts <= 0.2``) and the
orders 1 and 2 with the observer fed the MV delayed by the true dead time
(``input_delay``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import linalg

from ctrlblocks.blocks.adrc import ADRC
from ctrlblocks.blocks.base import ParameterError
from ctrlblocks.blocks.pid import PID
from ctrlblocks.tuning.margins import Loop, controller_ss, smith_ss

UNLIMITED = {"u_min": -math.inf, "u_max": math.inf}
CASES = ("load", "setpoint")
_B_GRID = np.linspace(0.0, 1.0, 21)  # the PID's set-point weights
_RATIOS = (3.0, 5.0, 10.0)
_NOISE_TOL = 1e-3  # the judged (Lyapunov) MV noise may exceed the budget by this fraction


@dataclass
class Best:
    """The best of one family on one experiment: IAE (judged in time) and the parameters."""

    iae: float = math.inf
    name: str = ""
    params: dict[str, Any] | None = None
    screened: float = math.inf  # the search's (FFT) IAE of the same controller


def _scales(model: Any) -> tuple[float, float, float]:
    t2 = getattr(model, "time_constant_2", 0.0)
    return abs(model.gain), model.time_constant + t2 + model.dead_time, model.dead_time + t2


def mv_noise_gain(lp: Loop) -> float:
    """``sigma_u/sigma_y`` of the closed loop for white PV noise: the Lyapunov equation."""
    p, c = lp.pss, lp.ctrl
    a = lp.closed_loop_a()
    by, dy = c.b[:, 1], c.d[0, 1]
    b_n = np.concatenate([p.b[:, 0] * dy, by])  # the noise enters where y enters the controller
    c_u = np.concatenate([dy * p.c[0], c.c[0]])
    q = linalg.solve_discrete_lyapunov(a, np.outer(b_n, b_n))
    return float(math.sqrt(max(c_u @ q @ c_u + dy * dy, 0.0)))


def response(lp: Loop, t_end: float, *, r: float = 0.0, load: float = 0.0) -> np.ndarray:
    """The PV of :meth:`Loop.simulate` (steps at t = 0, from rest), from the Markov parameters.

    From rest with constant inputs, ``y[k] = sum_{j<k} c A^j b``: the vectors
    ``A^j b`` are made 64 at a time (``A^64`` times the block before), so the
    whole response is a few matrix products instead of a loop over the
    samples; a test checks it against the state recursion.
    """
    p, c = lp.pss, lp.ctrl
    a = lp.closed_loop_a()
    b = np.concatenate([p.b[:, 0] * c.d[0, 0], c.b[:, 0]]) * r
    b = b + np.concatenate([p.b[:, 0], np.zeros(c.a.shape[0])]) * load
    c_y = np.concatenate([p.c[0], np.zeros(c.a.shape[0])])
    n = round(t_end / lp.ts) + 1
    m = 64
    block = np.empty((len(b), m))
    v = b
    for j in range(m):
        block[:, j] = v
        v = a @ v
    am = np.linalg.matrix_power(a, m)
    h = []
    for _ in range(math.ceil(n / m)):
        h.append(c_y @ block)
        block = am @ block
    markov = np.concatenate(h)[: n - 1]
    return np.concatenate([[0.0], np.cumsum(markov)])


class Oracle:
    """Judge candidates on the true process ``model`` (see the module docstring)."""

    def __init__(self, model: Any, ts: float, ms: float, noise_std: float, budget: float,
                 step: float, load: float) -> None:  # fmt: skip
        self.model, self.ts, self.ms = model, ts, ms
        self.gain_max = budget / noise_std if noise_std > 0 else math.inf
        self.step, self.load = step, load
        self.sign = -1.0 if model.gain < 0 else 1.0
        _k, tau, _L = _scales(model)
        self.t_end = 30.0 * tau
        self.evals = 0
        # the search's window: 12 times the lags and dead time (the best loops settle well
        # within it; one that does not scores infinite); the judgement's is 30 times
        self.n_fft = int(2 ** math.ceil(math.log2(12.0 * tau / ts + 1)))
        self.w = math.pi / ts * np.logspace(-6.0, 0.0, 4000)  # dense: no peak refinement
        wf = 2.0 * math.pi * np.arange(self.n_fft // 2 + 1) / (self.n_fft * ts)
        wf[0] = 1e-9 * math.pi / ts  # not z = 1, where an integral action's C_y is infinite
        self.grid = np.concatenate([self.w, wf])
        self.nw = len(self.w)
        probe = Loop(model, PID(kp=1.0, ts=ts, **UNLIMITED))
        self.p = probe.process(self.grid)
        fast = Loop(dataclasses.replace(model, dead_time=0.0), PID(kp=1.0, ts=ts, **UNLIMITED))
        self.dm = fast.process(self.grid) - self.p  # a perfect predictor: M0 - M
        # Parseval for the length-N DFT from its N/2 + 1 bins: the weights of |G_k|^2
        wt = np.full(len(wf), 2.0)
        wt[0] = wt[-1] = 1.0
        self.parseval = wt / self.n_fft

    # -- the judgement: one real block ------------------------------------------------

    def loop(self, block: Any, smith: bool) -> Loop:
        if smith:
            return Loop(self.model, smith_ss(controller_ss(block), self.model))
        return Loop(self.model, block)

    def ms_of(self, block: Any, smith: bool) -> float:
        """max |S| on the dense grid (the block's C_y, in a predictor C/(1 + C (M0 - M)))."""
        c = -controller_ss(block).response(self.w)[:, 0, 1]
        if smith:
            c = c / (1.0 + c * self.dm[: self.nw])
        return float(np.max(np.abs(1.0 / (1.0 + c * self.p[: self.nw]))))

    def admissible(self, block: Any, smith: bool) -> Loop | None:
        """The loop when stable, Ms within the target and the MV noise within the budget."""
        self.evals += 1
        try:
            if not self.ms_of(block, smith) <= self.ms:
                return None
            lp = self.loop(block, smith)
        except (ParameterError, ValueError):
            return None
        if not float(np.max(np.abs(np.linalg.eigvals(lp.closed_loop_a())))) < 1.0 - 1e-10:
            return None
        if self.gain_max < math.inf and mv_noise_gain(lp) > self.gain_max * (1 + _NOISE_TOL):
            return None
        return lp

    def iae(self, lp: Loop, case: str) -> float:
        """IAE of the set-point step or the load, the linear loop simulated in time."""
        e = response(lp, self.t_end, r=self.step if case == "setpoint" else 0.0,
                     load=self.load if case == "load" else 0.0)  # fmt: skip
        if case == "setpoint":
            e = self.step - e
        if not abs(e[-1]) <= 1e-3 * abs(self.step):
            return math.inf  # not settled within the window
        return float(np.sum(np.abs(e)) * self.ts)

    # -- the search: many controllers at once -----------------------------------------

    def responses(self, block: Any) -> tuple[np.ndarray, np.ndarray]:
        """``(C_r, C_y)`` of the block on the search grid (``u = C_r r - C_y y``)."""
        g = controller_ss(block).response(self.grid)
        return g[:, 0, 0], -g[:, 0, 1]

    def screen(self, cy: np.ndarray, cr: np.ndarray, cr_b: np.ndarray | None,
               smith: bool) -> dict[str, np.ndarray]:  # fmt: skip
        """The load and set-point IAE of each row of ``cy`` (``C_r = cr + b cr_b``, the best
        ``b`` of 0, 0.05, .., 1 with ``cr_b``), inf where Ms or the MV noise breaks its limit
        or the response does not die out in the window (module docstring).  Returns
        ``{"load": iae, "setpoint": iae, "b": b}``."""
        out = {c: np.full(cy.shape[0], math.inf) for c in CASES}
        out["b"] = np.ones(cy.shape[0])
        rows = max(1, int(1e6 // cy.shape[1]))
        for i in range(0, cy.shape[0], rows):
            sl = slice(i, i + rows)
            got = self._screen(cy[sl], cr[sl], None if cr_b is None else cr_b[sl], smith)
            for key, v in got.items():
                out[key][sl] = v
        return out

    def _screen(self, cy, cr, cr_b, smith: bool) -> dict[str, np.ndarray]:
        out = {c: np.full(cy.shape[0], math.inf) for c in CASES}
        out["b"] = np.ones(cy.shape[0])
        if smith:
            den = 1.0 + cy * self.dm
            cy, cr = cy / den, cr / den
            cr_b = None if cr_b is None else cr_b / den
        nw = self.nw
        s = 1.0 / (1.0 + cy[:, :nw] * self.p[:nw])
        ok = np.max(np.abs(s), axis=1) <= self.ms
        if not ok.any():
            return out
        pf = self.p[nw:]
        sf = 1.0 / (1.0 + cy[ok, nw:] * pf)
        if self.gain_max < math.inf:
            g2 = np.abs(cy[ok, nw:] * sf) ** 2 @ self.parseval
            good = np.sqrt(g2) <= self.gain_max
            ok[ok] = good
            sf = sf[good]
            if not ok.any():
                return out
        ps = pf * sf
        y = self._settled(self.load * ps)  # increments of y for a step load
        out["load"][ok] = _inf(np.sum(np.abs(y), axis=1) * self.ts)
        e = self._settled(self.step * (1.0 - ps * cr[ok, nw:]))  # increments of the error
        if cr_b is None:
            out["setpoint"][ok] = _inf(np.sum(np.abs(e), axis=1) * self.ts)
            return out
        e_b = self._settled(-self.step * ps * cr_b[ok, nw:])
        iae = _inf(np.stack([np.sum(np.abs(e + b * e_b), axis=1) for b in _B_GRID]) * self.ts)
        out["setpoint"][ok] = iae.min(axis=0)
        out["b"][ok] = _B_GRID[iae.argmin(axis=0)]
        return out

    def _settled(self, h: np.ndarray) -> np.ndarray:
        """The responses whose increments have the transforms ``h`` (rows): NaN where one has not
        died out at the window's end (not settled, or not causal: an unstable loop)."""
        y = np.cumsum(np.fft.irfft(h, self.n_fft, axis=1), axis=1)
        peak = np.max(np.abs(y), axis=1)
        tail = np.max(np.abs(y[:, -self.n_fft // 10 :]), axis=1)
        y[~(tail <= 1e-3 * peak)] = math.nan
        return y

    def judge(self, found: list[tuple[float, str, dict[str, Any]]], case: str,
              make: Callable[[dict[str, Any]], tuple[Any, bool]]) -> Best:  # fmt: skip
        """The first of the screened candidates (best first) the real block confirms."""
        for screened, name, params in sorted(found, key=lambda f: f[0]):
            if not math.isfinite(screened):
                break
            block, smith = make(params)
            lp = self.admissible(block, smith)
            if lp is None:
                continue
            return Best(self.iae(lp, case), name, params, screened)
        return Best()


def _inf(v: np.ndarray) -> np.ndarray:
    return np.where(np.isnan(v), math.inf, v)


def _zoom(evaluate, x: float, y: float, dx: float, dy: float, best: float,
          levels: int = 7) -> tuple[float, float, float]:  # fmt: skip
    """Around ``(x, y)`` (log coordinates, grid spacing ``dx``, ``dy``): a 5 x 5 grid of half
    the spacing, recentred on its best point, ``levels`` times.  ``evaluate(xs, ys)`` gives
    the objective on the grid ``xs x ys`` (inf: inadmissible)."""
    for _ in range(levels):
        dx, dy = dx / 2.0, dy / 2.0
        xs = x + dx * np.arange(-2, 3)
        ys = y + dy * np.arange(-2, 3)
        v = evaluate(xs, ys)
        i, j = np.unravel_index(int(np.argmin(v)), v.shape)
        if v[i, j] < best:
            best, x, y = float(v[i, j]), float(xs[i]), float(ys[j])
    return best, x, y


def _starts(v: np.ndarray, count: int = 2) -> list[tuple[int, int]]:
    """The ``count`` best finite grid points that are not neighbours of a better one."""
    out: list[tuple[int, int]] = []
    for flat in np.argsort(v, axis=None):
        i, j = np.unravel_index(int(flat), v.shape)
        if not math.isfinite(v[i, j]) or len(out) == count:
            break
        if all(abs(i - a) > 1 or abs(j - b) > 1 for a, b in out):
            out.append((int(i), int(j)))
    return out


def _pid(params: dict[str, Any], rev: bool, ts: float) -> PID:
    return PID(kp=params["kp"], ti=params["kp"] / params["ki"], td=params["td"], n=params["n"],
               b=params.get("b", 1.0), reverse=rev, ts=ts, **UNLIMITED)  # fmt: skip


def best_pid(o: Oracle, cases=CASES, *, smith_too: bool = True,
             pi_only: bool = False) -> dict[str, Best]:  # fmt: skip
    """The PID family's best load and set-point IAE on the true process (``smith_too``: also
    in a Smith predictor; ``pi_only``: the PI only)."""
    k, tau, _L = _scales(o.model)
    rev = o.sign < 0
    ts = o.ts
    lkp = np.log(np.geomspace(0.02, 50.0, 26) / k)
    lki = np.log(np.geomspace(0.01, 1000.0, 26) / (k * tau))
    dkp, dki = lkp[1] - lkp[0], lki[1] - lki[0]
    shapes = [(0.0, 10.0)] + [(float(f * tau), n) for f in np.geomspace(0.01, 2.0, 9)
                              for n in (2.5, 5.0, 10.0) if not pi_only]  # fmt: skip
    found: dict[str, list] = {c: [] for c in cases}
    for td, n in shapes:
        one = {"kp": 1.0, "reverse": rev, "ts": ts, **UNLIMITED}
        cr_p, cy_pd = o.responses(PID(td=td, n=n, **one))
        cr_pi, cy_pi = o.responses(PID(ti=1.0, **one))
        cr_0, cy_0 = o.responses(PID(**one))
        cr_i, cy_i = cr_pi - cr_0, cy_pi - cy_0  # the integral part per unit ki
        for smith in (False, True) if smith_too else (False,):
            name = ("PID" if td > 0 else "PI") + (" + Smith" if smith else "")

            def evaluate(xs, ys, smith=smith, cy_pd=cy_pd, cy_i=cy_i, cr_i=cr_i, cr_p=cr_p):
                kp, ki = np.exp(xs)[:, None, None], np.exp(ys)[None, :, None]
                shape = (-1, len(o.grid))
                cy = (kp * cy_pd + ki * cy_i).reshape(shape)
                cr = np.broadcast_to(ki * cr_i, (len(xs), len(ys), len(o.grid))).reshape(shape)
                cr_b = np.broadcast_to(kp * cr_p, (len(xs), len(ys), len(o.grid))).reshape(shape)
                got = o.screen(cy, cr, cr_b, smith)
                return {key: v.reshape(len(xs), len(ys)) for key, v in got.items()}

            grid = evaluate(lkp, lki)
            for case in cases:
                for i, j in _starts(grid[case]):
                    v, x, y = _zoom(lambda a, b_, case=case: evaluate(a, b_)[case], lkp[i],
                                    lki[j], dkp, dki, float(grid[case][i, j]))  # fmt: skip
                    b = float(evaluate(np.array([x]), np.array([y]))["b"][0, 0])
                    params = {"kp": math.exp(x), "ki": math.exp(y), "td": td, "n": n,
                              "b": b if case == "setpoint" else 1.0, "smith": smith}  # fmt: skip
                    found[case].append((v, name, params))
    return {c: o.judge(found[c], c, lambda p: (_pid(p, rev, ts), p["smith"])) for c in cases}


def best_adrc(o: Oracle, cases=CASES, orders=(1, 2, 3), *,
              delayed: bool = True) -> dict[str, Best]:  # fmt: skip
    """The ADRC family's best load and set-point IAE on the true process: the orders 1..3,
    and (``delayed``) 1..2 with the observer fed the MV delayed by the true dead time (the
    block's ``input_delay``)."""
    k, tau, _L = _scales(o.model)
    rev = o.sign < 0
    cap = 0.2 / o.ts
    delay = o.model.dead_time if delayed else 0.0
    kinds = [(n, 0.0) for n in orders] + ([(n, delay) for n in orders if n < 3] if delay else [])
    found: dict[str, list] = {c: [] for c in cases}

    def block(order: int, b0: float, wc: float, ratio: float, d: float) -> ADRC:
        return ADRC(order=order, b0=b0, omega_c=wc, omega_o=ratio * wc, ts=o.ts, reverse=rev,
                    input_delay=d, **UNLIMITED)  # fmt: skip

    for order, d in kinds:
        lb0 = np.log(k / tau**order * np.geomspace(0.03, 3000.0, 36))
        db0 = lb0[1] - lb0[0]
        for ratio in _RATIOS:
            lwc = np.log(np.geomspace(0.3 / tau, cap / ratio, 16))
            dwc = lwc[1] - lwc[0]
            cache: dict[float, dict[str, np.ndarray]] = {}

            def row(x: float, ys: np.ndarray, order=order, ratio=ratio, d=d, cache=cache):
                key = (x, tuple(ys))
                if key not in cache:  # C_r and C_y at b0 = 1, proportional to 1/b0
                    cr, cy = o.responses(block(order, 1.0, math.exp(x), ratio, d))
                    inv = np.exp(-ys)[:, None]
                    cache[key] = o.screen(inv * cy, inv * cr, None, False)
                return cache[key]

            def evaluate(xs, ys, case, top=lwc[-1]):
                v = np.full((len(xs), len(ys)), math.inf)
                for i, x in enumerate(xs):
                    if x <= top + 1e-9:  # omega_o ts <= 0.2
                        v[i] = row(float(x), ys)[case]
                return v

            name = f"ADRC n={order}" + (" + delayed ESO" if d else "")
            for case in cases:
                grid = evaluate(lwc, lb0, case)
                for i, j in _starts(grid):
                    v, x, y = _zoom(lambda a, b_, case=case: evaluate(a, b_, case), lwc[i],
                                    lb0[j], dwc, db0, float(grid[i, j]))  # fmt: skip
                    params = {"order": order, "b0": math.exp(y), "omega_c": math.exp(x),
                              "ratio": ratio, "input_delay": d}  # fmt: skip
                    found[case].append((v, name, params))

    def make(p: dict[str, Any]) -> tuple[ADRC, bool]:
        return block(p["order"], p["b0"], p["omega_c"], p["ratio"], p["input_delay"]), False

    return {c: o.judge(found[c], c, make) for c in cases}


def winner(pid: float, adrc: float, tie: float) -> str:
    if abs(pid - adrc) <= tie * max(pid, adrc):
        return "tie"
    return "PID" if pid < adrc else "ADRC"


def agrees(said: str, truth_pid: float, truth_adrc: float, tie: float) -> bool:
    """The verdict ``said`` is right, or a tie: a named winner may not lose on the true
    process by more than the tie band."""
    if said == "tie":
        return True
    if said == "PID":
        return truth_pid <= truth_adrc * (1.0 + tie)
    return truth_adrc <= truth_pid * (1.0 + tie)
