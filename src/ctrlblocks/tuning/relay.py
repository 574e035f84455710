"""Auto-tuning against a plant: relay feedback (fine tuning) and a bump test (pre-tuning).

These are the stand-ins for the two auto-tuning stages of Siemens
PID_Compact used as the PID reference in Nowak et al. 2018 (section 6: PID_PT by
"pretuning", PID_FT by "finetuning").  Both run against any object with the
plant contract of :mod:`ctrlblocks.plants.base` (``plant.y``,
``plant.step(u)``, ``plant.reset(u0)``, ``plant.ts``).

Relay feedback (Åström & Hägglund, *Automatic tuning of simple regulators
with specifications on phase and amplitude margins*, Automatica 20 (1984)
645-651).  The controller is replaced by a relay around the operating point
``u0``: ``u = u0 + d`` while the control error ``e = sp - y`` (times the
process-gain sign) is above ``+eps`` and ``u0 - d`` while it is below
``-eps`` (hysteresis ``eps``; in between the relay holds).  Most processes
settle into a limit cycle of period ``P`` and PV amplitude ``a``.

Two estimates of the ultimate gain ``ku`` and period ``pu`` are made from the
last ``cycles`` periods of the cycle:

* ``estimate="df"`` -- the describing function of the relay,
  ``N(a) = 4 d/(pi a)`` (Åström & Hägglund 1984): ``ku = 4 d/(pi a)``,
  ``pu = P``, with ``a`` the amplitude of the PV's fundamental (first Fourier
  coefficient over whole periods; ``amplitude="peak"``: half the
  peak-to-peak PV, the classic hand evaluation).  It assumes the PV is a
  sinusoid; the relay's third harmonic makes it a few per cent off for
  plants without dead time (third-order (10b) of Nowak et al. 2018: ``ku`` -6 %,
  ``pu`` +3 %).  With hysteresis the cycle sits where the process phase is
  ``-180 deg + asin(eps/a)``, not at the ultimate point.
* ``estimate="harmonic"`` (default) -- for a linear plant in periodic steady
  state each harmonic obeys ``Y_k = G(j k w1) U_k`` exactly, so the Fourier
  coefficients of ``u`` and ``y`` at ``w1 = 2 pi/P`` and ``3 w1`` give two
  exact points of the frequency response.  Phase (unwrapped so that
  ``phi1`` is in ``(-2 pi, 0]`` and ``phi3 - phi1`` in ``(-2 pi, 0]``) and
  log-magnitude are interpolated linearly in ``ln w`` to the -180 deg
  crossing::

      w180 = w1 exp((-pi - phi1)/s_phi),     s_phi = (phi3 - phi1)/ln 3
      |G(w180)| = |G1| (w180/w1)^s_m,        s_m = ln(|G3|/|G1|)/ln 3
      ku = 1/|G(w180)|,  pu = 2 pi/w180

  Without hysteresis the cycle is within a few degrees of -180 deg and the
  correction removes most of the describing-function error; measured on five
  plants (tests/tuning/test_relay.py and docs/tuning.md) the harmonic
  estimate is within 2.4 % (``ku``) and 1.7 % (``pu``), the describing
  function within 6.2 % and 3.7 % (10b: harmonic -1.5 %/+1.1 %, describing
  function -6.2 %/+3.1 %).  A hysteresis moves the cycle away from -180 deg
  (by ``asin(eps/a)``); the interpolation then has farther to go and is less
  accurate (``eps = 0.16 a``: up to 5 % harmonic, 10-45 % describing
  function), so keep the hysteresis just above the noise band.

**Noisy plants.**  A hysteresis below the noise lets the relay chatter, and
the sampled cycle of a real process is never the same twice: its switches
fall on sample instants (a 9.5 s period sampled at 0.1 s comes as 9.4, 9.5,
9.6 s in turn, with amplitudes 5 % apart) and noise moves each one.  So:

* ``hysteresis="auto"`` sizes the hysteresis from the noise: the relay first
  holds ``u0`` for ``noise_time`` (20 samples at least) and takes the noise
  standard deviation from the PV's first differences, ``sigma = std(dy)/sqrt 2``
  (a drift of the PV hardly enters them), then ``eps = max(3 sigma, eps_min)``:
  the band of 99.7 % of Gaussian noise around the set point, so noise alone
  cannot switch the relay;
* the cycle is judged over several periods: it is steady when the mean period
  of the last ``cycles`` cycles agrees with that of the ``cycles`` before
  within 2 % (plus one sample spread over the window) and their mean PV
  amplitudes within 5 %, and no single period is 25 % off (a switch by
  noise); the estimates use the last ``cycles`` cycles;
* a cycle whose PV amplitude is less than :data:`MIN_AMPLITUDE` hysteresis
  widths is refused (its estimates would be far off), and a cycle that does
  not form ends the test; both with a message saying what was seen: the
  switches, the periods and amplitudes with their spread, the noise and the
  hysteresis, and what to change.

Measured on the three-tank rig (``ThreeTank``, ts = 0.1 s, d = 0.5 bar, 1 mbar
Gaussian noise, 20 seeds; tests/tuning/test_relay.py): every test finds its
cycle within 86 s (the issue's failed after 240 s), ku 2-12 % and pu 0-4 %
from the noise-free relay without hysteresis -- of which +7 % and -1 % is the
3 mbar hysteresis itself (the same relay on the noise-free plant).

The PID settings from ``(ku, pu)`` are Ziegler-Nichols closed loop by default
(``rule="zn"``).  Nowak et al.'s (2018) PID_FT (``kP = 6.31``, ``TI = 5.40 s``,
``TD = 1.36 s``) has ``TI/TD = 3.97``, the Ziegler-Nichols ratio 4 (pu/2 over
pu/8); ``rule="tyreus-luyben"`` is the gentler alternative.

Bump test (pre-tuning): from a steady state at ``u0``, step the MV by
``du`` and record the PV, fit an FOPDT by least squares
(:func:`~ctrlblocks.tuning.identify.fit_fopdt`) and apply a model rule
(AMIGO PID by default).
"""

