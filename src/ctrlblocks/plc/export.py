"""Render the translated POUs in the dialect of each PLC target.

Targets (:data:`DIALECTS`, one :class:`Dialect` object each)
------------------------------------------------------------
``"codesys"``
    IEC 61131-3 Structured Text as CODESYS V3 writes it (paste into POUs or
    import the ``"plcopen"`` file).
``"twincat"``
    The same ST (TwinCAT 3 is CODESYS-based); :func:`export_files` gives one
    ``.TcPOU`` XML file per POU, which TwinCAT 3 adds to a PLC project.
``"tia"``
    Siemens SCL external source (``.scl``) for TIA Portal: ``"quoted"`` block
    names, ``#``-prefixed local variables, ``{ S7_Optimized_Access := 'TRUE' }``,
    ``BEGIN``, ``REGION`` ... ``END_REGION``.
``"plcopen"``
    PLCopen XML (TC6 0201) project with every POU's body in ST, the text as
    CODESYS and TwinCAT write and read it (``<xhtml xmlns=...>``).
``"beremiz"``
    The same project as Beremiz and the OpenPLC editor read it: every text in
    ``<xhtml:p><![CDATA[...]]></xhtml:p>`` (their reader takes the first
    ``xhtml:p`` of a text and nothing else).

Several blocks export into one project (:func:`export` of a list or a dict):
each helper POU once -- a POU's name is the Python function it is translated
from (and the array sizes of a small block), so a name has one text in every
export of this version -- and one FUNCTION_BLOCK per block.  ``test=True``
adds the test bench (:mod:`.bench`) in the target's unit-test form.

Only declarations, headers, this dialect syntax and the test bench's frame are
written here; the statements come from :mod:`.translate` (the blocks' own
Python).
"""

from __future__ import annotations

import re
import uuid
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import datetime, timezone
from typing import Any, ClassVar
from xml.sax.saxutils import escape, quoteattr

import numpy as np

from ..blocks import plc_cycle as pc
from .bench import Bench, default_trace, record
from .names import iec_name, is_iec_identifier
from .specs import BlockSpec, spec_for
from .translate import (
    BOOL,
    DINT,
    REAL,
    FbPou,
    Pou,
    Program,
    TranslationError,
    array_info,
    pou_ref,
    real_literal,
    var,
)

__all__ = ["DIALECTS", "TARGETS", "Dialect", "Exported", "Project", "build", "export",
           "export_files", "project"]  # fmt: skip

Item = tuple[str, str, str, str]  # (name, type, initial value, comment)


@dataclass
class FbDecl:
    """A FUNCTION_BLOCK or PROGRAM: interface sections and body (neutral ST)."""

    name: str
    title: str
    inputs: list[Item]
    outputs: list[Item]
    state: list[Item]
    temps: dict[str, str]
    body: list[str]
    kind: str = "FUNCTION_BLOCK"  # or "PROGRAM"
    extends: str = ""  # a unit-test framework's base FB (TcUnit, CfUnit)


@dataclass
class Exported:
    """One block translated: its functions (callees first), the small blocks' FBs it holds
    (callees first), its FB, the header text and (``test``) its test bench."""

    spec: BlockSpec
    functions: list[Pou]
    blocks: list[FbDecl]
    fb: FbDecl
    header: list[str]
    bench: Bench | None = None


@dataclass
class Project:
    """Everything one export writes: each helper POU once, then the blocks' FBs."""

    functions: list[Pou]
    blocks: list[FbDecl]
    members: list[Exported]
    tests: list[FbDecl] = field(default_factory=list)
    test_framework: str = ""

    @property
    def name(self) -> str:
        return "_".join(m.fb.name for m in self.members)

    @property
    def header(self) -> list[str]:
        if len(self.members) == 1:
            return self.members[0].header
        lines = [f"ctrlblocks {_version()}: {len(self.members)} blocks in one project"]
        for m in self.members:
            lines += [f"{m.fb.name}: {ln}" for ln in m.header[1:3]]
        return [*lines, *self.members[0].header[3:]]


def _version() -> str:
    from .. import __version__

    return __version__


def _zero(value: Any) -> bool:
    if isinstance(value, list | tuple | np.ndarray):
        return all(_zero(v) for v in value)
    return value is False or (not isinstance(value, bool) and value == 0)


