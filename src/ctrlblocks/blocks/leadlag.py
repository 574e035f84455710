"""Lead-lag block ``K (1 + Tt s) / (1 + Tn s)`` (Bonde et al. 2021, "Lead Lag Funksjonsblokk").

Source
------
Bonde et al. 2021 (NTNU working note *PID og Lead-Lag funksjonsblokk*), section
"Lead Lag Funksjonsblokk": the continuous element

    h_LL(s) = K (1 + Tt s) / (1 + Tn s)

with gain ``K`` (``k``), lead time constant ``Tt`` (``t_lead``, numerator) and
lag time constant ``Tn`` (``t_lag``, denominator); its use is feed-forward from
a setpoint or a measured disturbance.  The structured-text code of Bonde et al. 2021
Fig. 10 is the reference for the run-time behaviour (enable input, output
limits, what is stored as the previous output).

Difference equations
--------------------
Both discretisations have the form (``h`` the sample time, ``x`` the input,
``y`` the output)

    y[k] = b0 x[k] + b1 x[k-1] - a1 y[k-1]

* ``method="tustin"`` (default; Bonde et al. 2021, "Utledning av differenslikning:
  Tustins metode", ``s = (2/h)(1 - z^-1)/(1 + z^-1)``, and the code of Fig. 10)::

      b0 = K (h + 2 Tt) / (h + 2 Tn)
      b1 = K (h - 2 Tt) / (h + 2 Tn)
      a1 =   (h - 2 Tn) / (h + 2 Tn)

  With ``Tn = 0`` the pole is ``z = -a1 = -1``: the output would ring
  undamped at the Nyquist frequency.  That configuration is refused
  (use ``method="euler"`` or ``t_lag > 0``).
* ``method="euler"``: backward difference ``s = (1 - z^-1)/h`` (Bonde et al. 2021,
  "Bakoverdifferanse (Eulers metode)"; the first formula of the section
  "Utledning av differenslikning: Eulers metode",
  ``h_LL(z) = K ((h + Tt) - Tt z^-1) / ((h + Tn) - Tn z^-1)``; the rest of
  that section of the note repeats the Tustin derivation: an
  extraction slip)::

      b0 = K (h + Tt) / (h + Tn)
      b1 = -K Tt / (h + Tn)
      a1 = -Tn / (h + Tn)

  ``Tn = 0`` is allowed here (pure lead ``K (1 + Tt s)`` as a backward
  difference).

Both have the static gain ``K`` (``(b0 + b1)/(1 + a1) = K``).

Run-time behaviour (Bonde et al. 2021, Fig. 10)
-------------------------------------
* ``enable`` false: the output is 0, the previous output is set to 0 and the
  input memory follows the input (``Setpoint_prev := Setpoint``), so that
  enabling again starts from the current input without a derivative kick from
  an old input; the lag then starts from 0.
* Output limits ``out_min <= y <= out_max``: the *limited* value is what is
  stored as the previous output (Bonde et al. 2021, Fig. 10 stores ``U_prev :=
  LL_Output`` after saturation).  This is the note's behaviour: while the
  output is limited the recursion runs from the limit, so the block does not
  wind up, but its response while and after limiting is not that of the linear
  filter.
* NaN/inf input: the output and the memories are held, ``BAD_INPUT``; the block
  recovers with the next finite input.  A bad per-call ``dt`` holds the output
  and sets ``NO_CYCLE``.
* After ``reset()`` the memories are 0 (as the PLC variables of Fig. 10 after
  a cold start); :meth:`LeadLag.preset` starts at the steady state of a given
  input instead.
"""

from __future__ import annotations

import dataclasses
import math

from .base import (
    Block,
    BlockConfig,
    ErrorCode,
    ParameterError,
    as_flag,
    as_input,
    is_finite,
    require_choice,
    require_finite,
    require_limits,
    require_nonnegative,
    require_positive,
)
from .precision import block_limits
from .precision import check_precision as _check_precision
from .precision import float32_cycle as _float32_cycle
from .signals import clamp

__all__ = ["LeadLag", "LeadLagConfig", "leadlag_coefficients", "leadlag_law", "leadlag_step"]


