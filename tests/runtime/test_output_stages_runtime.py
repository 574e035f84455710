"""Pulse-width, three-step and gain-scheduled loops in the runtime.

As for the other structures (test_structures.py) the runtime runs the
simulator's controller side against the simulator's process side on a memory
bus, so its trace must equal :func:`ctrlblocks.sim.simulate` bit for bit.  What
the output stages write: the step controller's motor command (+1 OPEN, -1
CLOSE, 0 stop) on ``mv`` and, where bound, the ``open`` / ``close`` bits a
three-point actuator's two relays take; the pulse-width output's on/off MV
(``in_hi`` while on, ``in_lo`` while off).  On stop both write their off state.
"""

from __future__ import annotations

import asyncio

import numpy as np
import pytest

from ctrlblocks.runtime import (
    CommandError,
    FakeClock,
    MemoryAdapter,
    MemoryBus,
    Runtime,
    RuntimeConfigError,
    parse_config,
)
from ctrlblocks.sim import PlantProcess, parse_scenario, simulate

from ..toml_text import toml_value as _toml
from .test_structures import HEAD, _pi

THREE_STEP = (
    HEAD.format(name="valve", structure="three_step", ts=0.1, duration=60.0)
    + """
[inner_plant]
type = "MotorValve"
travel_time = 10.0
x0 = 50.0

[plant]
type = "FOPDT"
k = 1.0
t = 4.0
dead_time = 0.3

[initial]
u = 50.0

[[controllers]]
name = "valve"
[controllers.main]
"""
    + _pi(0.8, 4.0, 0.0, 100.0)
    + """
[controllers.stepper]
travel_time = 10.0
min_pulse = 0.2
min_pause = 0.3
deadband = 0.5
{feedback}

[[events]]
t = 2.0
do = "setpoint"
value = 65.0

[[events]]
t = 30.0
do = "setpoint"
value = 40.0
"""
)

PWM = (
    HEAD.format(name="heater", structure="pulse_width", ts=0.1, duration=60.0)
    + """
[plant]
type = "FOPDT"
k = 0.5
t = 20.0
dead_time = 0.5

[initial]
u = 0.0

[[controllers]]
name = "heater"
[controllers.main]
"""
    + _pi(3.0, 15.0, 0.0, 100.0)
    + """
[controllers.pwm]
period = 2.0
t_min_on = 0.2
t_min_off = 0.2

[[events]]
t = 1.0
do = "setpoint"
value = 30.0
"""
)

SCHEDULED = (
    HEAD.format(name="sched", structure="scheduled", ts=0.2, duration=80.0)
    + """
[plant]
type = "ThreeTank"

[actuator]
u_min = 0.0
u_max = 5.0

[initial]
y = 0.3

[[controllers]]
name = "sched"
[controllers.main]
"""
    + _pi(2.6, 17.0, 0.0, 5.0)
    + """
[controllers.schedule]
on = "y"
breakpoints = [0.3, 1.0, 2.5]
kp = [2.6, 2.5, 2.3]
ti = [17.0, 10.7, 6.0]

[[events]]
t = 2.0
do = "setpoint"
value = 1.5
"""
)


def _tables(sc, extra: str) -> str:
    """The runtime loop of the scenario's first controller entry (its very tables)."""
    c = sc.controllers[0]
    main = dict(c.blocks["main"].params)
    main.pop("safe_value", None)
    lines = [
        "[[loops]]",
        'name = "loop"',
        f"ts = {sc.ts}",
        f'structure = "{sc.structure}"',
        'pv = "io:pv"',
        'mv = "io:mv"',
        'sp = "io:sp"',
        "safe_value = 0.0",
        f"u0 = {PlantProcess(sc).u0!r}",
        'start = "block"',  # the blocks' own initial state, as the simulator's
        "[loops.main]",
        'type = "PID"',
        *(f"{k} = {v!r}" for k, v in main.items()),
    ]
    stage = {"three_step": "stepper", "pulse_width": "pwm", "scheduled": "schedule"}
    for key, table in ((stage[sc.structure], _stage_table(sc)),):
        lines.append(f"[loops.{key}]")
        lines += [f"{k} = {_toml(v)}" for k, v in table.items()]
    return "\n".join(lines[:9]) + "\n" + extra + "\n".join(lines[9:]) + "\n"


def _stage_table(sc) -> dict:
    opts = sc.controllers[0].options
    if "schedule" in opts:
        return dict(opts["schedule"])
    key = "stepper" if "stepper" in opts else "pwm"
    table = dict(opts[key].params)
    table.pop("ts", None)
    if opts.get("feedback"):
        table["feedback"] = True
    return table


def _run(sc, n: int, extra: str = "", outputs: tuple[str, ...] = ()):
    process = PlantProcess(sc)
    values = process.values()
    bus = MemoryBus(values)
    written: list[dict[str, float]] = []
    cycle: dict[str, float] = {}
    names = {"mv", *outputs}

    def on_write(address: str, u: float) -> None:
        cycle[address] = u
        if set(cycle) == names:  # the plant steps once every output of the cycle is in
            written.append(dict(cycle))
            process.step(cycle["mv"])
            cycle.clear()
            bus.values.update(process.values())

    bus.on_write = on_write
    text = '[connections.io]\nprotocol = "memory"\n' + _tables(sc, extra)
    cfg = parse_config(text + '[historian]\nbackend = "none"\n')
    clock = FakeClock()
    rows: list = []
    rt = Runtime(cfg, clock=clock, adapters={"io": MemoryAdapter(bus)}, historian=None,
                 on_sample=rows.append)  # fmt: skip

    async def main():
        await rt.start()
        await clock.run_until((n - 0.5) * sc.ts)
        await rt.stop()

    asyncio.run(main())
    return rows[:n], written, bus, rt