def _small_block(p: FbPou) -> FbDecl:
    """A small block's FUNCTION_BLOCK: its memory starts at 0 / FALSE (the IEC default)."""

    def plain(items: list[tuple[str, str]]) -> list[Item]:
        return [(n, t, "", "") for n, t in items]

    inst = [(n, t, "", "instance") for n, t in p.instances.items()]
    return FbDecl(p.name, f"{p.doc} [{p.source}]", plain(p.inputs), plain(p.outputs),
                  plain(p.state) + inst, p.temps, p.body)  # fmt: skip


def _init(typ: str, value: Any) -> str:
    arr = array_info(typ)
    if arr is not None:  # an ARRAY's initial values: [v0, v1, ...]
        return "[" + ", ".join(_init(arr[1], v) for v in value) + "]"
    if typ == BOOL:
        return "TRUE" if value else "FALSE"
    if typ == DINT:
        return _dint(int(value))
    return real_literal(float(value))


def _dint(v: int) -> str:
    return f"16#{v:04X}" if v >= 0x8000 else str(v)


def build(block: Any, name: str | None = None, units: Mapping[str, str] | None = None,
          prog: Program | None = None) -> Exported:  # fmt: skip
    """Translate a configured block (PID, ADRC, LeadLag) to neutral POUs.

    ``name``: the FUNCTION_BLOCK's name (default ``CB_PID``, ``CB_ADRC``,
    ``CB_LEADLAG``); ``units``: see :func:`.specs.spec_for`; ``prog``: the
    :class:`Program` shared by the blocks of one project.
    """
    spec = spec_for(block, units)
    fb_name = name or spec.fb_name
    if not is_iec_identifier(fb_name):
        raise ValueError(f"{fb_name!r} is no IEC 61131-3 identifier (letters, digits, single "
                         "inner underscores; not a keyword) for a FUNCTION_BLOCK")  # fmt: skip
    prog = prog or Program()
    vs = (*spec.inputs, *spec.outputs, *spec.state)
    st: dict[str, str] = {}
    for v in vs:  # the interface's names as IEC identifiers (the state's are Python's: ref)
        st[v.py] = iec_name(v.st, [*st.values(), "ERROR", fb_name])
    sizes = {k: len(v) for k, v in spec.values.items() if isinstance(v, list | np.ndarray)}
    body, fbvars, temps, instances = prog.fb_body(spec.cycle, spec.results, st, sizes)
    if "ts" in st:
        # the block's bad dt: a TS that is no finite REAL > 0 runs nothing (outputs and state
        # hold), as the float32 block does (plc_cycle.cycle_time_ok, NO_CYCLE)
        ok = prog.function(pc.cycle_time_ok)
        held = [f"    {var(st['error_id'])} := {pc.NO_CYCLE};"]
        if spec.limited is not None:
            # limits written with a bad TS: the held output stays inside them (the block's
            # output guard; the last valid limits stay when the new pair is no range)
            o, lo, hi = (var(st[n]) for n in spec.limited)
            held += [f"    IF {lo} <= {hi} THEN", f"        IF {o} < {lo} THEN",
                     f"            {o} := {lo};", f"        ELSIF {o} > {hi} THEN",
                     f"            {o} := {hi};", "        END_IF;", "    END_IF;"]  # fmt: skip
        body = [f"IF {pou_ref(ok.pou)}({ok.inputs['ts'][0]} := {var(st['ts'])}) THEN",
                *("    " + ln for ln in body), "ELSE", *held, "END_IF;"]  # fmt: skip
    body = [*body, f"{var('ERROR')} := {var(st['error_id'])} <> 0;"]
    for v in spec.state:
        if st[v.py] not in fbvars and not _zero(spec.values[v.py]):
            # a memory held by a small block's instance starts at the instance's 0
            raise TranslationError(f"{v.py} = {spec.values[v.py]!r} at the start, its "
                                   "instance starts at 0")  # fmt: skip

    def section(items: list[Any]) -> list[Item]:
        return [(st[v.py], fbvars[st[v.py]], _init(fbvars[st[v.py]], spec.values[v.py]),
                 v.comment) for v in items if st[v.py] in fbvars]  # fmt: skip

    sub = {p.name: p for p in prog.fbs.values()}
    held = [(n, t, "", f"instance: {sub[t].doc}") for n, t in instances.items()]
    outputs = [*section(spec.outputs), ("ERROR", BOOL, "FALSE", "ERROR_ID <> 0")]
    fb = FbDecl(fb_name, spec.title, section(spec.inputs), outputs,
                section(spec.state) + held, temps, body)  # fmt: skip
    cfg = ", ".join(f"{k}={v!r}" for k, v in vars(spec.config).items())
    header = [
        f"ctrlblocks {_version()}: {spec.title} exported as {fb_name}",
        f"configuration: {type(spec.config).__name__}({cfg})",
        f"statements translated from {spec.cycle.__module__}.{spec.cycle.__name__}",
        "and the block functions it calls; re-export instead of editing.",
        'REAL arithmetic: equals the block with precision="float32" (see docs/plc.md).',
        "Call once per cycle; TS is the cycle time [s] of the calling task.",
    ]
    blocks = [_small_block(p) for p in prog.fbs.values()]
    return Exported(spec, prog.ordered(), blocks, fb, header)


