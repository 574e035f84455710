"""ADRC bandwidth tuning (Nowak et al. 2018, section 3.3) and a ready ADRC configuration.

Nowak et al. 2018, section 3.3 (after Gao 2003, its reference [5]):

* controller bandwidth ``omega_c = (3..5)/tau_set`` for the desired
  closed-loop settling time ``tau_set``, "depending on the process relative
  order";
* observer bandwidth ``omega_o = (3..10) omega_c``, its upper end limited by
  the sample time ``ts`` and the measurement noise;
* ``b0`` from the FOPDT model by the inverse half-rule
  (:mod:`ctrlblocks.tuning.halfrule`).

Choice of the factor per order.  With the bandwidth parametrisation the ideal
closed loop has all ``n`` poles at ``-omega_c``; its 2 % settling time is
``x_n/omega_c`` with ``x_1 = ln 50 = 3.91``, ``x_2 = 5.83``, ``x_3 = 7.52``
(solutions of ``e^{-x} sum_{j<n} x^j/j! = 0.02``).  The factor used is
``x_n`` clipped to the paper's range: **3.91 for n = 1, 5 for n = 2 and 3**.
So a first-order loop is designed to settle in ``tau_set``; for n = 2 and 3
the paper's range gives an ideal settling time of ``1.17 tau_set`` and
``1.50 tau_set`` (reported as ``settling_time_model``).  Pass ``factor`` to
override.

Observer: ``omega_o = 5 omega_c`` by default (the ratio of Nowak et al. 2018, Table 2
for n = 2 and 3: 1.75/0.35).  The Euler observer (4a) with the gains
``l_i = C(n+1, i) omega_o^i`` is stable only for ``omega_o ts`` below
0.828 (n = 1), 0.520 (n = 2), 0.378 (n = 3) (see :mod:`ctrlblocks.blocks.adrc`,
which warns from 0.735/0.484/0.360 on), and follows the continuous design
closely only well below that; the check here asks
``omega_o ts <= MAX_OMEGA_O_TS = 0.2`` (Table 2: 1.75 x 0.1 = 0.175) and
lowers ``omega_o`` to that bound with a warning.  Without ``ts`` a sample
time with ``omega_o ts <= 0.1`` is suggested (1, 2 or 5 times a power of ten).

Measurement noise: with ``noise_std`` (standard deviation of the PV noise)
and ``u_noise_max`` (acceptable standard deviation of the MV), the MV noise
of the configured block is measured by running :class:`ctrlblocks.blocks.adrc.ADRC`
itself on 2000 samples of seeded white noise (one implementation of the
control law, no formula copied), and ``omega_o`` is lowered in steps of 10 %
down to ``3 omega_c`` until the MV noise is acceptable (a warning says so,
or says that even ``3 omega_c`` is too noisy).

Default when no settling time is given (the safe default): the fastest
``omega_c`` whose sampled loop on the model -- dead time exact, the block's own
discretisation, :mod:`ctrlblocks.tuning.margins` -- is stable with a maximum
sensitivity ``Ms <= 1.6`` (``ms``), ``omega_o = observer_ratio omega_c``.  The
bandwidth rule itself assumes a process without real dead time: with
``tau_set = 1.5 (T + T0)`` (the former default) the loop is unstable on every
FOPDT from ``T0/T`` of about 0.1 upwards, orders 1 and 2 alike (for
``k = 2, T = 30 s, T0 = 5 s``, n = 2: a closed-loop pole at ``|z| = 1.02``).
The searched default is stable but slow on such processes: with ``T0/T``
of 0.17..0.3 the order-2 loop on its FOPDT settles in about 5 to 7 times the
rule's ``tau_set`` (a slow integral tail; a warning says so).  A settling time
asked for is checked the same way and refused when ``Ms > 2`` or unstable,
with the fastest settling time that keeps ``Ms <= 2`` (``force`` keeps it).
For n = 1 on a process whose FOPDT has a large dead time the estimate
``b0 = k/T`` is far too small (Nowak et al. 2018: the final b0 was 3 times
larger): a warning says so.

Searched b0 (``b0_search=True``, used by ``ctrlblocks compare``): the inverse
half-rule's b0 comes from the FOPDT's gain and time constant and is only a
starting point (Nowak et al. 2018, section 5.1 and Table 2: the b0 finally
used on the three-tank rig was larger).  ``b0`` is then searched jointly with
the bandwidths: for each candidate ``b0`` (factors of 1.5 around the rule's,
0.2 to 25 times it) the safe default above gives the fastest ``omega_c`` with
``Ms <= ms`` on the model (``omega_o`` by the observer ratio); the candidate
whose loop has the largest integral gain ``ki`` (:meth:`.margins.Loop.integral_gain`)
is kept, then refined by two bisections of ``log b0`` between its
neighbours (the candidates' ``omega_c`` to ``Ms`` within 1 % of the target,
the kept one within 0.5 %).  That is the MIGO principle of Åström &
Hägglund 2006 (chapter 7: maximise ``ki`` under an Ms constraint; the
integrated error of a unit step load is ``-1/ki``, the final-value theorem)
applied to the ADRC's two free parameters.  On the SOPDT of the three-tank bump test
(docs/examples) at ts = 0.1 s the order-2 ADRC found has ``b0 = 0.125``
(5 times the rule's), ``omega_c = 0.62 rad/s`` and ``1/ki = 0.83 s`` against
``1/ki = 18.5 s`` with the rule's b0.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..blocks.base import ErrorCode, ParameterError, require_finite, require_positive
from .halfrule import inverse_half_rule
from .margins import MS_FRAGILE, Loop, Margins

__all__ = [
    "MAX_OMEGA_O_TS",
    "MS_DEFAULT",
    "SETTLING_FACTOR",
    "ADRCTuning",
    "adrc_bandwidth",
    "adrc_config",
    "adrc_tuning",
    "log_walk",
    "mv_noise",
]

SETTLING_TIME_2PCT = {1: 3.912023005428146, 2: 5.83392170191749, 3: 7.516603875609483}
"""2 % settling time of ``1/(s/omega_c + 1)^n`` times ``omega_c`` (see the module docstring)."""

SETTLING_FACTOR = {n: min(5.0, max(3.0, x)) for n, x in SETTLING_TIME_2PCT.items()}
"""``omega_c tau_set`` per order: the exact 2 % value clipped to the paper's 3..5."""

