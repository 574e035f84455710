"""Each structure is described once, as a Wiring that every executor runs (issue 31).

The structures' Python path is the generic run of their wiring (no structure
but ``open_loop`` writes its own ComputeOutput/UpdateState), the facts the
simulator and the runtime ask (measurements, MV roles, signals) are derived
from it, and the structures drive their blocks through the Controller
protocol, never by probing a block for attributes.
"""

from __future__ import annotations

import ast
import math
from pathlib import Path

import pytest

from ctrlblocks import ADRC, PID
from ctrlblocks.blocks.protocols import Controller, Tracking
from ctrlblocks.loops import STRUCTURES, ControllerSide, parse_controller
from ctrlblocks.loops.controller import Wired, set_manual
from ctrlblocks.loops.registry import read_controller
from ctrlblocks.loops.spec import SpecReader
from ctrlblocks.loops.structure import Structure
from ctrlblocks.loops.wiring import Loop, Wiring

LOOPS = Path(__file__).resolve().parents[2] / "src" / "ctrlblocks" / "loops"
PI = {"type": "PID", "kp": 1.0, "ti": 2.0, "u_min": -10.0, "u_max": 10.0}
ADRC1 = {"type": "ADRC", "order": 1, "b0": 1.0, "omega_c": 1.0, "omega_o": 5.0,
         "u_min": -10.0, "u_max": 10.0}  # fmt: skip

ENTRIES = {
    "single": {"name": "s", **PI},
    "cascade": {"name": "c", "primary": PI, "secondary": ADRC1},
    "override": {"name": "o", "selector": "max", "blocks": [
        {**PI, "measure": "y"}, {**ADRC1, "measure": "y2", "sp": 0.5}, {**PI, "sp": 2.0}]},
    "feedforward": {"name": "f", "main": PI,
                    "feedforward": {"type": "LeadLag", "k": -1.0, "t_lead": 2.0, "t_lag": 1.0}},
    "smith": {"name": "m", "main": PI,
              "model": {"type": "FOPDT", "k": 1.0, "t": 2.0, "dead_time": 0.5}},
    "split_range": {"name": "x", "main": PI, "split": {"split": 0.0}},
    "ratio": {"name": "r", "main": PI, "ratio": {"r_min": 0.0, "r_max": 5.0}},
    "pulse_width": {"name": "p", "main": PI, "pwm": {"period": 1.0, "in_hi": 1.0}},
    "three_step": {"name": "t", "main": PI, "stepper": {"travel_time": 10.0, "span": 100.0}},
    "scheduled": {"name": "g", "main": PI,
                  "schedule": {"on": "sp", "breakpoints": [0.0, 1.0], "kp": [1.0, 2.0]}},
    "heat_cool": {"name": "h", "main": {"type": "HeatCoolPID", "kp": 2.0, "ti": 5.0}},
}  # fmt: skip


def _side(structure: str) -> ControllerSide:
    if not STRUCTURES[structure].runtime:  # a simulator-only structure (heat_cool)
        spec = read_controller(SpecReader("<string>"), ENTRIES[structure], "c", structure, 0.1)
        return ControllerSide(structure, spec, 0.1)
    spec = parse_controller(ENTRIES[structure], structure, 0.1, key="c")
    return ControllerSide(structure, spec, 0.1)


def test_every_structure_but_open_loop_is_its_wiring() -> None:
    own = {
        name
        for name, s in STRUCTURES.items()
        if any(m in vars(c) for c in type(s).__mro__[:-2] for m in ("compute", "update"))
        and type(s) is not Structure
    }
    assert own == {"open_loop"}  # the one structure without a controller
    assert set(ENTRIES) == set(STRUCTURES) - {"open_loop"}
    for name in ENTRIES:
        assert isinstance(_side(name).wiring, Wiring), name


@pytest.mark.parametrize("name", sorted(ENTRIES))
def test_the_facts_of_a_side_are_its_wiring_and_within_the_declaration(name: str) -> None:
    side = _side(name)
    s = STRUCTURES[name]
    assert set(side.measurements) <= set(s.measurements)
    assert side.kind.controller_roles(side) == side.wiring.roles == tuple(side.ctrls)
    assert [side.blocks[r] for r in side.wiring.mv_roles] == side.mv_blocks
    u = side.step(1.0, 0.2, y2=0.3, dv=0.1, w=1.0)
    assert math.isfinite(u)
    assert set(side.wiring.signals) <= set(side.values) | {"v"}