def _blocks(blocks: Any) -> list[tuple[str | None, Any]]:
    if isinstance(blocks, Mapping):
        return list(blocks.items())
    if isinstance(blocks, list | tuple):
        return [(None, b) for b in blocks]
    return [(None, blocks)]


def project(blocks: Any, units: Mapping[str, str] | None = None, test: bool | str = False,
            trace: list[dict[str, Any]] | None = None) -> Project:  # fmt: skip
    """One project of one or several blocks (a block, a list, or ``{FB name: block}``).

    Each helper POU is written once; a name with two texts (a program error)
    raises :class:`TranslationError`.  ``test``: add each block's test bench
    (``True``: the target's framework; ``"plain"``, ``"tcunit"``, ``"cfunit"``);
    ``trace``: the bench's input writes (one block only; default
    :func:`.bench.default_trace`).
    """
    items = _blocks(blocks)
    if not items:
        raise ValueError("no block to export")
    if trace is not None and len(items) != 1:
        raise ValueError("a trace is the test bench of one block: export one block with it")
    prog = Program()
    members: list[Exported] = []
    taken: list[str] = []
    for name, block in items:
        if name is None:
            name = iec_name(spec_for(block).fb_name, taken)
        elif name.upper() in {t.upper() for t in taken}:
            raise ValueError(f"two blocks named {name!r}")
        ex = build(block, name, units, prog)
        taken.append(ex.fb.name)
        if test:
            ex.bench = record(ex.spec, trace if trace is not None else default_trace(ex.spec),
                              ex.fb.name)  # fmt: skip
        members.append(ex)
    functions = prog.ordered()
    blocks_ = [_small_block(p) for p in prog.fbs.values()]
    names = [p.name for p in functions] + [b.name for b in blocks_]
    clash = [m.fb.name for m in members if m.fb.name.upper() in {n.upper() for n in names}]
    if clash:
        raise ValueError(f"{clash[0]!r} is the name of a helper POU of the library")
    return Project(functions, blocks_, members, test_framework=test if isinstance(test, str)
                   else "")  # fmt: skip


# ---------------------------------------------------------------------------
# the test bench's frame
# ---------------------------------------------------------------------------

CHECK_FB = "CB_TEST_CHECK"
_BIG = 1.0e38


def _check_fb() -> FbDecl:
    """Counts the samples whose outputs differ from the recorded ones (the plain bench)."""
    s, f, first, ok = var("SAMPLE"), var("FAILURES"), var("FIRST_FAILURE"), var("OK")
    return FbDecl(CHECK_FB, "test bench: counts the samples whose outputs differ",
                  [("SAMPLE", DINT, "", "number of the sample (0 = the first)"),
                   ("OK", BOOL, "", "the outputs equal the recorded ones")],
                  [("SAMPLES", DINT, "", "samples checked"),
                   ("FAILURES", DINT, "", "samples that differed"),
                   ("FIRST_FAILURE", DINT, "-1", "the first that differed (-1: none)")],
                  [], {}, [f"{var('SAMPLES')} := {var('SAMPLES')} + 1;", f"IF NOT {ok} THEN",
                           f"    {f} := {f} + 1;", f"    IF {f} = 1 THEN",
                           f"        {first} := {s};", "    END_IF;", "END_IF;"])  # fmt: skip


