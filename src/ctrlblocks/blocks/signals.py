"""Small signal blocks: the pieces the PID and ADRC blocks are built from.

Sources
-------
* controltheplant 2024 (CODESYS ``PID_Controller``, section 1.3 "sub blocks"):
  ``DeadBand`` (dead zone; a negative width acts as its absolute value),
  ``RateLimiter`` (linear ramp), ``SCALE_R`` (range to range),
  ``MovingAverage`` (mean of the last N values), ``FindSteadyState``
  (variation below a tolerance for a stabilisation time) and ``LSim_PT1``
  (first-order lag).
* Åström 1987 (Åström, section 5 and Appendix A): ``Saturation``, ``Min selector``,
  ``Max selector``; the jump-and-rate module is in :mod:`.jumprate`.

Equations
---------
PT1, ``G(s) = K / (T s + 1)``, sample time h:

* ``method="exact"`` (default): ``y[k] = a y[k-1] + (1 - a) K u[k]`` with
  ``a = exp(-h/T)``.  The pole is the exact (ZOH) image of ``-1/T``; the input
  is the current sample, so a filter in a controller passes today's value
  (``H(z) = (1-a) K z / (z - a)``, the ZOH discretisation advanced one sample).
* ``method="euler"``: backward difference ``s = (1 - z^-1)/h`` (Bonde et al. 2021,
  "Bakoverdifferanse (Eulers metode)"): ``y[k] = (T y[k-1] + h K u[k]) / (T + h)``.
* ``T = 0`` switches the filter off (``y = K u``), as controltheplant 2024 says for its
  filter times.

Dead band (controltheplant 2024, Fig. 3): ``y = 0`` for ``|u| <= w``, else ``u - sign(u) w``;
continuous and odd.

Scale (SCALE_R): ``y = (u - in_lo) / (in_hi - in_lo) (out_hi - out_lo) + out_lo``.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from typing import Any, ClassVar

from .base import (
    Block,
    BlockConfig,
    ErrorCode,
    ParameterError,
    as_input,
    is_finite,
    require_bool,
    require_choice,
    require_finite,
    require_limits,
    require_nonnegative,
    require_positive,
)

__all__ = [
    "PT1",
    "DeadBand",
    "MaxSelector",
    "MinSelector",
    "MovingAverage",
    "RateLimiter",
    "Saturation",
    "Scale",
    "SteadyStateDetector",
    "clamp",
    "deadband",
    "pt1_coefficient",
    "pt1_step",
    "rate_limit_step",
    "scale",
]


# ---------------------------------------------------------------------------
# Plain functions (stateless; used inside the larger blocks)
# ---------------------------------------------------------------------------


def clamp(x: float, lo: float, hi: float) -> float:
    """``x`` limited to ``[lo, hi]``, ``lo <= hi`` (``sat`` of Åström 1987, section 5).

    The one limiter of the blocks' per-cycle code (PID, ADRC, lead-lag, manual
    station, :class:`Scale`); a NaN ``x`` passes through unchanged.
    """
    return lo if x < lo else hi if x > hi else x


def deadband(u: float, width: float) -> float:
    """Dead zone of controltheplant 2024 (``DeadBand`` FC, Fig. 3).

    ``0`` for ``|u| <= |width|``, else ``u - sign(u) |width|``.  A negative
    width acts as its absolute value (controltheplant 2024, section 2.3.10).
    """
    w = abs(width)
    if u > w:
        return u - w
    if u < -w:
        return u + w
    return 0.0


def scale(u: float, in_lo: float, in_hi: float, out_lo: float, out_hi: float) -> float:
    """Linear map of ``u`` from ``[in_lo, in_hi]`` to ``[out_lo, out_hi]``.

    ``SCALE_R`` of controltheplant 2024.

    No clamping: values outside the input range are extrapolated.
    """
    return (u - in_lo) / (in_hi - in_lo) * (out_hi - out_lo) + out_lo


def pt1_coefficient(t: float, h: float, method: str) -> float:
    """Pole ``a`` of the discrete PT1 ``y[k] = a y[k-1] + (1-a) K u[k]``.

    ``exp(-h/t)`` for ``"exact"``, ``t/(t+h)`` for ``"euler"`` (backward
    difference); ``0`` when ``t == 0`` (filter off).
    """
    if t <= 0.0:
        return 0.0
    if method == "exact":
        return math.exp(-h / t)
    return t / (t + h)


def pt1_step(a: float, y: float, k: float, u: float) -> float:
    """One sample of the PT1, ``y[k] = a y[k-1] + (1 - a) K u[k]`` (pole ``a`` from
    :func:`pt1_coefficient`); ``a = 0`` passes ``K u`` through."""
    return a * y + (1.0 - a) * k * u


def rate_limit_step(u: float, y: float, up: float, down: float, h: float) -> tuple[float, bool]:
    """One sample of the linear ramp: ``(y[k], limiting)``.

    ``y[k] = y[k-1] + clamp(u - y[k-1], -down h, up h)`` (controltheplant 2024,
    ``RateLimiter``); a rate of 0 is no limit in that direction.  ``limiting``
    is true when the ramp, not the input, set the output.
    """
    step = u - y
    if up > 0.0 and step > up * h:
        return y + up * h, True
    if down > 0.0 and step < -(down * h):
        return y - down * h, True
    return u, False


# ---------------------------------------------------------------------------
# PT1
# ---------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class PT1Config(BlockConfig):
    """Configuration of :class:`PT1`.

    Attributes
    ----------
    t : float
        Time constant [s]; 0 switches the filter off.
    ts : float
        Sample time [s].
    gain : float
        Static gain K [output units / input units].
    method : str
        ``"exact"`` (pole ``exp(-ts/t)``) or ``"euler"`` (backward difference).
    y0 : float
        Output after ``reset()``.
    """

    t: float = 0.0
    ts: float = 0.1
    gain: float = 1.0
    method: str = "exact"
    y0: float = 0.0

    def validate(self) -> None:
        require_nonnegative("t", self.t, ErrorCode.BAD_TIME_CONSTANT)
        require_positive("ts", self.ts, ErrorCode.NO_CYCLE)
        require_finite("gain", self.gain)
        require_choice("method", self.method, ("exact", "euler"))
        require_finite("y0", self.y0)


class PT1(Block):
    """First-order lag ``K/(T s + 1)`` (controltheplant 2024, ``LSim_PT1``); see the module.

    ``y = pt1(u)`` runs one sample.  A NaN/inf input holds the output and sets
    ``BAD_INPUT``; a bad ``dt`` holds the output and sets ``NO_CYCLE``.

    Examples
    --------
    >>> f = PT1(t=2.0, ts=0.1)
    >>> round(f(1.0), 6)
    0.048771
    """

    Config = PT1Config
    _state_fields = ("out",)
    config: PT1Config
    _config: PT1Config

    def _apply_config(self, old: BlockConfig | None) -> None:
        c = self._config
        self._t, self._k, self._method = float(c.t), float(c.gain), c.method
        self._ts = float(c.ts)
        self._h = self._ts
        self._a = pt1_coefficient(self._t, self._h, self._method)

    def _reset_state(self) -> None:
        self.out = float(self._config.y0)

    def preset(self, value: float) -> None:
        """Set the output (and so the filter state) to ``value``, e.g. the first measurement."""
        if is_finite(value):
            self.out = float(value)

    def __call__(self, u: float, dt: float | None = None) -> float:
        h = self._cycle_time(dt, self._ts)
        if h is None:
            return self.out
        u = as_input(u)
        if not math.isfinite(u):
            self.error_id = ErrorCode.BAD_INPUT
            return self.out
        self.error_id = ErrorCode.NO_ERROR
        if h != self._h:
            self._h = h
            self._a = pt1_coefficient(self._t, h, self._method)
        self.out = pt1_step(self._a, self.out, self._k, u)
        return self.out


# ---------------------------------------------------------------------------
# Rate limiter
# ---------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class RateLimiterConfig(BlockConfig):
    """Configuration of :class:`RateLimiter`.

    Attributes
    ----------
    rate_up, rate_down : float
        Largest rise and fall per second [units/s], both >= 0.  0 means no
        limit in that direction (controltheplant 2024: "set to a non-zero value to
        activate").
    ts : float
        Sample time [s].
    y0 : float
        Output after ``reset()``.
    """

    rate_up: float = 0.0
    rate_down: float = 0.0
    ts: float = 0.1
    y0: float = 0.0

    def validate(self) -> None:
        require_nonnegative("rate_up", self.rate_up, ErrorCode.BAD_RATE)
        require_nonnegative("rate_down", self.rate_down, ErrorCode.BAD_RATE)
        require_positive("ts", self.ts, ErrorCode.NO_CYCLE)
        require_finite("y0", self.y0)


class RateLimiter(Block):
    """Linear-ramp rate limiter (controltheplant 2024, ``RateLimiter``).

    ``y[k] = y[k-1] + clamp(u[k] - y[k-1], -rate_down h, rate_up h)``.
    ``limiting`` is true in a cycle where the ramp, not the input, set the
    output.  NaN/inf input: hold, ``BAD_INPUT``.
    """

    Config = RateLimiterConfig
    _state_fields = ("out", "limiting")
    config: RateLimiterConfig
    _config: RateLimiterConfig

    def _apply_config(self, old: BlockConfig | None) -> None:
        self._ts = float(self._config.ts)

    def _reset_state(self) -> None:
        self.out = float(self._config.y0)
        self.limiting = False

    def preset(self, value: float) -> None:
        """Set the output to ``value`` (no ramp), e.g. to follow another signal."""
        if is_finite(value):
            self.out = float(value)
            self.limiting = False

    def __call__(self, u: float, dt: float | None = None) -> float:
        h = self._cycle_time(dt, self._ts)
        if h is None:
            return self.out
        u = as_input(u)
        if not math.isfinite(u):
            self.error_id = ErrorCode.BAD_INPUT
            return self.out
        self.error_id = ErrorCode.NO_ERROR
        c = self._config
        self.out, self.limiting = rate_limit_step(u, self.out, c.rate_up, c.rate_down, h)
        return self.out


# ---------------------------------------------------------------------------
# Dead band and scale (stateless blocks around the functions above)
# ---------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class DeadBandConfig(BlockConfig):
    """Configuration of :class:`DeadBand`.

    ``width``: half-width of the dead zone; a negative width acts as its
    absolute value.
    """

    width: float = 0.0

    def validate(self) -> None:
        require_finite("width", self.width)


class DeadBand(Block):
    """Dead zone of controltheplant 2024 as a block: ``y = deadband(u, width)``.

    NaN/inf input: hold, ``BAD_INPUT``.
    """

    Config = DeadBandConfig
    _state_fields = ("out",)
    config: DeadBandConfig
    _config: DeadBandConfig

    def _reset_state(self) -> None:
        self.out = 0.0

    def __call__(self, u: float) -> float:
        u = as_input(u)
        if not math.isfinite(u):
            self.error_id = ErrorCode.BAD_INPUT
            return self.out
        self.error_id = ErrorCode.NO_ERROR
        self.out = deadband(u, self._config.width)
        return self.out


@dataclasses.dataclass(frozen=True)
class ScaleConfig(BlockConfig):
    """Configuration of :class:`Scale` (controltheplant 2024, ``SCALE_R``).

    The input range may be inverted (``in_hi < in_lo``) but not empty.
    ``clamp`` limits the output to the output range.
    """

    in_lo: float = 0.0
    in_hi: float = 100.0
    out_lo: float = 0.0
    out_hi: float = 100.0
    clamp: bool = False

    def validate(self) -> None:
        for name in ("in_lo", "in_hi", "out_lo", "out_hi"):
            require_finite(name, getattr(self, name), ErrorCode.BAD_LIMITS)
        require_bool("clamp", self.clamp)
        if self.in_lo == self.in_hi:
            raise ParameterError(
                ErrorCode.BAD_LIMITS, "in_lo/in_hi", f"input range is empty ({self.in_lo!r})"
            )


class Scale(Block):
    """Range-to-range scaling (controltheplant 2024, ``SCALE_R``); see :func:`scale`.

    NaN/inf input: hold, ``BAD_INPUT``.
    """

    Config = ScaleConfig
    _state_fields = ("out",)
    config: ScaleConfig
    _config: ScaleConfig

    def _reset_state(self) -> None:
        self.out = float(self._config.out_lo)

    def output_limits(self) -> tuple[float, float]:
        """The output range when ``clamp`` is set, else no limits."""
        c = self._config
        if c.clamp:
            return min(c.out_lo, c.out_hi), max(c.out_lo, c.out_hi)
        return -math.inf, math.inf

    def __call__(self, u: float) -> float:
        u = as_input(u)
        if not math.isfinite(u):
            self.error_id = ErrorCode.BAD_INPUT
            return self.out
        self.error_id = ErrorCode.NO_ERROR
        c = self._config
        y = scale(u, c.in_lo, c.in_hi, c.out_lo, c.out_hi)
        if c.clamp:
            y = clamp(y, min(c.out_lo, c.out_hi), max(c.out_lo, c.out_hi))
        self.out = y
        return y


# ---------------------------------------------------------------------------
# Moving average
# ---------------------------------------------------------------------------


MAX_WINDOW = 1_000_000
"""Longest moving-average window [samples]: the buffer is held in memory."""

SUM_LOSS_FLOAT64 = 2.0**23
"""The moving average sums its window afresh when the rounding-error bound of its running
sum exceeds this many unit roundoffs of the window's magnitudes: 2^23 x 2^-53 = 2^-30 of
them in float64 (:class:`MovingAverage`)."""

SUM_LOSS_REAL = 2.0**10
"""The same for a REAL (float32) running sum, the PID's dead band in the PLC cycle and its
FB: 2^10 x 2^-24 = 2^-14 (6.1e-5) of the window's magnitudes."""


def moving_average_step(
    u: float,
    n: int,
    loss: float,
    mean: float,
    buf: list[float],
    idx: int,
    count: int,
    since: int,
    total: float,
    spread: float,
    mag: float,
    n_prev: int,
) -> tuple[float, list[float], int, int, int, float, float, float, int]:
    """One sample of the moving average: the one cycle of :class:`MovingAverage` and the PLC.

    Mean of the last ``n`` inputs, ``1 <= n <= len(buf)`` (controltheplant 2024,
    ``MovingAverage``); until ``n`` values have arrived, the mean of those
    received.  ``mean`` is the last mean (the FB's output; not read).  ``buf``
    is a ring of ``len(buf)`` values (the block's list of
    ``n``, the PLC's ARRAY sized at export), ``idx`` the next place to write,
    ``count`` the values in the window.  The running sum ``total`` gains the
    new value and loses the one leaving; ``spread`` is its rounding-error
    bound in unit roundoffs (each operation rounds by at most one unit
    roundoff of its result: the difference and the sum, Higham 2002,
    section 4.2) and ``mag`` the running sum of the magnitudes.  The window is
    summed afresh -- a FOR loop with Neumaier's compensation (Neumaier 1974)
    -- once ``n`` samples after the last fresh sum, so that rounding cannot
    drift, and at once when ``spread`` exceeds ``loss`` times ``mag`` or is not
    finite (after one huge sample left a window of small values, say, which a
    plain running sum forgets until the window wraps; ``loss`` is
    :data:`SUM_LOSS_FLOAT64` or :data:`SUM_LOSS_REAL` by the precision that
    runs it).  A window whose sum overflows gives the sum of its values each
    divided by ``count``, limited to the window's smallest and largest value.
    A new ``n`` keeps the newest ``min(count, n)`` values and sums afresh.
    Returns ``(mean, buf, idx, count, since, total, spread, mag, n_prev)``.
    """
    cap = len(buf)
    if n != n_prev:
        # a new window keeps the newest min(count, n) values; summed afresh below
        count = min(count, n)
        since = n
        n_prev = n
    leaving = 0.0
    if count >= n:
        leaving = buf[(idx + cap - n) % cap]
    step = u - leaving
    total = total + step
    buf[idx] = u
    idx = (idx + 1) % cap
    if count < n:
        count = count + 1
    since = since + 1
    spread = spread + (abs(step) + abs(total))
    mag = mag + (abs(u) - abs(leaving))
    if since >= n or not spread <= loss * mag or spread - spread != 0.0:
        # (an infinite bound -- the sum overflowed -- is above any threshold, also an
        # infinite one: loss * mag overflows with it)
        # the window afresh, oldest first, with Neumaier's compensation c
        total = 0.0
        c = 0.0
        mag = 0.0
        for j in range(count):
            v = buf[(idx + cap - count + j) % cap]
            t = total + v
            big = total
            small = v
            if abs(v) > abs(total):
                big = v
                small = total
            c = c + ((big - t) + small)  # what t lost of the smaller addend, exactly
            total = t
            mag = mag + abs(v)
        total = total + c
        spread = abs(total)
        since = 0
    mean = total / float(count)
    if total - total != 0.0:  # inf or NaN
        # the sum of finite values overflowed: the mean itself is finite, between the
        # window's smallest and largest value (the roundings of v / count may push the sum
        # of three values of 1.8e308 past the range)
        mean = 0.0
        lo = buf[(idx + cap - count) % cap]
        hi = lo
        for j in range(count):
            v = buf[(idx + cap - count + j) % cap]
            mean = mean + v / float(count)
            lo = min(lo, v)
            hi = max(hi, v)
        mean = clamp(mean, lo, hi)
    return mean, buf, idx, count, since, total, spread, mag, n_prev


@dataclasses.dataclass(frozen=True)
class MovingAverageConfig(BlockConfig):
    """Configuration of :class:`MovingAverage`: window length ``n`` (samples, >= 1)."""

    n: int = 10

    def validate(self) -> None:
        if isinstance(self.n, bool) or not isinstance(self.n, int) or not 1 <= self.n <= MAX_WINDOW:
            raise ParameterError(
                ErrorCode.BAD_WINDOW,
                "n",
                f"must be an integer in 1..{MAX_WINDOW}, got {self.n!r}",
            )


class MovingAverage(Block):
    """Mean of the last ``n`` inputs (controltheplant 2024, ``MovingAverage``).

    Until ``n`` values have arrived, the mean of those received.  One sample is
    :func:`moving_average_step`, the cycle the PID's dead band runs in the PLC
    cycle too: a running sum, summed afresh once per window so that rounding
    cannot drift, and at once when its rounding-error bound (``_spread``, in
    unit roundoffs) exceeds 2^-30 of the window's magnitudes (``_mag``;
    :data:`SUM_LOSS_FLOAT64`) -- after one 1e300 sample left a window of small
    values, say, which a plain running sum forgets until the window wraps.  On
    ordinary data the bound stays near ``n`` unit roundoffs and nothing
    changes.  NaN/inf input: not stored, output held, ``BAD_INPUT``.
    """

    Config = MovingAverageConfig
    _state_fields = ("out", "_buf", "_idx", "_count", "_since", "_sum", "_spread", "_mag")
    config: MovingAverageConfig
    _config: MovingAverageConfig
    _buf: list[float]
    _idx: int
    _count: int
    _since: int

    def _apply_config(self, old: BlockConfig | None) -> None:
        """A new window length keeps the newest ``min(count, n)`` values, oldest first."""
        if old is None or old.n == self._config.n:  # type: ignore[attr-defined]
            return
        n_old, n = len(self._buf), self._config.n
        newest = [self._buf[(self._idx - self._count + j) % n_old] for j in range(self._count)]
        keep = newest[-n:]
        self._buf = keep + [0.0] * (n - len(keep))
        self._count = len(keep)
        self._idx = self._count % n
        self._since = self._idx
        self._exact_sums()
        if self._count:
            self.out = self._mean()

    def _exact_sums(self) -> None:
        """The running sums afresh from the window (``math.fsum``): no rounding error carried."""
        self._sum = _window_sum(self._buf)
        self._mag = _window_sum([abs(v) for v in self._buf])
        self._spread = abs(self._sum)

    def restore(self, snapshot: dict[str, Any]) -> None:
        """Restore a :meth:`snapshot`, also one of an earlier version of the block.

        A snapshot with the error bound in absolute terms (``_err``) converts it
        to unit roundoffs; one without any bound sums afresh.  Both summed afresh
        once per window from index 0 (``_since`` is the index).
        """
        fresh = "_spread" not in snapshot and "_err" not in snapshot
        if "_spread" not in snapshot:
            snapshot = {k: v for k, v in snapshot.items() if k != "_err"} | {
                "_spread": float(snapshot.get("_err", 0.0)) / _EPS,
                "_mag": snapshot.get("_mag", 0.0),
            }
        if "_since" not in snapshot:
            snapshot = {**snapshot, "_since": snapshot.get("_idx", 0)}
        super().restore(snapshot)
        if fresh:
            self._exact_sums()

    def _mean(self) -> float:
        s = self._sum
        if -math.inf < s < math.inf:
            return s / self._count
        # the sum of finite values overflowed: the mean itself is finite, between the
        # window's smallest and largest value (as in moving_average_step)
        n, count = self._config.n, self._count
        window = [self._buf[(self._idx - count + j) % n] for j in range(count)]
        mean = sum(v / count for v in window)
        return clamp(mean, min(window), max(window))

    def _resume(self, held: float) -> None:
        self._exact_sums()
        self.out = held

    def _reset_state(self) -> None:
        self.out = 0.0
        self._buf = [0.0] * self._config.n
        self._idx = 0
        self._count = 0
        self._since = 0
        self._sum = 0.0
        self._spread = 0.0
        self._mag = 0.0

    def preset(self, value: float) -> None:
        """Fill the whole window with ``value``."""
        if is_finite(value):
            n = self._config.n
            self._buf = [float(value)] * n
            self._idx, self._count, self._since = 0, n, 0
            self._sum = float(value) * n
            self._mag = abs(self._sum)
            self._spread = self._mag
            self.out = float(value)

    def __call__(self, u: float) -> float:
        u = as_input(u)
        if not math.isfinite(u):
            self.error_id = ErrorCode.BAD_INPUT
            return self.out
        self.error_id = ErrorCode.NO_ERROR
        n = self._config.n
        (self.out, self._buf, self._idx, self._count, self._since, self._sum, self._spread,
         self._mag, _n) = moving_average_step(
            u, n, SUM_LOSS_FLOAT64, self.out, self._buf, self._idx, self._count, self._since,
            self._sum, self._spread, self._mag, n,
        )  # fmt: skip
        return self.out


_EPS = sys.float_info.epsilon / 2.0  # unit roundoff of float64 (an old snapshot's bound)


def _window_sum(buf: list[float]) -> float:
    """Exact sum of the window (``math.fsum``); inf when it overflows a float."""
    try:
        return math.fsum(buf)
    except OverflowError:
        return math.inf


# ---------------------------------------------------------------------------
# Steady-state detector
# ---------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class SteadyStateDetectorConfig(BlockConfig):
    """Configuration of :class:`SteadyStateDetector`.

    Attributes
    ----------
    tolerance : float
        Largest variation [input units] still counted as steady, >= 0.
    t_stab : float
        Stabilisation time [s] > 0 (controltheplant 2024, ``irStabilizationTime``).
    ts : float
        Sample time [s].
    """

    tolerance: float = 1.0
    t_stab: float = 2.0
    ts: float = 0.1

    def validate(self) -> None:
        require_nonnegative("tolerance", self.tolerance)
        require_positive("t_stab", self.t_stab, ErrorCode.BAD_STAB_TIME)
        require_positive("ts", self.ts, ErrorCode.NO_CYCLE)


STEADY_TIME_CAP = 1e30
"""The longest time steady [s] the detector counts (3e22 years; a REAL holds it)."""


def steady_step(
    u: float,
    tolerance: float,
    t_stab: float,
    h: float,
    restart: bool,
    anchor: float,
    elapsed: float,
    started: bool,
) -> tuple[bool, float, float, bool]:
    """One sample of the steady-state detector: the one cycle of the block and the PLC.

    Has ``u`` stayed within ``tolerance`` of its anchor for ``t_stab`` [s]
    (controltheplant 2024, ``FindSteadyState``)?  A larger variation moves the
    anchor to ``u`` and restarts the time; ``restart`` (a bad input, the PID's
    dead band leaving) starts afresh; a small slack makes ``t_stab = k h``
    steady after exactly k samples; the time saturates at
    :data:`STEADY_TIME_CAP`.  :class:`SteadyStateDetector` and the PID's dead
    band (``pid.pid_update``: the block, float32 and the exported FB) run it.
    Returns ``(steady, anchor, elapsed, started)``.
    """
    steady = False
    if restart:
        started = False
        elapsed = 0.0
    else:
        if not started or abs(u - anchor) > tolerance:
            anchor = u
            elapsed = 0.0
            started = True
        else:
            elapsed = elapsed + h
            if elapsed > STEADY_TIME_CAP:
                elapsed = STEADY_TIME_CAP
        steady = elapsed >= t_stab - 1e-9 * h
    return steady, anchor, elapsed, started


class SteadyStateDetector(Block):
    """Is the input steady? (controltheplant 2024, ``FindSteadyState``).

    The block keeps an anchor value.  While ``|u - anchor| <= tolerance`` the
    time since the anchor was set grows; a larger variation moves the anchor to
    ``u`` and restarts the time.  ``steady`` is true once that time reaches
    ``t_stab``.  This is O(1) per cycle, like the PLC block, and never needs a
    window of history.  ``out`` is ``steady`` as 1.0/0.0.

    NaN/inf input: not steady, time restarts, ``BAD_INPUT``.
    """

    Config = SteadyStateDetectorConfig
    _state_fields = ("out", "steady", "_anchor", "_elapsed", "_started")
    config: SteadyStateDetectorConfig
    _config: SteadyStateDetectorConfig

    def _reset_state(self) -> None:
        self.out = 0.0
        self.steady = False
        self._anchor = 0.0
        self._elapsed = 0.0
        self._started = False

    def __call__(self, u: float, dt: float | None = None) -> bool:
        h = self._cycle_time(dt, self._config.ts)
        if h is None:
            return self.steady
        u = as_input(u)
        bad = not math.isfinite(u)  # not steady, the time restarts
        self.error_id = ErrorCode.BAD_INPUT if bad else ErrorCode.NO_ERROR
        c = self._config
        self.steady, self._anchor, self._elapsed, self._started = steady_step(
            u, c.tolerance, c.t_stab, h, bad, self._anchor, self._elapsed, self._started
        )
        self.out = 1.0 if self.steady else 0.0
        return self.steady


# ---------------------------------------------------------------------------
# Saturation and selectors (Åström 1987, section 5)
# ---------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class SaturationConfig(BlockConfig):
    """Configuration of :class:`Saturation`: limits ``lo <= hi`` (infinite allowed)."""

    lo: float = -math.inf
    hi: float = math.inf

    def validate(self) -> None:
        require_limits("lo", self.lo, "hi", self.hi)


class Saturation(Block):
    """Saturation module of Åström 1987 (section 5; Appendix A, system ``int``).

    ``y = min(max(u, lo), hi)``; ``high``/``low`` tell which limit is active.
    NaN/inf input: hold the last output, ``BAD_INPUT`` (an infinite command is
    a fault, not a request for full scale).
    """

    Config = SaturationConfig
    _state_fields = ("out", "high", "low")
    config: SaturationConfig
    _config: SaturationConfig

    def _reset_state(self) -> None:
        c = self._config
        self.out = clamp(0.0, c.lo, c.hi)
        self.high = self.low = False

    @property
    def active(self) -> bool:
        """True when a limit is active."""
        return self.high or self.low

    def output_limits(self) -> tuple[float, float]:
        """``(lo, hi)`` in force."""
        return self._config.lo, self._config.hi

    def __call__(self, u: float) -> float:
        u = as_input(u)
        if not math.isfinite(u):
            self.error_id = ErrorCode.BAD_INPUT
            return self.out
        self.error_id = ErrorCode.NO_ERROR
        c = self._config
        self.high = u > c.hi
        self.low = u < c.lo
        self.out = c.hi if self.high else c.lo if self.low else u
        return self.out


@dataclasses.dataclass(frozen=True)
class SelectorConfig(BlockConfig):
    """Selectors have no parameters."""


class _Selector(Block):
    """Common code of the min and max selectors (Åström 1987, section 3, "Selectors")."""

    Config = SelectorConfig
    _state_fields = ("out", "selected")
    _pick: ClassVar[Any]

    def _reset_state(self) -> None:
        self.out = 0.0
        self.selected = -1

    def __call__(self, *inputs: float) -> float:
        """Select among ``inputs``; ``selected`` is the index of the chosen one.

        Inputs that are NaN/inf are left out of the selection and set
        ``BAD_INPUT``; if none is finite the last output is held.
        """
        values = [as_input(x) for x in inputs]
        good = [(x, i) for i, x in enumerate(values) if math.isfinite(x)]
        self.error_id = ErrorCode.NO_ERROR if len(good) == len(inputs) else ErrorCode.BAD_INPUT
        if not good:
            return self.out
        value, index = self._pick(good, key=lambda p: p[0])
        self.out, self.selected = float(value), index
        return self.out


class MinSelector(_Selector):
    """Output the smallest input (Åström 1987, "Min selector"); ties pick the first."""

    _pick = staticmethod(min)


class MaxSelector(_Selector):
    """Output the largest input (Åström 1987, "Max selector"); ties pick the first."""

    _pick = staticmethod(max)
