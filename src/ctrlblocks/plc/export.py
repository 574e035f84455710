"""Render the translated POUs in the dialect of each PLC target.

Targets
-------
``"codesys"``
    IEC 61131-3 Structured Text as CODESYS V3 writes it (paste into POUs or
    import the ``"plcopen"`` file).
``"twincat"``
    The same ST (TwinCAT 3 is CODESYS-based); :func:`export_files` also gives
    one ``.TcPOU`` XML file per POU, which TwinCAT 3 adds to a PLC project.
``"tia"``
    Siemens SCL external source (``.scl``) for TIA Portal: ``"quoted"`` block
    names, ``#``-prefixed local variables, ``{ S7_Optimized_Access := 'TRUE' }``,
    ``BEGIN``, ``REGION`` ... ``END_REGION``, ``Void`` functions for several
    results.
``"plcopen"``
    PLCopen XML (TC6 0201) project with every POU's body in ST.

Only declarations, headers and this dialect syntax are written here; the
statements come from :mod:`.translate` (the blocks' own Python).
"""

from __future__ import annotations

import re
import uuid
from dataclasses import dataclass
from datetime import datetime, timezone
from typing import Any
from xml.sax.saxutils import escape, quoteattr

import numpy as np

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
    real_literal,
    var,
)

__all__ = ["TARGETS", "Exported", "build", "export", "export_files"]

TARGETS = ("codesys", "twincat", "tia", "plcopen")
_EXT = {"codesys": "st", "twincat": "st", "tia": "scl", "plcopen": "xml"}
_TIA_TYPES = {REAL: "Real", BOOL: "Bool", DINT: "DInt"}


@dataclass
class FbDecl:
    """The FUNCTION_BLOCK: interface sections and body (neutral ST)."""

    name: str
    title: str
    inputs: list[tuple[str, str, str, str]]  # (name, type, initial, comment)
    outputs: list[tuple[str, str, str, str]]
    state: list[tuple[str, str, str, str]]
    temps: dict[str, str]
    body: list[str]


@dataclass
class Exported:
    """One block translated: its functions (callees first), the small blocks' FBs it holds
    (callees first), its FB and the header text."""

    spec: BlockSpec
    functions: list[Pou]
    blocks: list[FbDecl]
    fb: FbDecl
    header: list[str]


def _zero(value: Any) -> bool:
    if isinstance(value, list | tuple | np.ndarray):
        return all(_zero(v) for v in value)
    return value is False or (not isinstance(value, bool) and value == 0)


def _small_block(p: FbPou) -> FbDecl:
    """A small block's FUNCTION_BLOCK: its memory starts at 0 / FALSE (the IEC default)."""

    def plain(items: list[tuple[str, str]]) -> list[tuple[str, str, str, str]]:
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


def build(block: Any) -> Exported:
    """Translate a configured block (PID, ADRC, LeadLag) to neutral POUs."""
    from .. import __version__

    spec = spec_for(block)
    prog = Program()
    names = spec.names()
    sizes = {k: len(v) for k, v in spec.values.items() if isinstance(v, list | np.ndarray)}
    body, fbvars, temps, instances = prog.fb_body(spec.cycle, spec.results, names, sizes)
    body = [*body, f"{var('ERROR')} := {var('ERROR_ID')} <> 0;"]
    for v in spec.state:
        if v.st not in fbvars and not _zero(spec.values[v.py]):
            # a memory held by a small block's instance starts at the instance's 0
            raise TranslationError(f"{v.py} = {spec.values[v.py]!r} at the start, its "
                                   "instance starts at 0")  # fmt: skip

    def section(vs: list[Any]) -> list[tuple[str, str, str, str]]:
        return [(v.st, fbvars[v.st], _init(fbvars[v.st], spec.values[v.py]), v.comment)
                for v in vs if v.st in fbvars]  # fmt: skip

    sub = {p.name: p for p in prog.fbs.values()}
    held = [(n, t, "", f"instance: {sub[t].doc}") for n, t in instances.items()]

    outputs = section(spec.outputs)
    outputs.append(("ERROR", BOOL, "FALSE", "ERROR_ID <> 0"))
    fb = FbDecl(
        name=spec.fb_name,
        title=spec.title,
        inputs=section(spec.inputs),
        outputs=outputs,
        state=section(spec.state) + held,
        temps=temps,
        body=body,
    )
    cfg = ", ".join(f"{k}={v!r}" for k, v in vars(spec.config).items())
    header = [
        f"ctrlblocks {__version__}: {spec.title} exported as {spec.fb_name}",
        f"configuration: {type(spec.config).__name__}({cfg})",
        f"statements translated from {spec.cycle.__module__}.{spec.cycle.__name__}",
        "and the block functions it calls; re-export instead of editing.",
        'REAL arithmetic: equals the block with precision="float32" (see docs/plc.md).',
        "Call once per cycle; TS is the cycle time [s] of the calling task.",
    ]
    blocks = [_small_block(p) for p in prog.fbs.values()]
    return Exported(spec, prog.ordered(), blocks, fb, header)