from __future__ import annotations

import itertools
import logging
import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from ..blocks.base import (
    ErrorCode,
    ParameterError,
    require_choice,
    require_finite,
    require_nonnegative,
    require_positive,
)
from .identify import FOPDT, fit_fopdt
from .pid_rules import PIDTuning, pid_from_model, tyreus_luyben, ziegler_nichols_closed

__all__ = ["BumpTestResult", "RelayResult", "bump_test", "relay_autotune", "step_pretune"]

_log = logging.getLogger(__name__)


class _Plant(Protocol):
    ts: float

    @property
    def y(self) -> float: ...

    def step(self, u: float) -> float: ...

    def reset(self, u0: float = 0.0) -> None: ...


@dataclass(frozen=True)
class RelayResult:
    """Result of :func:`relay_autotune`.

    Attributes
    ----------
    ku : float
        Ultimate gain estimate (sign of the process gain) [MV unit / PV unit].
    pu : float
        Ultimate period estimate [s].
    estimate : str
        ``"harmonic"`` or ``"df"`` (module docstring).
    ku_df : float
        Describing-function estimate ``4 d/(pi a)`` (whatever ``estimate`` is).
    period : float
        Measured period ``P`` of the limit cycle [s].
    amplitude : float
        PV amplitude ``a`` used by ``ku_df``.
    phase : float
        Measured process phase at the cycle frequency [deg].
    pid : PIDTuning
        The PID settings (ISA form).
    cycles : int
        Number of full cycles used.
    t, u, y : numpy.ndarray
        The recorded experiment.
    warnings : list of str
    """

    ku: float
    pu: float
    estimate: str
    ku_df: float
    period: float
    amplitude: float
    phase: float
    pid: PIDTuning
    cycles: int
    t: NDArray[np.float64]
    u: NDArray[np.float64]
    y: NDArray[np.float64]
    warnings: list[str] = field(default_factory=list)


