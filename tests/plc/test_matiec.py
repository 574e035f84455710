"""The exports compiled by a real IEC 61131-3 compiler and run: bit for bit the float32 block.

MATIEC (``iec2c``, the compiler of Beremiz and OpenPLC; GPL, built outside the
project by ``tests/plc/build_matiec.sh``, see :mod:`.matiec`) compiles every
exported configuration *strictly* (no ``-b``: standard syntax only); gcc
compiles the C (``-O2 -fsingle-precision-constant -ffp-contract=off``); the
compiled FUNCTION_BLOCK is driven over

* the project's own traces (:mod:`.traces`: setpoint steps, noise, limits,
  MAN/AUTO, RESET, TRACK, HOLD, AWIN, NaN/inf and 1.7e308/3e38 PV spikes,
  PV_OK false, retunes and new limits, the dead band's windows), and
* seeded hostile sequences (:mod:`.hostile`: NaN/inf/1.7e308/3e38/denormal
  SP and PV, random modes, retunes through ``configure()``, a jittering and
  sometimes broken cycle time),

and MV, ERROR_ID and the flags (and P/I/D, U_RAW, MAN_VALUE in the hostile
runs) are compared with the ``precision="float32"`` block after every call:
equal bits are required.  The exported test bench (a plain ST PROGRAM)
is compiled and run the same way, and the PLCopen XML is read back to ST as
Beremiz reads it and compiled.

The default run keeps a strict-compile smoke test (iec2c only); the runs
(gcc, the campaigns) are ``@pytest.mark.slow``.  Without a MATIEC build the tests skip
with a message (they fail instead under ``CTRLBLOCKS_REQUIRE_MATIEC=1``, as
in ``.ci/run``).
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ctrlblocks import ADRC, PID, LeadLag, Regulator, plc

from . import matiec
from .hostile import STARTS as HOSTILE
from .hostile import hostile_trace
from .plcopen_reader import BeremizReadError, st_from_plcopen
from .test_cycle_blocks_export import BLOCKS as CYCLE_BLOCKS
from .traces import (
    ADRC_OPTIONS,
    DB_OPTIONS,
    PID_OPTIONS,
    REAL_SPIKE,
    adrc_trace,
    leadlag_trace,
    pid_trace,
    replay,
    ulps,
)

FB = {"pid": "CB_PID", "adrc": "CB_ADRC", "leadlag": "CB_LEADLAG"}
FLAG = {"CB_PID": "LIMITS_ACTIVE", "CB_ADRC": "AWOUT", "CB_LEADLAG": None}


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    matiec.require_matiec()
    return tmp_path_factory.mktemp("matiec")


def _compiled(block: Any, cache: Path, fb: str) -> matiec.Instance:
    return matiec.build(plc.export(block, "codesys"), cache, [fb]).instance(fb)


def _same(got: Any, ref: Any) -> bool:
    if isinstance(ref, bool) or isinstance(got, bool):
        return bool(got) == bool(ref)
    if isinstance(ref, int):
        return int(got) == ref
    return ulps(got, ref) == 0


# ---------------------------------------------------------------------------
# default run: a strict compile of every block kind with its test bench
# ---------------------------------------------------------------------------


SMOKE = {"pid": PID(kp=1.2, ti=5.9, td=0.9, ts=0.1, u_min=0.0, u_max=100.0),
         "pid_all": PID(kp=2.0, ti=3.0, algorithm="velocity", pv_range=(0.0, 250.0),
                        sp_filter=1.0, out_rate=5.0, ff_k=0.5, bumpless="suppress_p_action",
                        anti_windup="back_calc_real", deadband=0.5, t_stab=1.0),
         "adrc": ADRC(order=2, b0=0.05, omega_c=0.5, omega_o=2.5, ts=0.1, t_ref=1.0),
         "adrc_exact": ADRC(order=3, b0=0.01, discretisation="exact", u_real_on=True,
                            anti_backoff=True, y_sat=90.0, reverse=True),
         "leadlag": LeadLag(k=2.0, t_lead=1.0, t_lag=3.0, method="euler", out_max=9.0)}  # fmt: skip


def test_every_block_kind_in_one_project_with_test_benches_compiles_strictly(tmp_path):
    """The five PID/ADRC/lead-lag configurations and the six one-cycle blocks (two/three-point,
    transfer function, set-point program, heat/cool stage, the regulator's stations), their
    helpers once, and a test program per block: iec2c without -b (standard syntax only)
    accepts the file."""
    blocks = {f"CB_{k.upper()}": b for k, b in SMOKE.items()}
    blocks.update((k, make()) for k, make in CYCLE_BLOCKS.items())
    src = plc.export(blocks, "codesys", test="plain")
    tests = re.findall(r"^PROGRAM (\w+_TEST)$", src, re.M)
    assert len(tests) == len(blocks)
    matiec.iec2c(src + matiec.configuration(list(blocks), tests), tmp_path)


def test_the_documented_regulator_wiring_compiles_strictly(tmp_path):
    """docs/plc.md's PROGRAM wiring CB_REGULATOR to CB_PID, with the two FBs exported from one
    Regulator: iec2c without -b accepts it."""
    doc = (Path(__file__).resolve().parents[2] / "docs" / "plc.md").read_text(encoding="utf-8")
    prog = re.search(r"^(PROGRAM REGULATOR_LOOP\n.*?^END_PROGRAM\n)", doc, re.M | re.S)
    assert prog is not None
    reg = Regulator(kp=2.0, ti=10.0, sp0=50.0, u0=40.0, ts=0.1)
    src = plc.export([reg, reg.pid], "codesys") + "\n" + prog.group(1)
    matiec.iec2c(src + matiec.configuration([], ["REGULATOR_LOOP"]), tmp_path)


@pytest.mark.slow
def test_the_exported_test_bench_passes_on_the_compiled_fb(tmp_path):
    """The plain test program (the recorded trace, 120 samples) compiled by MATIEC and gcc:
    every sample's MV, ERROR_ID and LIMITS_ACTIVE equal the recorded ones."""
    src = plc.export(SMOKE["pid"], "codesys", test="plain")
    prog = matiec.build(src, tmp_path, [], ["CB_PID_TEST"]).instance("CB_PID_TEST")
    assert prog() == matiec.FE_INVALID | matiec.FE_OVERFLOW  # the NaN and inf samples
    assert (prog["DONE"], prog["SAMPLES"], prog["FAILURES"]) == (True, 120, 0)
    assert prog["FIRST_FAILURE"] == -1


# ---------------------------------------------------------------------------
# the campaigns
# ---------------------------------------------------------------------------


TRACES = [
    ("pid", lambda: pid_trace(1500, seed=1)),
    ("pid", lambda: pid_trace(400, seed=2, integral_method="forward", derivative_method="tustin",
                              c=0.5, b=0.7, anti_windup="back_calc_model", tt=1.0, reverse=True)),
    ("pid", lambda: pid_trace(400, seed=2, integral_method="backward", derivative_method="forward",
                              td=2.0, ti=0.0, safe_value=12.5, reset_value=25.0)),
    *(("pid", lambda c=c: pid_trace(900, seed=30, modes=True, **c)) for c in PID_OPTIONS),
    *(("pid", lambda c=c: pid_trace(1000, seed=60, **c)) for c in DB_OPTIONS),
    ("adrc", lambda: adrc_trace(1500, seed=3)),
    ("adrc", lambda: adrc_trace(400, seed=4, order=1, b0=0.5, anti_windup="freeze", t_ref=2.0,
                                u_sf=7.0)),
    ("adrc", lambda: adrc_trace(400, seed=4, order=3, b0=0.01, omega_c=0.3, omega_o=1.2,
                                anti_windup="off")),
    *(("adrc", lambda c=c: adrc_trace(900, seed=50, modes=True, **c)) for c in ADRC_OPTIONS),
    ("leadlag", lambda: leadlag_trace(600, seed=5, method="tustin")),
    ("leadlag", lambda: leadlag_trace(600, seed=5, method="euler")),
]  # fmt: skip
"""The project's traces (those the interpreter tests ran): 28 cases, 24,100 cycles."""


@pytest.mark.slow
@pytest.mark.parametrize("case", range(len(TRACES)))
def test_compiled_fb_equals_float32_block_over_the_project_traces(case, cache):
    kind, make = TRACES[case]
    block, trace = make()
    fb = _compiled(block, cache, FB[kind])
    got = replay(fb, trace, "OUT" if kind == "leadlag" else "MV", FLAG[FB[kind]])
    for k, (g, ref) in enumerate(zip(got, trace.outputs, strict=True)):
        assert ulps(g[0], ref[0]) == 0, f"sample {k}: FB {g[0]!r} vs block {ref[0]!r}"
        assert g[1] == ref[1], f"sample {k}: ERROR_ID 16#{g[1]:04X} vs 16#{ref[1]:04X}"
        assert g[2] == ref[2], f"sample {k}: flag {g[2]} vs {ref[2]}"


SEEDS = (11, 12, 13)


@pytest.mark.slow
@pytest.mark.parametrize("jitter", [False, True], ids=["fixed_ts", "jittering_ts"])
@pytest.mark.parametrize("case", range(len(HOSTILE)))
def test_compiled_fb_equals_float32_block_over_seeded_hostile_sequences(case, jitter, cache):
    """8 configurations x 3 seeds x 2 cycle-time modes x 1000 samples = 48,000 cycles: every
    output the block exposes is bit-equal after every call."""
    kind, cfg = HOSTILE[case]
    for seed in SEEDS:
        block, run = hostile_trace(kind, 1000, seed + 100 * case, jitter=jitter, **cfg)
        fb = _compiled(block, cache, FB[kind])
        for k, (inp, out) in enumerate(zip(run.inputs, run.outputs, strict=True)):
            fb(**inp)
            for name, ref in out.items():
                assert _same(fb[name], ref), (
                    f"seed {seed}, sample {k}: {name} = {fb[name]!r}, block {ref!r}; "
                    f"inputs {inp}")  # fmt: skip


def _configurations() -> list[tuple[str, Any]]:
    out: list[tuple[str, Any]] = [(k, b) for k, b in SMOKE.items()]
    out += [(f"pid_option{j}", PID(**{"kp": 1.5, "ti": 4.0, "td": 0.5, **c})) for j, c in
            enumerate(PID_OPTIONS + DB_OPTIONS)]  # fmt: skip
    out += [(f"adrc_option{j}", ADRC(**{"order": 2, "b0": 0.05, **c}))
            for j, c in enumerate(ADRC_OPTIONS)]  # fmt: skip
    out += [(f"hostile{j}", {"pid": PID, "adrc": ADRC, "leadlag": LeadLag}[k](**c))
            for j, (k, c) in enumerate(HOSTILE)]  # fmt: skip
    return out + [(k.lower(), make()) for k, make in CYCLE_BLOCKS.items()]


@pytest.mark.slow
@pytest.mark.parametrize("target", ["codesys", "beremiz", "plcopen"])
def test_every_exported_configuration_compiles_strictly(target, tmp_path):
    """Every configuration the tests use (33) and the six one-cycle blocks, each with its
    test bench, in one project: the ST as written (TwinCAT's text is the same,
    test_export.py), the XML read back to ST (the Beremiz form as Beremiz reads it). TIA's
    SCL is another language (checked offline)."""
    configs = _configurations()
    src = plc.export([b for _n, b in configs], target, test="plain")
    if target in ("beremiz", "plcopen"):
        src = st_from_plcopen(src, "beremiz" if target == "beremiz" else "codesys")
    kinds = "PID|ADRC|LEADLAG|TWOPOINT|THREEPOINT|TRANSFER|SETPOINT|HEATCOOL|REGULATOR"
    fbs = re.findall(rf"^FUNCTION_BLOCK (CB_(?:{kinds})(?:_\d+)?)$", src, re.M)
    tests = re.findall(r"^PROGRAM (\w+_TEST)$", src, re.M)
    assert len(fbs) == len(tests) == len(configs)
    matiec.iec2c(src + matiec.configuration(fbs, tests), tmp_path)


@pytest.mark.slow
def test_beremiz_xml_read_back_compiles_and_equals_the_block_bit_for_bit(cache):
    """Beremiz -> ST -> MATIEC: the XML of the PID read as Beremiz reads it runs the
    project's long trace bit-identically; the CODESYS form gives Beremiz no body text."""
    block, trace = pid_trace(900, seed=30, modes=True, **PID_OPTIONS[2])
    st = st_from_plcopen(plc.export(block, "beremiz", test="plain"))
    fb = matiec.build(st, cache, ["CB_PID"], ["CB_PID_TEST"]).instance("CB_PID")
    got = replay(fb, trace, "MV", "LIMITS_ACTIVE")
    assert [(ulps(g[0], r[0]), g[1], g[2]) for g, r in zip(got, trace.outputs, strict=True)] == [
        (0, r[1], r[2]) for r in trace.outputs]  # fmt: skip
    with pytest.raises(BeremizReadError, match="xhtml:p"):
        st_from_plcopen(plc.export(block, "plcopen"))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["pid", "pid_all", "adrc", "adrc_exact", "leadlag",
                                  *sorted(CYCLE_BLOCKS)])  # fmt: skip
