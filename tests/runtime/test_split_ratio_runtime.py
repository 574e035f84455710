"""Split range and ratio control in the runtime: the simulator's trace, two MV tags, a wild flow.

As for the other structures (tests/runtime/test_structures.py) the runtime runs
the simulator's controller side against the simulator's process side on a
memory bus, so its recorded trace must equal ``simulate`` bit for bit.
"""

from __future__ import annotations

import asyncio

import numpy as np
import pytest

from ctrlblocks.runtime import MemoryBus, RuntimeConfigError, parse_config
from ctrlblocks.sim import parse_scenario, simulate

from .test_runtime_memory import make, run
from .test_structures import HEAD, _pi, arrays, run_in_memory

SPLIT = (
    HEAD.format(name="split", structure="split_range", ts=1.0, duration=300.0)
    + """
[plant]
type = "HeatCool"
k_heat = 0.6
k_cool = 0.4
t = 30.0
dead_time = 2.0

[initial]
u = 50.0

[[controllers]]
name = "split"
[controllers.main]
"""
    + _pi(4.0, 30.0, 0.0, 100.0)
    + """
[controllers.split]
gap = 6.0

[[events]]
t = 5.0
do = "setpoint"
value = 30.0

[[events]]
t = 120.0
do = "setpoint"
value = 12.0
ramp = 0.2
"""
)

RATIO = (
    HEAD.format(name="ratio", structure="ratio", ts=0.5, duration=100.0)
    + """
[plant]
type = "FOPDT"
k = 0.5
t = 3.0
dead_time = 0.5

[initial]
sp = 2.0
wild = 10.0
y = 20.0

[[controllers]]
name = "ratio"
[controllers.main]
"""
    + _pi(2.0, 3.0, 0.0, 100.0)
    + """
[controllers.ratio]
r_min = 1.0
r_max = 3.0
rate = 0.1

[[events]]
t = 10.0
do = "wild"
value = 14.0
ramp = 1.0

[[events]]
t = 30.0
do = "setpoint"
value = 2.5

[[events]]
t = 50.0
do = "wild"
ok = false
value = 12.0

[[events]]
t = 60.0
do = "wild"
ok = true

[[events]]
t = 80.0
do = "wild"
nan = true
"""
)


def test_split_range_runtime_writes_both_actuators_as_the_simulator():
    sc = parse_scenario(SPLIT)
    rows, rt = run_in_memory(sc, 300)
    ref = simulate(sc, "split").signals
    mv, pv = arrays(rows, "mv", "pv")
    np.testing.assert_array_equal(mv, ref["u"])  # the controller output
    np.testing.assert_array_equal(pv, ref["ym"])
    assert ref["u_a"].max() > 10.0 and ref["u_b"].max() > 10.0  # both actuators worked
    st = rt.state("loop")
    assert st["structure"] == "split_range" and st["bound"]["mv2"] == "io:mv2"
    sig = st["signals"]
    assert (sig["u_a"], sig["u_b"]) == pytest.approx((ref["u_a"][-1], ref["u_b"][-1]))


def test_ratio_runtime_holds_the_setpoint_on_a_bad_wild_flow_as_the_simulator():
    sc = parse_scenario(RATIO)
    rows, rt = run_in_memory(sc, 200)
    ref = simulate(sc, "ratio").signals
    sp, pv, mv = arrays(rows, "sp", "pv", "mv")
    np.testing.assert_array_equal(mv, ref["u"])
    np.testing.assert_array_equal(pv, ref["ym"])
    np.testing.assert_array_equal(sp, ref["sp_in"])  # the runtime's SP is the ratio
    (wild,) = arrays(rows, "m_wild")
    t = ref["t"]
    assert np.isnan(wild[(t >= 50.0) & (t < 60.0)]).all()
    # the flow controller's PV stays good while the wild flow is bad
    ok = np.array([r["pv_ok"] for r in rows])
    assert ok.all()
    sig = rt.state("loop")["signals"]
    assert sig["wild_hold"] == 1.0 and sig["sp_flow"] == ref["sp"][-1]