# ---------------------------------------------------------------------------
# text rendering
# ---------------------------------------------------------------------------


def _render_refs(lines: list[str], target: str) -> list[str]:
    if target == "tia":
        out = [re.sub("\x01([^\x02]*)\x02", r"#\1", ln) for ln in lines]
        out = [re.sub("\x03([^\x04]*)\x04", r'"\1"', ln) for ln in out]
    else:
        out = [re.sub("[\x01\x02\x03\x04]", "", ln) for ln in lines]
    return [_hex_codes(ln) for ln in out]


def _hex_codes(line: str) -> str:
    """Status codes (33025) written as the library writes them (16#8101)."""
    return re.sub(r"(?<![\w#.])(3[2-9]\d{3})(?![\w.])", lambda m: _dint(int(m.group(1))), line)


def _comment(text: str) -> str:
    return "(* " + text.replace("(*", "( *").replace("*)", "* )") + " *)"


def _typ(t: str, target: str) -> str:
    if target != "tia":
        return t
    arr = array_info(t)
    if arr is not None:
        return f"Array[0..{arr[0] - 1}] of {_TIA_TYPES[arr[1]]}"
    return _TIA_TYPES.get(t, f'"{t}"')  # an FB type (multi-instance) is a quoted block name


def _vars(kind: str, items: list[tuple[str, str, str, str]], target: str, ind: str) -> list[str]:
    if not items:
        return []
    out = [f"{ind}{kind}"]
    for name, typ, init, comment in items:
        ini = f" := {init}" if init else ""
        com = f" {_comment(comment)}" if comment else ""
        out.append(f"{ind}    {name} : {_typ(typ, target)}{ini};{com}")
    out.append(f"{ind}END_VAR")
    return out


def _function_text(p: Pou, target: str) -> list[str]:
    tia = target == "tia"
    void = tia and p.outputs
    rtype = "Void" if void else _typ(p.ret_type or BOOL, target)
    name = f'"{p.name}"' if tia else p.name
    lines = [f"FUNCTION {name} : {rtype}"]
    if tia:
        lines += ["{ S7_Optimized_Access := 'TRUE' }", "VERSION : 0.1"]
    lines.append(_comment(f"{p.doc} [{p.source}]"))
    ind = "   " if tia else ""
    lines += _vars("VAR_INPUT", [(n, t, "", "") for n, t in p.inputs], target, ind)
    lines += _vars("VAR_OUTPUT", [(n, t, "", "") for n, t in p.outputs], target, ind)
    lines += _vars("VAR_TEMP" if tia else "VAR", [(n, t, "", "") for n, t in p.locals.items()],
                   target, ind)  # fmt: skip
    body = p.body
    if void:
        body = [ln for ln in body if not ln.startswith(var(p.name) + " :=")]
    if tia:
        lines.append("BEGIN")
    lines += ["    " + ln for ln in _render_refs(body, target)]
    lines.append("END_FUNCTION")
    return lines


def _fb_text(fb: FbDecl, target: str) -> list[str]:
    tia = target == "tia"
    name = f'"{fb.name}"' if tia else fb.name
    lines = [f"FUNCTION_BLOCK {name}"]
    if tia:
        lines += ["{ S7_Optimized_Access := 'TRUE' }", "VERSION : 0.1"]
    lines.append(_comment(fb.title))
    ind = "   " if tia else ""
    lines += _vars("VAR_INPUT", fb.inputs, target, ind)
    lines += _vars("VAR_OUTPUT", fb.outputs, target, ind)
    lines += _vars("VAR", fb.state, target, ind)
    lines += _vars("VAR_TEMP", [(n, t, "", "") for n, t in fb.temps.items()], target, ind)
    body = _render_refs(fb.body, target)
    if tia:
        lines += ["BEGIN", f"    REGION {fb.title}"]
        lines += ["        " + ln for ln in body]
        lines += ["    END_REGION", "END_FUNCTION_BLOCK"]
    else:
        lines += ["    " + ln for ln in body]
        lines.append("END_FUNCTION_BLOCK")
    return lines


def _text(ex: Exported, target: str) -> str:
    lines = [_comment(h) for h in ex.header] if target != "tia" else ["// " + h for h in ex.header]
    lines.append("")
    for p in ex.functions:
        lines += _function_text(p, target)
        lines.append("")
    for b in ex.blocks:
        lines += _fb_text(b, target)
        lines.append("")
    lines += _fb_text(ex.fb, target)
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------
# XML targets
# ---------------------------------------------------------------------------


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