def test_every_test_bench_passes_on_its_compiled_fb(name, cache):
    block = SMOKE[name] if name in SMOKE else CYCLE_BLOCKS[name]()
    src = plc.export(block, "codesys", test="plain")
    fb = src.split("PROGRAM ")[1].split()[0]
    prog = matiec.build(src, cache, [], [fb]).instance(fb)
    prog()
    assert (prog["DONE"], prog["FAILURES"], prog["FIRST_FAILURE"]) == (True, 0, -1)
    assert prog["SAMPLES"] == 120


@pytest.mark.slow
def test_a_wrong_expectation_makes_the_test_bench_fail(tmp_path):
    """The bench can fail: one recorded MV changed by one ulp is found at its sample."""
    block = SMOKE["leadlag"]
    src = plc.export(block, "codesys", test="plain")
    from ctrlblocks.plc.bench import default_trace, record
    from ctrlblocks.plc.export import real32_literal
    from ctrlblocks.plc.specs import spec_for

    bench = record(spec_for(block), default_trace(spec_for(block)))
    k = 70
    v = np.float32(bench.expected[k]["OUT"])
    old = f"(fb.OUT = {real32_literal(v)})"
    assert old in src
    wrong = np.nextafter(v, np.float32(math.inf))
    src = src.replace(old, f"(fb.OUT = {real32_literal(wrong)})", 1)
    prog = matiec.build(src, tmp_path, [], ["CB_LEADLAG_TEST"]).instance("CB_LEADLAG_TEST")
    prog()
    assert (prog["FAILURES"], prog["FIRST_FAILURE"]) == (1, k)