def relay_autotune(
    plant: _Plant,
    d: float,
    *,
    u0: float = 0.0,
    setpoint: float | None = None,
    hysteresis: float = 0.0,
    gain_sign: int = 1,
    max_time: float | None = None,
    cycles: int = 3,
    estimate: str = "harmonic",
    amplitude: str = "fourier",
    rule: str = "zn",
    controller: str = "pid",
    noise_time: float = 2.0,
) -> RelayResult:
    """Relay-feedback experiment on ``plant``; ultimate point and PID settings.

    Parameters
    ----------
    plant : Plant
        Plant with the contract of :mod:`ctrlblocks.plants.base`; it is reset
        to ``u0`` first.
    d : float
        Relay amplitude [MV unit], > 0.
    u0 : float
        Relay bias: the MV at the operating point.
    setpoint : float, optional
        PV around which the relay switches; default: the PV at steady state
        for ``u0`` (a symmetric cycle).
    hysteresis : float or "auto"
        Relay hysteresis ``eps`` [PV unit] >= 0 (noise immunity); ``"auto"``:
        sized from the noise measured first (module docstring, "Noisy plants").
    gain_sign : {1, -1}
        Sign of the process gain (-1: the PV falls when the MV rises).
    max_time : float, optional
        Longest experiment [s]; default ``20000 ts``.
    cycles : int
        The cycle is steady when the last ``cycles`` cycles agree with the
        ``cycles`` before (module docstring); the estimates use the last ones.
    noise_time : float
        With ``hysteresis="auto"``: how long ``u0`` is held to measure the
        noise [s] (at least 20 samples).
    estimate : {"harmonic", "df"}
        Ultimate-point estimate (module docstring).
    amplitude : {"fourier", "peak"}
        How ``a`` is measured for the describing function.
    rule : {"zn", "tyreus-luyben"}
        Rule from (ku, pu) to PID settings.
    controller : {"p", "pi", "pid"}
        Controller type (``"p"`` only with ``"zn"``).

    Returns
    -------
    RelayResult

    Raises
    ------
    ParameterError
        Bad arguments.
    RuntimeError
        If no steady limit cycle forms within ``max_time``.
    """
    d = require_positive("d", d)
    u0 = require_finite("u0", u0)
    eps = None if hysteresis == "auto" else require_nonnegative("hysteresis", hysteresis)
    if gain_sign not in (1, -1):
        raise ParameterError(
            ErrorCode.BAD_PARAMETER, "gain_sign", f"must be 1 or -1, got {gain_sign!r}"
        )
    for name, value, choices in (
        ("estimate", estimate, ("harmonic", "df")),
        ("amplitude", amplitude, ("fourier", "peak")),
        ("rule", rule, ("zn", "tyreus-luyben")),
    ):
        require_choice(name, value, choices)
    if isinstance(cycles, bool) or not isinstance(cycles, int) or cycles < 1:
        raise ParameterError(
            ErrorCode.BAD_PARAMETER, "cycles", f"must be an int >= 1, got {cycles!r}"
        )
    ts = float(plant.ts)
    n_max = int((max_time if max_time is not None else 20000 * ts) / ts)
    plant.reset(u0)
    sp = float(plant.y) if setpoint is None else require_finite("setpoint", setpoint)
    exp = RelayExperiment(
        d, u0=u0, setpoint=sp, ts=ts, max_samples=n_max, hysteresis=eps,
        gain_sign=gain_sign, cycles=cycles, amplitude=amplitude,
        noise_samples=noise_samples(noise_time, ts) if eps is None else 0,
    )  # fmt: skip
    while True:
        u = exp.step(float(plant.y))
        if exp.done:
            break
        plant.step(u)
    return exp.result(estimate=estimate, rule=rule, controller=controller)


