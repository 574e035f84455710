"""A linear plant with a linear PID in the simulator equals python-control's closed loop.

The simulator wires ``PID`` and a ``LinearPlant`` in Åström's computational
order.  With wide limits both are linear, so the closed loop is the discrete
LTI system built independently here with python-control: the plant sampled by
``sample_system(..., "zoh")`` (times ``z^-d`` for a whole-sample dead time),
the PID from its difference equations as transfer functions in ``z``
(Tustin integral, backward-difference derivative filter, setpoint weights b
and c), closed by ``feedback()`` in state space and driven by ``forced_response``.
"""

from __future__ import annotations

import control
import numpy as np
import pytest

from ctrlblocks.sim import parse_scenario, simulate

H = 0.1
KP, TI, TD, N, B, C = 1.2, 4.0, 0.8, 8.0, 0.6, 0.3
NUM, DEN = [0.8], [6.0, 5.0, 1.0]  # 0.8 / ((3s+1)(2s+1))

SCENARIO = f"""
[scenario]
name = "linear"
title = "linear loop"
ts = {H}
duration = 30.0

[plant]
type = "LinearPlant"
num = {NUM}
den = {DEN}
dead_time = {{dead}}

[[controllers]]
name = "pid"
type = "PID"
kp = {KP}
ti = {TI}
td = {TD}
n = {N}
b = {B}
c = {C}
u_min = -1e12
u_max = 1e12
integral_method = "tustin"
derivative_method = "backward"

[[events]]
t = 0.5
do = "setpoint"
value = 1.0

[[events]]
t = 12.0
do = "load"
value = -0.4

[[events]]
t = 20.0
do = "setpoint"
value = 0.3
"""


def _pid_tfs(h: float) -> tuple[control.TransferFunction, control.TransferFunction]:
    """``u = Kr(z) r - Ky(z) y`` from the PID difference equations."""
    z = control.tf([1, 0], [1], h)
    ci = KP * h / (2 * TI) * (z + 1) / (z - 1)  # trapezoid integral
    tf_ = TD / N
    a = tf_ / (tf_ + h)
    bd = KP * TD / (tf_ + h)
    cd = bd * (z - 1) / (z - a)  # backward-difference filtered derivative (2.11)
    return KP * B + ci + C * cd, KP + ci + cd


@pytest.mark.parametrize("dead_samples", [0, 3])
def test_pid_on_linear_plant_equals_python_control_closed_loop(dead_samples):
    sc = parse_scenario(SCENARIO.replace("{dead}", repr(dead_samples * H)))
    run = simulate(sc, "pid")
    s = run.signals
    t = s["t"]
    gd = control.sample_system(control.tf(NUM, DEN), H, method="zoh")
    if dead_samples:
        gd = gd * control.tf([1], [1] + [0] * dead_samples, H)
    # state space: products of transfer functions lose digits (6e-9 here)
    gd = control.ss(gd)
    kr, ky = (control.ss(k) for k in _pid_tfs(H))
    t_yr = control.feedback(gd, ky) * kr
    t_yd = control.feedback(gd, ky)  # input load d enters with the MV
    r = s["sp"]
    d = s["load"]
    y_ref = (
        control.forced_response(t_yr, T=t, U=r).outputs
        + control.forced_response(t_yd, T=t, U=d).outputs
    )
    assert len(t) == 300
    assert np.max(np.abs(s["y"] - y_ref)) < 1e-9
    # the MV too: u = Kr r - Ky y
    u_ref = (
        control.forced_response(kr, T=t, U=r).outputs
        - control.forced_response(ky, T=t, U=s["y"]).outputs
    )
    assert np.max(np.abs(s["u"] - u_ref)) < 1e-9
    # and the loop really moved: a unit step reached, load visible
    assert 0.85 < s["y"][119] < 1.1
    assert np.min(s["y"][120:200]) < np.max(s["y"][120:200]) - 0.04