# ---------------------------------------------------------------------------
# The control law: pure functions over floats (no objects, no exceptions)
# ---------------------------------------------------------------------------


def leadlag_coefficients(
    k: float, t_lead: float, t_lag: float, h: float, tustin: bool
) -> tuple[float, float, float]:
    """Coefficients ``(b0, b1, a1)`` of ``y[k] = b0 x[k] + b1 x[k-1] - a1 y[k-1]``.

    Tustin as in Bonde et al. 2021 ("Utledning av differenslikning: Tustins metode",
    Fig. 10), backward Euler as in Bonde et al. 2021, "Bakoverdifferanse" (formulas in
    the module docstring).

    Parameters
    ----------
    k : float
        Gain K [output units / input units].
    t_lead, t_lag : float
        Lead (numerator) and lag (denominator) time constants Tt, Tn [s].
    h : float
        Sample time [s], > 0.
    tustin : bool
        True for Tustin (Bonde et al. 2021, Fig. 10), False for backward Euler.
    """
    if tustin:
        d = h + 2.0 * t_lag
        return k * (h + 2.0 * t_lead) / d, k * (h - 2.0 * t_lead) / d, (h - 2.0 * t_lag) / d
    d = h + t_lag
    return k * (h + t_lead) / d, -k * t_lead / d, -t_lag / d


def leadlag_step(
    x: float,
    x_prev: float,
    y_prev: float,
    b0: float,
    b1: float,
    a1: float,
    lo: float,
    hi: float,
) -> float:
    """One lead-lag sample, limited to ``[lo, hi]`` (Bonde et al. 2021, Fig. 10)."""
    return clamp(b0 * x + b1 * x_prev - a1 * y_prev, lo, hi)


def leadlag_law(
    x: float,
    x_ok: bool,
    enable: bool,
    out: float,
    x_prev: float,
    b0: float,
    b1: float,
    a1: float,
    lo: float,
    hi: float,
) -> tuple[float, float]:
    """The lead-lag's cycle (Bonde et al. 2021, Fig. 10): the new ``(out, x_prev)``.

    ``x_ok`` False (a NaN/inf input, judged by the caller in its precision) holds
    both; ``enable`` False gives 0 within the limits and lets the input memory
    follow ``x``; else one
    :func:`leadlag_step`.  Written once: the block (float64), its float32 cycle and
    the exported FB (:func:`.plc_cycle.leadlag_cycle`) run it.
    """
    if not x_ok:
        return out, x_prev
    if not enable:
        return clamp(0.0, lo, hi), x
    return leadlag_step(x, x_prev, out, b0, b1, a1, lo, hi), x


# ---------------------------------------------------------------------------
# The block
# ---------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class LeadLagConfig(BlockConfig):
    """Configuration of :class:`LeadLag`.

    Attributes
    ----------
    k : float
        Gain K [output units / input units] (Bonde et al. 2021, ``K_LL``).
    t_lead : float
        Lead time constant Tt [s], >= 0 (Bonde et al. 2021, ``T_t``, numerator).
    t_lag : float
        Lag time constant Tn [s], >= 0 (Bonde et al. 2021, ``T_n``, denominator); must be
        > 0 with Tustin.
    ts : float
        Sample time [s], > 0.
    method : str
        ``"tustin"`` (default, Bonde et al. 2021, Fig. 10) or ``"euler"`` (backward
        difference).
    out_min, out_max : float
        Output limits [output units]; infinite means no limit.
    precision : str
        ``"float64"`` (default) or ``"float32"``: compute the cycle as a PLC's
        REAL does, every intermediate rounded to single precision (the cycle
        of :mod:`.plc_cycle`, which :mod:`ctrlblocks.plc` exports); only for
        the configurations the export covers.
    """

    k: float = 1.0
    t_lead: float = 0.0
    t_lag: float = 1.0
    ts: float = 0.1
    method: str = "tustin"
    out_min: float = -math.inf
    out_max: float = math.inf
    precision: str = "float64"

    def validate(self) -> None:
        require_finite("k", self.k)
        require_nonnegative("t_lead", self.t_lead, ErrorCode.BAD_TIME_CONSTANT)
        t_lag = require_nonnegative("t_lag", self.t_lag, ErrorCode.BAD_TIME_CONSTANT)
        require_positive("ts", self.ts, ErrorCode.NO_CYCLE)
        require_choice("method", self.method, ("tustin", "euler"))
        require_limits("out_min", self.out_min, "out_max", self.out_max)
        if self.method == "tustin" and t_lag == 0.0:
            raise ParameterError(
                ErrorCode.BAD_TIME_CONSTANT,
                "t_lag",
                "Tustin with t_lag = 0 puts the pole at z = -1 (undamped ringing); "
                'use method="euler" or t_lag > 0',
            )
        if self.precision != "float64":
            _check_precision(self, "leadlag")


