"""Scenario errors name the line of their key path (``FILE, line N: KEY: PROBLEM``).

The line is looked up in the text only when an error is raised
(:func:`ctrlblocks.loops.toml.key_lines`): a valid scenario, and every valid
parameter set of a sweep, pays nothing for it.
"""

from __future__ import annotations

import pickle

import pytest
from click.testing import CliRunner

import ctrlblocks.loops.toml as toml_mod
from ctrlblocks.cli import main
from ctrlblocks.loops.toml import read_toml
from ctrlblocks.sim.scenario import ScenarioError, load_scenario, parse_scenario, parse_scenario_doc
from ctrlblocks.sim.sweep import SweepError, _scenario, sweep

TEXT = """\
[scenario]
name = "lines"
title = "t"
structure = "scheduled"
ts = 0.2
duration = 20.0

[plant]
type = "FOPDT"
k = 1.0
t = 5.0
dead_time = 1.0

[[controllers]]
name = "fixed"
[controllers.main]
type = "PID"
kp = 1.0
ti = 5.0
[controllers.schedule]
on = "sp"
breakpoints = [0.0]
kp = [1.0]

[[controllers]]
name = "scheduled"
[controllers.main]
type = "PID"
kp = 1.0
ti = 5.0
[controllers.schedule]
on = "sp"
breakpoints = [0.0, 1.0]
kp = [1.0, 2.0]

[[events]]
t = 1.0
do = "setpoint"
value = 1.0

[[events]]
t = 10.0
do = "load"
value = 0.1
"""

LINES = TEXT.splitlines()


def line_of(text: str, written: str, nth: int = 0) -> int:
    """The 1-based line of the ``nth`` line of ``text`` that reads ``written``."""
    hits = [i + 1 for i, s in enumerate(text.splitlines()) if s == written]
    return hits[nth]


def error_of(text: str) -> ScenarioError:
    with pytest.raises(ScenarioError) as e:
        parse_scenario(text, file="bad.toml")
    return e.value


def test_an_unknown_key_in_plant_names_its_line() -> None:
    text = TEXT.replace("dead_time = 1.0\n", "dead_time = 1.0\nkk = 2.0\n")
    e = error_of(text)
    assert (e.key, e.line) == ("plant.kk", 13) and line_of(text, "kk = 2.0") == 13
    assert str(e) == f"bad.toml, line 13: plant.kk: {e.problem}"
    assert e.problem.startswith("unknown key 'kk' (did you mean 'k'?)")
    # the same mistake in a document built in Python: no line
    doc = read_toml(TEXT, "d.toml")
    doc["plant"]["kk"] = 2.0
    with pytest.raises(ScenarioError) as d:
        parse_scenario_doc(doc, file="d.toml")
    assert d.value.line is None and str(d.value) == f"d.toml: plant.kk: {e.problem}"


def test_a_bad_value_in_the_second_controller_names_that_entry_s_line() -> None:
    # the second entry's main.kp (line 29), not the first one's (line 18)
    first, second = TEXT.rsplit("kp = 1.0\n", 1)
    text = first + "kp = -1.0\n" + second
    e = error_of(text)
    assert e.key == "controllers[1].main.kp" and "must be > 0" in e.problem
    assert e.line == line_of(text, "kp = -1.0") == 29
    assert str(e).startswith("bad.toml, line 29: controllers[1].main.kp: must be > 0")


def test_a_bad_event_names_the_line_of_its_field_or_of_its_entry() -> None:
    e = error_of(TEXT.replace('do = "load"', 'do = "explode"'))
    assert (e.key, e.line) == ("events[1].do", 43) and LINES[42] == 'do = "load"'
    # a missing field: the [[events]] header of that entry
    e = error_of(TEXT.replace('do = "load"\nvalue = 0.1\n', 'do = "load"\n'))
    assert (e.key, e.line) == ("events[1].value", 41) and line_of(TEXT, "[[events]]", 1) == 41
    assert str(e).startswith("bad.toml, line 41: events[1].value: missing")