def real32_literal(x: float) -> str:
    """The shortest REAL literal of the float32 ``x`` that reads back as ``x`` whether the
    compiler parses it as REAL or as LREAL and then rounds (finite ``x`` only)."""
    v = np.float32(x)
    if v == 0.0 or 1e-4 <= abs(v) < 1e7:
        s = np.format_float_positional(v, unique=True, trim="0")
    else:
        s = np.format_float_scientific(v, unique=True, trim="0")
    if np.float32(float(s)) != v:  # pragma: no cover - a double-rounding tie
        s = repr(float(v))
    m, _, e = s.lower().partition("e")
    m = m if "." in m and not m.endswith(".") else m.rstrip(".") + ".0"
    return f"{m}E{int(e)}" if e else m


def _value(x: Any, typ: str) -> str:
    """A recorded value as ST: non-finite REALs through the bench's computed variables."""
    if typ == BOOL:
        return "TRUE" if x else "FALSE"
    if typ == DINT:
        return _dint(int(x))
    v = float(np.float32(x)) if abs(float(x)) < 3.5e38 else float(x)
    if v != v:
        return var("nan_v")
    if v in (np.inf, -np.inf) or abs(v) > 3.4028235677973366e38:
        return var("inf_v") if v > 0 else f"-{var('inf_v')}"
    return real32_literal(v)


def bench_unit(ex: Exported, framework: str) -> list[FbDecl]:
    """The test bench of ``ex`` in ``framework`` (``plain``, ``tcunit``, ``cfunit``)."""
    assert ex.bench is not None
    fb, b = ex.fb, ex.bench
    types = {n: t for n, t, _i, _c in fb.inputs + fb.outputs}
    inst = var("fb")
    lines = [f"{var('inf_v')} := {var('big')} * {var('big')};  (* +inf, computed: REAL has no "
             "literal for it *)", f"{var('nan_v')} := {var('inf_v')} - {var('inf_v')};"]
    for k, (inp, exp) in enumerate(zip(b.inputs, b.expected, strict=True)):
        args = ", ".join(f"{n} := {_value(v, types[n])}" for n, v in inp.items())
        lines.append(f"{inst}({args});")
        if framework == "plain":
            conds = []
            for n in b.checked:
                out = f"{inst}.{n}"
                if types[n] == BOOL:
                    conds.append(out if exp[n] else f"NOT {out}")
                else:
                    conds.append(f"({out} = {_value(exp[n], types[n])})")
            lines.append(f"{var('check')}(SAMPLE := {k}, OK := {' AND '.join(conds)});")
        else:
            for n in b.checked:
                t = types[n]
                delta = ", Delta := 0.0" if t == REAL else ""
                lines.append(f"AssertEquals_{t}(Expected := {_value(exp[n], t)}, Actual := "
                             f"{inst}.{n}{delta}, Message := 'sample {k}: {n}');")  # fmt: skip
    title = (f"test bench of {fb.name}: replays {len(b.inputs)} samples recorded from the "
             f"ctrlblocks block (precision=\"float32\") and compares {', '.join(b.checked)} "
             "after every call, bit for bit")  # fmt: skip
    state: list[Item] = [("fb", fb.name, "", "the block under test"),
                         ("big", REAL, real_literal(_BIG), ""), ("inf_v", REAL, "", ""),
                         ("nan_v", REAL, "", "")]  # fmt: skip
    name = iec_name(f"{fb.name}_TEST")
    if framework == "plain":
        state.append(("check", CHECK_FB, "", ""))
        done = var("DONE")
        body = [f"IF NOT {done} THEN", *("    " + ln for ln in lines),
                f"    {var('FAILURES')} := {var('check')}.FAILURES;",
                f"    {var('FIRST_FAILURE')} := {var('check')}.FIRST_FAILURE;",
                f"    {var('SAMPLES')} := {var('check')}.SAMPLES;", f"    {done} := TRUE;",
                "END_IF;"]  # fmt: skip
        outputs: list[Item] = [("DONE", BOOL, "FALSE", "the trace has been replayed"),
                               ("SAMPLES", DINT, "0", "samples compared"),
                               ("FAILURES", DINT, "0", "samples that differed: 0 = passed"),
                               ("FIRST_FAILURE", DINT, "-1", "first that differed")]  # fmt: skip
        return [_check_fb(), FbDecl(name, title, [], outputs, state, {}, body, kind="PROGRAM")]
    state.append(("done", BOOL, "FALSE", ""))
    body = [f"IF NOT {var('done')} THEN",
            f"    TEST('{fb.name}_replays_{len(b.inputs)}_recorded_samples');",
            *("    " + ln for ln in lines), "    TEST_FINISHED();", f"    {var('done')} := TRUE;",
            "END_IF;"]  # fmt: skip
    lib = "TcUnit" if framework == "tcunit" else "CfUnit"
    suite = FbDecl(name, title, [], [], state, {}, body, extends=f"{lib}.FB_TestSuite")
    run = FbDecl(iec_name(f"PRG_{name}"), f"runs the test suite {name} ({lib})", [], [],
                 [("suite", name, "", "")], {}, [f"{lib}.RUN();"], kind="PROGRAM")  # fmt: skip
    return [suite, run]


