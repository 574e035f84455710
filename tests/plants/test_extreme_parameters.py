"""Every plant, every number parameter, hostile values: refused, or a model that stays finite.

A plant is made from a scenario file or from Python; a parameter it cannot
model must be refused with ``ParameterError`` when it is made, and a plant it
accepts must give finite outputs for ordinary inputs.  Found by this campaign
(fixed in the same commit): ``PT2Osc(t=1e-320)`` raised ``ZeroDivisionError``
(``1/t^2``); ``PT2Osc(ts=1e-320)`` gave NaN (a steady-state map of inf); a
``ThreeTank`` with ``ts = 10`` s grew without bound (two RK4 steps of 5 s:
4e150 bar in one sample), with ``ts = 1e308`` it gave NaN.
"""

from __future__ import annotations

import math

import pytest

import ctrlblocks.plants as P
from ctrlblocks.blocks.base import ParameterError

HOSTILE = (math.nan, math.inf, -math.inf, 0.0, -1.0, 1e308, -1e308, 1e-320, 5e-324, 10**400,
           "1", None, True)  # fmt: skip
PLANTS = {
    "FOPDT": dict(k=1.0, t=2.0, dead_time=1.0, ts=0.1),
    "PT1": dict(k=1.0, t=2.0, ts=0.1, dead_time=0.0),
    "PT2": dict(k=1.0, t1=2.0, t2=1.0, ts=0.1, dead_time=0.0),
    "PT2Osc": dict(k=1.0, t=2.0, zeta=0.5, ts=0.1, dead_time=0.0),
    "PTn": dict(k=1.0, t=(2.0, 1.0), ts=0.1, dead_time=0.0),
    "IT1": dict(k=1.0, t=2.0, ts=0.1, dead_time=0.0),
    "DeadTime": dict(dead_time=1.0, ts=0.1),
    "ThreeTank": dict(ts=0.1, u_min=0.0, u_max=5.0),
    "HeatCool": dict(k_heat=1.0, k_cool=1.0, t=10.0, ts=0.1, dead_time=0.0),
    "MotorValve": dict(travel_time=10.0, ts=0.1, span=100.0, x0=0.0),
}


@pytest.mark.parametrize("name", sorted(PLANTS))
def test_a_plant_refuses_a_parameter_or_stays_finite(name):
    cls = getattr(P, name)
    for key in PLANTS[name]:
        for value in HOSTILE:
            kw = dict(PLANTS[name], **{key: value})
            try:
                plant = cls(**kw)
            except ParameterError:
                continue
            plant.reset(0.0)
            ys = [plant.step(u) for u in (1.0, 1.0, 0.5, 1.0)]
            assert all(math.isfinite(y) for y in ys), (name, key, value, ys)


@pytest.mark.parametrize("ts", [0.5, 2.0, 10.0, 100.0])
def test_the_three_tank_process_is_stable_for_any_sample_time(ts):
    """The step response at a long ts equals the one at 0.1 s, sampled (to the RK4 error)."""
    fine, coarse = P.ThreeTank(ts=0.1), P.ThreeTank(ts=ts)
    fine.reset(1.0)
    coarse.reset(1.0)
    n = round(ts / 0.1)
    for _ in range(3):
        for _ in range(n):
            y_fine = fine.step(2.0)
        y = coarse.step(2.0)
        assert y == pytest.approx(y_fine, abs=2e-3)
    assert coarse.steps >= math.ceil(ts / 0.41)  # no RK4 step beyond the fastest mode
    assert coarse.discrete_model().substeps == coarse.steps  # the compiled paths step alike


def test_the_three_tank_keeps_its_steps_where_they_were_stable():
    """ts = 0.1 and 0.5 s with 2 substeps: the traces of every shipped scenario stay as they are."""
    assert P.ThreeTank(ts=0.1).steps == 2 and P.ThreeTank(ts=0.5).steps == 2
    with pytest.raises(ParameterError, match="RK4 steps per sample"):
        P.ThreeTank(ts=1e308)
