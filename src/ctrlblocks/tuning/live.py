"""Live auto-tuning on a running loop: step pretuning and relay fine tuning with safety bounds.

Siemens PID_Compact tunes a running loop in two stages, "pretuning" (a step
of the output from a steady state) and "fine tuning" (a relay oscillation
around the setpoint); Nowak et al. 2018 (section 6) used both to get their
reference PID_PT and PID_FT.  :class:`LiveTuner` runs the same two
experiments one sample at a time on a real loop, with the experiment objects
of :mod:`ctrlblocks.tuning.relay` (:class:`~ctrlblocks.tuning.relay.StepExperiment`,
:class:`~ctrlblocks.tuning.relay.RelayExperiment`) that the offline
``step_pretune`` / ``relay_autotune`` run against simulated plants: one
implementation of each experiment.

What a plant needs from a live experiment, and what this class guarantees:

* **Bounds before it starts.** Every MV the experiment will apply
  (``u0 + du`` for the step, ``u0 +- d`` for the relay) must lie inside
  ``[mv_min, mv_max]``; otherwise the tuner refuses to start
  (:class:`~ctrlblocks.ParameterError`).
* **Abort on a PV bound, bad data or time.** A PV outside
  ``[pv_min, pv_max]``, a non-finite PV, or an experiment longer than
  ``max_time`` ends the experiment at once: state ``ABORTED`` (or ``FAILED``
  for time), with the reason.  :meth:`abort` does the same for the operator.
* **Back to where it was.** From the sample the experiment ends, :meth:`step`
  returns ``u0``, the MV before the test.  The caller puts the loop back in
  its previous mode; a loop that was in MANUAL is then exactly where it was,
  and a loop that was in AUTO continues bumplessly when its controller tracked
  the applied MV during the test (the runtime does both).
* **Nothing applied without acceptance.** A finished experiment is ``DONE``
  with :attr:`result` (the identified model or ultimate point and the
  proposed tunings); applying one is the caller's decision.

The proposals: for a step test the FOPDT fit
(:func:`~ctrlblocks.tuning.identify.fit_fopdt`) gives PID settings by AMIGO
and SIMC (Åström & Hägglund 2006; Skogestad 2003), and the designs of
``ctrlblocks compare`` (:mod:`ctrlblocks.tuning.design`: the smallest load IAE
with ``Ms <= 1.6`` and the MV noise from the record's PV noise within 5 % of
the step) of a PID (``PID_MIGO``) and an ADRC of order 2 (``ADRC_2``), on the
same FOPDT (the model the runtime computes the proposals' margins on); for
the relay the ultimate point gives Ziegler-Nichols and Tyreus-Luyben PID
settings (Ziegler & Nichols 1942; Tyreus & Luyben 1992).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

from ..blocks.base import (
    ErrorCode,
    ParameterError,
    require_choice,
    require_finite,
    require_nonnegative,
    require_positive,
)
from .identify import fit_fopdt
from .pid_rules import amigo, simc, tyreus_luyben, ziegler_nichols_closed
from .relay import RelayExperiment, StepExperiment

__all__ = ["LiveTuner", "TunerState", "TuningResult"]


class TunerState(str, Enum):
    """Where a live experiment stands."""

    RUNNING = "running"
    DONE = "done"
    ABORTED = "aborted"
    FAILED = "failed"


@dataclass(frozen=True)
class TuningResult:
    """What a finished live experiment found.

    Attributes
    ----------
    method : str
        ``"step"`` or ``"relay"``.
    model : dict
        ``{"kind": "FOPDT", "k", "T", "L"}`` for a step test;
        ``{"kind": "ultimate", "ku", "pu"}`` for a relay test.
    proposals : dict
        Name -> keyword arguments for the block (``{"type": "PID", "kp": ...}``
        or ``{"type": "ADRC", ...}``).
    warnings : list of str
    """

    method: str
    model: dict[str, Any]
    proposals: dict[str, dict[str, Any]]
    warnings: list[str] = field(default_factory=list)


class LiveTuner:
    """A step or relay experiment on a running loop (see the module docstring).

    Parameters
    ----------
    method : {"step", "relay"}
    ts : float
        Sample time of the loop [s].
    u0 : float
        The MV at the start (the loop's present output).
    amplitude : float
        Step size ``du`` (signed) or relay amplitude ``d`` (> 0) [MV unit].
    setpoint : float, optional
        Relay: the PV the relay switches around (default: the first PV).
    mv_min, mv_max : float
        Bounds every experiment MV must respect.
    pv_min, pv_max : float
        PV bounds; leaving them aborts (default: none).
    max_time : float
        Longest experiment [s].
    hysteresis : float
        Relay hysteresis [PV unit] (just above the noise band).
    gain_sign : {1, -1}
        Relay: sign of the process gain.
    pre_time : float
        Step: time held at ``u0`` before the step [s].
    """

    def __init__(
        self,
        method: str,
        *,
        ts: float,
        u0: float,
        amplitude: float,
        mv_min: float,
        mv_max: float,
        setpoint: float | None = None,
        pv_min: float = -math.inf,
        pv_max: float = math.inf,
        max_time: float = 3600.0,
        hysteresis: float = 0.0,
        gain_sign: int = 1,
        pre_time: float = 1.0,
    ) -> None:
        self.method = require_choice("method", method, ("step", "relay"))
        self.ts = require_positive("ts", ts, ErrorCode.NO_CYCLE)
        self.u0 = require_finite("u0", u0)
        amp = require_finite("amplitude", amplitude)
        lo, hi = float(mv_min), float(mv_max)
        if not lo <= hi:
            raise ParameterError(ErrorCode.BAD_LIMITS, "mv_min/mv_max", "need mv_min <= mv_max")
        self.pv_min, self.pv_max = float(pv_min), float(pv_max)
        self.max_samples = max(1, round(require_positive("max_time", max_time) / self.ts))
        self.state = TunerState.RUNNING
        self.reason = ""
        self.result: TuningResult | None = None
        self._sp = None if setpoint is None else require_finite("setpoint", setpoint)
        self._k = 0
        if method == "step":
            if amp == 0.0:
                raise ParameterError(ErrorCode.BAD_PARAMETER, "amplitude", "must be non-zero")
            used = (self.u0, self.u0 + amp)
            n_pre = max(1, round(require_nonnegative("pre_time", pre_time) / self.ts))
            self._exp: StepExperiment | RelayExperiment | None = StepExperiment(
                amp, u0=self.u0, ts=self.ts, n_pre=n_pre, n_max=self.max_samples
            )
        else:
            if amp <= 0.0:
                raise ParameterError(ErrorCode.BAD_PARAMETER, "amplitude", "must be > 0")
            if gain_sign not in (1, -1):
                raise ParameterError(ErrorCode.BAD_PARAMETER, "gain_sign", "must be 1 or -1")
            used = (self.u0 - amp, self.u0 + amp)
            self._exp = None  # made at the first sample, around its PV
            self._relay = (amp, require_nonnegative("hysteresis", hysteresis), gain_sign)
        if min(used) < lo or max(used) > hi:
            raise ParameterError(
                ErrorCode.BAD_LIMITS,
                "amplitude",
                f"the experiment would drive the MV to {min(used):g}..{max(used):g}, "
                f"outside the bounds {lo:g}..{hi:g}",
            )

    # -- the cycle ---------------------------------------------------------------

    @property
    def running(self) -> bool:
        """True while the experiment drives the MV."""
        return self.state is TunerState.RUNNING

    def step(self, pv: float) -> float:
        """One sample: the PV of this cycle -> the MV to apply (``u0`` once it has ended)."""
        if not self.running:
            return self.u0
        try:
            pv = float(pv)
        except (TypeError, ValueError, OverflowError):
            pv = math.nan
        if not math.isfinite(pv):
            return self._end(TunerState.ABORTED, f"PV not valid ({pv!r})")
        if not self.pv_min <= pv <= self.pv_max:
            return self._end(
                TunerState.ABORTED,
                f"PV {pv:g} left the bounds {self.pv_min:g}..{self.pv_max:g}",
            )
        if self._exp is None:  # relay: switch around the set point or the first PV
            d, eps, sign = self._relay
            sp = pv if self._sp is None else self._sp
            self._exp = RelayExperiment(
                d, u0=self.u0, setpoint=sp, ts=self.ts, max_samples=self.max_samples,
                hysteresis=eps, gain_sign=sign,
            )  # fmt: skip
        u = self._exp.step(pv)
        self._k += 1
        if self._exp.done:
            self._finish()
            return self.u0
        return u

    def record(self) -> tuple[Any, Any, Any] | None:
        """``(t, u, y)`` of a finished step test (what the model was fitted to); None otherwise."""
        if isinstance(self._exp, StepExperiment) and not self.running:
            return self._exp.record()
        return None

    def abort(self, reason: str = "aborted by the operator") -> None:
        """End the experiment now; :meth:`step` returns ``u0`` from here on."""
        if self.running:
            self._end(TunerState.ABORTED, reason)

    def _end(self, state: TunerState, reason: str) -> float:
        self.state, self.reason = state, reason
        return self.u0

    def _finish(self) -> None:
        """Evaluate the record: the model or ultimate point and the proposals."""
        try:
            if isinstance(self._exp, StepExperiment):
                self.result = _step_result(self._exp)
            else:
                assert self._exp is not None
                self.result = _relay_result(self._exp)
        except (RuntimeError, ValueError) as exc:  # e.g. no steady limit cycle
            self._end(TunerState.FAILED, str(exc))
            return
        except Exception as exc:  # any other defect of the evaluation: FAILED, never a raise
            self._end(TunerState.FAILED, f"{type(exc).__name__}: {exc}")
            return
        self.state = TunerState.DONE

    def status(self) -> dict[str, Any]:
        """A plain dictionary for a faceplate or a log: state, reason, progress, result."""
        out: dict[str, Any] = {
            "method": self.method,
            "state": self.state.value,
            "reason": self.reason,
            "elapsed": self._k * self.ts,
            "max_time": self.max_samples * self.ts,
        }
        if self.result is not None:
            out["model"] = self.result.model
            out["proposals"] = self.result.proposals
            out["warnings"] = self.result.warnings
        return out


def _pid_proposal(tuning: Any) -> dict[str, Any]:
    return {"type": "PID", **tuning.as_kwargs()}


def _step_result(exp: StepExperiment) -> TuningResult:
    t, u, y = exp.record()
    model = fit_fopdt(t, u, y)
    warnings = [] if exp.settled else ["the PV had not settled when the test ended"]
    import numpy as np

    from .design import MV_NOISE_FRACTION, design_adrc, design_pid

    proposals = {
        "PID_AMIGO": _pid_proposal(amigo(model.gain, model.time_constant, model.dead_time)),
        "PI_SIMC": _pid_proposal(simc(model.gain, model.time_constant, model.dead_time)),
    }
    noise = float(np.std(np.asarray(y, float) - model.response(t, u)))
    kw = {"noise_std": noise, "mv_noise_max": MV_NOISE_FRACTION * abs(float(u[-1] - u[0]))}
    try:
        pid = design_pid(model, exp.ts, **kw)
        proposals["PID_MIGO"] = {"type": "PID", "reverse": False, **pid.params}
    except ParameterError as exc:
        warnings.append(f"no PID_MIGO proposal: {exc}")
    try:
        adrc = design_adrc(model, 2, exp.ts, **kw)
        proposals["ADRC_2"] = {"type": "ADRC", "reverse": False, **adrc.params}
        warnings += adrc.warnings
    except ParameterError as exc:  # e.g. a dead time too long for every bandwidth
        warnings.append(f"no ADRC proposal: {exc}")
    return TuningResult(
        "step",
        {
            "kind": "FOPDT",
            "gain": model.gain,
            "time_constant": model.time_constant,
            "dead_time": model.dead_time,
        },
        proposals,
        warnings,
    )


def _relay_result(exp: RelayExperiment) -> TuningResult:
    r = exp.result()
    proposals = {
        "PID_ZN": _pid_proposal(ziegler_nichols_closed(r.ku, r.pu)),
        "PID_TL": _pid_proposal(tyreus_luyben(r.ku, r.pu)),
    }
    return TuningResult("relay", {"kind": "ultimate", "ku": r.ku, "pu": r.pu}, proposals,
                        list(r.warnings))  # fmt: skip