def _with_tests(proj: Project, framework: str) -> Project:
    if not any(m.bench for m in proj.members):
        return proj
    tests: list[FbDecl] = []
    for m in proj.members:
        if m.bench is not None:
            units = bench_unit(m, framework)
            tests += [u for u in units if u.name not in {t.name for t in tests}]
    return Project(proj.functions, proj.blocks, proj.members, tests, framework)


# ---------------------------------------------------------------------------
# dialects
# ---------------------------------------------------------------------------


def _hex_codes(line: str) -> str:
    """Status codes (33025) written as the library writes them (16#8101)."""
    return re.sub(r"(?<![\w#.])(3[2-9]\d{3})(?![\w.])", lambda m: _dint(int(m.group(1))), line)


def _comment(text: str) -> str:
    return "(* " + text.replace("(*", "( *").replace("*)", "* )") + " *)"


class Dialect:
    """The syntax of one target.  Subclasses override the hooks; :meth:`text` and
    :meth:`files` render a :class:`Project`."""

    name = ""
    ext = ""
    test_framework = "plain"  # the unit-test form of the bench (test=True)

    # -- syntax hooks ----------------------------------------------------------------
    def ref(self, name: str) -> str:
        """A variable reference."""
        return name

    def pou(self, name: str) -> str:
        """A POU name where it is called or declared."""
        return name

    def type(self, t: str) -> str:
        return t

    def comment(self, text: str) -> str:
        return _comment(text)

    def render(self, lines: list[str]) -> list[str]:
        """Neutral ST (``\\x01var\\x02``, ``\\x03POU\\x04``) in this dialect."""
        out = [re.sub("\x01([^\x02]*)\x02", lambda m: self.ref(m.group(1)), ln) for ln in lines]
        out = [re.sub("\x03([^\x04]*)\x04", lambda m: self.pou(m.group(1)), ln) for ln in out]
        return [_hex_codes(ln) for ln in out]

    # -- text targets ------------------------------------------------------------------
    indent = ""
    function_locals = "VAR"

    def preamble(self) -> list[str]:
        """Lines after a POU's first line (TIA: attributes, VERSION)."""
        return []

    def vars(self, kind: str, items: list[Item]) -> list[str]:
        if not items:
            return []
        ind = self.indent
        out = [f"{ind}{kind}"]
        for name, typ, init, comment in items:
            ini = f" := {init}" if init else ""
            com = f" {self.comment(comment)}" if comment else ""
            out.append(f"{ind}    {name} : {self.type(typ)}{ini};{com}")
        out.append(f"{ind}END_VAR")
        return out

    def begin(self, title: str) -> list[str]:
        return []

    def body(self, lines: list[str], title: str) -> list[str]:
        return ["    " + ln for ln in self.render(lines)]

    def function_text(self, p: Pou) -> list[str]:
        lines = [f"FUNCTION {self.pou(p.name)} : {self.type(p.ret_type or REAL)}",
                 *self.preamble(), _comment(f"{p.doc} [{p.source}]")]  # fmt: skip
        lines += self.vars("VAR_INPUT", [(n, t, "", "") for n, t in p.inputs])
        lines += self.vars("VAR_OUTPUT", [(n, t, "", "") for n, t in p.outputs])
        lines += self.vars(self.function_locals, [(n, t, "", "") for n, t in p.locals.items()])
        lines += self.begin("")
        lines += self.body(p.body, "")
        return [*lines, "END_FUNCTION"]

    def fb_text(self, fb: FbDecl) -> list[str]:
        ext = f" EXTENDS {fb.extends}" if fb.extends else ""
        lines = [f"{fb.kind} {self.pou(fb.name)}{ext}", *self.preamble(), _comment(fb.title)]
        lines += self.vars("VAR_INPUT", fb.inputs)
        lines += self.vars("VAR_OUTPUT", fb.outputs)
        lines += self.vars("VAR", fb.state)
        lines += self.vars("VAR_TEMP", [(n, t, "", "") for n, t in fb.temps.items()])
        lines += self.begin(fb.title)
        lines += self.body(fb.body, fb.title)
        return [*lines, f"END_{fb.kind}"]

    def head(self, proj: Project) -> list[str]:
        return [self.comment(h) for h in proj.header]

    def pous(self, proj: Project) -> list[list[str]]:
        """Every POU of the project, callees first."""
        out = [self.function_text(p) for p in proj.functions]
        out += [self.fb_text(b) for b in proj.blocks]
        out += [self.fb_text(m.fb) for m in proj.members]
        out += [self.fb_text(t) for t in proj.tests]
        return out

    def text(self, proj: Project) -> str:
        lines = [*self.head(proj), ""]
        for pou in self.pous(proj):
            lines += [*pou, ""]
        return "\n".join(lines[:-1]) + "\n"

    def files(self, proj: Project) -> dict[str, str]:
        return {f"{proj.name}.{self.ext}": self.text(proj)}


