"""The TOML helpers shared by the scenario parser and the runtime's configuration."""

from __future__ import annotations

import math

import pytest

from ctrlblocks.loops.toml import KeyPathError, TableReader, read_toml, type_name
from ctrlblocks.runtime import RuntimeConfigError
from ctrlblocks.sim import ScenarioError


def test_type_name_names_toml_types() -> None:
    assert [type_name(v) for v in ({}, [], "x", True, 1, 1.5)] == [
        "a table",
        "an array",
        "a string",
        "a boolean",
        "an integer",
        "a number",
    ]


def test_read_toml_reports_the_line_with_the_given_error_class() -> None:
    assert read_toml("a = 1\n[b]\nc = 'x'", "f.toml") == {"a": 1, "b": {"c": "x"}}
    with pytest.raises(RuntimeConfigError) as e:
        read_toml("a = 1\nb = = 2\n", "f.toml", RuntimeConfigError)
    assert e.value.line == 2 and e.value.problem.startswith("TOML syntax error")
    assert str(e.value).startswith("f.toml, line 2: TOML syntax error")


def test_both_file_errors_share_the_key_path_base() -> None:
    assert issubclass(ScenarioError, KeyPathError) and issubclass(RuntimeConfigError, KeyPathError)
    err = ScenarioError("s.toml", "scenario.ts", "must be > 0")
    assert str(err) == "s.toml: scenario.ts: must be > 0"


def test_table_reader_number_checks_type_nan_and_sign() -> None:
    r = TableReader("r.toml")
    assert r.number({"x": 2}, "x", "t.x") == 2.0 and type(r.number({"x": 2}, "x", "t.x")) is float
    assert r.number({}, "x", "t.x", default=None) is None
    assert math.isnan(r.number({"x": math.nan}, "x", "t.x"))
    with pytest.raises(KeyPathError, match=r"t\.x: must not be NaN"):
        r.number({"x": math.nan}, "x", "t.x", allow_nan=False)
    with pytest.raises(KeyPathError, match=r"t\.x: must be > 0, got -1"):
        r.number({"x": -1}, "x", "t.x", positive=True)
    with pytest.raises(KeyPathError, match=r"t\.x: must be a number, got a boolean True"):
        r.number({"x": True}, "x", "t.x")
    with pytest.raises(KeyPathError, match=r"t\.x: missing"):
        r.number({}, "x", "t.x")


def test_table_reader_check_keys_names_the_first_unknown_key() -> None:
    with pytest.raises(KeyPathError) as e:
        TableReader("r.toml").check_keys({"a": 1, "zz": 2, "yy": 3}, {"a", "b"}, "t")
    assert e.value.key == "t.yy" and e.value.problem == "unknown key 'yy'; valid keys: a, b"


def test_a_reader_subclass_raises_its_own_error_class() -> None:
    class Reader(TableReader):
        error = RuntimeConfigError

    with pytest.raises(RuntimeConfigError, match=r"r\.toml: t\.x: missing"):
        Reader("r.toml").number({}, "x", "t.x")
    with pytest.raises(KeyPathError) as e:
        TableReader("r.toml").number({}, "x", "t.x")
    assert type(e.value) is KeyPathError