MAX_OMEGA_O_TS = 0.2
"""Largest ``omega_o ts`` accepted for the Euler observer (4a)."""

MS_DEFAULT = 1.6
"""Default maximum sensitivity of the searched tuning (``--ms``; accepted 1.1..2)."""

_SUGGEST_OMEGA_O_TS = 0.1  # omega_o ts of a suggested sample time

OMEGA_O_STABILITY = {1: 2.0 * (math.sqrt(2.0) - 1.0), 2: 0.5198, 3: 0.3784}
"""``omega_o ts`` at which the Euler observer (4a) becomes unstable."""


@dataclass(frozen=True)
class ADRCTuning:
    """Result of :func:`adrc_bandwidth` / :func:`adrc_tuning`.

    Attributes
    ----------
    order : int
    omega_c, omega_o : float
        Controller and observer bandwidths [rad/s].
    ts : float
        Sample time [s] (given or suggested).
    settling_time : float
        The requested ``tau_set`` [s].
    settling_time_model : float
        2 % settling time of the ideal closed loop with these bandwidths [s].
    b0, b0_min, b0_max : float
        Scaling parameter and its range (NaN from :func:`adrc_bandwidth`).
    warnings : list of str
    margins : Margins or None
        Robustness of the tuning on its model (:mod:`.margins`; None from
        :func:`adrc_bandwidth`).
    ms_target : float
        The Ms the bandwidths were searched for (NaN when a settling time was given).
    settling_time_loop : float
        2 % settling time [s] of a set-point step of the sampled loop on the
        model, dead time included (NaN: not settled).
    fastest_settling_time : float
        Shortest ``settling_time`` [s] (the ``tau_set`` of the rule) whose loop
        has ``Ms <= 2`` on the model (NaN if not searched).
    integral_gain : float
        ``ki`` of the loop's controller [MV/(PV s)] (:meth:`.margins.Loop.integral_gain`;
        NaN from :func:`adrc_bandwidth`).
    b0_rule : float
        The inverse half-rule's b0 (equal to ``b0`` unless ``b0_search``).
    reverse : bool
        The process gain is negative: the block takes ``reverse = True``
        (:class:`~ctrlblocks.blocks.adrc.ADRCConfig`) and everything else is
        the tuning of the process with the opposite gain (``b0 > 0``, the same
        margins); ``integral_gain`` keeps the controller's sign (negative).
    """

    order: int
    omega_c: float
    omega_o: float
    ts: float
    settling_time: float
    settling_time_model: float
    b0: float = math.nan
    b0_min: float = math.nan
    b0_max: float = math.nan
    warnings: list[str] = field(default_factory=list)
    margins: Margins | None = None
    ms_target: float = math.nan
    settling_time_loop: float = math.nan
    fastest_settling_time: float = math.nan
    integral_gain: float = math.nan
    b0_rule: float = math.nan
    reverse: bool = False

    def settings(self) -> dict[str, Any]:
        """The tuned keywords of ``ctrlblocks.ADRC``: ``order, b0, omega_c, omega_o``, and
        ``reverse = True`` for a process with a negative gain (the sample time apart)."""
        out: dict[str, Any] = {
            "order": self.order,
            "b0": self.b0,
            "omega_c": self.omega_c,
            "omega_o": self.omega_o,
        }
        if self.reverse:
            out["reverse"] = True
        return out

    def config(self, **extra: Any) -> dict[str, Any]:
        """Keyword arguments for ``ctrlblocks.ADRC(**tuning.config(u_min=..., u_max=...))``:
        :meth:`settings`, ``ts`` and ``extra``."""
        return {**self.settings(), "ts": self.ts, **extra}