class Codesys(Dialect):
    """IEC 61131-3 ST as CODESYS V3 writes it; the bench in CfUnit's form."""

    name, ext, test_framework = "codesys", "st", "cfunit"


class TwinCat(Codesys):
    """The same ST; :meth:`files` gives one ``.TcPOU`` per POU; the bench in TcUnit's form."""

    name, test_framework = "twincat", "tcunit"

    def files(self, proj: Project) -> dict[str, str]:
        out = {}
        head = [self.comment(h) for h in proj.header]
        for j, lines in enumerate(self.pous(proj)):
            name = lines[0].split()[1]
            if j == len(proj.functions) + len(proj.blocks) and len(proj.members) == 1:
                lines = [lines[0], *head, *lines[1:]]  # the block's FB carries the header
            out[f"{name}.TcPOU"] = _tcpou(name, lines)
        return out


class Tia(Dialect):
    """Siemens SCL external source for TIA Portal (S7-1200/1500, optimized access)."""

    name, ext = "tia", "scl"
    indent = "   "
    function_locals = "VAR_TEMP"
    _TYPES: ClassVar[dict[str, str]] = {REAL: "Real", BOOL: "Bool", DINT: "DInt"}

    def ref(self, name: str) -> str:
        return f"#{name}"

    def pou(self, name: str) -> str:
        return f'"{name}"'

    def type(self, t: str) -> str:
        arr = array_info(t)
        if arr is not None:
            return f"Array[0..{arr[0] - 1}] of {self._TYPES[arr[1]]}"
        return self._TYPES.get(t, f'"{t}"')  # an FB type (multi-instance) is a quoted block name

    def preamble(self) -> list[str]:
        return ["{ S7_Optimized_Access := 'TRUE' }", "VERSION : 0.1"]

    def begin(self, title: str) -> list[str]:
        return ["BEGIN"]

    def body(self, lines: list[str], title: str) -> list[str]:
        if not title:
            return super().body(lines, title)
        inner = ["        " + ln for ln in self.render(lines)]
        return [f"    REGION {title}", *inner, "    END_REGION"]

    def fb_text(self, fb: FbDecl) -> list[str]:
        if fb.kind == "PROGRAM":  # TIA has no PROGRAM: a FUNCTION_BLOCK called from an OB
            fb = FbDecl(fb.name, fb.title, fb.inputs, fb.outputs, fb.state, fb.temps, fb.body)
        return super().fb_text(fb)

    def head(self, proj: Project) -> list[str]:
        return ["// " + h for h in proj.header]