def _xvars(tag: str, items: list[tuple[str, str, str, str]]) -> list[str]:
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
            out.append(f"              <documentation><xhtml xmlns=\"http://www.w3.org/1999/xhtml\">"
                       f"{escape(comment)}</xhtml></documentation>")  # fmt: skip
        out.append("            </variable>")
    out.append(f"          </{tag}>")
    return out


def _xpou(name: str, kind: str, ret: str | None, sections: list[tuple[str, list[Any]]],
          body: list[str], doc: str) -> list[str]:  # fmt: skip
    out = [f'      <pou name={quoteattr(name)} pouType="{kind}">', "        <interface>"]
    if ret:
        out.append(f"          <returnType><{ret} /></returnType>")
    for tag, items in sections:
        out += _xvars(tag, items)
    out += [
        "        </interface>",
        '        <body><ST><xhtml xmlns="http://www.w3.org/1999/xhtml">'
        + escape("\n".join(body))
        + "</xhtml></ST></body>",
        '        <documentation><xhtml xmlns="http://www.w3.org/1999/xhtml">'
        + escape(doc)
        + "</xhtml></documentation>",
        "      </pou>",
    ]
    return out


def _plcopen(ex: Exported) -> str:
    from .. import __version__

    now = datetime.now(timezone.utc).replace(microsecond=0, tzinfo=None).isoformat()
    lines = [
        '<?xml version="1.0" encoding="utf-8"?>',
        '<project xmlns="http://www.plcopen.org/xml/tc6_0201">',
        f'  <fileHeader companyName="ctrlblocks" productName="ctrlblocks" '
        f'productVersion="{__version__}" creationDateTime="{now}" />',
        f'  <contentHeader name="{ex.fb.name}">',
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
    for p in ex.functions:
        sections = [("inputVars", [(n, t, "", "") for n, t in p.inputs]),
                    ("outputVars", [(n, t, "", "") for n, t in p.outputs]),
                    ("localVars", [(n, t, "", "") for n, t in p.locals.items()])]  # fmt: skip
        lines += _xpou(p.name, "function", p.ret_type or BOOL, sections,
                       _render_refs(p.body, "plcopen"), f"{p.doc} [{p.source}]")  # fmt: skip
    for fb, doc in [*((b, b.title) for b in ex.blocks), (ex.fb, " ".join(ex.header))]:
        sections = [("inputVars", fb.inputs), ("outputVars", fb.outputs), ("localVars", fb.state),
                    ("tempVars", [(n, t, "", "") for n, t in fb.temps.items()])]  # fmt: skip
        lines += _xpou(fb.name, "functionBlock", None, sections,
                       _render_refs(fb.body, "plcopen"), doc)  # fmt: skip
    lines += ["    </pous>", "  </types>", "  <instances>", "    <configurations />",
              "  </instances>", "</project>", ""]  # fmt: skip
    return "\n".join(lines)


# ---------------------------------------------------------------------------
# public API
# ---------------------------------------------------------------------------


def _check_target(target: str) -> None:
    if target not in TARGETS:
        raise ValueError(f"unknown PLC target {target!r}; choose one of {', '.join(TARGETS)}")


def export(block: Any, target: str = "codesys") -> str:
    """The PLC source of a configured block for ``target`` (see the module docstring).

    Parameters
    ----------
    block : PID, ADRC or LeadLag
        The configured block; its configuration gives the inputs' initial
        values (the PLC can retune through them).
    target : str
        ``"codesys"``, ``"twincat"`` (ST), ``"tia"`` (SCL) or ``"plcopen"`` (XML).

    Raises
    ------
    UnsupportedBlock
        For another block type or options the export does not cover.
    ValueError
        For an unknown target.
    """
    _check_target(target)
    ex = build(block)
    if target == "plcopen":
        return _plcopen(ex)
    return _text(ex, target)


def export_files(block: Any, target: str = "codesys") -> dict[str, str]:
    """``{file name: content}``: one file, or one ``.TcPOU`` per POU for ``"twincat"``."""
    _check_target(target)
    ex = build(block)
    if target != "twincat":
        return {f"{ex.fb.name}.{_EXT[target]}": export(block, target)}
    files = {}
    head = [_comment(h) for h in ex.header]
    for p in ex.functions:
        files[f"{p.name}.TcPOU"] = _tcpou(p.name, _function_text(p, "twincat"))
    for b in ex.blocks:
        files[f"{b.name}.TcPOU"] = _tcpou(b.name, _fb_text(b, "twincat"))
    fb_lines = _fb_text(ex.fb, "twincat")
    files[f"{ex.fb.name}.TcPOU"] = _tcpou(ex.fb.name, [fb_lines[0], *head, *fb_lines[1:]])
    return files