def adrc_bandwidth(
    settling_time: float,
    order: int,
    ts: float | None = None,
    *,
    factor: float | None = None,
    observer_ratio: float = 5.0,
) -> ADRCTuning:
    """Controller and observer bandwidths from a desired settling time.

    ``omega_c = factor/settling_time`` (``factor = SETTLING_FACTOR[order]``
    unless given: 3.91, 5, 5), ``omega_o = observer_ratio omega_c``, then the
    sample-time check of the module docstring.

    Parameters
    ----------
    settling_time : float
        Desired closed-loop settling time ``tau_set`` [s].
    order : int
        ADRC order n (1..3).
    ts : float, optional
        Controller sample time [s]; suggested if not given.
    factor : float, optional
        ``omega_c tau_set``; Nowak et al. 2018 gives 3..5 (outside: a warning).
    observer_ratio : float
        ``omega_o/omega_c``; Nowak et al. 2018 gives 3..10 (outside: a warning).

    Returns
    -------
    ADRCTuning
        With ``b0`` NaN (see :func:`adrc_tuning`).
    """
    tau = require_positive("settling_time", settling_time, ErrorCode.BAD_TIME_CONSTANT)
    order = _order(order)
    warnings: list[str] = []
    f = SETTLING_FACTOR[order] if factor is None else require_positive("factor", factor)
    if not 3.0 <= f <= 5.0:
        warnings.append(f"factor {f:g} is outside Nowak et al.'s (2018) omega_c = (3..5)/tau_set")
    ratio = _observer_ratio(observer_ratio)
    if not 3.0 <= ratio <= 10.0:
        warnings.append(
            f"observer_ratio {ratio:g} is outside omega_o = (3..10) omega_c (Nowak et al. 2018)"
        )
    omega_c = f / tau
    omega_o = ratio * omega_c
    if ts is None:
        ts = _nice_floor(0.1 / omega_o)
    else:
        ts = require_positive("ts", ts, ErrorCode.NO_CYCLE)
        if omega_o * ts > MAX_OMEGA_O_TS:
            new = MAX_OMEGA_O_TS / ts
            warnings.append(
                f"omega_o = {omega_o:.4g} rad/s is too fast for ts = {ts:g} s (omega_o ts = "
                f"{omega_o * ts:.3g} > {MAX_OMEGA_O_TS}); lowered to {new:.4g} rad/s"
            )
            omega_o = new
            if omega_o < 3.0 * omega_c:
                warnings.append(
                    f"omega_o is now only {omega_o / omega_c:.2g} x omega_c "
                    "(Nowak et al. 2018: >= 3): "
                    "use a shorter sample time or a longer settling time"
                )
    return ADRCTuning(
        order,
        omega_c,
        omega_o,
        float(ts),
        tau,
        SETTLING_TIME_2PCT[order] / omega_c,
        warnings=warnings,
    )


