"""Output stages: a controller whose continuous output drives an output block that makes the MV.

The structures ``pulse_width`` (a :class:`~ctrlblocks.PulseWidth`: an on/off
MV whose duty is the controller output) and ``three_step`` (a
:class:`~ctrlblocks.StepController`: OPEN/CLOSE motor commands for a
motorised valve).  The controller tracks its own output (the output block
realises it on average: a PWM duty, a motor's travel), so its anti-windup
and modes are unchanged.  Without the output block's table the controller
output is the MV (the continuous reference in the same scenario; signal
``v_ctrl``).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

from ..blocks.pwm import PulseWidth
from ..blocks.stepper import StepController
from .spec import BlockSpec
from .structure import ENTRY_KEYS, Structure
from .wiring import Loop, Measured, OutputStage, Wiring

__all__ = ["PulseWidthStructure", "ThreeStepStructure"]


class _Stage(OutputStage):
    """The output block of :class:`_OutputStage` (``side.parts["output"]``; None: none)."""

    realises = True

    def __init__(self, structure: _OutputStage) -> None:
        self.structure = structure
        self.measurements = structure.stage_measurements

    def setup(self, side):
        spec = side.spec.options.get(self.structure.stage_key)
        side.parts[self.name] = None if spec is None else side.make(spec, "block")

    def shape(self, side, v, m):
        if side.parts[self.name] is None:
            return v, {"v_ctrl": v}
        return self.structure.stage(side.parts[self.name], side, v, m)


class _OutputStage(Structure):
    """A controller and an output block (module docstring).

    Subclasses name the output block's table (:attr:`stage_key`) and its
    class, and give its MV (:meth:`stage`) and its off state (:meth:`stage_off`).
    """

    roles = ("main",)
    stage_key: ClassVar[str]
    stage_block: ClassVar[type]
    stage_options: ClassVar[tuple[str, ...]] = ()
    stage_measurements: ClassVar[tuple[str, ...]] = ()

    def __init__(self) -> None:
        self._wiring = Wiring((Loop("main"),), output=_Stage(self))

    def wiring_of(self, side):
        return self._wiring

    def parse(self, r, e, key, ts, tune):
        r.check_keys(e, {*ENTRY_KEYS, "main", self.stage_key}, key)
        main = r.role(e, "main", key, ts, tune)
        opts: dict[str, Any] = {}
        if self.stage_key in e:
            tkey = f"{key}.{self.stage_key}"
            table = r.table(e, self.stage_key, tkey, True)
            opts = {k: table[k] for k in self.stage_options if k in table}
            params = {k: v for k, v in table.items() if k not in self.stage_options}
            spec = r.block_spec(
                {"type": self.stage_block.__name__, **params},
                tkey,
                ts,
                kind="block",
                table_keys=self.stage_options,
            )
            opts[self.stage_key] = spec
        return {"main": main}, opts

    def stage(self, block: Any, side: Any, v: float, m: Measured) -> tuple[float, dict]:
        """The output block's MV for the controller output ``v``, and its signals."""
        raise NotImplementedError

    def off_mv(self, spec):
        if self.stage_key not in spec.options:
            return None  # no output block: the controller output is the MV
        return self.stage_off(spec.options[self.stage_key])

    def stage_off(self, stage: BlockSpec) -> float:
        """The MV of the output block's off state (stop, a non-finite MV)."""
        raise NotImplementedError


class PulseWidthStructure(_OutputStage):
    """A controller and a pulse-width output (:class:`~ctrlblocks.PulseWidth`): an on/off MV.

    ``[controllers.pwm]`` holds the PulseWidth parameters (``period``,
    ``t_min_on``, ``t_min_off``, ``in_lo``, ``in_hi``); the MV is ``in_hi``
    while the output is on and ``in_lo`` while it is off (a heater's full
    power or none).  Signals: ``v_ctrl`` (the controller output), ``duty``.
    """

    name = "pulse_width"
    options = ("pwm",)
    stage_key = "pwm"
    stage_block = PulseWidth

    def stage(self, block, side, v, m):
        pwm: PulseWidth = block
        on = pwm(v, m.dt)
        c = pwm.config
        return c.in_lo + on * (c.in_hi - c.in_lo), {"v_ctrl": v, "duty": pwm.duty}

    def stage_off(self, stage):
        return float(stage.params.get("in_lo", PulseWidth.Config.in_lo))  # the output off


class ThreeStepStructure(_OutputStage):
    """A controller and a three-point step controller (:class:`~ctrlblocks.StepController`).

    The controller's output is the valve position it demands [%]; the step
    controller turns it into OPEN (+1) / CLOSE (-1) motor commands, the MV.
    The process is ``[inner_plant]`` = the motorised valve
    (:class:`~ctrlblocks.plants.MotorValve`, ``y2`` = its position) in series
    with ``[plant]``.  The valve's end switches are its position at 0 and at
    the span; ``feedback = true`` in ``[controllers.stepper]`` also wires the
    position as feedback.  Signals: ``demand``, ``position_est`` (the block's
    estimate), ``est_error`` (``|estimate - position|``), ``pulses`` (pulses
    started so far).
    """

    name = "three_step"
    options = ("stepper",)
    measurements = ("y", "y2")
    optional_measurements = ("y2",)
    output_tags = ("open", "close")
    series_plant = True
    tuned_roles = ()
    stage_key = "stepper"
    stage_block = StepController
    stage_options = ("feedback",)
    stage_measurements = ("y2",)

    def parse(self, r, e, key, ts, tune):
        blocks, opts = super().parse(r, e, key, ts, tune)
        fb = opts.get("feedback", False)
        if not isinstance(fb, bool):
            raise r.fail(f"{key}.stepper.feedback", f"must be true or false, got {fb!r}")
        return blocks, opts

    def stage(self, block, side, v, m):
        sc: StepController = block
        span = sc.config.span
        pos = m.y2
        known = m.y2_ok and math.isfinite(pos)
        cmd = sc(
            v,
            m.dt,
            open_limit=known and pos >= span,
            close_limit=known and pos <= 0.0,
            feedback=pos if side.spec.options.get("feedback") and known else None,
        )
        est_error = abs(sc.position - pos) if known else math.nan
        return float(cmd), {
            "demand": v,
            "position_est": sc.position,
            "est_error": est_error,
            "pulses": float(sc.pulses),
        }

    def stage_off(self, stage):
        return 0.0  # the motor stopped: the valve stays where it is

    def output_values(self, spec, u):
        # a three-point actuator's two relays: OPEN and CLOSE, never both
        return {"open": 1.0 if u > 0.0 else 0.0, "close": 1.0 if u < 0.0 else 0.0}
