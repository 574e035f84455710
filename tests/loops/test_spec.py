"""The block registry, the factory and the structure objects shared by simulator and runtime."""

from __future__ import annotations

import pytest

import ctrlblocks
from ctrlblocks.blocks.base import Block
from ctrlblocks.loops import (
    BLOCK_TYPES,
    PLANT_TYPES,
    STRUCTURES,
    BlockSpec,
    ControllerSide,
    KeyPathError,
    build,
    parse_controller,
    register,
)
from ctrlblocks.runtime import RuntimeConfigError
from ctrlblocks.runtime import config as runtime_config
from ctrlblocks.sim import ScenarioError
from ctrlblocks.sim import scenario as sim_scenario


def test_registry_holds_every_exported_block_and_plant():
    exported = {
        n
        for n in ctrlblocks.blocks.__all__
        if isinstance(getattr(ctrlblocks.blocks, n), type)
        and issubclass(getattr(ctrlblocks.blocks, n), Block)
        and n != "Block"
    }
    assert set(BLOCK_TYPES) == exported
    assert {"PID", "ADRC", "LeadLag", "JumpAndRate"} <= set(BLOCK_TYPES)
    assert {"FOPDT", "LinearPlant", "ThreeTank", "PT1"} <= set(PLANT_TYPES)
    assert BLOCK_TYPES["PT1"] is ctrlblocks.blocks.PT1  # the filter block, not the plant
    assert PLANT_TYPES["PT1"] is ctrlblocks.plants.PT1


def test_build_passes_ts_and_raises_the_callers_error_class():
    pid = build(BlockSpec("PID", {"kp": 2.0, "ti": 5.0}, "x.main"), 0.25, kind="block")
    assert pid.config.ts == 0.25 and pid.config.kp == 2.0
    with pytest.raises(RuntimeConfigError) as e:
        build(BlockSpec("Flux", {}, "loops[0].block"), 0.1, kind="block", error=RuntimeConfigError)
    assert e.value.key == "loops[0].block.type" and "available: ADRC" in e.value.problem
    with pytest.raises(KeyPathError) as e:
        build(BlockSpec("PID", {"kp": 1.0, "ti": -1.0}, "c"), 0.1, kind="block")
    assert type(e.value) is KeyPathError and e.value.key == "c.ti"


def test_a_registered_block_type_is_accepted_in_a_scenario():
    class Doubler:
        def __init__(self, ts: float = 1.0) -> None:
            self.ts = ts

        def __call__(self, sp: float, y: float) -> float:
            return 2.0 * (sp - y)

    register("block", Doubler)
    try:
        spec = parse_controller({"name": "d", "type": "Doubler"}, "single", 0.5, key="c")
        side = ControllerSide("single", spec, 0.5)
        assert side.main.ts == 0.5 and side.step(3.0, 1.0) == 4.0
    finally:
        del BLOCK_TYPES["Doubler"]


def test_simulator_and_runtime_tables_are_derived_from_the_structures():
    assert {n: s.roles for n, s in STRUCTURES.items()} == sim_scenario.STRUCTURES
    assert set(runtime_config.STRUCTURES) == {n for n, s in STRUCTURES.items() if s.runtime}
    assert runtime_config.STRUCTURES["cascade"] == ("primary", "secondary", "aw_handshake")
    assert runtime_config.STRUCTURES["single"] == ("block",)
    assert runtime_config.READS == {
        "single": ("pv",),
        "cascade": ("pv", "pv2"),
        "override": ("pv", "pv2"),
        "feedforward": ("pv", "dv"),
        "smith": ("pv",),
        "split_range": ("pv",),
        "ratio": ("pv", "wild"),
        "pulse_width": ("pv",),
        "three_step": ("pv", "pv2"),  # pv2 (the valve position) may stay unbound
        "scheduled": ("pv",),
    }
    assert {n: s.event_target for n, s in STRUCTURES.items()} == {
        "single": "main",
        "cascade": "primary",
        "override": "blocks[0]",
        "feedforward": "main",
        "smith": "main",
        "split_range": "main",
        "ratio": "main",
        "pulse_width": "main",
        "three_step": "main",
        "scheduled": "main",
        "heat_cool": "main",
        "open_loop": "main",
    }
    series = [n for n, s in STRUCTURES.items() if s.series_plant]
    assert series == ["cascade", "override", "three_step"]
    two = {"split_range": 2, "heat_cool": 2}
    assert {n: s.actuators for n, s in STRUCTURES.items() if s.actuators != 1} == two


def test_parse_controller_raises_the_given_error_class_not_a_scenario_error():
    entry = {"name": "c", "primary": {"type": "PID", "kp": "x"}, "secondary": {"type": "PID"}}
    with pytest.raises(RuntimeConfigError) as e:
        parse_controller(entry, "cascade", 0.1, key="loops[0]", error=RuntimeConfigError)
    assert not isinstance(e.value, ScenarioError) and e.value.key.startswith("loops[0].primary")
    with pytest.raises(KeyPathError, match="no controller entry for 'open_loop'"):
        parse_controller({"name": "c"}, "open_loop", 0.1, key="loops[0]")


@pytest.mark.parametrize(
    ("structure", "entry", "measurements", "mv_roles"),
    [
        ("single", {"type": "PID", "kp": 1.0}, ("y",), ["main"]),
        (
            "cascade",
            {"primary": {"type": "PID", "kp": 1.0}, "secondary": {"type": "PID", "kp": 2.0}},
            ("y", "y2"),
            ["secondary"],
        ),
        (
            "override",
            {"blocks": [{"type": "PID", "kp": 1.0, "measure": "y2"}, {"type": "PID", "kp": 2.0}]},
            ("y", "y2"),
            ["blocks[0]", "blocks[1]"],
        ),
        (
            "feedforward",
            {"main": {"type": "PID", "kp": 1.0}, "feedforward": {"type": "LeadLag", "k": 0.5}},
            ("y", "dv"),
            ["main"],
        ),
        (
            "smith",
            {
                "main": {"type": "PID", "kp": 1.0},
                "model": {"type": "FOPDT", "k": 1.0, "t": 5.0, "dead_time": 1.0},
            },
            ("y",),
            ["main"],
        ),
    ],
)
def test_controller_side_takes_roles_and_measurements_from_its_structure(
    structure, entry, measurements, mv_roles
):
    spec = parse_controller({"name": "c", **entry}, structure, 0.1, key="c")
    side = ControllerSide(structure, spec, 0.1)
    assert side.kind is STRUCTURES[structure]
    assert side.measurements == measurements
    assert side.mv_blocks == [side.blocks[r] for r in mv_roles]
    assert side.event_target == STRUCTURES[structure].event_target