def adrc_tuning(
    gain: float,
    time_constant: float,
    dead_time: float,
    order: int,
    *,
    settling_time: float | None = None,
    ts: float | None = None,
    factor: float | None = None,
    observer_ratio: float = 5.0,
    noise_std: float | None = None,
    u_noise_max: float | None = None,
    ms: float = MS_DEFAULT,
    force: bool = False,
    model: Any = None,
    discretisation: str = "euler",
    b0_search: bool = False,
) -> ADRCTuning:
    """Full ADRC tuning from an FOPDT model: ``b0``, bandwidths and their margins.

    ``b0`` by :func:`~ctrlblocks.tuning.halfrule.inverse_half_rule` (Nowak et
    al. 2018, (5)-(9); ``b0 = b0_min`` for n = 3 as the paper advises).  Then:

    * **no settling time** (the safe default): ``omega_c`` is the fastest for
      which the sampled loop on the model, dead time exact, is stable with
      ``Ms <= ms`` (:mod:`.margins`), ``omega_o = observer_ratio omega_c``
      (lowered to ``MAX_OMEGA_O_TS/ts`` when the sample time asks, with a
      warning).  Without ``ts`` the sample time is suggested from the result
      (``omega_o ts <= 0.1``) and the search repeated at that ``ts``.  The
      search is coarse (factor 1.5 from ``0.1/(T + T0)``) then a bisection
      to ``0.995 ms <= Ms <= ms``.  When even the slowest candidate exceeds
      ``ms`` (dead time too long for this order) a ParameterError says so and
      points to the Smith predictor and to a lower order.
    * **a settling time**: the bandwidth rule of :func:`adrc_bandwidth`; a
      result that is unstable or has ``Ms > 2`` on the model is refused
      (ParameterError ``BAD_BANDWIDTH``, with the fastest settling time that
      keeps ``Ms <= 2``) unless ``force``, which keeps it with a warning.

    Then the optional MV-noise check (module docstring) and the final margins
    and settling time on the model.

    Parameters
    ----------
    gain, time_constant, dead_time : float
        FOPDT model k [PV/MV], T [s], T0 [s].
    order : int
        ADRC order n (1..3).
    settling_time, ts, factor, observer_ratio
        See :func:`adrc_bandwidth`.
    noise_std, u_noise_max : float, optional
        PV noise standard deviation and acceptable MV noise standard
        deviation (give both); ``omega_o`` is lowered to meet it.
    ms : float
        Target maximum sensitivity of the search, 1.1..2 (default 1.6).
    force : bool
        Keep a requested settling time even when its loop is fragile or unstable.
    model : optional
        The model the margins are computed on (an ``FOPDT``, ``SOPDT``,
        ``Integrating`` or a ``LinearPlant``); default the FOPDT given.
    discretisation : {"euler", "exact"}
        The ADRC block's discretisation the margins are computed for.
    b0_search : bool
        Search ``b0`` jointly with the bandwidths (module docstring: the
        largest integral gain with ``Ms <= ms`` on the model) instead of
        taking the inverse half-rule's; only for the safe default (no
        ``settling_time``).
    """
    from .identify import FOPDT

    # a reverse-acting process (k < 0): the block with reverse = True works on -y, so the loop
    # is that of the mirrored process (gain -k) with the ordinary block; tuned on that one
    reverse = require_finite("gain", gain, ErrorCode.BAD_B0) < 0.0
    if reverse:
        gain = -gain
        if model is not None:
            model = _mirrored(model)
    ihr = inverse_half_rule(gain, time_constant, dead_time, order)
    T, T0 = float(time_constant), float(dead_time)
    ratio = _observer_ratio(observer_ratio)
    target = require_positive("ms", ms, ErrorCode.BAD_PARAMETER)
    if not 1.1 <= target <= MS_FRAGILE:
        raise ParameterError(ErrorCode.BAD_PARAMETER, "ms", f"must lie in 1.1..2, got {ms!r}")
    if ts is not None:
        ts = require_positive("ts", ts, ErrorCode.NO_CYCLE)
    mdl = FOPDT(float(gain), T, T0) if model is None else model
    if b0_search and settling_time is not None:
        raise ParameterError(
            ErrorCode.BAD_PARAMETER, "b0_search", "searches the safe default: no settling_time"
        )
    search = _Search(mdl, order, ihr.b0, ratio, T + T0, discretisation)
    warnings = list(ihr.warnings)
    fastest = math.nan
    if b0_search:
        search, bw, w = _search_b0(search, target, ts, factor)
        warnings += w
    elif settling_time is None:
        bw, w = search.safe(target, ts, factor)
        warnings += w
    else:
        bw = adrc_bandwidth(settling_time, order, ts, factor=factor, observer_ratio=ratio)
        warnings += bw.warnings
        mg = search.loop(bw.omega_c, bw.omega_o, bw.ts).margins()
        if not mg.stable or mg.ms > MS_FRAGILE:
            wc2 = search.fastest(MS_FRAGILE, bw.ts)
            fastest = SETTLING_FACTOR[order] / wc2 if factor is None else factor / wc2
            how = "unstable" if not mg.stable else f"fragile (Ms = {mg.ms:.3g} > {MS_FRAGILE:g})"
            msg = (
                f"settling time {bw.settling_time:g} s gives an {how} loop on the model "
                f"(dead time {T0:g} s); the fastest settling time with Ms <= {MS_FRAGILE:g} "
                f"at ts = {bw.ts:g} s is {fastest:.4g} s"
            )
            if not force:
                raise ParameterError(
                    ErrorCode.BAD_BANDWIDTH,
                    "settling_time",
                    msg + "; leave the settling time out for the safe default, or force it",
                )
            warnings.append(msg + " (forced)")
    if order == 1 and T0 > 0.25 * T and not b0_search:
        warnings.append(
            f"order 1 with T0/T = {T0 / T:.2f}: the process is of higher order and b0 = k/T is "
            "too small (Nowak et al. 2018, Table 2: 3 times); expect oscillation, prefer order 2"
        )
    omega_o = bw.omega_o
    if noise_std is not None or u_noise_max is not None:
        if noise_std is None or u_noise_max is None:
            raise ParameterError(
                ErrorCode.BAD_PARAMETER, "noise_std/u_noise_max", "give both or neither"
            )
        omega_o, w = _limit_mv_noise(
            order, search.b0, bw.omega_c, omega_o, bw.ts,
            require_positive("noise_std", noise_std), require_positive("u_noise_max", u_noise_max),
        )  # fmt: skip
        warnings += w
    lp = search.loop(bw.omega_c, omega_o, bw.ts)
    mg = lp.margins()
    if settling_time is None and mg.ms > target * (1.0 + 1e-6):
        warnings.append(
            f"Ms = {mg.ms:.3g} exceeds the target {target:g} after the MV-noise adjustment"
        )
    settle = lp.settling_time() if mg.stable else math.nan
    open_loop = T0 + 4.0 * T  # 98 % settling time of the FOPDT itself
    if settle > open_loop:
        lower = f" or a lower order than {order}" if order > 1 else ""
        warnings.append(
            f"no ADRC of order {order} reaches Ms <= {target:g} at a useful speed on this model: "
            f"the loop settles in {settle:.4g} s, slower than the process itself (T0 + 4 T = "
            f"{open_loop:.4g} s); use the Smith predictor structure (a scenario's structure = "
            f'"smith"){lower}, or compare a PID (ctrlblocks tune pid)'
        )
    elif settle > 3.0 * bw.settling_time:
        warnings.append(
            f"the loop on the model settles in {settle:.4g} s, {settle / bw.settling_time:.2g} "
            "times the rule's settling time: at this bandwidth the ADRC's integral action is "
            "weak (a slow tail); on a dead-time process compare a PID (ctrlblocks tune pid) or "
            "the Smith predictor structure"
        )
    return ADRCTuning(
        bw.order, bw.omega_c, omega_o, bw.ts, bw.settling_time, bw.settling_time_model,
        search.b0, ihr.b0_min, ihr.b0_max, warnings, mg,
        target if settling_time is None else math.nan, settle, fastest,
        -lp.integral_gain() if reverse else lp.integral_gain(), ihr.b0, reverse,
    )  # fmt: skip


