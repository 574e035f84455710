"""Liveness under retuning: a controller retuned every sample keeps acting.

The class of defect: a retune (or a sample time written every cycle, as a PLC
writes its measured cycle time) that holds the output for the sample of the
change freezes a controller whose tuning changes every sample -- a gain
schedule on the measurement, a ramped tuning, a measured ``TS``.  The ADRC
did, in the block (held for one sample, then (11)) and in its float32 PLC
cycle (frozen for ever by a per-call ``dt``).  Each case below alternates
between two valid tunings every sample (or varies ``dt``) in a closed loop
with a first-order process in a transient and checks that the output moves
in every sample in which it is inside its limits, and that the loop still
reaches its setpoint; none holds a value.
"""

from __future__ import annotations

import numpy as np
import pytest

from ctrlblocks import ADRC, PID

# each case: block factory, then two alternating changes (or "dt" for a per-call dt)
PID_BASE = dict(kp=1.0, ti=2.0, td=0.2, ts=0.1, u_min=-10.0, u_max=10.0)
ADRC_BASE = dict(order=1, b0=0.5, omega_c=0.5, omega_o=2.5, ts=0.1, u_min=-10.0, u_max=10.0)

CASES = [
    ("PID", PID_BASE, {"kp": 1.0}, {"kp": 1.3}),
    ("PID", PID_BASE, {"ti": 2.0}, {"ti": 1.6}),
    ("PID", PID_BASE, {"td": 0.2}, {"td": 0.1}),
    ("PID", PID_BASE, {"n": 10.0}, {"n": 5.0}),
    ("PID", PID_BASE, {"b": 1.0}, {"b": 0.5}),
    ("PID", PID_BASE, "dt", "dt"),
    ("ADRC", ADRC_BASE, {"b0": 0.5}, {"b0": 0.6}),
    ("ADRC", ADRC_BASE, {"omega_c": 0.5}, {"omega_c": 0.6}),
    ("ADRC", ADRC_BASE, {"omega_o": 2.5}, {"omega_o": 2.0}),
    ("ADRC", ADRC_BASE, {"order": 1, "b0": 0.5}, {"order": 2, "b0": 0.25}),
    ("ADRC", ADRC_BASE, {"discretisation": "euler"}, {"discretisation": "exact"}),
    ("ADRC", ADRC_BASE, {"ts": 0.1}, {"ts": 0.11}),
    ("ADRC", ADRC_BASE, "dt", "dt"),
]


def _ids(case: tuple) -> str:
    kind, _, a, b = case
    return f"{kind}-{'dt' if a == 'dt' else '-'.join(sorted(set(a) | set(b)))}"


@pytest.mark.parametrize("precision", ["float64", "float32"])
@pytest.mark.parametrize("case", CASES, ids=[_ids(c) for c in CASES])
def test_a_controller_retuned_every_sample_keeps_acting(case: tuple, precision: str) -> None:
    kind, base, first, second = case
    block = (PID if kind == "PID" else ADRC)(**base, precision=precision)
    y, outs = 0.0, []
    for k in range(400):
        dt = None
        if first == "dt":
            dt = 0.1 if k % 2 else 0.11  # a measured cycle time, different every sample
        else:
            block.configure(**(second if k % 2 else first))
        u = block(1.0, y, dt=dt)
        outs.append(u)
        y += 0.1 * (0.8 * u - y) / 2.0  # 0.8/(2s + 1), Euler at 0.1 s
    u = np.array(outs)
    inside = (np.abs(u[1:]) < 10.0) & (np.abs(u[:-1]) < 10.0)
    moved = np.diff(u)[:60][inside[:60]]
    assert moved.size > 30  # the transient is mostly inside the limits
    assert np.all(moved != 0.0), "the output was held in a sample of the transient"
    assert y == pytest.approx(1.0, abs=0.02)
