"""The registry of block types: names, the controllers among them, their parameters."""

from __future__ import annotations

import dataclasses
import json
import math

import pytest

import ctrlblocks
from ctrlblocks.blocks import registry
from ctrlblocks.blocks.registry import (
    BLOCK_TYPES,
    block_class,
    controller_types,
    is_controller_type,
    parameters,
    register_block,
)
from ctrlblocks.loops import spec


def test_every_exported_block_is_a_type_and_the_loops_read_the_same_registry() -> None:
    exported = {
        n for n in ctrlblocks.__all__
        if isinstance(getattr(ctrlblocks, n), type)
        and issubclass(getattr(ctrlblocks, n), ctrlblocks.Block)
        and getattr(ctrlblocks, n) is not ctrlblocks.Block
    }  # fmt: skip
    assert set(BLOCK_TYPES) == exported
    assert spec.BLOCK_TYPES is BLOCK_TYPES
    assert block_class("PID") is ctrlblocks.PID
    with pytest.raises(KeyError, match="unknown block type 'PIDD'; available: ADRC, Alarm"):
        block_class("PIDD")


def test_the_controllers_are_the_types_with_the_interface() -> None:
    assert controller_types() == ["ADRC", "PID"]
    assert not is_controller_type("LeadLag") and not is_controller_type("nothing")


def test_a_registered_block_counts_by_its_methods_or_by_what_it_says() -> None:
    class MyPI:
        def __call__(self, sp, pv, *, pv_ok=True, dt=None): ...
        def compute_output(self, sp, pv, *, pv_ok=True, dt=None): ...
        def update_state(self, applied): ...
        def set_limits(self, u_min, u_max): ...

    class Filter:
        def __call__(self, x): ...

    try:
        register_block(MyPI)
        register_block(Filter, "MyFilter")
        assert "MyPI" in controller_types() and not is_controller_type("MyFilter")
        register_block(Filter, "MyFilter", controller=True)
        assert is_controller_type("MyFilter")
        spec.register("block", Filter, "ViaLoops")  # the loops' register is the same registry
        assert block_class("ViaLoops") is Filter
    finally:
        for n in ("MyPI", "MyFilter", "ViaLoops"):
            BLOCK_TYPES.pop(n, None)
            registry._CONTROLLERS.pop(n, None)


@pytest.mark.parametrize("name", sorted(BLOCK_TYPES))
def test_the_parameters_of_every_type_are_its_config_fields_and_json(name: str) -> None:
    cls = BLOCK_TYPES[name]
    got = parameters(name)
    fields = [f.name for f in dataclasses.fields(cls.Config)]
    assert [p.name for p in got] == fields
    text = json.dumps([p.as_json() for p in got], allow_nan=False)
    assert [p["name"] for p in json.loads(text)] == fields  # the selectors have none


def test_a_parameter_shows_its_default_and_type() -> None:
    by = {p.name: p for p in parameters("ADRC")}
    assert by["order"].default == 2 and by["order"].type == "int"
    assert by["u_min"].default == -math.inf and by["u_min"].as_json()["default"] == "-inf"