def _mirrored(model: Any) -> Any:
    """The process model with the opposite gain (the one a reverse-acting ADRC sees)."""
    from ..plants.linear import LinearPlant

    if isinstance(model, LinearPlant):
        return LinearPlant(A=model.a_c, B=model.b_c, C=-model.c_c, ts=model.ts,
                           dead_time=model.dead_time)  # fmt: skip
    return dataclasses.replace(model, gain=-model.gain)


_B0_FACTORS = (0.2, 25.0)  # the searched b0 range, times the inverse half-rule's
_B0_STEP = 1.5


def _search_b0(
    rule: _Search, target: float, ts: float | None, factor: float | None
) -> tuple[_Search, ADRCTuning, list[str]]:
    """The b0 (and safe-default bandwidths) with the largest ``ki`` (module docstring)."""
    found: dict[float, tuple[float, _Search, ADRCTuning, list[str]]] = {}

    def score(b0: float) -> float:
        if b0 not in found:
            s = _Search(rule.model, rule.order, b0, rule.ratio, rule.t_sum, rule.disc)
            s.tol = 0.99  # candidates: Ms within 1 % of the target; the kept one to 0.5 %
            try:
                bw, w = s.safe(target, ts, factor)
            except ParameterError:
                found[b0] = (-math.inf, s, None, [])  # type: ignore[arg-type]
            else:
                ki = s.loop(bw.omega_c, bw.omega_o, bw.ts).integral_gain()
                found[b0] = (ki, s, bw, w)
        return found[b0][0]

    best_b0 = log_walk(score, rule.b0, _B0_FACTORS, step=_B0_STEP)
    if not math.isfinite(score(best_b0)):
        rule.safe(target, ts, factor)  # raises the rule's own "no ADRC of order n" error
    s = found[max(found, key=lambda b: found[b][0])][1]
    s.tol = rule.tol
    bw, w = s.safe(target, ts, factor)
    ki = s.loop(bw.omega_c, bw.omega_o, bw.ts).integral_gain()
    w = [
        *w,
        f"b0 = {s.b0:.4g} ({s.b0 / rule.b0:.3g} times the inverse half-rule's {rule.b0:.4g}) "
        f"gives the largest integral gain ki = {ki:.4g} (IE = 1/ki = {1 / ki:.4g} per unit "
        f"load) with Ms <= {target:g} on the model",
    ]
    return s, bw, w


