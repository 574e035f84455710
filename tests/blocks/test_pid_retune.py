"""Bumpless retuning of the PID: continuous at the change, the new law from the same sample.

The rule (``pid.retune_states``; Åström & Hägglund 2006, bumpless parameter
changes): at the change the integrator takes ``K_old (b_old r - y) -
K_new (b_new r - y)`` on the last cycle's signals, so the output is what it
was; the next cycle runs the new law in full.  The numbers below are the
PI law evaluated by hand (ISA form, trapezoid integral, ``ts = 0.1``).
"""

from __future__ import annotations

import math
import random

import pytest

from ctrlblocks import PID, GainSchedule
from ctrlblocks.blocks import plc_cycle as pc


def _pi() -> PID:
    pid = PID(kp=2.0, ti=1.0, ts=0.1, u_min=-10.0, u_max=10.0)
    assert pid(1.0, 0.0) == 2.0  # P = K e = 2, no integral in the first cycle
    assert pid(1.0, 0.0) == pytest.approx(2.2, abs=1e-15)  # + K h/(2 Ti)(e + e) = 0.2
    return pid


def test_a_retune_acts_in_the_same_sample() -> None:
    pid = _pi()
    pid.configure(kp=4.0)
    # I' = 0.2 + 2 - 4 = -1.8; P = 4; + 4*0.1/1 * (1 + 1)/2 = 0.4 -> 4 - 1.4 = 2.6
    assert pid(1.0, 0.0) == pytest.approx(2.6, abs=1e-12)
    assert pid.i == pytest.approx(-1.4, abs=1e-12)
    assert pid(1.0, 0.0) == pytest.approx(3.0, abs=1e-12)  # the new law's 0.4 per sample


def test_a_setpoint_step_at_a_retune_keeps_its_proportional_kick() -> None:
    pid = _pi()
    pid.configure(kp=4.0)
    # P = 4*2 = 8; I = -1.8 + 0.4 (1 + 2)/2 = -1.2 -> 6.8: the kick K_new (r1 - r0) = 4
    assert pid(2.0, 0.0) == pytest.approx(6.8, abs=1e-12)


def test_the_output_is_continuous_at_the_change() -> None:
    # on the last cycle's signals the new law gives the last output (P only: no increment)
    pid = PID(kp=1.0, ti=0.0, td=0.5, n=5.0, ts=0.1, u_min=-50.0, u_max=50.0)
    for k in range(20):
        u = pid(3.0, 0.1 * k)
    pid.configure(kp=2.5, td=0.0, b=0.4)
    assert pid(3.0, 1.9) == pytest.approx(u, abs=1e-12)  # D gone, P changed: no bump
    assert pid(3.0, 2.0) == pytest.approx(u - 2.5 * 0.1, abs=1e-12)  # then the new K acts


@pytest.mark.parametrize("reverse", [False, True])
def test_the_velocity_algorithm_retunes_without_a_bump(reverse: bool) -> None:
    pid = PID(kp=2.0, ti=1.0, ts=0.1, algorithm="velocity", u_min=-10.0, u_max=10.0,
              reverse=reverse)  # fmt: skip
    s = -1.0 if reverse else 1.0
    pid(1.0, 0.0)
    u = pid(1.0, 0.0)
    pid.configure(kp=4.0)
    # x + (P_new - P_new on the last signals) + K_new h/Ti e = u + 0 + 0.4 e
    assert pid(1.0, 0.0) == pytest.approx(u + s * 0.4, abs=1e-12)


def test_a_velocity_p_controller_keeps_its_steady_state_through_a_retune() -> None:
    pid = PID(kp=2.0, ti=0.0, ts=0.1, algorithm="velocity", u_min=-10.0, u_max=10.0)
    for _ in range(200):
        u = pid(1.0, 0.5)  # P + bias = 1 at rest
    pid.configure(kp=5.0)
    for _ in range(50):
        assert pid(1.0, 0.5) == pytest.approx(u, abs=1e-9)


def test_a_retune_every_sample_does_not_freeze_the_output() -> None:
    # a schedule on the measurement retunes every cycle: the integrator must still move
    pid = PID(kp=1.0, ti=2.0, ts=0.1, u_min=-100.0, u_max=100.0)
    pid(1.0, 0.0)
    u = pid(1.0, 0.0)
    for k in range(30):
        kp = 1.0 + 0.05 * (k + 1)
        pid.configure(kp=kp)
        v = pid(1.0, 0.0)
        assert v == pytest.approx(u + kp * 0.1 / 2.0, abs=1e-12)  # K h/Ti e, e = 1
        u = v


