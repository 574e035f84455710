"""The oracle of the compare tests: each family's best on the TRUE process, by brute force.

Independent of :mod:`ctrlblocks.tuning.design` (which designs on the
*identified* model by following the Ms boundary and scoring with an FFT of the
loop's frequency response): here every family's parameters are searched by a
plain grid and a Nelder-Mead refinement from its best points, on the true
process, and every candidate is judged by

* its Ms on the true process (:meth:`Loop.peak_sensitivity`, the loop of the
  real block's matrices: checked against python-control in
  tests/tuning/test_margins.py),
* its MV noise by the discrete Lyapunov equation of the closed loop with the
  PV noise as input (scipy), not by a frequency integral,
* its set-point and load IAE by simulating the linear loop in time
  (:meth:`Loop.simulate`), the set-point weight ``b`` of a PID searched too.

The PID family is PI, PID (derivative filter N of 2.5, 5, 10) and PI/PID in a
Smith predictor on the true process (a perfect predictor: the family at its
best); the ADRC family is the orders 1..3 with ``b0``, ``omega_c`` and the
observer ratio 3, 5, 10 (``omega_o ts <= 0.2``), and the orders 1 and 2 with
the observer fed the MV delayed by the true dead time (``input_delay``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import linalg, optimize

from ctrlblocks.blocks.adrc import ADRC
from ctrlblocks.blocks.base import ParameterError
from ctrlblocks.blocks.pid import PID
from ctrlblocks.tuning.margins import Loop, controller_ss, smith_ss

UNLIMITED = {"u_min": -math.inf, "u_max": math.inf}


@dataclass
class Best:
    """The best of one family on one experiment: IAE and the parameters."""

    iae: float = math.inf
    name: str = ""
    params: dict[str, Any] | None = None


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
        import dataclasses

        probe = Loop(model, PID(kp=1.0, ts=ts, **UNLIMITED))
        self.w = math.pi / ts * np.logspace(-6.0, 0.0, 4000)  # dense: no peak refinement
        self.p = probe.process(self.w)
        fast = Loop(dataclasses.replace(model, dead_time=0.0), PID(kp=1.0, ts=ts, **UNLIMITED))
        self.dm = fast.process(self.w) - self.p  # a perfect predictor: M0 - M

    def loop(self, block: Any, smith: bool) -> Loop:
        if smith:
            return Loop(self.model, smith_ss(controller_ss(block), self.model))
        return Loop(self.model, block)

    def ms_of(self, block: Any, smith: bool) -> float:
        """max |S| on the dense grid (the block's C_y, in a predictor C/(1 + C (M0 - M)))."""
        c = -controller_ss(block).response(self.w)[:, 0, 1]
        if smith:
            c = c / (1.0 + c * self.dm)
        return float(np.max(np.abs(1.0 / (1.0 + c * self.p))))

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
        if self.gain_max < math.inf and mv_noise_gain(lp) > self.gain_max:
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


def _pid(kp: float, ti: float, td: float, n: float, b: float, reverse: bool, ts: float) -> PID:
    return PID(kp=kp, ti=ti, td=td, n=n, b=b, reverse=reverse, ts=ts, **UNLIMITED)


def best_pid(o: Oracle, *, fine: bool = True) -> dict[str, Best]:
    """The PID family's best load and set-point IAE on the true process."""
    k, tau, _L = _scales(o.model)
    rev = o.sign < 0
    out = {"load": Best(), "setpoint": Best()}
    kps = np.geomspace(0.05, 20.0, 16 if fine else 10) / k
    tis = np.geomspace(0.1, 3.0, 14 if fine else 9) * tau
    shapes = [(0.0, 10.0)] + [(f * tau, n) for f in (0.15, 0.4) for n in (2.5, 5.0, 10.0)]
    for smith in (False, True):
        for td, n in shapes:
            name = ("PID" if td > 0 else "PI") + (" + Smith" if smith else "")
            scored = []
            for kp in kps:
                for ti in tis:
                    lp = o.admissible(_pid(kp, ti, td, n, 1.0, rev, o.ts), smith)
                    if lp is not None:
                        scored.append((o.iae(lp, "load"), kp, ti))
            if not scored:
                continue
            scored.sort()
            starts = [(kp, ti) for _v, kp, ti in scored[:2]]
            if fine:

                def make(x, td=td, n=n):
                    return _pid(math.exp(x[0]), math.exp(x[1]), td, n, 1.0, rev, o.ts)

                starts = [_refine(o, make, smith, s) for s in starts]
            for kp, ti in starts:
                lp = o.admissible(_pid(kp, ti, td, n, 1.0, rev, o.ts), smith)
                if lp is None:
                    continue
                v = o.iae(lp, "load")
                if v < out["load"].iae:
                    out["load"] = Best(v, name, {"kp": kp, "ti": ti, "td": td, "n": n})
            # set point: the b of 0, 0.25 .. 1 for the best load tunings and the grid's best
            for _v, kp, ti in scored[:6]:
                for b in (0.0, 0.25, 0.5, 0.75, 1.0):
                    lp = o.loop(_pid(kp, ti, td, n, b, rev, o.ts), smith)
                    v = o.iae(lp, "setpoint")
                    if v < out["setpoint"].iae:
                        out["setpoint"] = Best(v, name, {"kp": kp, "ti": ti, "td": td, "n": n,
                                                         "b": b})  # fmt: skip
    return out


def _refine(o: Oracle, make, smith: bool, start: tuple[float, ...]) -> tuple[float, ...]:
    """Nelder-Mead on the log parameters, the constraints as an infinite cost."""

    def cost(x: np.ndarray) -> float:
        try:
            block = make(x)
        except (ParameterError, ValueError):
            return math.inf
        lp = o.admissible(block, smith)
        return math.inf if lp is None else o.iae(lp, "load")

    x0 = np.log(np.asarray(start, float))
    simplex = [x0, x0 + np.array([0.15, 0.0]), x0 + np.array([0.0, 0.15])]
    r = optimize.minimize(cost, x0, method="Nelder-Mead",
                          options={"xatol": 0.01, "fatol": 1e-6, "maxfev": 60,
                                   "initial_simplex": simplex})  # fmt: skip
    x = r.x if math.isfinite(r.fun) and r.fun <= cost(x0) else x0
    return tuple(float(v) for v in np.exp(x))


def best_adrc(o: Oracle, *, fine: bool = True, orders=(1, 2, 3)) -> dict[str, Best]:
    """The ADRC family's best load and set-point IAE on the true process: the orders 1..3,
    and 1..2 with the observer fed the MV delayed by the true dead time (the block's
    ``input_delay``)."""
    k, tau, _L = _scales(o.model)
    rev = o.sign < 0
    out = {"load": Best(), "setpoint": Best()}
    cap = 0.2 / o.ts
    delays = [0.0] + ([o.model.dead_time] if o.model.dead_time > 0 else [])
    kinds = [(n, 0.0) for n in orders] + [(n, d) for d in delays[1:] for n in orders if n < 3]
    for order, delay in kinds:
        b0s = k / tau**order * np.geomspace(0.3, 300.0, 12 if fine else 8)
        for ratio in (3.0, 5.0, 10.0):
            wcs = np.geomspace(0.3 / tau, cap / ratio, 14 if fine else 9)

            def make(b0: float, wc: float, ratio: float = ratio, order: int = order,
                     delay: float = delay) -> ADRC:  # fmt: skip
                return ADRC(order=order, b0=b0, omega_c=wc, omega_o=ratio * wc, ts=o.ts,
                            reverse=rev, input_delay=delay, **UNLIMITED)  # fmt: skip

            scored = []
            for b0 in b0s:
                for wc in wcs:
                    lp = o.admissible(make(b0, wc), False)
                    if lp is not None:
                        scored.append((o.iae(lp, "load"), o.iae(lp, "setpoint"), b0, wc))
            if not scored:
                continue
            name = f"ADRC n={order}" + (" + delayed ESO" if delay else "")
            for key, idx in (("load", 0), ("setpoint", 1)):
                ranked = sorted(scored, key=lambda s, i=idx: s[i])[:2]
                for s in ranked:
                    b0, wc = s[2], s[3]
                    if fine:
                        b0, wc = _refine_adrc(o, make, (b0, wc), key, cap / ratio)
                    lp = o.admissible(make(b0, wc), False)
                    if lp is None:
                        continue
                    v = o.iae(lp, key)
                    if v < out[key].iae:
                        found = {"order": order, "b0": b0, "omega_c": wc, "ratio": ratio,
                                 "input_delay": delay}
                        out[key] = Best(v, name, found)
    return out


def _refine_adrc(o: Oracle, make, start, case: str, cap_wc: float) -> tuple[float, float]:
    def cost(x: np.ndarray) -> float:
        try:
            block = make(math.exp(x[0]), math.exp(x[1]))
        except (ParameterError, ValueError):
            return math.inf
        if math.exp(x[1]) > cap_wc * (1 + 1e-9):
            return math.inf
        lp = o.admissible(block, False)
        return math.inf if lp is None else o.iae(lp, case)

    x0 = np.log(np.asarray(start, float))
    r = optimize.minimize(cost, x0, method="Nelder-Mead",
                          options={"xatol": 0.01, "fatol": 1e-6, "maxfev": 50,
                                   "initial_simplex": [x0, x0 + np.array([0.2, 0.0]),
                                                       x0 + np.array([0.0, 0.1])]})  # fmt: skip
    x = r.x if math.isfinite(r.fun) and r.fun <= cost(x0) else x0
    return float(math.exp(x[0])), float(math.exp(x[1]))


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