class _Search:
    """The ADRC of one order and b0 on one model: the bandwidth searches of :func:`adrc_tuning`."""

    def __init__(self, model: Any, order: int, b0: float, ratio: float, t_sum: float,
                 discretisation: str) -> None:  # fmt: skip
        self.model, self.order, self.b0 = model, _order(order), b0
        self.ratio, self.t_sum, self.disc = ratio, t_sum, discretisation
        self.tol = 0.995  # the bisection stops at tol * target <= Ms <= target

    def omega_o(self, wc: float, ts: float) -> float:
        return min(self.ratio * wc, MAX_OMEGA_O_TS / ts)

    def loop(self, wc: float, wo: float, ts: float) -> Loop:
        from ..blocks.adrc import ADRC

        block = ADRC(order=self.order, b0=self.b0, omega_c=wc, omega_o=wo, ts=ts,
                     discretisation=self.disc)  # fmt: skip
        return Loop(self.model, block)

    def ms(self, wc: float, ts: float) -> float:
        return self.loop(wc, self.omega_o(wc, ts), ts).peak_sensitivity()

    def fastest(self, target: float, ts: float) -> float:
        """Largest omega_c [rad/s] with a stable loop and ``Ms <= target`` at ``ts``."""
        lo = 0.1 / self.t_sum
        ms_lo = self.ms(lo, ts)
        if ms_lo > target:
            raise ParameterError(
                ErrorCode.BAD_BANDWIDTH,
                "order",
                f"no ADRC of order {self.order} reaches Ms <= {target:g} on this model, even "
                f"with omega_c = {lo:.3g} rad/s (the dead time is too long for the "
                "bandwidth rule): use the Smith predictor structure (a scenario's "
                'structure = "smith") or a lower order',
            )
        wc_max = MAX_OMEGA_O_TS / ts / 1.5  # omega_o >= 1.5 omega_c at the sample-time bound
        hi = lo
        while True:
            hi = min(hi * 1.5, wc_max)
            m = self.ms(hi, ts)
            if m > target:
                break
            lo, ms_lo = hi, m
            if hi >= wc_max:
                return wc_max
        while hi / lo > 1.0005 and ms_lo < self.tol * target:
            mid = math.sqrt(lo * hi)
            m = self.ms(mid, ts)
            if m <= target:
                lo, ms_lo = mid, m
            else:
                hi = mid
        return lo

    def safe(
        self, target: float, ts: float | None, factor: float | None
    ) -> tuple[ADRCTuning, list[str]]:
        """The fastest tuning with ``Ms <= target``; a suggested ``ts`` when none is given."""
        n = self.order
        f = SETTLING_FACTOR[n] if factor is None else require_positive("factor", factor)
        warnings: list[str] = []
        if ts is None:
            # suggest ts from the result (omega_o ts <= 0.1) and search again at it, until
            # the suggestion repeats; a cycle between two round values takes the shorter ts
            found: dict[float, float] = {}
            ts_try = _nice_floor(_SUGGEST_OMEGA_O_TS / (self.ratio * f / (1.5 * self.t_sum)))
            while ts_try not in found and len(found) < 4:
                found[ts_try] = self.fastest(target, ts_try)
                ts_try = _nice_floor(_SUGGEST_OMEGA_O_TS / (self.ratio * found[ts_try]))
            fixed = (
                ts_try in found
                and _nice_floor(_SUGGEST_OMEGA_O_TS / (self.ratio * found[ts_try])) == ts_try
            )
            ts = ts_try if fixed else min(found)
            wc = found[ts]
        else:
            wc = self.fastest(target, ts)
            if wc >= MAX_OMEGA_O_TS / ts / 1.5 * (1 - 1e-12):
                warnings.append(
                    f"omega_c is limited by the sample time ts = {ts:g} s (omega_o ts <= "
                    f"{MAX_OMEGA_O_TS}), not by Ms <= {target:g}: a shorter ts allows a faster loop"
                )
        wo = self.omega_o(wc, ts)
        if wo < self.ratio * wc * (1 - 1e-12):
            warnings.append(
                f"observer ratio lowered from {self.ratio:g} to {wo / wc:.3g} (omega_o ts <= "
                f"{MAX_OMEGA_O_TS} at ts = {ts:g} s)"
            )
        warnings.append(
            f"omega_c = {wc:.4g} rad/s is the fastest with Ms <= {target:g} on the model "
            f"(dead time included); omega_o = {wo / wc:.3g} omega_c"
        )
        tun = ADRCTuning(n, wc, wo, float(ts), f / wc, SETTLING_TIME_2PCT[n] / wc)
        return tun, warnings