FPE_FLTOVF = 4  # si_code of a SIGFPE on a floating-point overflow (Linux)


@pytest.mark.slow
@pytest.mark.parametrize("case", range(len(TRACES)))
def test_with_fp_exceptions_unmasked_only_a_law_beyond_real_stops_the_compiled_fb(case, cache):
    """NaN, inf and 1.7e308 inputs raise no floating-point exception (the NaN test is a quiet
    comparison); the first cycle that raises one is a PV spike whose arithmetic overflows REAL
    (3e38: FE_OVERFLOW), and with the exceptions unmasked the FB stops exactly there."""
    kind, make = TRACES[case]
    block, trace = make()
    lib = matiec.build(plc.export(block, "codesys"), cache, [FB[kind]])
    fb = lib.instance(FB[kind])
    flags = [fb(**inp) for inp in trace.inputs]
    first = next((k for k, f in enumerate(flags) if f), None)
    before = trace.inputs[: len(flags) if first is None else first]
    assert any(v != v for inp in before for v in inp.values() if isinstance(v, float))
    if first is None:
        return
    assert flags[first] & matiec.FE_OVERFLOW and trace.inputs[first]["PV"] == REAL_SPIKE
    trapped = lib.instance(FB[kind])
    trapped.trap = True
    codes = [trapped(**inp) for inp in trace.inputs[: first + 1]]
    assert codes[:-1] == [0] * first and codes[-1] == -FPE_FLTOVF, lib.trap_site()