NOISE_SAMPLES = 20
"""Fewest samples the noise is measured on (``hysteresis="auto"``)."""

NOISE_BAND = 3.0
"""The auto hysteresis in noise standard deviations (99.7 % of Gaussian noise inside)."""

MIN_AMPLITUDE = 4.0
"""The cycle's PV amplitude must be at least this many hysteresis widths: with less, the
cycle sits far from -180 deg and noise moves its harmonics (measured on the three-tank rig:
a/eps below 4 gave ku errors up to 85 %)."""


def noise_samples(noise_time: float, ts: float) -> int:
    """Samples held at ``u0`` to measure the noise: ``noise_time / ts``, at least 20."""
    return max(NOISE_SAMPLES, round(require_positive("noise_time", noise_time) / ts))


def noise_sigma(y: NDArray[np.float64]) -> float:
    """The noise standard deviation of a PV record held at one MV: ``std(dy) / sqrt 2``.

    First differences remove a slow drift; white noise of variance s^2 gives
    differences of variance 2 s^2.
    """
    dy = np.diff(np.asarray(y, dtype=float))
    return float(np.std(dy) / math.sqrt(2.0)) if len(dy) > 1 else 0.0


class RelayExperiment:
    """The relay experiment of :func:`relay_autotune`, one sample per call.

    ``u = exp.step(y)`` takes this sample's PV and returns the MV to apply;
    :attr:`done` turns true when the cycle is steady over several periods
    (module docstring; or the sample budget ``max_samples`` is spent), then
    :meth:`result` gives the estimates.  The same object runs the offline
    experiment against a simulated plant (:func:`relay_autotune`) and the live
    one on a running loop (:class:`ctrlblocks.tuning.live.LiveTuner`).
    Arguments as :func:`relay_autotune` (already validated there);
    ``hysteresis`` None and ``noise_samples`` > 0: the hysteresis is sized from
    the noise of the first ``noise_samples`` samples, held at ``u0``.
    """

    def __init__(
        self,
        d: float,
        *,
        u0: float,
        setpoint: float,
        ts: float,
        max_samples: int,
        hysteresis: float | None = 0.0,
        gain_sign: int = 1,
        cycles: int = 3,
        amplitude: str = "fourier",
        noise_samples: int = 0,
    ) -> None:
        self.d, self.u0, self.sp, self.ts = d, u0, setpoint, ts
        self.eps_min = 0.0 if hysteresis is None else hysteresis
        self.n_noise = noise_samples if hysteresis is None else 0
        self.eps = self.eps_min
        self.sigma = math.nan  # the measured noise (auto hysteresis)
        self.gain_sign = gain_sign
        self.cycles, self.amplitude = cycles, amplitude
        self.max_samples = max_samples + self.n_noise
        n = self.max_samples + 1
        self.t, self.u, self.y = np.empty(n), np.empty(n), np.empty(n)
        self.k = 0  # samples recorded
        self.ups: list[int] = []  # sample indices where the relay switches to +d
        self._u = u0 if self.n_noise else u0 + d  # push the PV up first (gain_sign = 1)
        self.cycle: tuple[float, float, float] | None = None  # period, amplitude, asymmetry
        self.done = False

    def step(self, y: float) -> float:
        """Record the PV ``y`` of this sample; the relay output to apply now."""
        if self.done:
            return self._u
        k = self.k
        if k < self.n_noise:  # measuring the noise at u0
            self.t[k], self.u[k], self.y[k] = k * self.ts, self.u0, y
            self.k = k + 1
            if self.k == self.n_noise:
                self.sigma = noise_sigma(self.y[: self.k])
                self.eps = max(self.eps_min, NOISE_BAND * self.sigma)
                self._u = self.u0 + self.d
            return self.u0
        e = self.gain_sign * (self.sp - y)
        if e > self.eps and self._u != self.u0 + self.d:
            self._u = self.u0 + self.d
            self.ups.append(k)
        elif e < -self.eps and self._u != self.u0 - self.d:
            self._u = self.u0 - self.d
        self.t[k], self.u[k], self.y[k] = k * self.ts, self._u, y
        self.k = k + 1
        ups, n = self.ups, self.cycles
        if len(ups) >= 2 * n + 1 and ups[-1] == k:
            self.cycle = _steady_cycles(ups[-(2 * n + 1) :], self.u, self.y, self.u0,
                                        self.amplitude, self.ts)  # fmt: skip
        self.done = self.cycle is not None or self.k > self.max_samples
        return self._u

    def seen(self) -> str:
        """What the experiment saw, for a message when no steady cycle formed."""
        ups = self.ups
        noise = "" if math.isnan(self.sigma) else f"noise sigma {self.sigma:.3g}, "
        head = (f"{len(ups)} upward switch(es) in {self.k * self.ts:g} s; {noise}"
                f"hysteresis {self.eps:.3g}")  # fmt: skip
        if len(ups) < 3:
            y = self.y[self.n_noise : self.k]
            span = f"PV {np.min(y):.4g} .. {np.max(y):.4g}" if len(y) else "no PV"
            return (f"{head}; {span} around the set point {self.sp:.4g}: the PV hardly "
                    "crosses the set point band -- increase d, or check the gain sign "
                    "and that u0 +- d can move the PV across the set point")  # fmt: skip
        p, a = _per_cycle(ups[-min(len(ups), 2 * self.cycles + 1) :], self.u, self.y,
                          self.u0, self.amplitude, self.ts)[:2]  # fmt: skip
        pm, am = float(np.mean(p)), float(np.mean(a))
        advice = ("increase d, so the cycle stands out of the noise"
                  if am < MIN_AMPLITUDE * self.eps else "increase max_time")  # fmt: skip
        return (f"{head}; the last {len(p)} cycles: period {pm:.4g} s "
                f"(spread {np.ptp(p):.3g} s), PV amplitude {am:.4g} "
                f"(spread {100 * np.ptp(a) / am:.0f} %); {advice}")  # fmt: skip

    def result(
        self, *, estimate: str = "harmonic", rule: str = "zn", controller: str = "pid"
    ) -> RelayResult:
        """Estimates and PID settings of a finished experiment (see :func:`relay_autotune`).

        Raises RuntimeError if no steady limit cycle formed.
        """
        cyc = self.cycle
        if cyc is None:
            raise RuntimeError(
                f"no steady relay limit cycle within {self.max_samples * self.ts:g} s: "
                + self.seen()
            )
        ups, cycles, eps, d, gain_sign = self.ups, self.cycles, self.eps, self.d, self.gain_sign
        n = self.k
        u_rec, y_rec, t_rec = self.u, self.y, self.t
        period, a, asym = cyc
        warnings = []
        if asym > 0.1:
            warnings.append(
                f"asymmetric cycle (half periods differ by {100 * asym:.0f} %): the setpoint is "
                "not the steady state of the bias u0; the estimates are less accurate"
            )
        if a < MIN_AMPLITUDE * eps:
            raise RuntimeError(
                f"the cycle's PV amplitude {a:.4g} is less than {MIN_AMPLITUDE:g} times the "
                f"hysteresis {eps:.4g}: the estimates would be far off; " + self.seen()
            )
        i0, i1 = ups[-(cycles + 1)], ups[-1]
        ku_h, pu_h, phase = _harmonic_estimate(
            u_rec[i0:i1], y_rec[i0:i1], cycles, self.ts, gain_sign
        )
        ku_df = 4.0 * d / (math.pi * a)
        if estimate == "harmonic":
            ku, pu = ku_h, pu_h
        else:
            ku, pu = ku_df, period
        ku *= gain_sign
        ku_df *= gain_sign
        if rule == "zn":
            pid = ziegler_nichols_closed(ku, pu, controller=controller)
        else:
            pid = tyreus_luyben(ku, pu, controller=controller)
        for w in warnings:
            _log.info("relay: %s", w)
        return RelayResult(
            ku,
            pu,
            estimate,
            ku_df,
            period,
            a,
            phase,
            pid,
            cycles,
            t_rec[:n].copy(),
            u_rec[:n].copy(),
            y_rec[:n].copy(),
            warnings,
        )