def _config(loop: str) -> str:
    return (
        '[connections.io]\nprotocol = "memory"\n[connections.other]\nprotocol = "memory"\n'
        '[[loops]]\nname = "l"\nts = 1.0\nsp = 20.0\nsafe_value = 50.0\npv = "io:pv"\n'
        'mv = "io:mv"\n' + loop + '[historian]\nbackend = "none"\n'
    )


SPLIT_LOOP = (
    'structure = "split_range"\n'
    'main = { type = "PID", kp = 1.0, u_min = 0.0, u_max = 100.0 }\n'
    "split = { gap = 10.0 }\n"
)


@pytest.mark.parametrize(
    ("loop", "key", "problem"),
    [
        (SPLIT_LOOP, "loops[0].mv2", "missing: the split range's second actuator"),
        (SPLIT_LOOP + 'mv2 = "other:b"\n', "loops[0].mv2", "must be on the connection of mv"),
        (SPLIT_LOOP + 'mv2 = "io:mv"\n', "loops[0].mv2", "is the address of mv"),
        (SPLIT_LOOP + "mv2 = 3.0\n", "loops[0].mv2", "must be an I/O address"),
        ('block = { type = "PID" }\nmv2 = "io:b"\n', "loops[0].mv2", "writes one MV"),
        ('block = { type = "PID" }\nwild = "io:w"\n', "loops[0].wild", "does not read wild"),
        (
            'structure = "ratio"\nmain = { type = "PID" }\n',
            "loops[0].wild",
            "missing",
        ),
        (
            'structure = "ratio"\nmain = { type = "PID" }\nwild = "io:w"\n'
            "ratio = { r_min = 2.0, r_max = 1.0 }\n",
            "loops[0].ratio.r_min",
            "<= r_max",
        ),
    ],
)
def test_runtime_config_errors_of_the_new_tags_name_the_key(loop, key, problem):
    with pytest.raises(RuntimeConfigError) as e:
        parse_config(_config(loop))
    assert e.value.key == key and problem in e.value.problem


def test_two_loops_cannot_write_the_same_actuator():
    text = _config(SPLIT_LOOP + 'mv2 = "io:b"\n').replace('[historian]', (
        '[[loops]]\nname = "m"\nts = 1.0\nsp = 1.0\nsafe_value = 0.0\npv = "io:p2"\n'
        'mv = "io:b"\nblock = { type = "PID" }\n[historian]'
    ))  # fmt: skip
    with pytest.raises(RuntimeConfigError, match="io:b is already written by loop 'l'"):
        parse_config(text)


def test_split_range_writes_both_mvs_in_one_batch_and_a_rejected_item_fails_the_loop():
    """Manual 77.5 % with a 10 % gap: cooler 0 %, heater (77.5 - 55) / 45 = 50 %; stop value 50."""
    bus = MemoryBus({"pv": 20.0})
    loop = _config(SPLIT_LOOP + 'mv2 = "io:b"\nmode = "manual"\nmanual_value = 77.5\n')
    loop = loop.split("[[loops]]", 1)[1].rsplit("[historian]", 1)[0]
    rt, clock, samples = make("[[loops]]" + loop, {"io": bus})

    async def main():
        await run(rt, clock, 2.5)  # cycles at 0, 1, 2
        bus.reject.add("b")
        await clock.run_until(3.5)  # one more cycle: actuator B's write is refused
        await rt.stop()

    asyncio.run(asyncio.wait_for(main(), 60.0))
    assert bus.writes[:2] == [("mv", 0.0), ("b", 50.0)]
    # one request per cycle, + the refused item's retry, + the stop write and its retry
    assert rt.connections["io"].adapter.requests["write"] == 4 + 1 + 2
    assert [s.write_ok for s in samples] == [True, True, True, False]
    assert [s.mv for s in samples] == [77.5] * 4
    # the stop value (safe_value 50 %, the split point inside the gap) turns both off
    assert bus.values["mv"] == 0.0 and ("b", 0.0) not in bus.writes  # b still refused