def test_the_override_reads_what_its_blocks_measure_and_selects_over_all() -> None:
    side = _side("override")
    w = side.wiring
    assert w.mv == "max" and w.mv_roles == ("blocks[0]", "blocks[1]", "blocks[2]")
    assert [lp.pv for lp in w.loops] == ["y", "y2", "y"]
    assert [lp.sp for lp in w.loops] == ["sp", 0.5, 2.0]
    assert side.measurements == ("y", "y2") and w.signals == ("v1", "v2", "v3")
    u = side.compute(1.0, 0.2, y2=0.3)
    assert u == max(side.values["v1"], side.values["v2"], side.values["v3"])


def test_the_cascade_wiring_says_follow_and_handshake_once() -> None:
    side = _side("cascade")
    primary, secondary = side.wiring.loops
    assert (primary.follows, primary.awin, primary.signal) == ("secondary", "secondary", "sp2")
    assert (secondary.sp, secondary.pv, secondary.ok) == ("primary", "y2", ("y2",))
    off = ControllerSide(
        "cascade",
        parse_controller({**ENTRIES["cascade"], "aw_handshake": False}, "cascade", 0.1, key="c"),
        0.1,
    )
    assert off.wiring.loops[0].awin is None
    # the warm-up: the primary holds y2, the secondary the MV
    side.kind.hold_for_warmup(side, 0.7, 0.4)
    prim, sec = side.blocks["primary"], side.blocks["secondary"]
    assert prim.manual_value == 0.4 and sec.manual_value == 0.7


def test_one_call_is_the_single_loop_only() -> None:
    assert Wiring((Loop("main"),)).one_call
    assert not Wiring((Loop("main", pv="y2"),)).one_call
    assert [n for n in ENTRIES if _side(n).wiring.one_call] == ["single"]


def test_a_plain_block_has_no_modes_and_sees_nan_for_a_bad_measurement() -> None:
    seen = []

    def block(sp: float, y: float) -> float:
        seen.append(y)
        return 2.0

    w = Wired(block)
    assert not w.two_phase and w.auto and not w.manual and not w.awout
    assert w.follow(3.0) is None  # runs its own law
    assert w.output(1.0, 5.0, False) == 2.0 and math.isnan(seen[-1])
    w.update(9.0, measured=1.0)  # nothing to commit
    set_manual(block, True, 1.0)  # no mode: nothing happens


def test_tracking_uses_the_track_mode_where_there_is_one_else_manual() -> None:
    from ctrlblocks.blocks import LeadLag

    pid, adrc = PID(kp=1.0, ti=2.0), ADRC(order=1, b0=1.0, omega_c=1.0, omega_o=5.0)
    assert isinstance(pid, Tracking) and isinstance(adrc, Tracking)  # the ADRC has TRACK now
    assert isinstance(pid, Controller) and isinstance(adrc, Controller)
    assert Wired(LeadLag()).follow(0.4) is None  # no modes: its own law
    for block, mode in ((pid, "track"), (adrc, "track")):
        w = Wired(block)
        saved = w.follow(0.4)
        assert saved is not None and saved[0] == mode
        assert w.output(1.0, 0.2, True) == pytest.approx(0.4)
        w.restore(saved)
        assert not block.manual and not getattr(block, "track", False)


def test_the_structures_never_probe_a_block_for_attributes() -> None:
    # issue 31: 27 hasattr/getattr calls on 22 lines of the old structures.py probed the
    # controllers; the Controller protocol and its optional abilities replace them
    found = []
    for path in sorted(LOOPS.glob("*.py")):
        if path.name in ("spec.py", "toml.py"):  # reading tables: classes and packages
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Name)
                and node.func.id in ("hasattr", "getattr")
                and not (isinstance(node.args[0], ast.Name) and node.args[0].id == "self")
            ):
                found.append(f"{path.name}:{node.lineno}")
    assert found == []


def test_the_heat_cool_warmup_holds_the_demand_and_the_end_of_it_releases_the_block() -> None:
    side = _side("heat_cool")
    block = side.blocks["main"]
    side.kind.hold_for_warmup(side, -30.0, math.nan)  # 30 % cooling, cool_factor 1
    assert block.manual and block.manual_value == -30.0
    assert side.step(20.0, 20.0) == -30.0 and (block.heat, block.cool) == (0.0, 30.0)
    assert side.kind.actuator_values(side.spec, -30.0) == (30.0, 0.0)
    side.set_modes(manual=False)  # a one-call block with a manual mode (ManualMode)
    assert not block.manual