def _per_cycle(starts, u, y, u0, how, ts):
    """Period [s], PV amplitude and asymmetry of each cycle between the ``starts``."""
    periods, amps, asym = [], [], []
    for i0, i1 in itertools.pairwise(starts):
        seg = y[i0:i1]
        periods.append((i1 - i0) * ts)
        if how == "peak":
            amps.append(0.5 * float(np.ptp(seg)))
        else:
            amps.append(abs(_harmonic(seg, 1)))
        n_up = int(np.count_nonzero(u[i0:i1] > u0))
        asym.append(abs(2.0 * n_up - (i1 - i0)) / (i1 - i0))
    return np.array(periods), np.array(amps), np.array(asym)


def _steady_cycles(starts, u, y, u0, how, ts):
    """Mean period, PV amplitude and asymmetry of the last half of the cycles, if steady.

    ``starts`` bound ``2 n`` cycles: steady when the last ``n`` agree with the ``n``
    before (mean period within 2 % plus one sample over the window, mean
    amplitude within 5 %) and no period is 25 % off (module docstring).
    """
    p, a, asym = _per_cycle(starts, u, y, u0, how, ts)
    n = len(p) // 2
    p1, p2 = float(np.mean(p[:n])), float(np.mean(p[n:]))
    a1, a2 = float(np.mean(a[:n])), float(np.mean(a[n:]))
    if abs(p1 - p2) > 0.02 * p2 + 1.01 * ts / n or abs(a1 - a2) > 0.05 * a2:
        return None
    if np.max(np.abs(p - p2)) > 0.25 * p2:
        return None
    return p2, a2, float(np.max(asym[n:]))


