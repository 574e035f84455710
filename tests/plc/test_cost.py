"""The operation counts per call that docs/plc.md gives (execution-cost estimate)."""

from __future__ import annotations

import pytest

from ctrlblocks import ADRC, PID, LeadLag, plc

from .st_interpreter import Interpreter

pytest.importorskip("blark")
pytestmark = pytest.mark.slow  # blark's parser: the long campaign (pytest -m slow)

# (block, FB, inputs) -> documented (arithmetic, comparison, standard function, FUNCTION call,
# FB instance call) counts
CASES = [
    (lambda: PID(kp=2.0, ti=5.0, td=1.0), "CB_PID", {"SP": 50.0, "PV": 40.0}, (52, 108, 17, 39, 0)),
    (lambda: PID(kp=2.0, ti=5.0, td=1.0, algorithm="velocity"), "CB_PID",
     {"SP": 50.0, "PV": 40.0}, (56, 91, 17, 35, 0)),
    (lambda: PID(kp=2.0, ti=5.0, td=1.0, sp_filter=1.0, pv_filter=1.0, sp_rate=5.0,
                 out_rate=10.0), "CB_PID", {"SP": 50.0, "PV": 40.0}, (59, 116, 19, 41, 0)),
    # the error inside the dead band, the detector counting, the average still following MV
    (lambda: PID(kp=2.0, ti=5.0, td=1.0, deadband=1.0, t_stab=2.0), "CB_PID",
     {"SP": 50.0, "PV": 50.5}, (73, 118, 29, 40, 1)),
    (lambda: ADRC(order=1, b0=1.0, u_min=0.0, u_max=100.0), "CB_ADRC",
     {"SP": 1.0, "PV": 0.5}, (99, 74, 16, 25, 1)),
    (lambda: ADRC(order=2, b0=1.0, u_min=0.0, u_max=100.0), "CB_ADRC",
     {"SP": 1.0, "PV": 0.5}, (132, 79, 19, 27, 1)),
    (lambda: ADRC(order=2, b0=1.0, u_min=0.0, u_max=100.0, discretisation="exact"), "CB_ADRC",
     {"SP": 1.0, "PV": 0.5}, (140, 74, 18, 27, 1)),
    (lambda: ADRC(order=3, b0=1.0, u_min=0.0, u_max=100.0, t_ref=1.0), "CB_ADRC",
     {"SP": 1.0, "PV": 0.5}, (137, 80, 20, 27, 1)),
    (lambda: ADRC(order=3, b0=1.0, u_min=0.0, u_max=100.0, discretisation="exact"), "CB_ADRC",
     {"SP": 1.0, "PV": 0.5}, (169, 75, 18, 27, 1)),
    # the tracking differentiator of order 3 (its chain, derivatives and r_eff)
    (lambda: ADRC(order=3, b0=1.0, u_min=0.0, u_max=100.0, td_time=1.0), "CB_ADRC",
     {"SP": 1.0, "PV": 0.5}, (197, 100, 21, 30, 1)),
    (lambda: LeadLag(t_lead=1.0), "CB_LEADLAG", {"IN": 1.0}, (18, 11, 2, 8, 0)),
]  # fmt: skip


@pytest.mark.parametrize(("make", "fb_name", "inputs", "documented"), CASES)
def test_operations_per_auto_call_are_the_documented_ones(make, fb_name, inputs, documented):
    it = Interpreter(plc.export(make()), count=True)
    fb = it.instance(fb_name)
    for _ in range(5):
        fb(**inputs)
    it.counts.clear()
    fb(**inputs)
    kinds = ("arithmetic", "comparison", "standard function", "function call", "FB call")
    assert tuple(it.counts.get(k, 0) for k in kinds) == documented