def test_a_retune_in_manual_returns_to_auto_without_a_bump() -> None:
    pid = _pi()
    pid.manual, pid.manual_value = True, 5.0
    pid(1.0, 0.0)
    pid.configure(kp=4.0)
    pid(1.0, 0.0)
    pid.manual = False
    assert pid(1.0, 0.0) == pytest.approx(5.0, abs=1e-12)


def test_gain_schedule_on_the_measurement_is_bumpless_at_every_change() -> None:
    pid = PID(kp=1.0, ti=5.0, ts=0.1, u_min=0.0, u_max=100.0)
    gs = GainSchedule(pid, breakpoints=(0.0, 10.0), kp=(1.0, 3.0), ti=(5.0, 10.0))
    y, y_prev, u_prev = 0.0, 0.0, 0.0
    for k in range(600):
        kp_old, ti_old = pid.config.kp, pid.config.ti
        u = gs(10.0, y, w=y)
        if k > 0:
            # the new law's output on these signals minus the old law's: only the
            # integral increment of the new law (trapezoid, e and e_prev)
            e, e_prev = 10.0 - y, 10.0 - y_prev
            kp, ti = pid.config.kp, pid.config.ti
            expected = u_prev + kp * (y_prev - y) + kp * 0.1 / ti * (e + e_prev) / 2.0
            if 0.0 < u < 100.0 and 0.0 < u_prev < 100.0:
                assert u == pytest.approx(expected, abs=1e-9), (k, kp_old, ti_old)
        y_prev, u_prev = y, u
        y += 0.1 * (u - y)  # a first-order process (gain 1, 1 s)
    assert abs(10.0 - y) < 0.1  # and it controls (1 % of the setpoint after 60 s)


def _cycle_args(pid: PID) -> dict:
    args = {"sp": 0.0, "pv": 0.0, "ff": 0.0, "dv": 0.0, "pv_ok": True, "manual": False,
            "man_value": 0.0, "rst": False, "track": False, "track_value": 0.0,
            "hold": False, "awin": False, "actuator_pos": math.nan}  # fmt: skip
    args.update(pc.pid_inputs(pid.config), **pc.pid_state(pid.config))
    args["man_value"] = args["out"]
    return args


@pytest.mark.parametrize(
    "cfg",
    [
        {"kp": 1.5, "ti": 2.0, "td": 0.3, "ts": 0.1, "u_min": -10.0, "u_max": 10.0},
        {"kp": 1.5, "ti": 2.0, "td": 0.3, "ts": 0.1, "anti_windup": "back_calc_model"},
        {"kp": 0.8, "ti": 3.0, "td": 0.2, "ts": 0.1, "algorithm": "velocity", "u_min": -5.0},
        {"kp": 0.8, "ti": 0.0, "td": 0.2, "ts": 0.1, "algorithm": "velocity", "u_min": -5.0},
    ],
)
def test_fast_lane_two_phase_and_plc_cycle_agree_through_retunes(cfg: dict) -> None:
    """One retune rule: the per-call lane, the two phases and the PLC cycle in float64."""
    rng = random.Random(7)
    lane, phases = PID(**cfg), PID(**cfg)
    args = _cycle_args(lane)
    y = 0.0
    for k in range(300):
        if k % 3 == 1:  # retune often, also with the derivative switched off and on
            ti = 0.0 if cfg["ti"] == 0.0 else rng.uniform(0.5, 4.0)
            changes = {"kp": rng.uniform(0.2, 3.0), "ti": ti,
                       "td": rng.choice((0.0, rng.uniform(0.05, 0.5))),
                       "b": rng.uniform(0.0, 1.0), "c": rng.uniform(0.0, 0.5)}  # fmt: skip
            lane.configure(**changes)
            phases.configure(**changes)
            args.update(k=changes["kp"], ti=ti, td=changes["td"], b=changes["b"],
                        c=changes["c"])  # fmt: skip
        sp = 1.0 if k < 150 else 3.0
        u = lane(sp, y)
        v = phases.compute_output(sp, y)
        phases.update_state(v)
        args.update(sp=sp, pv=y)
        res = dict(zip(pc.PID_RESULTS, pc.pid_cycle(**args), strict=True))
        args.update({n: res[n] for n in args if n in res})
        assert u == v, k
        assert res["mv"] == pytest.approx(u, abs=1e-12), k
        y += 0.1 * (u - y) + rng.gauss(0.0, 0.01)
    assert lane.snapshot() == phases.snapshot()
