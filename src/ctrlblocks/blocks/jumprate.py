"""Jump-and-rate module (Åström 1987, section 5, Figs. 5.1/5.2, Appendix A system ``jar``).

Source
------
Åström 1987 (*Implementation of PID Regulators*), section 5:
"It is sometimes needed to make sure that command signals do not change too
rapidly.  This can be ensured by using a jump- and rate module.  See Figure
5.1.  The module has one input and one output and four parameters."  The
block diagram (Fig. 5.1) is lost in the text extraction; the Simnon system
``jar`` of Appendix A (macro ``fig52``) defines it::

    e  = u - x
    y1 = sat(e, jlow, jhigh)        "jump part
    y2 = sat(e, rlow, rhigh)        "rate part
    dx/dt = y2
    y  = y1 + x

(the line ``e = u - x`` was lost in the extraction; it is the only definition
consistent with the diagram's description and with Fig. 5.2).  Defaults
``jlow = rlow = -1``, ``jhigh = rhigh = 1`` as in the listing.

What it does: when the input jumps, the output jumps at once by at most
``jhigh`` (up) or ``|jlow|`` (down); the rest of the change is followed by the
state ``x`` at a rate of at most ``rhigh`` (up) or ``|rlow|`` (down) units per
second; the last part, once ``|u - x|`` is inside the rate limits, is
approached exponentially with a time constant of **1 s** (the listing has no
gain on ``e``, so in its linear region ``dx/dt = u - x``).  Units: jumps in
signal units, rates in signal units per second.

Discretisation (exact)
----------------------
The input is held constant over a sample (zero-order hold), and the state
equation ``dx/dt = sat(u - x, rlow, rhigh)`` is piecewise linear in ``x``, so
it is solved exactly over each sample of length ``h`` (see
:func:`jar_state_update`): with ``e = u - x``,

* if ``e > rhigh``: ``x`` ramps at ``rhigh`` for ``t1 = (e - rhigh)/rhigh``
  (or the whole sample if that is longer), then
* if ``e < rlow``: ``x`` ramps at ``rlow`` for ``t1 = (e - rlow)/rlow``, then
* inside the rate limits: ``e(t) = e(t0) exp(-(t - t0))``, ``x = u - e``.

So the sampled output equals the continuous module of Appendix A at the sample
instants for any ``h`` (the tests check this against a fine-step reference and
against the Fig. 5.2 experiment evaluated by hand), not just for ``h`` small
as forward Euler would be.  The output of sample ``k`` is
``y[k] = x[k] + sat(u[k] - x[k], jlow, jhigh)``, with ``x[k]`` the state at
the sample instant; the state then advances to ``x[k+1]``.

Errors
------
NaN/inf input: the output and the state are held, ``BAD_INPUT``; the block
recovers with the next finite input.  A bad per-call ``dt`` holds the output
and sets ``NO_CYCLE``.  Configuration: a jump limit pair that is reversed or
does not contain 0 gives ``BAD_LIMITS``; a rate pair with ``rlow > 0``,
``rhigh < 0`` or NaN gives ``BAD_RATE`` (the output would otherwise never
settle at the input).  Infinite limits mean no limit.
"""

from __future__ import annotations

import dataclasses
import math

from .base import (
    Block,
    BlockConfig,
    ErrorCode,
    ParameterError,
    as_input,
    is_finite,
    require_limits,
    require_positive,
)

__all__ = ["JumpAndRate", "JumpAndRateConfig", "jar_output", "jar_state_update"]


# ---------------------------------------------------------------------------
# The module's law: pure functions over floats
# ---------------------------------------------------------------------------


def jar_output(u: float, x: float, jlow: float, jhigh: float) -> float:
    """Output ``y = x + sat(u - x, jlow, jhigh)`` (Åström 1987, Appendix A, system ``jar``)."""
    e = u - x
    if e > jhigh:
        return x + jhigh
    if e < jlow:
        return x + jlow
    return u  # exactly the input (x + (u - x) may differ from u by rounding)


def jar_state_update(x: float, u: float, h: float, rlow: float, rhigh: float) -> float:
    """Exact solution of ``dx/dt = sat(u - x, rlow, rhigh)`` after ``h`` seconds, ``u`` constant.

    Requires ``rlow <= 0 <= rhigh`` (checked by the configuration).

    Parameters
    ----------
    x : float
        State at the start of the sample [signal units].
    u : float
        Input, held over the sample [signal units].
    h : float
        Sample time [s], > 0.
    rlow, rhigh : float
        Rate limits [signal units/s]; infinite means no limit.

    Returns
    -------
    float
        State at the end of the sample.
    """
    e = u - x
    t = h
    if e > rhigh:
        if rhigh <= 0.0:
            return x  # rhigh = 0: the state may not rise
        t1 = (e - rhigh) / rhigh  # time to ramp down to the rate limit
        if t1 >= h:
            return x + rhigh * h
        e = rhigh
        t = h - t1
    elif e < rlow:
        if rlow >= 0.0:
            return x  # rlow = 0: the state may not fall
        t1 = (e - rlow) / rlow
        if t1 >= h:
            return x + rlow * h
        e = rlow
        t = h - t1
    return u - e * math.exp(-t)


