"""Gain scheduling: the controller's parameters follow the setpoint or the measurement.

The structure ``scheduled``: ``[controllers.schedule]`` holds ``on`` (the
scheduling variable: ``"sp"``, the setpoint, or ``"y"``, the measurement),
``breakpoints`` and, per parameter, its values at the breakpoints
(``kp = [...]``, ``ti = [...]``).  Every sample the schedule
(:class:`~ctrlblocks.GainSchedule`) retunes the controller for ``w`` (through
its ``configure``, bumplessly; only when the parameters change) before it
computes.  The retune keeps the output continuous at the change and runs
the new law from the same sample (the PID's integrator by
``pid.retune_states``, the ADRC's x4 by ``adrc.retune_x4``), so a schedule
on the measurement, which retunes every sample, acts as the interpolated
law.  Signals: ``w`` (the scheduling variable) and the scheduled parameters.
"""

from __future__ import annotations

import dataclasses
import math

from ..blocks.base import ParameterError
from ..blocks.schedule import GainSchedule
from .structure import ENTRY_KEYS, Structure
from .wiring import Loop, Stage, Wiring

__all__ = ["ScheduleStage", "ScheduledStructure"]


class ScheduleStage(Stage):
    """The gain schedule before the controller: retune it for ``w`` (signals ``w``, parameters)."""

    name = "schedule"
    signals = ("w",)

    def setup(self, side):
        sched = dict(side.spec.options["schedule"])
        sched.pop("on")
        side.parts[self.name] = GainSchedule(side.blocks["main"], **sched)

    def compute(self, side, sp, m, signals):
        gs: GainSchedule = side.parts[self.name]
        # retune the controller for w = sp or y (a bad w keeps the parameters in force)
        on_y = side.spec.options["schedule"]["on"] == "y"
        gs.schedule((m.y if m.y_ok else math.nan) if on_y else sp)
        signals["w"] = gs.w
        signals.update(gs.parameters)


class ScheduledStructure(Structure):
    """Gain scheduling: the parameters follow the setpoint or the measurement (module docstring)."""

    name = "scheduled"
    roles = ("main",)
    options = ("schedule",)
    wiring = Wiring((Loop("main"),), stages=(ScheduleStage(),), measured_mv=True)

    def parse(self, r, e, key, ts, tune):
        r.check_keys(e, {*ENTRY_KEYS, "main", "schedule"}, key)
        main = r.role(e, "main", key, ts, tune)
        skey = f"{key}.schedule"
        table = dict(r.table(e, "schedule", skey, True))
        on = table.pop("on", "sp")
        if on not in ("sp", "y"):
            raise r.fail(f"{skey}.on", f"must be 'sp' or 'y', got {on!r}")
        bps = table.pop("breakpoints", None)
        if not isinstance(bps, list) or not table:
            raise r.fail(skey, "needs breakpoints = [...] and at least one parameter = [...]")
        block = r.build(main, ts, kind="block")
        fields = {f.name for f in dataclasses.fields(block.config)} - {"precision"}
        r.check_keys(table, fields | {"on", "breakpoints"}, skey)  # a parameter of the block
        try:
            GainSchedule(block, breakpoints=bps, **table)
        except ParameterError as exc:
            raise r.fail(f"{skey}.{exc.field}", exc.message) from None
        except (TypeError, ValueError) as exc:
            raise r.fail(skey, str(exc)) from None
        return {"main": main}, {"schedule": {"on": on, "breakpoints": bps, **table}}

    def scheduled_parameters(self, spec):
        return tuple(k for k in spec.options["schedule"] if k not in ("on", "breakpoints"))
