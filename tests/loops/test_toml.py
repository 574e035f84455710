"""The TOML helpers shared by the scenario parser and the runtime's configuration."""

from __future__ import annotations

import math

import pytest

from ctrlblocks.loops.toml import (
    KeyPathError,
    TableReader,
    key_line,
    key_lines,
    located,
    read_text,
    read_toml,
    type_name,
)
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
    # a NaN written in a file is refused unless the caller allows it
    with pytest.raises(KeyPathError, match=r"t\.x: must not be NaN"):
        r.number({"x": math.nan}, "x", "t.x")
    assert math.isnan(r.number({"x": math.nan}, "x", "t.x", allow_nan=True))
    assert r.number({"x": -math.inf}, "x", "t.x", limit=True) == -math.inf  # no limit
    # +-inf is no number but a limit's "none": any other field refuses it where it is written
    for v in (math.inf, -math.inf):
        with pytest.raises(KeyPathError, match=r"t\.x: must be finite, got -?inf"):
            r.number({"x": v}, "x", "t.x")
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


DOC = """\
name = "x"
notes = '''
[loops]
kp = 9
'''
[[loops]]
name = "a"
block.kp = 1.0
[[loops]]
name = "b"
[loops.block]
"kp" = 2.0
[loops.block.limits]
u_min = 0
"""


def test_key_lines_maps_keys_tables_and_array_entries_to_their_lines() -> None:
    lines = key_lines(DOC)
    assert lines == {
        "name": 1,
        "notes": 2,  # the multi-line string's lines are no keys
        "loops[0]": 6,
        "loops[0].name": 7,
        "loops[0].block": 8,
        "loops[0].block.kp": 8,
        "loops[1]": 9,
        "loops[1].name": 10,
        "loops[1].block": 11,
        "loops[1].block.kp": 12,
        "loops[1].block.limits": 13,
        "loops[1].block.limits.u_min": 14,
    }
    # a key not written: its nearest parent (the table, the array entry)
    assert key_line(DOC, "loops[1].block.ti") == 11
    assert key_line(DOC, "loops[1].block.u_min/u_max") == 11
    assert key_line(DOC, "loops[0].pv") == 6
    assert key_line(DOC, "historian.db") is None


def test_located_gives_an_error_the_line_of_its_key_path_once() -> None:
    with pytest.raises(RuntimeConfigError) as e, located(DOC):
        raise RuntimeConfigError("c.toml", "loops[1].block.kp", "must be > 0")
    assert type(e.value) is RuntimeConfigError and e.value.line == 12
    assert str(e.value) == "c.toml, line 12: loops[1].block.kp: must be > 0"
    # a line it has (a syntax error), no key path, or no text: left as it is
    for text, err in [
        (DOC, KeyPathError("c.toml", "name", "p", 3)),
        (DOC, KeyPathError("c.toml", "", "p")),
        (None, KeyPathError("c.toml", "name", "p")),
    ]:
        before = str(err)
        with pytest.raises(KeyPathError) as e, located(text):
            raise err
        assert e.value is err and str(err) == before and err.line == (3 if err.line else None)


def test_read_text_names_an_unreadable_or_non_utf8_file(tmp_path) -> None:
    p = tmp_path / "c.toml"
    with pytest.raises(RuntimeConfigError, match=r"c\.toml: cannot read the file \(No such"):
        read_text(p, RuntimeConfigError)
    p.write_bytes(b"a = 1\n\n# caf\xe9\n")
    with pytest.raises(KeyPathError) as e:
        read_text(p)
    assert (e.value.line, e.value.problem) == (3, "not a UTF-8 text file (byte 0xe9)")