def test_the_alarm_blocks_translate_to_st_that_compiles_strictly(tmp_path):
    """CB_ALARM and CB_ROC (blocks/alarms.py, small blocks in the translator's subset)."""
    from ctrlblocks.blocks import alarms
    from ctrlblocks.plc.export import DIALECTS, _small_block
    from ctrlblocks.plc.translate import Program

    prog = Program()
    fbs = [prog.fb_type(fn).pou for fn in (alarms.alarm_cycle, alarms.rate_cycle)]
    st = DIALECTS["codesys"]
    lines = [ln for p in prog.ordered() for ln in st.function_text(p)]
    lines += [ln for name in fbs for ln in st.fb_text(_small_block(prog.fbs[name]))]
    matiec.iec2c("\n".join(lines) + "\n" + matiec.configuration(fbs), tmp_path)


@pytest.mark.slow
def test_the_build_script_finds_the_source_archive_from_a_fresh_clone(tmp_path):
    """.ci/run in a fresh clone (``git clone . "$(mktemp -d)/c"``): the build script there
    finds the archive this checkout finds (beside the repository it was cloned from)."""
    import subprocess

    script = Path(__file__).with_name("build_matiec.sh")
    root = script.parents[2]
    env = {k: v for k, v in os.environ.items() if k != "CTRLBLOCKS_MATIEC_ARCHIVE"}

    def find(cwd: Path) -> subprocess.CompletedProcess[str]:
        return subprocess.run(["bash", "tests/plc/build_matiec.sh", "--archive"], cwd=cwd,
                              env=env, capture_output=True, text=True, timeout=60,
                              check=False)  # fmt: skip

    here = find(root)
    if here.returncode == 2:
        pytest.skip(f"no MATIEC source archive beside this checkout: {here.stderr.strip()}")
    assert here.returncode == 0, here.stderr
    clone = tmp_path / "c"
    subprocess.run(["git", "clone", "-q", "--no-checkout", str(root), str(clone)], check=True,
                   timeout=300)  # fmt: skip
    subprocess.run(["git", "checkout", "-q", "HEAD", "--", "tests/plc/build_matiec.sh"],
                   cwd=clone, check=True, timeout=60)  # fmt: skip
    (clone / "tests" / "plc" / "build_matiec.sh").write_bytes(script.read_bytes())  # this one's
    there = find(clone)
    assert there.returncode == 0, there.stderr
    assert Path(there.stdout.strip()).resolve() == Path(here.stdout.strip()).resolve()
