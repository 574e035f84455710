"""``ctrlblocks export``: every way of giving the block, every target, clear errors."""

from __future__ import annotations

import json
import re
from importlib import resources

from click.testing import CliRunner

from ctrlblocks.cli import main


def _run(*args: str):
    return CliRunner().invoke(main, list(args), catch_exceptions=False)


def test_export_with_set_prints_the_st_of_the_configured_pid():
    r = _run("export", "pid", "--set", "kp=2.5", "--set", "ti=30", "--set", "reverse=true")
    assert r.exit_code == 0, r.output
    assert "FUNCTION_BLOCK CB_PID" in r.output
    assert "K : REAL := 2.5;" in r.output and "REVERSE : BOOL := TRUE;" in r.output


def test_export_from_a_tune_json_file_to_a_tia_source(tmp_path):
    tuned = tmp_path / "pid.json"
    tuned.write_text(json.dumps({"kp": 1.2, "ti": 5.8, "td": 0.9, "reverse": False,
                                 "rule": "amigo", "form": "ISA"}))  # fmt: skip
    out = tmp_path / "PID.scl"
    r = _run("export", "--from-json", str(tuned), "--set", "ts=0.2", "--target", "tia",
             "--out", str(out))  # fmt: skip
    assert r.exit_code == 0, r.output
    text = out.read_text()
    assert 'FUNCTION_BLOCK "CB_PID"' in text and "TI : Real := 5.8;" in text


def test_export_a_controller_of_a_shipped_scenario_as_plcopen(tmp_path):
    toml = resources.files("ctrlblocks") / "scenarios" / "nowak_fig5.toml"
    out = tmp_path / "adrc.xml"
    r = _run("export", "--toml", str(toml), "--target", "plcopen", "--out", str(out))
    assert r.exit_code == 0, r.output
    assert 'pouType="functionBlock"' in out.read_text()


def test_export_tcpou_writes_one_file_per_pou(tmp_path):
    r = _run("export", "leadlag", "--set", "t_lead=2", "--target", "twincat", "--tcpou",
             "--out", str(tmp_path / "plc"))  # fmt: skip
    assert r.exit_code == 0, r.output
    names = {p.name for p in (tmp_path / "plc").iterdir()}
    assert "CB_LEADLAG.TcPOU" in names and len(names) >= 3


def test_export_mistakes_are_messages_not_tracebacks(tmp_path):
    r = _run("export", "pid", "--set", "kq=1")
    assert r.exit_code == 2 and "no parameter(s) kq" in r.output
    r = _run("export", "pid", "--set", "deadband=0.5", "--set", "ti=1", "--set", "t_stab=20000")
    assert r.exit_code == 1 and "does not cover the PID options ['t_stab']" in r.output
    # the delayed observer exports (a DELAY ring sized at export), it is no mistake
    r = _run("export", "adrc", "--set", "order=1", "--set", "b0=1", "--set", "input_delay=0.5")
    assert r.exit_code == 0 and "DELAY" in r.output, r.output
    r = _run("export", "pid", "--set", "kp=-1")
    assert r.exit_code == 1 and "kp" in r.output
    r = _run("export", "pid", "--set", "novalue")
    assert r.exit_code == 2 and "KEY=VALUE" in r.output
    r = _run("export")
    assert r.exit_code == 2 and "BLOCK_TYPE" in r.output
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    r = _run("export", "--from-json", str(bad))
    assert r.exit_code == 1 and "cannot read JSON" in r.output
    toml = resources.files("ctrlblocks") / "scenarios" / "nowak_fig5.toml"
    r = _run("export", "--toml", str(toml), "--controller", "nope")
    assert r.exit_code == 2 and "no controller 'nope'" in r.output


def test_a_reverse_acting_adrc_from_tune_adrc_exports_with_reverse(tmp_path):
    # a negative process gain: tune adrc sets reverse, and the exported FB has it
    r = _run("tune", "adrc", "--order", "2", "--gain", "-2", "--time-constant", "5",
             "--dead-time", "1", "--json")  # fmt: skip
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["reverse"] is True
    tuned = tmp_path / "adrc.json"
    tuned.write_text(r.output)
    r = _run("export", "--from-json", str(tuned))  # at the tuning's ts
    assert r.exit_code == 0, r.output
    assert "FUNCTION_BLOCK CB_ADRC" in r.output and "REVERSE : BOOL := TRUE;" in r.output
    assert re.search(r"^    TS : REAL := 0\.02;", r.output, re.M)


def test_export_takes_a_one_cycle_block_of_a_shipped_scenario():
    """The two-point thermostat scenario's controller exports as CB_TWOPOINT with the
    scenario's hysteresis (HYSTERESIS is a standard FB's name: escaped)."""
    toml = resources.files("ctrlblocks") / "scenarios" / "two_point_thermostat.toml"
    r = _run("export", "--toml", str(toml), "--controller", "H = 4 K", "--target", "codesys")
    assert r.exit_code == 0, r.output
    assert "FUNCTION_BLOCK CB_TWOPOINT" in r.output and "HYSTERESIS_v : REAL := 4.0;" in r.output