def _assert_trace(sc, rows, n):
    ref = simulate(sc, sc.controllers[0].name).signals
    assert len(rows) == n and not any(r.overrun for r in rows)
    np.testing.assert_array_equal([r.mv for r in rows], ref["u"][:n])
    np.testing.assert_array_equal([r.pv for r in rows], ref["ym"][:n])
    return ref


@pytest.mark.parametrize("feedback", [False, True])
def test_three_step_loop_writes_open_close_as_the_simulator(feedback):
    sc = parse_scenario(THREE_STEP.format(feedback="feedback = true" if feedback else ""))
    n = 500
    extra = 'pv2 = "io:pv2"\nopen = "io:open"\nclose = "io:close"\n'
    rows, written, bus, rt = _run(sc, n, extra, outputs=("open", "close"))
    ref = _assert_trace(sc, rows, n)
    cmd = np.array([w["mv"] for w in written[:n]])
    assert set(np.unique(cmd)) == {-1.0, 0.0, 1.0}  # it opened and closed
    np.testing.assert_array_equal([w["open"] for w in written[:n]], cmd > 0)
    np.testing.assert_array_equal([w["close"] for w in written[:n]], cmd < 0)
    assert rt.state("loop")["signals"]["pulses"] == ref["pulses"][n - 1]
    # the stop: the motor stopped (both relays off), not the controller's safe value
    assert bus.values["mv"] == 0.0 and bus.values["open"] == 0.0 and bus.values["close"] == 0.0


def test_three_step_loop_runs_without_position_feedback_wiring():
    sc = parse_scenario(THREE_STEP.format(feedback=""))
    rows, written, _bus, _rt = _run(sc, 100)
    cmd = [w["mv"] for w in written]
    assert 1.0 in cmd  # the setpoint step opens the valve on the block's own estimate
    assert all(r.pv_ok for r in rows)


def test_pulse_width_loop_writes_the_on_off_mv_as_the_simulator():
    sc = parse_scenario(PWM)
    n = 500
    rows, _written, bus, rt = _run(sc, n)
    ref = _assert_trace(sc, rows, n)
    assert set(np.unique([r.mv for r in rows])) == {0.0, 100.0}
    assert rt.state("loop")["signals"]["duty"] == ref["duty"][n - 1]
    assert bus.values["mv"] == 0.0  # stopped: the output off (in_lo)


def test_scheduled_loop_on_the_measurement_equals_the_simulator_and_refuses_scheduled_tunings():
    sc = parse_scenario(SCHEDULED)
    n = 300
    rows, _written, _bus, rt = _run(sc, n)
    ref = _assert_trace(sc, rows, n)
    sig = rt.state("loop")["signals"]
    assert sig["kp"] == ref["kp"][n - 1] and sig["w"] == ref["y"][n - 1]
    lp = rt.loops["loop"]
    with pytest.raises(CommandError, match="set by the loop's gain schedule"):
        lp.command(tunings={"kp": 1.0})
    lp.command(tunings={"td": 0.5})  # an unscheduled parameter is the operator's


def _config(loop: str) -> str:
    return (
        '[connections.io]\nprotocol = "memory"\n[connections.other]\nprotocol = "memory"\n'
        '[[loops]]\nname = "l"\nts = 0.1\nsp = 20.0\nsafe_value = 0.0\npv = "io:pv"\n'
        'mv = "io:mv"\n' + loop + '[historian]\nbackend = "none"\n'
    )


STEPPER = 'structure = "three_step"\nmain = { type = "PID", kp = 1.0 }\nstepper = {}\n'


@pytest.mark.parametrize(
    ("loop", "key", "problem"),
    [
        (STEPPER + 'open = "other:o"\n', "loops[0].open", "must be on the connection of mv"),
        (STEPPER + 'close = "io:mv"\n', "loops[0].close", "is the address of mv"),
        (STEPPER + 'open = "io:o"\nclose = "io:o"\n', "loops[0].close", "is the address of open"),
        (STEPPER + "stop_value = 0.0\n", "loops[0].stop_value", "off state"),
        (
            'structure = "pulse_width"\nmain = { type = "PID" }\npwm = { period = 2.0 }\n'
            'open = "io:o"\n',
            "loops[0].open",
            "unknown key",
        ),
        (
            'structure = "scheduled"\nmain = { type = "ADRC", b0 = 1.0 }\n'
            'schedule = { on = "w", breakpoints = [0.0], b0 = [1.0] }\n',
            "loops[0].schedule.on",
            "must be 'sp' or 'y'",
        ),
    ],
)  # fmt: skip
def test_runtime_config_errors_of_the_output_stages_name_the_key(loop, key, problem):
    with pytest.raises(RuntimeConfigError) as e:
        parse_config(_config(loop))
    assert e.value.key == key and problem in e.value.problem, str(e.value)


def test_two_loops_cannot_write_the_same_relay():
    text = _config(STEPPER + 'open = "io:o"\n').replace("[historian]", (
        '[[loops]]\nname = "m"\nts = 0.1\nsp = 1.0\nsafe_value = 0.0\npv = "io:p2"\n'
        'mv = "io:o"\nblock = { type = "PID" }\n[historian]'
    ))  # fmt: skip
    with pytest.raises(RuntimeConfigError, match="io:o is already written by loop 'l'"):
        parse_config(text)
