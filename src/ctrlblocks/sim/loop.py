"""Closed-loop wiring of blocks and plants, in Åström's computational order.

Every sample ``k`` (time ``t_k = k ts``) runs Listing 6.3 of Åström 1987
(section 6, "Digital Implementation"):

1. *events*: everything scheduled at or before ``t_k`` takes effect
   (setpoint steps and ramps, loads, mode switches, limits, plant parameter
   switches, sensor faults);
2. *Adin*: read the measurement ``y`` of the plant (with an output load and
   the sensor: saturation, noise, faults) and, behind an inner plant, ``y2``
   (its faults: ``sensor`` events with ``target = "y2"``);
3. *ComputeOutput*: each controller computes its output ``v`` with
   ``compute_output`` (no state is touched);
4. *ShapeOutput*: the structure shapes the outputs (min/max selector, the
   secondary's setpoint in a cascade);
5. *Daout*: the applied value ``u`` goes to the plant (plus an input load);
6. *UpdateState*: every controller updates its state with the value actually
   applied (``update_state(u)``), so tracking anti-windup and selectors use
   simultaneous values (Åström 1987, section 6: "it is essential that
   simultaneous values of the tracking signal and the regulator output are
   used"); the plant advances by ``ts``.  In the single-loop structures
   the actuator's real output of the sample (after its load, rate and range)
   is wired to blocks configured for a measured MV: the PID's
   ``actuator_pos`` (BACK_CALC_REAL) and the ADRC's ``u_real``
   (``u_real_on``).

Structures (``scenario.structure``)
-----------------------------------
``single``
    one controller, one plant.
``cascade``
    ``inner_plant`` (``u -> y2``) in series with ``plant`` (``y2 -> y``); the
    primary controller's output is the secondary's setpoint; the secondary's
    ``awout`` (at a limit) is written to the primary's ``awin`` before the
    primary updates its state (the AW handshake of Nowak et al. 2018, section 5, and
    Åström 1987, section 3 "Cascade Control"); ``aw_handshake = false`` in the
    controller entry leaves it out, for comparison.
``override``
    two or more controllers, each on ``y`` or ``y2``; a min (or max) selector
    picks the applied ``u`` and every controller tracks it (Åström 1987,
    Figs. 3.8/3.9).
``feedforward``
    the input load (the measured disturbance) goes through a lead-lag block
    whose output is the controller's ``ff`` input, summed before the
    controller's limits so that limits and anti-windup act on it (Bonde et al. 2021).
``split_range``
    one controller, two actuators: the controller output ``u`` is split by a
    static, continuous function into ``u_a`` and ``u_b``, the two inputs of
    a two-input plant (``HeatCool``: cooler and heater); both are recorded
    with their limit status (``ctrlblocks.loops.split``).
``ratio``
    the setpoint profile is the requested ratio; the ratio station's
    ``bias + ratio * wild`` (the wild flow has its own profile,
    ``initial.wild`` and ``wild`` events) is the flow loop's setpoint,
    recorded as ``sp`` (the requested ratio as ``sp_in``, the working ratio
    as ``ratio``, the wild flow as ``wild``; ``ctrlblocks.loops.ratio``).
``smith``
    Smith predictor (Nowak et al. 2018, section 3.1): the controller sees
    ``y + y_model_fast - y_model`` where ``y_model`` is a plant model with the
    dead time and ``y_model_fast`` the same model without it.
``open_loop``
    a block driven by the setpoint profile (e.g. the jump-and-rate module of
    Åström 1987, Fig. 5.2); ``y`` is its output.

Series plants (cascade, override) are coupled with a zero-order hold: the
outer plant receives ``y2`` at the start of the sample.  This adds an error of
order ``ts`` against the continuous series connection; use a small ``ts``
where it matters.

Controllers are used through their two-phase interface
(``compute_output``/``update_state``); a block without it is called once per
sample as ``block(sp, y)``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable
from typing import Any

import numpy as np

from ..loops.structures import ControllerSide, set_manual
from .process import ProcessSide
from .scenario import Case, ControllerSpec, Event, Scenario, ScenarioError

__all__ = ["Run", "simulate"]


@dataclasses.dataclass
class Run:
    """The trace of one controller in one case.

    ``signals`` maps names to arrays of equal length: always ``t`` [s], ``sp``,
    ``y`` (process output incl. output load, without noise), ``ym``
    (measured), ``u`` (MV from the controllers), ``v`` (controller output
    before shaping), ``u_act`` (input applied to the process after load, rate
    and range of the actuator), ``load`` (input load); plus structure-specific
    ones (``y2``, the inner plant's output without its sensor faults, ``sp2``,
    ``v1``, ``v2``, ..., ``ff``, ``y_pred``).  The
    open-loop structure records ``sp`` (input) and ``y = u = v`` (output).
    """

    scenario: str
    controller: str
    case: str
    ts: float
    signals: dict[str, np.ndarray]
    events: tuple[Event, ...]
    duration: float


def _set_attr(block: Any, attr: str, value: Any) -> None:
    cfg = getattr(block, "config", None)
    if (
        cfg is not None
        and dataclasses.is_dataclass(cfg)
        and attr in {f.name for f in dataclasses.fields(cfg)}
        and hasattr(block, "configure")
    ):
        block.configure(**{attr: value})
    else:
        setattr(block, attr, value)


# ---------------------------------------------------------------------------
# Simulation
# ---------------------------------------------------------------------------


def simulate(
    scenario: Scenario,
    controller: ControllerSpec | str,
    case: Case | str | None = None,
    *,
    duration: float | None = None,
) -> Run:
    """Run one controller of ``scenario`` in one case and return its trace.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario (:func:`~ctrlblocks.sim.scenario.load_scenario`).
    controller : ControllerSpec or str
        The controller entry (or its name).
    case : Case or str, optional
        The case (or its name); default the first.
    duration : float, optional
        Stop earlier than the case's duration [s] (short runs in tests).
    """
    if isinstance(controller, str):
        controller = next(c for c in scenario.controllers if c.name == controller)
    if case is None:
        case = scenario.cases[0]
    elif isinstance(case, str):
        case = scenario.case(case)
    t_end = case.duration if duration is None else min(duration, case.duration)
    sim = _Simulation(scenario, controller, case, t_end)
    return sim.run()


def played_events(case: Case, t_end: float, h: float) -> list[Event]:
    """The events of ``case`` a run to ``t_end`` plays (those due before its end)."""
    return [e for e in case.events if e.t < t_end - 0.5 * h or e.t == 0.0]


class _Simulation:
    """One run's process side and controller side.

    ``proc``: a :class:`ProcessSide` of the same scenario, case and
    ``t_end`` in its initial state (the compiled lane shares one between the
    controllers of a case: it only reads it); default a new one.
    """

    def __init__(
        self,
        sc: Scenario,
        ctrl: ControllerSpec,
        case: Case,
        t_end: float,
        proc: ProcessSide | None = None,
    ) -> None:
        self.sc, self.ctrl_spec, self.case = sc, ctrl, case
        self.ts = h = sc.ts
        self.n = math.floor(t_end / h + 1e-9)
        self.structure = sc.structure
        events = played_events(case, t_end, h)
        self.events = tuple(events)
        # the process side: Sensor(Actuator(model)) or Sensor(model) behind Actuator(inner model)
        self.proc = ProcessSide(sc, events, ctrl) if proc is None else proc
        # the controller side: the blocks wired for the structure (shared with the runtime)
        self.side = ControllerSide(
            sc.structure, ctrl, h, u0=self.proc.u0, file=sc.file, error=ScenarioError
        )
        self.blocks = self.side.blocks
        self.sp_signal = self.side.kind.setpoint_signal
        self.rec: dict[str, list[float]] = {}

    # -- events ------------------------------------------------------------------

    def _targets(self, ev: Event) -> list[Any]:
        """What ``ev`` acts on: a plant it names, else :meth:`ControllerSide.event_blocks`."""
        name = ev.fields.get("target")
        if name in ("plant", "inner_plant"):
            return [self.proc.model if name == "plant" else self.proc.inner_model]
        try:
            return self.side.event_blocks(ev.kind, name)
        except KeyError:  # the scenario parser refuses it; a scenario built in Python may not
            raise ValueError(
                f"{self.sc.file}: event at t={ev.t:g}: unknown target {name!r}; "
                f"expected one of {', '.join(self.blocks)}"
            ) from None

    def _apply(self, ev: Event) -> None:
        """A controller-side event (the process side applies the others)."""
        f = ev.fields
        k = ev.kind
        for b in self._targets(ev):
            if k == "set":
                _set_attr(b, f["attr"], f["value"])
            elif k == "mode":
                set_manual(b, f["mode"] == "manual", f.get("manual_value"))
            elif k == "manual_value":
                set_manual(b, bool(getattr(b, "manual", True)), f["value"])
            elif k == "limits":
                b.set_limits(f["u_min"], f["u_max"])

    # -- one sample ----------------------------------------------------------------

    def _record(self, **values: float) -> None:
        for name, v in values.items():
            self.rec.setdefault(name, []).append(v)

    def _sample(self, record: bool) -> None:
        proc, side = self.proc, self.side
        sp = proc.setpoint.value
        if not self.side.kind.closed_loop:
            out = side.compute(sp)
            if record:
                self._record(sp=sp, y=out, ym=out, u=out, v=out, load=0.0)
            return
        y = proc.plant.y_true
        ym = proc.plant.y if record else y  # warm-up: no noise, no sensor effects
        ok = proc.sensor_ok and math.isfinite(ym)
        load_in = proc.actuator.load
        series = proc.inner is not None  # cascade, override
        y2 = proc.inner.y if series else math.nan  # the inner plant's output (recorded)
        y2m = proc.y2_measured if record else y2  # what the controllers see (y2 faults)
        ok2 = proc.sensor2_ok and (math.isfinite(y2m) or not series)
        u = side.compute(
            sp, ym, y_ok=ok, y2=y2m, y2_ok=ok2, dv=load_in, w=proc.wild_value, w_ok=proc.wild_ok
        )
        proc.step(*side.actuator_values(u))  # DA: the actuator(s) shape the MV(s)
        side.update(u, measured=None if series else proc.actuator.u)
        extra = {"y2": y2, **side.values} if series else dict(side.values)
        v = extra.pop("v")
        if self.sp_signal is not None:  # the setpoint of y is the structure's (ratio)
            extra["sp_in"] = sp  # the setpoint input (ratio: the requested ratio)
            sp = extra.pop(self.sp_signal)
        if record:
            u_act = proc.actuator.u
            self._record(sp=sp, y=y, ym=ym, u=u, v=v, u_act=u_act, load=load_in, **extra)

    # -- run -----------------------------------------------------------------------

    def _warmup(self) -> None:
        """Hold every controller in manual at the initial MV for ``initial.warmup`` s.

        The plant is in steady state and measured without noise, so the
        controllers' bumpless logic initialises their states consistently; then
        the initial mode is set.  Not recorded.
        """
        ini = self.sc.initial
        nw = round(ini["warmup"] / self.ts)
        inner = self.proc.inner
        self.side.kind.hold_for_warmup(
            self.side, self.proc.u0, math.nan if inner is None else inner.y
        )
        for _ in range(nw):
            self._sample(record=False)
            self.proc.reset()  # keep the plant exactly at its steady state
            self.side.reset_models()
        self.side.set_modes(manual=ini["mode"] == "manual")

    def run(self) -> Run:
        if self.side.kind.closed_loop and (
            self.sc.initial["warmup"] > 0 or self.sc.initial["mode"] == "manual"
        ):
            self._warmup()
        h = self.ts
        proc = self.proc
        for k in range(self.n):
            t = k * h
            if k > 0:
                proc.setpoint.advance(h)
                proc.wild.advance(h)
            for ev in proc.due(t):
                if not proc.apply(ev):
                    self._apply(ev)
            self._sample(record=True)
            self._record(t=t)
        signals = {name: np.asarray(v, dtype=float) for name, v in self.rec.items()}
        return Run(
            scenario=self.sc.name,
            controller=self.ctrl_spec.name,
            case=self.case.name,
            ts=h,
            signals=signals,
            events=self.events,
            duration=self.n * h,
        )


def event_times(events: Iterable[Event]) -> list[tuple[float, str, bool]]:
    """``(t, label, switch)`` of events, for :func:`~ctrlblocks.sim.metrics.windows_from_events`.

    ``switch``: the event puts the loop in control (a switch to AUTO), so a
    distance to the setpoint after it is a step the loop is asked to make.
    """
    return [(e.t, e.label, e.kind == "mode" and e.fields.get("mode") == "auto") for e in events]