class LeadLag(Block):
    """Lead-lag ``K (1 + Tt s)/(1 + Tn s)`` of Bonde et al. 2021 (see the module docstring).

    ``y = ll(x)`` runs one sample; ``ll(x, enable=False)`` gives 0 and lets the
    input memory follow ``x``.  ``ll(x, dt=0.05)`` uses a measured sample time
    instead of ``ts`` (the coefficients are recomputed when ``dt`` changes).

    Attributes
    ----------
    out : float
        Output of the last sample [output units].
    enabled : bool
        The ``enable`` input of the last sample.

    Examples
    --------
    Lead 2 s, lag 1 s, Tustin at 0.1 s: a unit step first jumps to about
    ``K (h + 2 Tt)/(h + 2 Tn) = 4.1/2.1`` and then settles at ``K``.

    >>> ll = LeadLag(k=1.0, t_lead=2.0, t_lag=1.0, ts=0.1)
    >>> ll.preset(0.0)
    >>> round(ll(1.0), 6)
    1.952381
    """

    Config = LeadLagConfig
    _state_fields = ("out", "enabled", "_x_prev", "_plc_state")
    config: LeadLagConfig
    _config: LeadLagConfig

    def _apply_config(self, old: BlockConfig | None) -> None:
        c = self._config
        self._k, self._t_lead, self._t_lag = float(c.k), float(c.t_lead), float(c.t_lag)
        self._tustin = c.method == "tustin"
        self._lo, self._hi = block_limits(float(c.out_min), float(c.out_max), c.precision)
        self._ts = float(c.ts)
        self._set_h(self._ts)

    def _set_h(self, h: float) -> None:
        self._h = h
        self._b0, self._b1, self._a1 = leadlag_coefficients(
            self._k, self._t_lead, self._t_lag, h, self._tustin
        )

    def _reset_state(self) -> None:
        self.out = clamp(0.0, self._lo, self._hi)  # 0 limited: out is always inside the limits
        self.enabled = True
        self._x_prev = 0.0
        self._plc_state = None  # the precision="float32" cycle starts afresh

    def output_limits(self) -> tuple[float, float]:
        """``(out_min, out_max)`` in force."""
        return self._lo, self._hi

    def preset(self, x: float) -> None:
        """Start at the steady state of input ``x``: output ``K x`` (limited), memory ``x``.

        A non-finite ``x`` is ignored.
        """
        if is_finite(x):
            self._x_prev = float(x)
            self.out = clamp(self._k * float(x), self._lo, self._hi)

    def __call__(self, x: float, enable: bool = True, dt: float | None = None) -> float:
        """Run one sample and return the output.

        Parameters
        ----------
        x : float
            Input (setpoint or measured disturbance) [input units].
        enable : bool
            False: output 0, the input memory follows ``x`` (Bonde et al. 2021, Fig. 10).
        dt : float, optional
            Sample time of this call [s]; default the configured ``ts``.
        """
        h = self._cycle_time(dt, self._ts)
        if h is None:
            return self.out
        x = as_input(x)
        if self._config.precision == "float32":
            return _float32_cycle("leadlag")(self, x, enable, dt)
        x_ok = math.isfinite(x)
        if x_ok:
            self.enabled = as_flag(enable, False)
            if h != self._h:
                self._set_h(h)
        self.error_id = ErrorCode.NO_ERROR if x_ok else ErrorCode.BAD_INPUT
        self.out, self._x_prev = leadlag_law(
            x, x_ok, self.enabled, self.out, self._x_prev,
            self._b0, self._b1, self._a1, self._lo, self._hi,
        )  # fmt: skip
        return self.out