class PlcOpen(Dialect):
    """PLCopen XML (TC6 0201), texts as CODESYS and TwinCAT write them."""

    name, ext = "plcopen", "xml"
    xmlns = ""

    def formatted(self, text: str) -> str:
        """A TC6 ``formattedText``'s content."""
        return f'<xhtml xmlns="http://www.w3.org/1999/xhtml">{escape(text)}</xhtml>'

    def xvars(self, tag: str, items: list[Item]) -> list[str]:
        if not items:
            return []
        out = [f"          <{tag}>"]
        for name, typ, init, comment in items:
            out.append(f"            <variable name={quoteattr(name)}>")
            arr = array_info(typ)
            if arr is not None:
                kind = (f'<array><dimension lower="0" upper="{arr[0] - 1}" />'
                        f"<baseType><{arr[1]} /></baseType></array>")  # fmt: skip
            elif typ in (REAL, BOOL, DINT):
                kind = f"<{typ} />"
            else:
                kind = f"<derived name={quoteattr(typ)} />"
            out.append(f"              <type>{kind}</type>")
            if init and arr is not None and init.startswith("["):
                values = "".join(f"<value><simpleValue value={quoteattr(v.strip())} /></value>"
                                 for v in init[1:-1].split(","))  # fmt: skip
                out.append(f"              <initialValue><arrayValue>{values}</arrayValue>"
                           "</initialValue>")  # fmt: skip
            elif init:
                out.append(f"              <initialValue><simpleValue value={quoteattr(init)} />"
                           "</initialValue>")  # fmt: skip
            if comment:
                out.append(f"              <documentation>{self.formatted(comment)}"
                           "</documentation>")  # fmt: skip
            out.append("            </variable>")
        out.append(f"          </{tag}>")
        return out

    def xpou(self, name: str, kind: str, ret: str | None, sections: list[tuple[str, list[Item]]],
             body: list[str], doc: str) -> list[str]:  # fmt: skip
        out = [f'      <pou name={quoteattr(name)} pouType="{kind}">', "        <interface>"]
        if ret:
            out.append(f"          <returnType><{ret} /></returnType>")
        for tag, items in sections:
            out += self.xvars(tag, items)
        out += ["        </interface>",
                f"        <body><ST>{self.formatted(chr(10).join(body))}</ST></body>",
                f"        <documentation>{self.formatted(doc)}</documentation>",
                "      </pou>"]  # fmt: skip
        return out

    def text(self, proj: Project) -> str:
        now = datetime.now(timezone.utc).replace(microsecond=0, tzinfo=None).isoformat()
        lines = [
            '<?xml version="1.0" encoding="utf-8"?>',
            f'<project xmlns="http://www.plcopen.org/xml/tc6_0201"{self.xmlns}>',
            f'  <fileHeader companyName="ctrlblocks" productName="ctrlblocks" '
            f'productVersion="{_version()}" creationDateTime="{now}" />',
            f"  <contentHeader name={quoteattr(proj.name)}>",
            "    <coordinateInfo>",
            '      <fbd><scaling x="1" y="1" /></fbd>',
            '      <ld><scaling x="1" y="1" /></ld>',
            '      <sfc><scaling x="1" y="1" /></sfc>',
            "    </coordinateInfo>",
            "  </contentHeader>",
            "  <types>",
            "    <dataTypes />",
            "    <pous>",
        ]
        for p in proj.functions:
            sections = [("inputVars", [(n, t, "", "") for n, t in p.inputs]),
                        ("outputVars", [(n, t, "", "") for n, t in p.outputs]),
                        ("localVars", [(n, t, "", "") for n, t in p.locals.items()])]  # fmt: skip
            lines += self.xpou(p.name, "function", p.ret_type or REAL, sections,
                               self.render(p.body), f"{p.doc} [{p.source}]")  # fmt: skip
        docs = [*((b, b.title) for b in proj.blocks),
                *((m.fb, " ".join(m.header)) for m in proj.members),
                *((t, t.title) for t in proj.tests)]  # fmt: skip
        for fb, doc in docs:
            kind = "program" if fb.kind == "PROGRAM" else "functionBlock"
            sections = [("inputVars", fb.inputs), ("outputVars", fb.outputs),
                        ("localVars", fb.state),
                        ("tempVars", [(n, t, "", "") for n, t in fb.temps.items()])]  # fmt: skip
            lines += self.xpou(fb.name, kind, None, sections, self.render(fb.body), doc)
        lines += ["    </pous>", "  </types>", "  <instances>", "    <configurations />",
                  "  </instances>", "</project>", ""]  # fmt: skip
        return "\n".join(lines)


class Beremiz(PlcOpen):
    """PLCopen XML as Beremiz and the OpenPLC editor read it: texts in ``<xhtml:p>``."""

    name = "beremiz"
    xmlns = ' xmlns:xhtml="http://www.w3.org/1999/xhtml"'

    def formatted(self, text: str) -> str:
        return f"<xhtml:p><![CDATA[{text.replace(']]>', ']]]]><![CDATA[>')}]]></xhtml:p>"


DIALECTS: dict[str, Dialect] = {d.name: d for d in (Codesys(), TwinCat(), Tia(), PlcOpen(),
                                                    Beremiz())}  # fmt: skip
"""The targets: name -> :class:`Dialect`."""
TARGETS = tuple(DIALECTS)