def mv_noise(
    order: int, b0: float, omega_c: float, omega_o: float, ts: float, noise_std: float
) -> float:
    """Standard deviation of the ADRC output for white PV noise of ``noise_std``.

    Runs :class:`ctrlblocks.blocks.adrc.ADRC` (no limits, set point 0) on 2000
    samples of seeded Gaussian noise and discards the first 500.
    """
    from ..blocks.adrc import ADRC

    block = ADRC(order=order, b0=b0, omega_c=omega_c, omega_o=omega_o, ts=ts)
    rng = np.random.default_rng(0)
    u = np.array([block(0.0, float(e)) for e in rng.normal(0.0, noise_std, 2000)])
    return float(np.std(u[500:]))


def _limit_mv_noise(order, b0, omega_c, omega_o, ts, noise_std, u_noise_max):
    warnings: list[str] = []
    sd = mv_noise(order, b0, omega_c, omega_o, ts, noise_std)
    start = omega_o
    while sd > u_noise_max and omega_o > 3.0 * omega_c * (1 + 1e-9):
        omega_o = max(0.9 * omega_o, 3.0 * omega_c)
        sd = mv_noise(order, b0, omega_c, omega_o, ts, noise_std)
    if omega_o < start:
        warnings.append(
            f"omega_o lowered from {start:.4g} to {omega_o:.4g} rad/s for an MV noise of "
            f"{sd:.3g} (limit {u_noise_max:g})"
        )
    if sd > u_noise_max:
        warnings.append(
            f"MV noise {sd:.3g} exceeds {u_noise_max:g} even with omega_o = 3 omega_c: "
            "filter the PV, lower the order or lengthen the settling time"
        )
    return omega_o, warnings