def _harmonic(x: NDArray, k: int) -> complex:
    """Complex amplitude of the k-th harmonic of ``x`` over its whole window."""
    m = len(x)
    return complex(2.0 * np.sum(x * np.exp(-2j * np.pi * k * np.arange(m) / m)) / m)


def _harmonic_estimate(
    u: NDArray, y: NDArray, cycles: int, ts: float, sign: int
) -> tuple[float, float, float]:
    """(ku, pu, phase at w1 [deg]) from the 1st and 3rd harmonics (module docstring)."""
    g1 = sign * _harmonic(y, cycles) / _harmonic(u, cycles)
    g3 = sign * _harmonic(y, 3 * cycles) / _harmonic(u, 3 * cycles)
    w1 = 2.0 * math.pi * cycles / (len(u) * ts)
    phi1 = math.atan2(-g1.imag, -g1.real) - math.pi  # in (-2 pi, 0]
    dphi = (math.atan2(g3.imag, g3.real) - phi1) % (-2.0 * math.pi)  # in (-2 pi, 0]
    s_phi = dphi / math.log(3.0)
    s_m = math.log(abs(g3) / abs(g1)) / math.log(3.0)
    w180 = w1 * math.exp((-math.pi - phi1) / s_phi) if s_phi < 0.0 else w1
    mag = abs(g1) * (w180 / w1) ** s_m
    return 1.0 / mag, 2.0 * math.pi / w180, math.degrees(phi1)


@dataclass(frozen=True)
class BumpTestResult:
    """Result of :func:`step_pretune`: the record, the model and the PID settings."""

    model: FOPDT
    pid: PIDTuning
    t: NDArray[np.float64]
    u: NDArray[np.float64]
    y: NDArray[np.float64]