def test_a_nested_table_of_an_array_entry_names_its_line() -> None:
    text = TEXT.replace('on = "sp"\nbreakpoints = [0.0, 1.0]', 'on = "z"\nbreakpoints = [0.0, 1.0]')
    e = error_of(text)
    assert (e.key, e.line) == ("controllers[1].schedule.on", 32) and LINES[31] == 'on = "sp"'
    e = error_of(TEXT.replace("kp = [1.0, 2.0]", "kp = [1.0]"))
    assert (e.key, e.line) == ("controllers[1].schedule.kp", 34)
    e = error_of(TEXT.replace("breakpoints = [0.0, 1.0]", "breakpoints = [1.0, 0.0]"))
    assert (e.key, e.line) == ("controllers[1].schedule.breakpoints", 33)


def test_load_scenario_names_the_line_and_a_file_that_is_not_utf8(tmp_path) -> None:
    p = tmp_path / "s.toml"
    p.write_text(TEXT.replace("t = 5.0\n", 't = "slow"\n'), encoding="utf-8")
    with pytest.raises(ScenarioError) as e:
        load_scenario(p)
    assert str(e.value).startswith(f"{p}, line 11: plant.t: must be a number")
    p.write_bytes(b"[scenario]\n# \xff\n")
    with pytest.raises(ScenarioError) as e:
        load_scenario(p)
    assert str(e.value) == f"{p}, line 2: not a UTF-8 text file (byte 0xff)"


def test_the_error_pickles_with_its_line() -> None:
    # a process pool ships it back from a worker
    e = error_of(TEXT.replace("dead_time = 1.0\n", "dead_time = 1.0\nkk = 2.0\n"))
    back = pickle.loads(pickle.dumps(e))
    assert type(back) is ScenarioError and str(back) == str(e) and back.line == 13


def test_the_line_map_is_built_only_for_an_error(monkeypatch, tmp_path) -> None:
    calls = []
    real = toml_mod.key_lines
    monkeypatch.setattr(toml_mod, "key_lines", lambda text: calls.append(1) or real(text))
    assert [c.name for c in parse_scenario(TEXT).controllers] == ["fixed", "scheduled"]
    for kp in (0.5, 1.0, 2.0):  # a sweep's sets: one document, copied per set
        _scenario(TEXT, "ok.toml", {"controllers[1].main.kp": kp})
    assert calls == []
    with pytest.raises(ScenarioError) as e:
        _scenario(TEXT, "ok.toml", {"controllers[1].main.kp": -1.0})
    assert calls == [1] and e.value.line == 29
    # the sweep's check names the file's line of the varied key
    p = tmp_path / "s.toml"
    p.write_text(TEXT, encoding="utf-8")
    with pytest.raises(SweepError) as s:
        sweep(p, {"controllers[1].main.kp": [1.0, -1.0]}, executor="serial")
    assert str(s.value).startswith(
        f"with controllers[1].main.kp = -1.0: {p}, line 29: controllers[1].main.kp: must be > 0"
    )


def test_run_prints_one_line_with_file_line_and_key(tmp_path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(TEXT.replace('do = "load"', 'do = "explode"'), encoding="utf-8")
    res = CliRunner().invoke(main, ["run", str(bad), "--out", str(tmp_path / "out")])
    assert res.exit_code == 1 and isinstance(res.exception, SystemExit), res.output
    out = res.output.strip().splitlines()
    assert len(out) == 1 and "Traceback" not in res.output, res.output
    assert out[0].startswith(f"Error: {bad}, line 43: events[1].do: unknown event 'explode'")
    assert not (tmp_path / "out").exists()
    # a file that is not UTF-8: one line too, not a traceback
    bad.write_bytes(b"[scenario]\n# \xff\n")
    res = CliRunner().invoke(main, ["run", str(bad), "--out", str(tmp_path / "out")])
    assert res.exit_code == 1 and isinstance(res.exception, SystemExit), res.output
    assert res.output.strip() == f"Error: {bad}, line 2: not a UTF-8 text file (byte 0xff)"