# ---------------------------------------------------------------------------
# The block
# ---------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class JumpAndRateConfig(BlockConfig):
    """Configuration of :class:`JumpAndRate` (the four parameters of Åström 1987, Fig. 5.1).

    Attributes
    ----------
    jlow, jhigh : float
        Largest immediate jump down (``jlow <= 0``) and up (``jhigh >= 0``)
        [signal units].
    rlow, rhigh : float
        Largest rate down (``rlow <= 0``) and up (``rhigh >= 0``)
        [signal units/s].
    ts : float
        Sample time [s], > 0.
    """

    jlow: float = -1.0
    jhigh: float = 1.0
    rlow: float = -1.0
    rhigh: float = 1.0
    ts: float = 0.1

    def validate(self) -> None:
        jlow, jhigh = require_limits("jlow", self.jlow, "jhigh", self.jhigh)
        if not jlow <= 0.0 <= jhigh:
            raise ParameterError(
                ErrorCode.BAD_LIMITS,
                "jlow/jhigh",
                f"jump limits must satisfy jlow <= 0 <= jhigh, got {jlow!r}, {jhigh!r}",
            )
        rlow, rhigh = require_limits(
            "rlow", self.rlow, "rhigh", self.rhigh, code=ErrorCode.BAD_RATE
        )
        if not rlow <= 0.0 <= rhigh:
            raise ParameterError(
                ErrorCode.BAD_RATE,
                "rlow/rhigh",
                f"rate limits must satisfy rlow <= 0 <= rhigh, got {rlow!r}, {rhigh!r}",
            )
        require_positive("ts", self.ts, ErrorCode.NO_CYCLE)


class JumpAndRate(Block):
    """Jump-and-rate module of Åström 1987 (Fig. 5.1, system ``jar``); see the module docstring.

    ``y = jar(u)`` runs one sample (``dt`` optional, in seconds).

    Attributes
    ----------
    out : float
        Output of the last sample [signal units].
    x : float
        The rate-limited state (Appendix A ``x``), already advanced to the next
        sample instant.
    jump_limited : bool
        The jump limits cut the output in the last sample (``y != u``).
    rate_limited : bool
        ``u - x`` was outside the rate limits at the last sample instant.

    Examples
    --------
    Start of the Fig. 5.2 experiment: input 4 from 0, jhigh = 1, rhigh = 1.

    >>> jar = JumpAndRate(jlow=-0.5, rlow=-0.5, ts=0.5)
    >>> jar(4.0), jar(4.0), jar(4.0)
    (1.0, 1.5, 2.0)
    """

    Config = JumpAndRateConfig
    _state_fields = ("out", "x", "jump_limited", "rate_limited")
    config: JumpAndRateConfig
    _config: JumpAndRateConfig

    def _apply_config(self, old: BlockConfig | None) -> None:
        c = self._config
        self._jlow, self._jhigh = float(c.jlow), float(c.jhigh)
        self._rlow, self._rhigh = float(c.rlow), float(c.rhigh)
        self._ts = float(c.ts)

    def _reset_state(self) -> None:
        self.out = 0.0
        self.x = 0.0
        self.jump_limited = False
        self.rate_limited = False

    def _resume(self, held: float) -> None:
        """After a failed step the module settles at the held output (state and output)."""
        self.out = self.x = held
        self.jump_limited = self.rate_limited = False

    def preset(self, value: float) -> None:
        """Settle the module at ``value`` (output and state), e.g. the current command."""
        if is_finite(value):
            self.out = self.x = float(value)
            self.jump_limited = self.rate_limited = False

    def __call__(self, u: float, dt: float | None = None) -> float:
        """Run one sample: output ``x + sat(u - x, jlow, jhigh)``, then advance ``x`` exactly.

        Parameters
        ----------
        u : float
            Input command [signal units].
        dt : float, optional
            Sample time of this call [s]; default the configured ``ts``.
        """
        h = self._cycle_time(dt, self._ts)
        if h is None:
            return self.out
        u = as_input(u)
        if not math.isfinite(u):
            self.error_id = ErrorCode.BAD_INPUT
            return self.out
        self.error_id = ErrorCode.NO_ERROR
        x = self.x
        e = u - x
        self.jump_limited = e > self._jhigh or e < self._jlow
        self.rate_limited = e > self._rhigh or e < self._rlow
        self.out = jar_output(u, x, self._jlow, self._jhigh)
        self.x = jar_state_update(x, u, h, self._rlow, self._rhigh)
        return self.out
