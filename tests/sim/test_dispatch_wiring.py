"""Structures the compiled lane was never written for run on it, equal to the Python path.

The lane has no wiring of its own (issue 31): it runs the structure's
``Wiring``.  So a structure that exists only as a description -- two new ones
here, registered for the test: a Smith predictor whose controller also gets
the lead-lag feed-forward, and a cascade whose secondary gets it -- runs on
the lane as soon as it is registered, and every signal equals the Python
path's bit for bit.  Before, each structure was written a second time in the
lane, and a new one ran on the Python path until someone wrote it there.
"""

from __future__ import annotations

import logging

import numpy as np
import pytest

from ctrlblocks.fast._jit import HAVE_NUMBA
from ctrlblocks.loops import STRUCTURES
from ctrlblocks.loops.feedforward import FeedForwardStage
from ctrlblocks.loops.registry import register_structure
from ctrlblocks.loops.smith import SmithPredictor
from ctrlblocks.loops.structure import ENTRY_KEYS, Structure
from ctrlblocks.loops.wiring import Loop, Wiring
from ctrlblocks.sim import parse_scenario, run_scenario

from ..toml_text import toml_table as _table

pytestmark = pytest.mark.skipif(not HAVE_NUMBA, reason="the compiled lane needs numba")


class SmithFeedForward(Structure):
    """A Smith predictor whose controller also gets the lead-lag feed-forward."""

    name = "test_smith_feedforward"
    roles = ("main", "model", "feedforward")
    measurements = ("y", "dv")
    wiring = Wiring(
        (Loop("main", pv="y_pred", ff="ff"),),
        stages=(FeedForwardStage(), SmithPredictor()),
        measured_mv=True,
    )

    def parse(self, r, e, key, ts, tune):
        r.check_keys(e, {*ENTRY_KEYS, *self.roles}, key)
        return {
            "main": r.role(e, "main", key, ts),
            "model": r.role(e, "model", key, ts, kind="plant"),
            "feedforward": r.role(e, "feedforward", key, ts),
        }, {}


class CascadeFeedForward(Structure):
    """A cascade whose secondary gets the measured disturbance through a lead-lag."""

    name = "test_cascade_feedforward"
    roles = ("primary", "secondary", "feedforward")
    measurements = ("y", "y2", "dv")
    mv_roles = ("secondary",)
    event_target = "primary"
    series_plant = True
    tuned_roles = ()
    wiring = Wiring(
        (
            Loop("primary", awin="secondary", follows="secondary", signal="sp2"),
            Loop("secondary", sp="primary", pv="y2", ok=("y2",), ff="ff"),
        ),
        mv="secondary",
        stages=(FeedForwardStage(),),
    )


@pytest.fixture
def registered():
    for s in (SmithFeedForward(), CascadeFeedForward()):
        register_structure(s)
    yield
    for name in (SmithFeedForward.name, CascadeFeedForward.name):
        del STRUCTURES[name]


HEAD = """
[scenario]
name = "wired"
title = "wired"
structure = "{structure}"
ts = 0.1
duration = 80.0
seed = 5
[sensor]
noise = 0.01
[initial]
y = 0.5
warmup = 2.0
"""
_PRIMARY = {
    "PID": {"type": "PID", "kp": 1.5, "ti": 8.0, "u_min": -1.0, "u_max": 3.0},
    "ADRC": {"type": "ADRC", "order": 1, "b0": 0.2, "omega_c": 0.3, "omega_o": 1.5,
             "u_min": -1.0, "u_max": 3.0},
}  # fmt: skip
_PID = {"type": "PID", "kp": 2.0, "ti": 1.0, "td": 0.1, "u_min": 0.0, "u_max": 1.2,
        "anti_windup": "back_calc_model"}  # fmt: skip
_LEADLAG = {"type": "LeadLag", "k": -0.8, "t_lead": 2.0, "t_lag": 1.0}
_EVENTS = [
    dict(t=2.0, do="setpoint", value=1.2),
    dict(t=20.0, do="load", value=-0.2),
    dict(t=35.0, do="mode", mode="manual"),
    dict(t=38.0, do="manual_value", value=0.4),
    dict(t=42.0, do="mode", mode="auto"),
    dict(t=50.0, do="sensor", ok=False),
    dict(t=55.0, do="sensor", ok=True),
    dict(t=60.0, do="limits", u_min=0.0, u_max=0.9),
]


def _scenario(structure: str, plants: str, controllers: str) -> str:
    events = "".join(_table("[events]", **ev) for ev in _EVENTS)
    return HEAD.format(structure=structure) + plants + controllers + events


def _same_on_both_engines(text: str, caplog) -> None:
    sc = parse_scenario(text)
    with caplog.at_level(logging.DEBUG, logger="ctrlblocks.sim.dispatch"):
        caplog.clear()
        lane = run_scenario(sc, engine="compiled")  # refused if the lane cannot run it
    ref = run_scenario(sc, engine="python")
    for ra, rb in zip(lane.runs, ref.runs, strict=True):
        assert list(ra.signals) == list(rb.signals)
        for name, x in ra.signals.items():
            np.testing.assert_array_equal(x, rb.signals[name], err_msg=name)
    assert lane.metrics == ref.metrics


def test_a_smith_predictor_with_feed_forward_runs_on_the_lane(registered, caplog) -> None:
    plants = _table("plant", type="FOPDT", k=1.5, t=8.0, dead_time=2.0)
    ctrl = (
        _table("[controllers]", name="exact model")
        + _table("controllers.main", **_PID)
        + _table("controllers.model", type="FOPDT", k=1.5, t=8.0, dead_time=2.0)
        + _table("controllers.feedforward", **_LEADLAG)
        + _table("[controllers]", name="wrong model")
        + _table("controllers.main", **_PID)
        + _table("controllers.model", type="FOPDT", k=1.2, t=6.0, dead_time=2.5)
        + _table("controllers.feedforward", **_LEADLAG)
    )
    _same_on_both_engines(_scenario(SmithFeedForward.name, plants, ctrl), caplog)


@pytest.mark.parametrize("primary", ["PID", "ADRC"])
def test_a_cascade_with_feed_forward_on_its_secondary_runs_on_the_lane(
    registered, caplog, primary
) -> None:
    plants = _table("inner_plant", type="PT1", k=1.0, t=1.5) + _table(
        "plant", type="FOPDT", k=1.5, t=8.0, dead_time=1.0
    )
    ctrl = (
        _table("[controllers]", name=f"{primary} / PID")
        + _table("controllers.primary", **_PRIMARY[primary])
        + _table("controllers.secondary", **_PID)
        + _table("controllers.feedforward", **_LEADLAG)
    )
    _same_on_both_engines(_scenario(CascadeFeedForward.name, plants, ctrl), caplog)
