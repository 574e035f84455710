"""Make the figures of docs/blocks/actuators.md.

Run from the repository root::

    .venv/bin/python docs/figures/make_actuator_figures.py

Writes ``actuator_step_controller.png`` (a PI through a three-point step
controller and a motorised valve, 30 s travel, on a FOPDT process
K = 1, T = 60 s, L = 5 s; setpoint 20 -> 50 % at t = 10 s; PV noise 0.2 %)
and ``actuator_pwm.png`` (a PI on a heater K = 1, T = 50 s: on/off through a
2 s PWM against the same PI driving a continuous actuator).
"""

from __future__ import annotations

import random
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from ctrlblocks import PID, PulseWidth, StepController
from ctrlblocks.blocks.pwm import pwm_ripple
from ctrlblocks.plants import FOPDT, PT1, MotorValve

HERE = Path(__file__).resolve().parent


def run_valve_loop(n: int = 6000, ts: float = 0.1, noise: float = 0.2, deadband: float = 1.0):
    """PI -> StepController -> MotorValve -> FOPDT; returns the traces as lists."""
    pid = PID(kp=1.5, ti=40.0, ts=ts, u_min=0.0, u_max=100.0)
    sc = StepController(travel_time=30.0, min_pulse=0.3, min_pause=0.5, deadband=deadband, ts=ts)
    valve = MotorValve(travel_time=30.0, ts=ts, x0=20.0)
    proc = FOPDT(k=1.0, t=60.0, dead_time=5.0, ts=ts)
    proc.reset(20.0)
    sc.preset_position(20.0)
    rnd = random.Random(1)
    tr: dict[str, list[float]] = {"t": [], "sp": [], "pv": [], "u": [], "x": [], "cmd": []}
    for k in range(n):
        sp = 20.0 if k < 100 else 50.0
        y = proc.y + noise * rnd.gauss(0.0, 1.0)
        u = pid(sp, y)
        cmd = sc(u, open_limit=valve.open_limit, close_limit=valve.close_limit)
        proc.step(valve.step(cmd))
        for key, v in zip(tr, (k * ts, sp, y, u, valve.y, cmd), strict=True):
            tr[key].append(v)
    return tr, sc


def make_step_controller(path: Path) -> Path:
    tr, sc = run_valve_loop()
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7.5, 5.2), dpi=110, sharex=True,
                                 gridspec_kw={"height_ratios": [3, 1.3]})
    a1.plot(tr["t"], tr["pv"], color="C0", lw=0.8, label="PV (with 0.2 % noise)")
    a1.step(tr["t"], tr["sp"], where="post", color="k", lw=1.0, ls="--", label="SP")
    a1.plot(tr["t"], tr["u"], color="C2", lw=0.8, label="PI output (position demand)")
    a1.plot(tr["t"], tr["x"], color="C1", lw=1.4, label="valve position")
    a1.set(ylabel="[%]", title=f"PI + step controller + motorised valve: {sc.pulses} pulses "
                               "in 600 s (dead band 1 %)")
    a1.title.set_fontsize(10)
    a1.legend(fontsize=8, loc="lower right")
    a1.grid(alpha=0.3)
    a2.step(tr["t"], tr["cmd"], where="post", color="C3", lw=0.8)
    a2.set(xlabel="time [s]", ylabel="OPEN (+1) / CLOSE (-1)", ylim=(-1.3, 1.3))
    a2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def make_pwm(path: Path) -> Path:
    ts, period, k, t = 0.1, 2.0, 1.0, 50.0
    traces = {}
    for with_pwm in (False, True):
        pid = PID(kp=4.0, ti=40.0, ts=ts, u_min=0.0, u_max=100.0)
        plant = PT1(k=k, t=t, ts=ts)
        pwm = PulseWidth(period=period, ts=ts)
        ys = []
        for _ in range(3000):
            u = pid(40.0, plant.y)
            plant.step(100.0 * pwm(u) if with_pwm else u)
            ys.append(plant.y)
        traces[with_pwm] = ys
    time = [i * ts for i in range(3000)]
    ripple = pwm_ripple(100.0 * k, t, period, 0.4)
    fig, ax = plt.subplots(figsize=(7.5, 3.8), dpi=110)
    ax.plot(time, traces[False], color="C0", lw=1.6, label="continuous actuator")
    ax.plot(time, traces[True], color="C3", lw=0.8, label="on/off heater via PWM, P = 2 s")
    ax.axhline(40.0, color="k", lw=0.8, ls="--", label="SP")
    ax.set(xlabel="time [s]", ylabel="temperature rise [K]",
           title=f"PWM on a heater K = 1 K/%, T = 50 s: ripple {ripple:.2f} K peak-to-peak "
                 "(formula) at duty 0.4")
    ax.title.set_fontsize(10)
    ax.legend(fontsize=8, loc="lower right")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


if __name__ == "__main__":
    print(make_step_controller(HERE / "actuator_step_controller.png"))
    print(make_pwm(HERE / "actuator_pwm.png"))