def _split_decl(lines: list[str]) -> tuple[str, str]:
    """(declaration part, body) of a rendered codesys POU."""
    for j, ln in enumerate(lines):
        if (
            ln.startswith("    ")
            and not ln.lstrip().startswith(("(*",))
            and j > 0
            and (lines[j - 1].startswith("END_VAR") or lines[j - 1].startswith("(*"))
        ):
            return "\n".join(lines[:j]), "\n".join(x[4:] for x in lines[j:-1])
    return "\n".join(lines[:-1]), ""


def _tcpou(pou_name: str, lines: list[str]) -> str:
    decl, body = _split_decl(lines)
    guid = uuid.uuid5(uuid.NAMESPACE_URL, f"ctrlblocks/{pou_name}")
    return (
        '<?xml version="1.0" encoding="utf-8"?>\n'
        '<TcPlcObject Version="1.1.0.1" ProductVersion="3.1.4024.0">\n'
        f'  <POU Name="{pou_name}" Id="{{{guid}}}" SpecialFunc="None">\n'
        f"    <Declaration><![CDATA[{decl}]]></Declaration>\n"
        "    <Implementation>\n"
        f"      <ST><![CDATA[{body}]]></ST>\n"
        "    </Implementation>\n"
        "  </POU>\n"
        "</TcPlcObject>\n"
    )


# ---------------------------------------------------------------------------
# public API
# ---------------------------------------------------------------------------


def _dialect(target: str) -> Dialect:
    if target not in DIALECTS:
        raise ValueError(f"unknown PLC target {target!r}; choose one of {', '.join(TARGETS)}")
    return DIALECTS[target]


def _project(blocks: Any, d: Dialect, units: Mapping[str, str] | None, test: bool | str,
             trace: list[dict[str, Any]] | None) -> Project:  # fmt: skip
    framework = (d.test_framework if test is True else test) if test else ""
    if framework and framework not in ("plain", "tcunit", "cfunit"):
        raise ValueError(f"unknown test framework {framework!r}; choose plain, tcunit or cfunit")
    if framework in ("tcunit", "cfunit") and not isinstance(d, Codesys):
        # a test suite EXTENDS the framework's FB: neither SCL nor PLCopen XML can say so
        raise ValueError(f"the {framework} test suite is CODESYS/TwinCAT ST; the {d.name} "
                         "target takes the plain test program (test=True or 'plain')")  # fmt: skip
    proj = project(blocks, units, bool(test), trace)
    return _with_tests(proj, framework) if framework else proj


def export(blocks: Any, target: str = "codesys", *, units: Mapping[str, str] | None = None,
           test: bool | str = False, trace: list[dict[str, Any]] | None = None) -> str:  # fmt: skip
    """The PLC source of one or several configured blocks for ``target`` (module docstring).

    Parameters
    ----------
    blocks : PID, ADRC or LeadLag, a list of them, or ``{FB name: block}``
        The configured blocks; their configuration gives the inputs' initial
        values (the PLC can retune through them).  Several blocks share the
        helper POUs (each written once).
    target : str
        ``"codesys"``, ``"twincat"`` (ST), ``"tia"`` (SCL), ``"plcopen"`` or
        ``"beremiz"`` (PLCopen XML).
    units : mapping, optional
        ``{"pv": "bar", "mv": "%"}``: the units named in the comments.
    test : bool or str
        Add the test bench: ``True`` for the target's framework (CfUnit for
        CODESYS, TcUnit for TwinCAT, a plain program elsewhere), or
        ``"plain"``, ``"tcunit"``, ``"cfunit"``.
    trace : list of dict, optional
        The test bench's input writes per sample (PLC names); default
        :func:`.bench.default_trace`.

    Raises
    ------
    UnsupportedBlock
        For another block type or options the export does not cover.
    ValueError
        For an unknown target or framework, or a FB name that is no identifier.
    """
    d = _dialect(target)
    return d.text(_project(blocks, d, units, test, trace))


def export_files(blocks: Any, target: str = "codesys", *, units: Mapping[str, str] | None = None,
                 test: bool | str = False,
                 trace: list[dict[str, Any]] | None = None) -> dict[str, str]:  # fmt: skip
    """``{file name: content}``: one file, or one ``.TcPOU`` per POU for ``"twincat"``."""
    d = _dialect(target)
    return d.files(_project(blocks, d, units, test, trace))
