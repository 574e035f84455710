"""The Smith predictor (Nowak et al. 2018, section 3.1): the controller sees a prediction.

The structure ``smith``: the entry's plant table ``model`` (with its
``dead_time``) is the process model; the predictor runs it twice, with and
without the dead time, from the controller output ``u``.  The controller's
measurement is the signal ``y_pred = y + y_model_fast - y_model``: the
measured output with the model's delayed response replaced by its
undelayed one, so the controller acts as on the process without its dead
time.  Both models advance with the MV after the controller's UpdateState,
and start in the steady state of the initial MV.
"""

from __future__ import annotations

import dataclasses

from .spec import BlockSpec
from .structure import ENTRY_KEYS, Structure
from .wiring import Loop, Stage, Wiring

__all__ = ["Smith", "SmithPredictor"]


class SmithPredictor(Stage):
    """The two process models of the predictor; their difference corrects ``y`` (``y_pred``)."""

    name = "smith"
    signals = ("y_pred",)
    measurements = ("y",)
    roles = ("model",)

    def models(self, side):
        """``(model, model without the dead time)`` of ``side``."""
        return side.parts[self.name]

    def setup(self, side):
        model: BlockSpec = side.spec.blocks["model"]
        fast = dataclasses.replace(model, params={**model.params, "dead_time": 0.0})
        side.parts[self.name] = (side.make(model, "plant"), side.make(fast, "plant"))
        self.reset(side)

    def compute(self, side, sp, m, signals):
        model, model_fast = side.parts[self.name]
        signals["y_pred"] = m.y + model_fast.y - model.y

    def update(self, side, u):
        for model in side.parts[self.name]:
            model.step(u)

    def reset(self, side):
        for model in side.parts[self.name]:
            model.reset(side.u0)


class Smith(Structure):
    """Smith predictor (Nowak et al. 2018, section 3.1): ``y + y_model_fast - y_model``."""

    name = "smith"
    roles = ("main", "model")
    wiring = Wiring((Loop("main", pv="y_pred"),), stages=(SmithPredictor(),), measured_mv=True)

    def parse(self, r, e, key, ts, tune):
        r.check_keys(e, {*ENTRY_KEYS, "main", "model"}, key)
        model = r.role(e, "model", key, ts, kind="plant")
        if "dead_time" not in model.params:
            raise r.fail(
                f"{key}.model.dead_time", "missing: the Smith predictor's model needs the dead time"
            )
        return {"main": r.role(e, "main", key, ts, tune), "model": model}, {}
