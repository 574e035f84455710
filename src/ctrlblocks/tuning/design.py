"""PID and ADRC designed to one robustness target and one MV-noise budget: the one design path.

``ctrlblocks compare``, ``ctrlblocks tune pid`` (``--rule migo``, the default),
``ctrlblocks tune adrc`` (no ``--settling-time``), a scenario's
``[controllers.tune]`` (``rule = "migo"``, and ``"adrc"`` without a settling
time) and the live tuning proposals (``PID_MIGO``, ``ADRC_2``) all call the two
functions of this module, so a tuning means the same everywhere.

The design problem (both families alike)
----------------------------------------
On the process model, sampled exactly at the controller's ``ts`` with its
dead time (:mod:`ctrlblocks.tuning.margins`), the controller being the block
itself (its matrices read off the configured block):

    minimise   IAE of a unit step load at the process input
    subject to Ms = max |S| <= ms      (default 1.6)
               sigma_u <= mv_noise_max (when the PV noise sigma_y is given)

This is the MIGO idea of Åström & Hägglund (2006, chapter 7; for the PI
Åström, Panagopoulos & Hägglund 1998, for the PID Panagopoulos, Åström &
Hägglund 2002): the best load rejection the robustness constraint allows.
MIGO maximises the integral gain ``ki`` (``IE = 1/ki`` for a unit load, the
final-value theorem), which equals the IAE only for a well-damped loop; on
the Ms boundary a PID's load response is often poorly damped (IAE up to twice
IE), so here the IAE itself is the objective, searched on and inside the
boundary (for ``FOPDT(2, 30, 5)`` the largest-``ki`` PID has IAE 11.6 per unit
load, the smallest-IAE one 8.3).  The IAE is computed from the loop's
frequency response on an FFT grid (``y = P S d``: the transform of the
increments of ``y`` is ``P S``, inverted and summed); a test checks it against
the loop simulated in time.  ``sigma_u`` is the standard deviation of the MV
caused by white PV noise of standard deviation ``sigma_y`` (one value per
sample, as the simulator's sensor noise) in the closed loop, ``u = -C_y S n``:

    sigma_u^2 = sigma_y^2 (1/pi) integral_0^pi |C_y S|^2 (e^{j theta}) d theta

(Parseval's relation for a sampled stationary process, Åström & Wittenmark
1997), evaluated on a uniform grid of ``theta``; tests check it against the
closed loop's discrete Lyapunov equation and a simulation of the real block
on noise.

PID (:func:`design_pid`)
    ISA form of :class:`ctrlblocks.PID` (its own discretisation, derivative
    on the measurement, filter ``Tf = td/N``).  ``C_y = kp C_P(td, N) + ki
    C_I`` is linear in ``kp`` and ``ki`` for a fixed ``(td, N)``, so for each
    ``(td, N)`` of a grid (``td = 0`` is the PI; ``td`` 0.15..1.2 times the
    model's dead time, ``N`` 2.5, 5, 10) the search runs over ``kp``
    (ascending from a small gain until even ``ki -> 0`` breaks a constraint,
    then a golden-section search of ``log kp``) and, for each ``kp``, over
    ``ki``: the largest ``ki`` that keeps both constraints (an ascending scan
    and a bisection, so the feasible set is followed from the origin, where
    the loop is stable) and a golden-section search of the IAE below it.  The
    derivative filter is therefore the one that keeps the MV noise within the
    budget, and ``td = 0`` wins where the derivative buys nothing.  Then the
    set-point weight ``b`` (Åström 1987, (2.2)) is chosen for tracking: the
    ``b`` of 0, 0.1, .., 1 with the smallest IAE of a set-point step on the
    model (it does not change ``C_y``: Ms, noise and load response stay).
ADRC (:func:`design_adrc`)
    The block :class:`ctrlblocks.ADRC` of order n, its three tuning
    parameters searched: for each observer ratio ``omega_o/omega_c`` of
    :data:`OBSERVER_RATIOS` (Nowak et al. 2018, section 3.3, recommend 3..10;
    the sample time caps ``omega_o ts <= 0.2``, and a ratio it forces below 3
    is reported) and each ``b0`` (a walk in factors of 1.5 from the inverse
    half-rule's and two bisections of ``log b0``), the fastest ``omega_c``
    that keeps both constraints and a golden-section search of the IAE below
    it; the ``(b0, omega_c, ratio)`` with the smallest load IAE is kept.
    ``input_delay`` designs the ADRC whose observer is fed the MV delayed by
    the model's dead time (the block's ``input_delay``; Zhao & Gao 2014).

Dead-time compensation of the PID (``smith=True``)
    The PID inside a Smith predictor (Nowak et al. 2018, section 3.1; the
    structure :class:`ctrlblocks.loops.structures.Smith`): the controller sees
    ``y + M_0 u - M u``, ``M`` the model and ``M_0`` the model without its
    dead time.  The feedback part of the whole controller is
    ``C_y / (1 + C_y (M_0 - M))``; its Ms is that of the real loop (a Smith
    predictor with an exact model has ``S = 1 - T_0 e^{-sL}``, which reaches
    2 when the delay-free loop is fast: the Ms constraint is what keeps the
    predictor robust).  :func:`ctrlblocks.tuning.margins.smith_ss` gives the
    exact loop for the final margins.

Every design ends with the exact margins of the block on the model
(:meth:`~ctrlblocks.tuning.margins.Loop.margins`); a design whose exact Ms is
above the target (the search's grid missed a sharp peak) has its integral
action lowered until it is not, or is refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..blocks.base import ErrorCode, ParameterError
from .adrc import log_walk
from .margins import DiscreteSS, Loop, Margins, controller_ss, smith_ss

__all__ = [
    "MS_DEFAULT",
    "MV_NOISE_FRACTION",
    "OBSERVER_RATIOS",
    "Design",
    "default_ts",
    "design_adrc",
    "design_pid",
    "mv_noise_gain",
]

MS_DEFAULT = 1.6
"""The default robustness target: maximum sensitivity on the model."""

MV_NOISE_FRACTION = 0.05
"""``compare``'s default MV-noise budget: this fraction of the bump test's MV step (std)."""

OBSERVER_RATIOS = (3.0, 5.0, 10.0)
"""The ``omega_o/omega_c`` searched (Nowak et al. 2018, section 3.3: 3..10)."""

_MAX_OMEGA_O_TS = 0.2  # as tuning.adrc.MAX_OMEGA_O_TS
_TD_FACTORS = (0.15, 0.3, 0.5, 0.8, 1.2)  # td / the model's dead time (lags and delay)
_N_GRID = (2.5, 5.0, 10.0)
_B_GRID = tuple(i / 10 for i in range(11))
_GRID_POINTS = 1500  # log grid of the Ms search, 5 decades below the Nyquist frequency
_NOISE_POINTS = 1024  # uniform theta grid of the noise integral


@dataclass(frozen=True)
class Design:
    """One designed controller (:func:`design_pid`, :func:`design_adrc`).

    Attributes
    ----------
    family : {"PID", "ADRC"}
    params : dict
        The block's keywords without ``ts`` (``reverse = True`` for a negative
        process gain).
    ts : float
        Sample time [s].
    structure : {"single", "smith"}
        ``"smith"``: the block inside a Smith predictor on the model.
    ms_target : float
    margins : Margins
        Exact margins of the loop on the model (predictor included).
    ki : float
        Integral gain of the loop's feedback part [MV/(PV s)] (``IE = 1/|ki|``
        per unit load), with the controller's sign.
    mv_noise : float
        Standard deviation of the MV from the PV noise ``noise_std`` [MV units]
        (NaN without noise).
    noise_std, mv_noise_max : float
        The PV noise designed for and the MV-noise budget (NaN: none).
    warnings : list of str
    """

    family: str
    params: dict[str, Any]
    ts: float
    structure: str
    ms_target: float
    margins: Margins
    ki: float
    mv_noise: float
    noise_std: float
    mv_noise_max: float
    warnings: list[str] = field(default_factory=list)

    def block(self) -> Any:
        """The configured block (unlimited output)."""
        from ..blocks.registry import block_class

        cls = block_class(self.family)
        return cls(**self.params, ts=self.ts, u_min=-math.inf, u_max=math.inf)

    def loop(self, model: Any) -> Loop:
        """The exact loop of this design on ``model`` (a Smith predictor on ``model`` too)."""
        if self.structure == "smith":
            return Loop(model, smith_ss(controller_ss(self.block()), model))
        return Loop(model, self.block())

    def load_iae(self, model: Any, load: float = 1.0) -> float:
        """IAE [PV s] of a step ``load`` at the process input, linear loop on ``model``."""
        lp = self.loop(model)
        _t, y, _u = lp.simulate(lp.response_time(), r=0.0, load=load)
        return float(np.sum(np.abs(y)) * self.ts)


def default_ts(time_constant: float, dead_time: float) -> float:
    """The designs' default sample time [s]: ``min(T, L)/40`` (``T/40`` without dead time),
    rounded down to 1, 2 or 5 times a power of ten -- short enough that the ADRC's observer
    can be 3..10 times faster than its loop within ``omega_o ts <= 0.2``."""
    from .adrc import _nice_floor

    T, L = time_constant, dead_time
    return _nice_floor(max(min(T, L) if L > 0 else T, 1e-6) / 40.0)


# ---------------------------------------------------------------------------
# Frequency responses on the model, computed once per design
# ---------------------------------------------------------------------------


class _Model:
    """The model at ``ts``: its frequency response on the search grids, and the loop tools.

    Grids (in this order in every tuple of responses): ``w`` log-spaced over 5
    decades below the Nyquist frequency (the Ms search), about 1024 uniformly
    spaced frequencies (the noise integral), ``w0`` one very low frequency
    (the integral gain) and ``wf`` the ``n_fft/2 + 1`` frequencies of a real
    FFT of length ``n_fft`` (the load response).  The searches use the first
    three only; the last is computed for the points they score.
    """

    def __init__(self, model: Any, ts: float, smith: bool) -> None:
        from ..blocks.pid import PID

        self.model, self.ts, self.smith = model, ts, smith
        probe = Loop(model, PID(kp=1.0, ts=ts, u_min=-math.inf, u_max=math.inf))
        wn = math.pi / ts
        _k, tau, _L = _scales(model)
        self.n_fft = int(min(2**15, max(2**11, 2 ** math.ceil(math.log2(40.0 * tau / ts)))))
        self.step = max(1, self.n_fft // 2 // _NOISE_POINTS)  # noise on every step-th point
        self.wf = 2.0 * math.pi * np.arange(self.n_fft // 2 + 1) / self.n_fft / ts
        self.w = wn * np.logspace(-5.0, 0.0, _GRID_POINTS)
        self.w0 = np.array([1e-7 * wn])
        self.wn_sub = self.wf[:: self.step][1:]
        self.grids = (self.w, self.wn_sub, self.w0, self.wf)
        self.p = tuple(probe.process(w) for w in self.grids)
        self.wf[0] = 1e-9 * wn  # not z = 1 itself, where an integral action's C_y is infinite
        self.zf = np.exp(1j * self.wf * ts)
        if smith:
            fp = Loop(_without_dead_time(model), PID(kp=1.0, ts=ts, u_min=-math.inf,
                                                      u_max=math.inf))  # fmt: skip
            # C_eq = C / (1 + C (M0 - M)): the predictor's model is the model itself
            self.dm = tuple(fp.process(w) - p for w, p in zip(self.grids, self.p, strict=True))

    def c_raw(self, ss: DiscreteSS, grids: int = 4) -> tuple[np.ndarray, ...]:
        """The block's own ``C_y`` on the first ``grids`` grids (its transfer function there)."""
        from scipy import signal

        if ss.a.shape[0] == 0:
            return tuple(np.full(len(w), -ss.d[0, 1], complex) for w in self.grids[:grids])
        if ss.delay is not None:  # a delay line: the rest's transfer functions, closed by it
            return self._c_delayed(ss, grids)
        num, den = signal.ss2tf(ss.a, ss.b[:, 1:2], ss.c, ss.d[:, 1:2])
        out = []
        for w in self.grids[:grids]:
            z = np.exp(1j * w * self.ts)
            out.append(-np.polyval(num[0], z) / np.polyval(den, z))
        return tuple(out)

    def _c_delayed(self, ss: DiscreteSS, grids: int) -> tuple[np.ndarray, ...]:
        """``C_y`` of a controller with a history register (the ADRC's ``input_delay``).

        With ``h`` the register's oldest value, ``s`` its source state and
        ``w`` the PV input: ``s = G_sw w + G_sh h``, ``u = G_uw w + G_uh h`` (the
        ``m`` other states, transfer functions of a small system), and
        ``h = z^-lag s``: ``u/w = G_uw + G_uh z^-lag G_sw / (1 - z^-lag G_sh)``.
        """
        from scipy import signal

        assert ss.delay is not None
        src, m = ss.delay
        n = ss.a.shape[0]
        used = np.flatnonzero(np.any(ss.a[:m, m:] != 0.0, axis=0) | (ss.c[0, m:] != 0.0))
        if len(used) != 1:  # pragma: no cover - the ADRC feeds its ESO the oldest value only
            return tuple(-ss.response(w)[:, 0, 1] for w in self.grids[:grids])
        j = int(used[0])
        lag = n - m - j
        a = ss.a[:m, :m]
        bw, bh = ss.b[:m, 1:2], ss.a[:m, m + j : m + j + 1]
        cs = np.zeros((1, m))
        cs[0, src] = 1.0
        cu = ss.c[:, :m]
        parts = [signal.ss2tf(a, b_, c_, d_) for b_, c_, d_ in (
            (bw, cs, np.zeros((1, 1))), (bh, cs, np.zeros((1, 1))),
            (bw, cu, ss.d[:, 1:2]), (bh, cu, ss.c[:, m + j : m + j + 1]))]  # fmt: skip
        out = []
        for w in self.grids[:grids]:
            z = np.exp(1j * w * self.ts)
            den = np.polyval(parts[0][1], z)
            g_sw, g_sh, g_uw, g_uh = (np.polyval(num[0], z) / den for num, _d in parts)
            zd = np.exp(-1j * w * self.ts * lag)
            out.append(-(g_uw + g_uh * zd * g_sw / (1.0 - zd * g_sh)))
        return tuple(out)

    def eq(self, *c: np.ndarray) -> tuple[np.ndarray, ...]:
        """The loop's feedback part from the block's: ``C/(1 + C (M0 - M))`` in a predictor."""
        if self.smith:
            return tuple(ci / (1 + ci * d) for ci, d in zip(c, self.dm, strict=False))
        return c

    def cy(self, ss: DiscreteSS, grids: int = 4) -> tuple[np.ndarray, ...]:
        """The loop's feedback part of the controller ``ss`` on the first ``grids`` grids."""
        return self.eq(*self.c_raw(ss, grids))

    def ms(self, c: tuple[np.ndarray, ...]) -> float:
        return float(np.max(np.abs(1.0 / (1.0 + c[0] * self.p[0]))))

    def noise(self, c: tuple[np.ndarray, ...]) -> float:
        """``sigma_u / sigma_y`` (module docstring): the mean over the uniform FFT grid."""
        g = np.abs(c[1] / (1.0 + c[1] * self.p[1])) ** 2
        return float(math.sqrt(np.mean(g)))

    def ki(self, c: tuple[np.ndarray, ...]) -> float:
        z = np.exp(1j * self.w0[0] * self.ts)
        return float(((z - 1.0) / self.ts * c[2][0]).real)

    def load_iae(self, c: tuple[np.ndarray, ...]) -> float:
        """IAE [PV s] of a unit step load at the process input, from the loop's frequency
        response: ``y = P S d``; the increments ``y[k] - y[k-1]`` have the transform
        ``P S`` (no pole at z = 1), inverted on the FFT grid and summed.

        ``n_fft`` covers 40 times the model's lags and dead time; a loop that has not
        settled by then is no contender, and gets its IAE in the window plus a
        penalty that grows with its slowness (``10/ki``), which keeps the searches
        moving towards faster loops.
        """
        ps = self.p[3] / (1.0 + c[3] * self.p[3])
        with np.errstate(over="ignore", invalid="ignore"):  # huge gains: judged by _iae
            y = np.cumsum(np.fft.irfft(ps, self.n_fft))
        return self._iae(y, self.ki(c))

    def setpoint_iae(self, ss: DiscreteSS) -> float:
        """IAE [PV s] of a unit set-point step: ``e = (1 - P C_r/(1 + C_y P)) r``, its
        increments' transform ``1 - T_r`` inverted on the FFT grid and summed."""
        g = ss.response(self.wf)
        cr, cy = g[:, 0, 0], -g[:, 0, 1]
        if self.smith:
            den = 1.0 + cy * self.dm[3]
            cr, cy = cr / den, cy / den
        p = self.p[3]
        with np.errstate(over="ignore", invalid="ignore"):  # huge gains: judged by _iae
            e = np.cumsum(np.fft.irfft(1.0 - p * cr / (1.0 + cy * p), self.n_fft))
        return self._iae(e, self.ki((np.array([]), np.array([]), -ss.response(self.w0)[:, 0, 1])))

    def _iae(self, e: np.ndarray, ki: float) -> float:
        if not np.all(np.isfinite(e)):  # a response beyond float (a gain of 1e308): no contender
            return math.inf
        iae = float(np.sum(np.abs(e)) * self.ts)
        tail = float(np.max(np.abs(e[-self.n_fft // 8 :])))
        if not ki > 0.0:
            return math.inf
        if tail > 1e-3 * float(np.max(np.abs(e))):
            iae += 10.0 / ki
        return iae

    def loop(self, block: Any) -> Loop:
        """The exact loop of ``block`` on the model (inside the predictor when ``smith``)."""
        if self.smith:
            return Loop(self.model, smith_ss(controller_ss(block), self.model))
        return Loop(self.model, block)


def _without_dead_time(model: Any) -> Any:
    import dataclasses

    return dataclasses.replace(model, dead_time=0.0)


def mv_noise_gain(model: Any, block: Any, *, smith: bool = False) -> float:
    """``sigma_u/sigma_y`` of ``block`` on ``model``: MV noise per unit of white PV noise."""
    m = _Model(model, float(block.config.ts), smith)
    return m.noise(m.cy(controller_ss(block)))


def _feasible(m: _Model, c, ms: float, noise_max: float) -> bool:
    if m.ms(c) > ms:
        return False
    return not (noise_max < math.inf and m.noise(c) > noise_max)


GAIN_RANGE = (1e-30, 1e30)
"""The process gains the designs accept (by magnitude); any real plant's, in any units."""


def _check(
    model: Any, ts: float, ms: float, noise_std: float | None, mv_noise_max: float | None
):
    from ..plants.linear import MAX_DEAD_SAMPLES
    from .identify import FOPDT, SOPDT

    if not isinstance(model, (FOPDT, SOPDT)):
        raise ParameterError(ErrorCode.BAD_PARAMETER, "model", "an FOPDT or SOPDT model")
    if not (math.isfinite(ts) and ts > 0.0):
        raise ParameterError(ErrorCode.BAD_TIME_CONSTANT, "ts", f"must be finite > 0, got {ts!r}")
    k, tau, _L = _scales(model)
    if not GAIN_RANGE[0] <= abs(k) <= GAIN_RANGE[1]:
        # the searches span controller gains 0.1/k .. 1e4/k and the loop's responses k
        # times them: beyond this the floats underflow or overflow (a gain of 1e308 divided
        # by zero in the PID's search)
        raise ParameterError(
            ErrorCode.BAD_PARAMETER, "gain",
            f"|gain| must be {GAIN_RANGE[0]:g} .. {GAIN_RANGE[1]:g} (PV units per MV unit), "
            f"got {model.gain:g}: rescale the PV or the MV",
        )  # fmt: skip
    if not tau / ts <= MAX_DEAD_SAMPLES:
        # the search grids and the load response's FFT are sized in samples of ts
        raise ParameterError(
            ErrorCode.BAD_TIME_CONSTANT, "time_constant",
            f"the model's time scale {tau:g} s is more than {MAX_DEAD_SAMPLES:,} samples of "
            f"ts = {ts:g} s: take a longer ts",
        )  # fmt: skip
    if not (math.isfinite(ms) and 1.1 <= ms <= 3.0):
        raise ParameterError(ErrorCode.BAD_PARAMETER, "ms", f"must be 1.1..3, got {ms!r}")
    ns = 0.0 if noise_std is None else float(noise_std)
    if not (math.isfinite(ns) and ns >= 0.0):
        raise ParameterError(ErrorCode.BAD_PARAMETER, "noise_std", "must be finite and >= 0")
    budget = math.inf if mv_noise_max is None else float(mv_noise_max)
    if not budget > 0.0 or math.isnan(budget):
        raise ParameterError(ErrorCode.BAD_PARAMETER, "mv_noise_max", "must be > 0")
    # the noise constraint as a gain: sigma_u/sigma_y <= budget/sigma_y
    gain_max = budget / ns if ns > 0.0 and budget < math.inf else math.inf
    return ns, budget, gain_max


def _mirror(model: Any) -> tuple[Any, bool]:
    import dataclasses

    if model.gain < 0:
        return dataclasses.replace(model, gain=-model.gain), True
    return model, False


def _scales(model: Any) -> tuple[float, float, float]:
    """``(k, time scale, dead time)`` of the model (time scale: lags plus dead time)."""
    t2 = getattr(model, "time_constant_2", 0.0)
    return model.gain, model.time_constant + t2 + model.dead_time, model.dead_time + t2


# ---------------------------------------------------------------------------
# PID
# ---------------------------------------------------------------------------


def design_pid(
    model: Any,
    ts: float,
    *,
    ms: float = MS_DEFAULT,
    noise_std: float | None = None,
    mv_noise_max: float | None = None,
    controller: str = "pid",
    smith: bool = False,
    b: float | None = None,
) -> Design:
    """The PID (or PI) with the largest integral gain under ``Ms <= ms`` and the noise budget.

    Parameters
    ----------
    model : FOPDT or SOPDT
        The process model (:mod:`ctrlblocks.tuning.identify`).
    ts : float
        Sample time [s].
    ms : float
        Maximum sensitivity target (1.1..3).
    noise_std, mv_noise_max : float, optional
        PV noise standard deviation [PV units] and the largest MV noise standard
        deviation it may cause [MV units]; without them no noise constraint.
    controller : {"pid", "pi"}
        ``"pi"`` searches ``td = 0`` only.
    smith : bool
        Design the PID inside a Smith predictor on the model (module docstring).
    b : float, optional
        Set-point weight; default: chosen for tracking (module docstring).

    Returns
    -------
    Design
    """
    from ..blocks.pid import PID

    noise_std, budget, gmax = _check(model, ts, ms, noise_std, mv_noise_max)
    if controller not in ("pi", "pid"):
        raise ParameterError(ErrorCode.BAD_PARAMETER, "controller", "must be 'pi' or 'pid'")
    pos, reverse = _mirror(model)
    k, tau, _L = _scales(pos)
    m = _Model(pos, ts, smith)
    unlimited = {"ts": ts, "u_min": -math.inf, "u_max": math.inf}
    i_part = m.c_raw(controller_ss(PID(kp=1.0, ti=1.0, **unlimited)))
    p_only = m.c_raw(controller_ss(PID(kp=1.0, **unlimited)))
    ci = tuple(a - b_ for a, b_ in zip(i_part, p_only, strict=True))
    td_scale = max(_L, 0.05 * tau)
    tds = [0.0] if controller == "pi" else [0.0] + [f * td_scale for f in _TD_FACTORS]
    best: tuple[float, float, float, float, float] | None = None  # -IAE, kp, ki, td, n
    for td in tds:
        for n in (_N_GRID if td > 0 else (10.0,)):
            if td > 0 and td / n < 0.5 * ts:
                continue  # a filter faster than the sample time: the derivative is noise
            cp = m.c_raw(controller_ss(PID(kp=1.0, td=td, n=n, **unlimited)))
            found = _best_kp(m, cp, ci, ms, gmax, k, tau)
            if found is not None and (best is None or found[0] > best[0]):
                best = (*found, td, n)
    if best is None:
        raise ParameterError(
            ErrorCode.BAD_PID_COEFFS, "ms",
            f"no PID reaches Ms <= {ms:g} within the MV-noise budget on this model",
        )  # fmt: skip
    _score, kp, ki, td, n = best
    params: dict[str, Any] = {"kp": kp, "ti": kp / ki, "td": td, "n": n}
    params, mg, ki_loop = _polish(m, params, lambda p: PID(**p, **unlimited), "ti", ms)
    warnings: list[str] = []
    params["b"] = _choose_b(m, params, unlimited) if b is None else float(b)
    if reverse:
        params["reverse"] = True
    block = PID(**params, **unlimited)
    c = m.cy(controller_ss(block))
    noise = m.noise(c) * noise_std if noise_std > 0 else math.nan
    kind = "PI" if td == 0.0 else "PID"
    warnings.append(
        f"{kind}{' inside a Smith predictor' if smith else ''}: the smallest load IAE "
        f"({m.load_iae(c):.4g} per unit load; IE = 1/ki = {1 / ki_loop:.4g}) with "
        f"Ms <= {ms:g}"
        + (f", MV noise <= {budget:.3g}" if budget < math.inf and noise_std > 0 else "")
        + f"; b = {params['b']:g} for tracking"
    )
    return Design("PID", params, ts, "smith" if smith else "single", ms, mg,
                  -ki_loop if reverse else ki_loop, noise, noise_std if noise_std > 0 else math.nan,
                  budget if budget < math.inf else math.nan, warnings)  # fmt: skip


def _best_kp(m: _Model, cp, ci, ms: float, gmax: float, k: float, tau: float):
    """``(-IAE, kp, ki)`` of the best point of the Ms/noise boundary for one ``(td, N)``.

    For each ``kp`` the largest feasible ``ki`` (module docstring); of these
    boundary points the one with the smallest load IAE (a scan of ``kp`` in
    factors of 1.25, then a golden-section search of ``log kp``).
    """

    def comb(kp: float, ki: float, grids: int = 3):
        return m.eq(*(kp * a + ki * b for a, b in zip(cp[:grids], ci[:grids], strict=True)))

    last = [0.0]

    def ki_max(kp: float) -> float:
        ki = 1e-4 * kp / tau
        if not _feasible(m, comb(kp, ki), ms, gmax):
            return -1.0
        lo, hi = ki, None
        if last[0] > ki and _feasible(m, comb(kp, 0.5 * last[0]), ms, gmax):
            lo = 0.5 * last[0]  # warm start from the neighbouring kp's boundary
        while hi is None:
            ki = lo * 1.5
            if _feasible(m, comb(kp, ki), ms, gmax):
                lo = ki
                if lo > 1e6 * kp / m.ts:
                    return lo
            else:
                hi = ki
        while hi / lo > 1.003:
            mid = math.sqrt(lo * hi)
            if _feasible(m, comb(kp, mid), ms, gmax):
                lo = mid
            else:
                hi = mid
        last[0] = lo
        return lo

    cache: dict[float, tuple[float, float, float]] = {}

    def score(x: float) -> float:
        if x not in cache:
            kp = math.exp(x)
            ki = ki_max(kp)
            if ki > 0:
                iae, ki = _golden_min(lambda v: m.load_iae(comb(kp, v, 4)), ki / 5.0, ki, 5)
                cache[x] = (-iae, kp, ki)
            else:
                cache[x] = (-math.inf, kp, ki)
        return cache[x][0]

    x = math.log(0.1 / k)
    xs: list[float] = []
    while x < math.log(1e4 / k):
        if ki_max(math.exp(x)) < 0:
            break
        xs.append(x)
        x += math.log(1.3)
    if not xs:
        return None
    i = max(range(len(xs)), key=lambda j: score(xs[j]))
    lo = xs[max(i - 1, 0)]
    hi = xs[i + 1] if i + 1 < len(xs) else xs[i] + math.log(1.3)
    g = (math.sqrt(5) - 1) / 2
    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    for _ in range(8):
        if score(x1) > score(x2):
            hi, x2 = x2, x1
            x1 = hi - g * (hi - lo)
        else:
            lo, x1 = x1, x2
            x2 = lo + g * (hi - lo)
    best = max(cache.values(), key=lambda v: v[0])
    return best if math.isfinite(best[0]) else None


def _golden_min(f, lo: float, hi: float, steps: int = 8) -> tuple[float, float]:
    """``(min f, argmin)`` over ``[lo, hi]`` in log scale: the end ``hi`` (the boundary) and a
    golden-section search (the IAE is smallest inside when the boundary is poorly damped)."""
    g = (math.sqrt(5) - 1) / 2
    a, b = math.log(lo), math.log(hi)
    best = (f(hi), hi)
    x1, x2 = b - g * (b - a), a + g * (b - a)
    f1, f2 = f(math.exp(x1)), f(math.exp(x2))
    for _ in range(steps):
        if f1 < f2:
            b, x2, f2 = x2, x1, f1
            x1 = b - g * (b - a)
            f1 = f(math.exp(x1))
        else:
            a, x1, f1 = x1, x2, f2
            x2 = a + g * (b - a)
            f2 = f(math.exp(x2))
    for fx, x in ((f1, x1), (f2, x2)):
        if fx < best[0]:
            best = (fx, math.exp(x))
    return best


def _polish(m: _Model, params: dict[str, Any], make, key: str, ms: float):
    """Exact margins; lower the integral action until the exact Ms is within the target."""
    lp = m.loop(make(params))
    mg = lp.margins()
    tries = 0
    while (not mg.stable or mg.ms > ms * (1 + 1e-3)) and tries < 40:
        params = dict(params)
        if key == "ti":
            params["ti"] *= 1.02
            params["kp"] /= 1.005
        else:  # ADRC: omega_c
            params["omega_c"] /= 1.02
            params["omega_o"] /= 1.02
        lp = m.loop(make(params))
        mg = lp.margins()
        tries += 1
    if not mg.stable or mg.ms > ms * (1 + 1e-3):
        raise ParameterError(
            ErrorCode.BAD_PARAMETER, "ms",
            f"the design's exact Ms on the model is {mg.ms:.3g}, above the target {ms:g} "
            "(the search's frequency grid missed a peak); no tuning is offered",
        )  # fmt: skip
    return params, mg, lp.integral_gain()


def _choose_b(m: _Model, params: dict[str, Any], unlimited: dict[str, Any]) -> float:
    """The set-point weight of 0, 0.1, .., 1 with the smallest set-point IAE on the model."""
    from ..blocks.pid import PID

    best = (math.inf, 1.0)
    for b in _B_GRID:
        iae = m.setpoint_iae(controller_ss(PID(**params, b=b, **unlimited)))
        if iae < best[0] * (1 - 1e-9):
            best = (iae, b)
    return best[1]


# ---------------------------------------------------------------------------
# ADRC
# ---------------------------------------------------------------------------


def design_adrc(
    model: Any,
    order: int,
    ts: float,
    *,
    ms: float = MS_DEFAULT,
    noise_std: float | None = None,
    mv_noise_max: float | None = None,
    ratios: tuple[float, ...] = OBSERVER_RATIOS,
    input_delay: float = 0.0,
    discretisation: str = "euler",
) -> Design:
    """The ADRC of ``order`` with the largest integral gain under ``Ms <= ms`` and the budget.

    ``b0``, ``omega_c`` and the observer ratio are searched (module
    docstring).  ``input_delay`` [s] > 0 feeds the ESO with the MV delayed by
    it (the block's ``input_delay``: the predictive ADRC of Zhao & Gao 2014).
    Parameters otherwise as :func:`design_pid`.
    """
    from ..blocks.adrc import ADRC
    from .halfrule import inverse_half_rule

    noise_std, budget, gmax = _check(model, ts, ms, noise_std, mv_noise_max)
    if isinstance(order, bool) or order not in (1, 2, 3):
        raise ParameterError(ErrorCode.BAD_ORDER, "order", f"must be 1, 2 or 3, got {order!r}")
    if not ratios or not all(math.isfinite(r) and 1.0 <= r <= 100.0 for r in ratios):
        raise ParameterError(
            ErrorCode.BAD_BANDWIDTH, "observer_ratio",
            f"omega_o / omega_c must be 1..100, got {', '.join(f'{r:g}' for r in ratios)}",
        )  # fmt: skip
    pos, reverse = _mirror(model)
    k, tau, L = _scales(pos)
    m = _Model(pos, ts, False)
    extra: dict[str, Any] = {"discretisation": discretisation}
    if input_delay > 0.0:
        extra["input_delay"] = float(input_delay)
    try:
        b0_rule = inverse_half_rule(k, tau - L, L, order).b0
    except (ParameterError, ValueError):
        b0_rule = math.nan
    if not (math.isfinite(b0_rule) and b0_rule > 0):
        b0_rule = k / (tau - L) ** order if tau > L else k / tau**order
    wo_cap = _MAX_OMEGA_O_TS / ts

    def make(b0: float, wc: float, ratio: float) -> Any:
        return ADRC(order=order, b0=b0, omega_c=wc, omega_o=min(ratio * wc, wo_cap), ts=ts,
                    u_min=-math.inf, u_max=math.inf, **extra)  # fmt: skip

    evals: dict[tuple[float, float, float], bool] = {}

    def feasible(b0: float, wc: float, ratio: float) -> bool:
        key = (b0, wc, ratio)
        if key not in evals:
            try:
                c = m.cy(controller_ss(make(b0, wc, ratio)), 3)
            except ParameterError:
                evals[key] = False
            else:
                evals[key] = _feasible(m, c, ms, gmax)
        return evals[key]

    last: dict[float, float] = {}  # ratio -> the boundary omega_c of the b0 before

    def fastest(b0: float, ratio: float) -> tuple[float, float]:
        """``(-IAE, omega_c)`` of the fastest feasible omega_c (-inf: none)."""
        wc_max = wo_cap / ratio  # the observer ratio kept: omega_o = ratio omega_c <= the cap
        lo = min(0.05 / tau, wc_max)
        if not feasible(b0, lo, ratio):
            return -math.inf, math.nan
        warm = 0.6 * last.get(ratio, 0.0)
        if lo < warm < wc_max and feasible(b0, warm, ratio):
            lo = warm  # start from the neighbouring b0's boundary
        hi = math.inf
        while hi == math.inf:
            wc = min(lo * 1.5, wc_max)
            if feasible(b0, wc, ratio):
                lo = wc
                if wc >= wc_max:
                    break
            else:
                hi = wc
        while hi < math.inf and hi / lo > 1.01:
            mid = math.sqrt(lo * hi)
            if feasible(b0, mid, ratio):
                lo = mid
            else:
                hi = mid
        last[ratio] = lo

        def iae(wc: float) -> float:
            return m.load_iae(m.cy(controller_ss(make(b0, wc, ratio))))

        v, wc = _golden_min(iae, lo / 3.0, lo, steps=5)
        return -v, wc

    best: tuple[float, float, float, float] = (-math.inf, math.nan, math.nan, math.nan)
    for ratio in ratios:
        found = _search_b0(lambda b0, r=ratio: fastest(b0, r), b0_rule)
        if found[0] > best[0]:
            best = (found[0], found[1], found[2], ratio)
    ki, b0, wc, ratio = best
    if not math.isfinite(ki):
        raise ParameterError(
            ErrorCode.BAD_BANDWIDTH, "order",
            f"no ADRC of order {order} reaches Ms <= {ms:g} within the MV-noise budget on this "
            "model",
        )  # fmt: skip
    params: dict[str, Any] = {"order": order, "b0": b0, "omega_c": wc,
                              "omega_o": min(ratio * wc, wo_cap), **extra}  # fmt: skip
    if discretisation == "euler":
        params.pop("discretisation")
    params, mg, ki_loop = _polish(
        m, params, lambda p: ADRC(**p, ts=ts, u_min=-math.inf, u_max=math.inf), "omega_c", ms
    )
    warnings: list[str] = []
    eff = params["omega_o"] / params["omega_c"]
    if eff < 3.0 * (1 - 1e-9):
        warnings.append(
            f"omega_o = {eff:.3g} omega_c, below the 3..10 of Nowak et al. 2018: the sample "
            f"time ts = {ts:g} s caps omega_o at {wo_cap:.4g} rad/s (omega_o ts <= "
            f"{_MAX_OMEGA_O_TS}); a shorter ts allows a faster observer"
        )
    c = m.cy(controller_ss(ADRC(**params, ts=ts, u_min=-math.inf, u_max=math.inf)))
    warnings.append(
        f"b0 = {b0:.4g} ({b0 / b0_rule:.3g} times the inverse half-rule's {b0_rule:.4g}), "
        f"omega_c = {params['omega_c']:.4g} rad/s and omega_o = {eff:.3g} omega_c: the "
        f"smallest load IAE ({m.load_iae(c):.4g} per unit load; IE = 1/ki = {1 / ki_loop:.4g}) "
        f"with Ms <= {ms:g}"
        + (f", MV noise <= {budget:.3g}" if budget < math.inf and noise_std > 0 else "")
    )
    if reverse:
        params["reverse"] = True
    block = ADRC(**params, ts=ts, u_min=-math.inf, u_max=math.inf)
    noise = m.noise(m.cy(controller_ss(block))) * noise_std if noise_std > 0 else math.nan
    return Design("ADRC", params, ts, "single", ms, mg, -ki_loop if reverse else ki_loop, noise,
                  noise_std if noise_std > 0 else math.nan,
                  budget if budget < math.inf else math.nan, warnings)  # fmt: skip


_B0_RANGE = (0.1, 50.0)
_B0_STEP = 1.5


def _search_b0(score_of, b0_rule: float) -> tuple[float, float, float]:
    """``(score, b0, omega_c)`` of the b0 with the best score: :func:`log_walk`."""
    found: dict[float, tuple[float, float]] = {}

    def score(b0: float) -> float:
        if b0 not in found:
            found[b0] = score_of(b0)
        return found[b0][0]

    log_walk(score, b0_rule, _B0_RANGE, step=_B0_STEP, scan=True)
    b0 = max(found, key=lambda x: found[x][0])
    return found[b0][0], b0, found[b0][1]