def adrc_config(
    gain: float,
    time_constant: float,
    dead_time: float,
    order: int,
    *,
    settling_time: float | None = None,
    ts: float | None = None,
    u_min: float = -math.inf,
    u_max: float = math.inf,
    t_ref: float = 0.0,
    factor: float | None = None,
    observer_ratio: float = 5.0,
    noise_std: float | None = None,
    u_noise_max: float | None = None,
) -> dict[str, Any]:
    """Keyword arguments for ``ctrlblocks.ADRC(**config)`` from an FOPDT model.

    Returns ``{"order", "b0", "omega_c", "omega_o", "ts", "u_min", "u_max",
    "t_ref"}`` from :func:`adrc_tuning` (and ``"reverse": True`` for a
    negative gain); ``u_min``/``u_max`` are the MV limits
    and ``t_ref`` [s] the time constant of the set-point reference trajectory
    (Nowak et al. 2018, Fig. 2: ``T_ref``), passed through.
    """
    tun = adrc_tuning(
        gain,
        time_constant,
        dead_time,
        order,
        settling_time=settling_time,
        ts=ts,
        factor=factor,
        observer_ratio=observer_ratio,
        noise_std=noise_std,
        u_noise_max=u_noise_max,
    )
    return tun.config(u_min=float(u_min), u_max=float(u_max), t_ref=require_finite("t_ref", t_ref))


def _order(order: int) -> int:
    if isinstance(order, bool) or order not in (1, 2, 3):
        raise ParameterError(ErrorCode.BAD_ORDER, "order", f"must be 1, 2 or 3, got {order!r}")
    return int(order)


def _observer_ratio(value: float) -> float:
    """``omega_o / omega_c``: >= 1, the observer at least as fast as the loop it serves.

    Nowak et al. (2018) use 3..10 (a ratio outside gives a warning); below 1
    the ESO would estimate the total disturbance more slowly than the loop
    acts on it, and an absurdly small ratio (1e-320) made the suggested
    sample time infinite.
    """
    ratio = require_positive("observer_ratio", value, ErrorCode.BAD_BANDWIDTH)
    if ratio < 1.0:
        raise ParameterError(
            ErrorCode.BAD_BANDWIDTH,
            "observer_ratio",
            f"must be >= 1 (omega_o at least omega_c; Nowak et al. 2018 use 3..10), got {value!r}",
        )
    return ratio


def _nice_floor(x: float) -> float:
    """Largest 1, 2 or 5 times a power of ten that is <= x."""
    e = math.floor(math.log10(x))
    for m in (5.0, 2.0, 1.0):
        if m * 10.0**e <= x * (1 + 1e-12):
            return float(f"{m * 10.0**e:.12g}")
    return float(f"{10.0 ** (e - 1) * 5.0:.12g}")  # pragma: no cover - unreachable


def log_walk(score, start: float, factors: tuple[float, float], *, step: float = 1.5,
             scan: bool = False) -> float:  # fmt: skip
    """The ``x`` with the largest ``score(x)`` in ``start * factors``: a walk in factors of
    ``step`` from ``start`` up and down while the score grows (one maximum), then two
    bisections of ``log x`` around the best point.  ``scan``: when the walk finds no
    finite score, every grid point is tried (else ``start`` is returned, its score
    not finite).  ``score`` should cache: points are asked again."""
    lo_j = math.floor(math.log(factors[0]) / math.log(step))
    hi_j = math.ceil(math.log(factors[1]) / math.log(step))
    grid = [start * step**j for j in range(lo_j, hi_j + 1)]
    j0 = grid.index(start)
    best = j0
    for direction in (1, -1):
        j = j0 + direction
        while 0 <= j < len(grid) and score(grid[j]) > score(grid[j - direction]):
            j += direction
        if 0 <= j - direction < len(grid) and score(grid[j - direction]) > score(grid[best]):
            best = j - direction
    if not math.isfinite(score(grid[best])):
        if not scan:
            return start
        best = max(range(len(grid)), key=lambda i: score(grid[i]))
        if not math.isfinite(score(grid[best])):
            return start
    lo, mid, hi = grid[max(best - 1, 0)], grid[best], grid[min(best + 1, len(grid) - 1)]
    for _ in range(2):
        pts = [lo, math.sqrt(lo * mid), mid, math.sqrt(mid * hi), hi]
        i = max(range(5), key=lambda q: score(pts[q]))
        lo, mid, hi = pts[max(i - 1, 0)], pts[i], pts[min(i + 1, 4)]
    return mid