def bump_test(
    plant: _Plant,
    du: float,
    *,
    u0: float = 0.0,
    duration: float | None = None,
    pre_time: float | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Open-loop step on ``plant``: returns ``(t, u, y)``.

    The plant is reset to ``u0``, held there for ``pre_time`` (default
    10 samples), then the MV steps to ``u0 + du``.  Without ``duration`` the
    test stops once the PV has moved by less than 0.5 % of its change over
    the last third of the time since the step (at least 50 samples after the
    step, at most 20000 samples).
    """
    du = require_finite("du", du)
    if du == 0.0:
        raise ParameterError(ErrorCode.BAD_PARAMETER, "du", "must be non-zero")
    ts = float(plant.ts)
    n_pre = 10 if pre_time is None else max(1, round(require_positive("pre_time", pre_time) / ts))
    n_max = 20000 if duration is None else round(require_positive("duration", duration) / ts)
    plant.reset(u0)
    exp = StepExperiment(du, u0=u0, ts=ts, n_pre=n_pre, n_max=n_max, settle=duration is None)
    while True:
        u = exp.step(float(plant.y))
        if exp.done:
            break
        plant.step(u)
    return exp.record()


class StepExperiment:
    """The bump test of :func:`bump_test`, one sample per call.

    ``u = exp.step(y)`` records this sample's PV and returns the MV to apply:
    ``u0`` for ``n_pre`` samples, then ``u0 + du``.  :attr:`done` turns true
    after ``n_pre + n_max + 1`` samples or, with ``settle``, once the PV has
    moved by less than 0.5 % of its change over the last third of the time
    since the step (checked every 10 samples from 50 samples after the step).
    The same object runs offline (:func:`bump_test`) and on a running loop
    (:class:`ctrlblocks.tuning.live.LiveTuner`).
    """

    def __init__(
        self, du: float, *, u0: float, ts: float, n_pre: int, n_max: int, settle: bool = True
    ) -> None:
        self.du, self.u0, self.ts = du, u0, ts
        self.n_pre, self.n_max, self.settle = n_pre, n_max, settle
        self.t: list[float] = []
        self.u: list[float] = []
        self.y: list[float] = []
        self.done = False
        self.settled = False

    def step(self, y: float) -> float:
        """Record the PV ``y`` of this sample; the MV to apply now."""
        k = len(self.t)
        n_pre = self.n_pre
        uk = self.u0 if k < n_pre else self.u0 + self.du
        if self.done:
            return uk
        self.t.append(k * self.ts)
        self.u.append(uk)
        self.y.append(y)
        if self.settle and k - n_pre >= 50 and (k - n_pre) % 10 == 0:
            change = abs(self.y[-1] - self.y[0])
            tail = self.y[n_pre + 2 * (k - n_pre) // 3 :]
            if change > 0 and max(tail) - min(tail) < 0.005 * change:
                self.settled = self.done = True
        if k >= n_pre + self.n_max:
            self.done = True
        return uk

    def record(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The recorded ``(t, u, y)``."""
        return np.array(self.t), np.array(self.u), np.array(self.y)


def step_pretune(
    plant: _Plant,
    du: float,
    *,
    u0: float = 0.0,
    duration: float | None = None,
    rule: str = "amigo",
    controller: str = "pid",
) -> BumpTestResult:
    """Bump test, FOPDT least-squares fit and a model rule: the pre-tuning stand-in.

    Parameters
    ----------
    plant : Plant
    du : float
        MV step [MV unit].
    u0 : float
        Operating point MV.
    duration : float, optional
        Test length after the step [s]; automatic if not given (:func:`bump_test`).
    rule : {"amigo", "simc", "zn", "lambda"}
        PID rule applied to the identified FOPDT (:mod:`.pid_rules`).
    controller : {"pi", "pid"}
        Controller type (SIMC gives a PI for an FOPDT whatever is asked).
    """
    t, u, y = bump_test(plant, du, u0=u0, duration=duration)
    model = fit_fopdt(t, u, y)
    pid = pid_from_model(model, rule, controller=controller)
    return BumpTestResult(model, pid, t, u, y)
