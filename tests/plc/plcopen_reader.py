"""PLCopen XML read back to ST the way Beremiz (and so the OpenPLC editor) reads it.

Beremiz loads a project (``plcopen/plcopen.py``, ``LoadProjectXML``) by first
wrapping every CDATA section that is not already inside ``<xhtml:p>`` in one,
then binding the XML to the TC6 0201 schema; a ``formattedText`` (an ST body,
a documentation) is read as the text of its *first* ``xhtml:p`` child and
nothing else (``xmlclass.GenerateAnyInfos``: ``tree.xpath("ns:p")[0].text``),
so a body written in the CODESYS form ``<xhtml xmlns=...>text</xhtml>`` has no
text at all for it.  The ST it hands to MATIEC is generated per POU
(``PLCGenerator.ProgramGenerator.GenerateProgram``): ``FUNCTION name :
RETTYPE`` / ``FUNCTION_BLOCK name`` / ``PROGRAM name``, one ``VAR_...`` section
per variable list of the interface with ``name : TYPE := initial;`` lines, the
body text, ``END_...``.

:func:`st_from_plcopen` does the same with the standard library's XML parser
(the test is written from reading those functions, not from their code), so
the tests can compile what Beremiz would compile.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

NS = {"p": "http://www.plcopen.org/xml/tc6_0201", "xhtml": "http://www.w3.org/1999/xhtml"}
_SECTIONS = {"inputVars": "VAR_INPUT", "outputVars": "VAR_OUTPUT", "inOutVars": "VAR_IN_OUT",
             "externalVars": "VAR_EXTERNAL", "globalVars": "VAR_GLOBAL",
             "accessVars": "VAR_ACCESS", "localVars": "VAR", "tempVars": "VAR_TEMP"}  # fmt: skip
_KINDS = {"function": "FUNCTION", "functionBlock": "FUNCTION_BLOCK", "program": "PROGRAM"}


class BeremizReadError(ValueError):
    """The project is one Beremiz could not turn into ST."""


def _wrap_cdata(xml: str) -> str:
    """Beremiz's first step: a CDATA section outside ``<xhtml:p>`` is put in one."""
    xml = re.sub(r"(?<!<xhtml:p>)(?:<!\[CDATA\[)", "<xhtml:p><![CDATA[", xml)
    return re.sub(r"(?:]]>)(?!</xhtml:p>)", "]]></xhtml:p>", xml)


def formatted_text(el: ET.Element | None, where: str, form: str = "beremiz") -> str:
    """The text of a formattedText element as Beremiz reads it: its first ``xhtml:p``
    (``form="codesys"``: the text of its ``<xhtml>`` element, as CODESYS writes it)."""
    if el is None:
        raise BeremizReadError(f"{where}: no text element")
    tag = "xhtml:p" if form == "beremiz" else "xhtml:xhtml"
    ps = el.findall(tag, NS)
    if not ps:
        raise BeremizReadError(f"{where}: no <{tag}> (Beremiz reads nothing else)")
    return ps[0].text or ""


def _type(t: ET.Element, where: str) -> str:
    (content,) = list(t)
    tag = content.tag.split("}")[1]
    if tag == "derived":
        return content.get("name", "")
    if tag == "array":
        dims = ", ".join(f"{d.get('lower')}..{d.get('upper')}"
                         for d in content.findall("p:dimension", NS))  # fmt: skip
        base = content.find("p:baseType", NS)
        if base is None:
            raise BeremizReadError(f"{where}: an array without a base type")
        return f"ARRAY [{dims}] OF {_type(base, where)}"
    return tag.upper()


def st_from_plcopen(xml: str, form: str = "beremiz") -> str:
    """The ST of every POU of a PLCopen XML project, as Beremiz generates it for MATIEC
    (``form="codesys"``: the texts read from the CODESYS form instead)."""
    root = ET.fromstring(_wrap_cdata(xml) if form == "beremiz" else xml)
    out: list[str] = []
    for pou in root.iterfind("p:types/p:pous/p:pou", NS):
        name, kind = pou.get("name", ""), _KINDS[pou.get("pouType", "")]
        head = f"{kind} {name}"
        interface = pou.find("p:interface", NS)
        if interface is None:
            raise BeremizReadError(f"{name}: no interface")
        if kind == "FUNCTION":
            ret = interface.find("p:returnType", NS)
            if ret is None:
                raise BeremizReadError(f"{name}: a function without a return type")
            head += f" : {_type(ret, name)}"
        lines = [head]
        for section in interface:
            tag = section.tag.split("}")[1]
            if tag not in _SECTIONS:
                continue
            lines.append(f"  {_SECTIONS[tag]}")
            for v in section.iterfind("p:variable", NS):
                t = v.find("p:type", NS)
                assert t is not None
                init = v.find("p:initialValue/p:simpleValue", NS)
                ini = f" := {init.get('value')}" if init is not None else ""
                vdoc = v.find("p:documentation", NS)
                if vdoc is not None:
                    formatted_text(vdoc, f"{name}.{v.get('name')} documentation", form)
                lines.append(f"    {v.get('name')} : {_type(t, name)}{ini};")
            lines.append("  END_VAR")
        if len(lines) == 1:
            raise BeremizReadError(f'No variable defined in "{name}" POU')
        body = pou.find("p:body/p:ST", NS)
        text = formatted_text(body, f"{name} body", form)
        if not text.strip():
            raise BeremizReadError(f'No body defined in "{name}" POU')
        doc = pou.find("p:documentation", NS)
        if doc is not None:
            formatted_text(doc, f"{name} documentation", form)
        out += [*lines, "", text, f"END_{kind}", ""]
    return "\n".join(out)
