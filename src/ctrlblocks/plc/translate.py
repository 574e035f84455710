"""Translate the blocks' restricted Python to IEC 61131-3 Structured Text (via :mod:`ast`).

The per-cycle code of the blocks (:mod:`ctrlblocks.blocks.plc_cycle` and the
pure functions it calls in ``blocks/pid.py``, ``adrc.py``, ``leadlag.py``,
``signals.py``) is written in a small subset of Python: float / bool / int
scalars, ``if``/``elif``/``else``, conditional expressions, ``and``/``or``/
``not``, arithmetic, tuples (as several return values, or as a parameter
tuple unpacked in one statement), and calls of other such functions.  This
module turns that subset into ST:

* every called function becomes a ``FUNCTION`` POU (a tuple-returning one
  gets ``VAR_OUTPUT`` parameters, one per returned value, and is called with
  ``=>``); its parameter tuple (``k, sgn, ... = prm``) becomes separate inputs,
  and so does one it only passes on to a callee (named as the callee unpacks it);
* the top-level cycle function becomes the body of the ``FUNCTION_BLOCK``:
  its parameters are the FB's inputs and state variables, its final
  ``return`` assigns the outputs and the new state;
* a conditional expression becomes ``IF`` when it is a whole assigned or
  returned value, else ``SEL``; ``x - x`` style tricks are not used: NaN and
  inf are caught by ``ABS(x) <= 3.402823E38`` (``is_real``);
* a string argument (``pt1_coefficient(t, h, "exact")``) is folded at
  translation time: the function is specialised for that constant;
* Python comments become ``(* ... *)`` comments at the same place.

Anything outside the subset raises :class:`TranslationError` naming the
function and line, so a change of a kernel that the PLC cannot follow is
caught by the export tests instead of producing wrong code.

The output is *neutral* ST: variable references are wrapped as
``\\x01name\\x02`` and POU names as ``\\x03NAME\\x04`` so that a dialect can
render them (Siemens SCL writes ``#name`` and ``"NAME"``).
"""

from __future__ import annotations

import ast
import functools
import inspect
import io
import re
import textwrap
import tokenize
import types
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from .names import iec_name

__all__ = [
    "FbPou",
    "Pou",
    "Program",
    "TranslationError",
    "array_info",
    "array_type",
    "pou_ref",
    "real_literal",
    "var",
]

REAL, BOOL, DINT = "REAL", "BOOL", "DINT"
_ANN = {"float": REAL, "bool": BOOL, "int": DINT}
_ELEM = {"list[float]": REAL, "list[int]": DINT, "list[bool]": BOOL}
_ARRAY = re.compile(r"ARRAY\[0\.\.(\d+)\] OF (REAL|DINT|BOOL)")


def array_type(n: int, elem: str) -> str:
    """The ST type of a Python list of ``n`` values: ``ARRAY[0..n-1] OF elem``."""
    return f"ARRAY[0..{n - 1}] OF {elem}"


def array_info(typ: str) -> tuple[int, str] | None:
    """``(length, element type)`` of an array type, None for a scalar or an FB type."""
    m = _ARRAY.fullmatch(typ)
    return (int(m.group(1)) + 1, m.group(2)) if m else None

PREC_OR, PREC_XOR, PREC_AND, PREC_EQ, PREC_CMP, PREC_ADD, PREC_MUL, PREC_UNARY, PREC_ATOM = range(
    1, 10
)


class TranslationError(ValueError):
    """The Python code uses a construct the ST translator does not cover."""


def var(name: str) -> str:
    """A variable reference in neutral ST (rendered by the dialect)."""
    return f"\x01{name}\x02"


def pou_ref(name: str) -> str:
    """A POU (function) name in neutral ST (rendered by the dialect)."""
    return f"\x03{name}\x04"


def real_literal(x: float) -> str:
    """A REAL literal: ``1.0``, ``-2.5E-9``; +-inf as +-3.402823E38 (the documented REAL range)."""
    x = float(x)
    if x != x:
        raise TranslationError("a NaN literal has no REAL spelling")
    if abs(x) >= 3.4028230607370965e38:  # inf or plc_cycle.REAL_MAX
        return "3.402823E38" if x > 0 else "-3.402823E38"
    s = repr(x)
    if "e" in s or "E" in s:
        m, e = s.lower().split("e")
        if "." not in m:
            m += ".0"
        return f"{m}E{int(e)}"
    return s if "." in s else s + ".0"


@dataclass
class Pou:
    """One translated FUNCTION: interface and neutral-ST body lines."""

    name: str
    doc: str
    inputs: list[tuple[str, str]]
    outputs: list[tuple[str, str]]
    locals: dict[str, str]
    ret_type: str | None
    body: list[str]
    source: str
    calls: list[str] = field(default_factory=list)


@dataclass
class FbPou:
    """One translated small block (a :func:`plc_block` function) as a FUNCTION_BLOCK.

    ``inputs`` are its parameters but the state, ``outputs`` its results (a
    result that is a state parameter is the memory itself, readable by the
    caller), ``state`` the hidden memory, ``instances`` the FBs it holds.
    """

    name: str
    doc: str
    inputs: list[tuple[str, str]]
    outputs: list[tuple[str, str]]
    state: list[tuple[str, str]]
    instances: dict[str, str]
    temps: dict[str, str]
    body: list[str]
    source: str


@dataclass
class _FbSig:
    """What a caller needs to know about a small block's FUNCTION_BLOCK."""

    pou: str
    short: str
    params: list[str]  # python parameter names in order
    state: set[str]  # the parameters that are the instance's memory
    results: tuple[str, ...]
    hidden: set[str]  # state the caller cannot read (VAR, not VAR_OUTPUT)
    st: dict[str, str]  # python name -> ST name of every parameter and result
    types: dict[str, str]  # ST name -> type


@dataclass
class _Sig:
    """What a caller needs to know about a translated function."""

    pou: str
    params: list[str]  # python parameter names in order
    inputs: dict[str, list[str]]  # python param -> ST input names (a tuple param expands)
    ret_type: str | None  # the function's value (a tuple's first value)
    outputs: list[tuple[str, str]]  # a tuple's other values: (ST output name, type)
    tuple_ret: bool = False  # returns a tuple: called as ``a := F(..., OUT => b)``


def _iec_names(wanted: dict[str, str], taken: set[str] | None = None) -> dict[str, str]:
    """``{key: wanted name}`` -> ``{key: IEC identifier}``, distinct (case-insensitively)
    from ``taken`` and from each other, given in order."""
    used = set(taken or ())
    out: dict[str, str] = {}
    for key, name in wanted.items():
        out[key] = iec_name(name, used)
        used.add(out[key])
    return out


class Program:
    """The set of POUs translated for one export (functions are shared between blocks)."""

    def __init__(self, prefix: str = "CB_") -> None:
        self.prefix = prefix
        self.pous: dict[str, Pou] = {}
        self.fbs: dict[str, FbPou] = {}
        self._sigs: dict[tuple[Any, ...], _Sig] = {}
        self._fb_sigs: dict[tuple[Any, ...], _FbSig] = {}

    def fb_type(self, fn: Callable[..., Any], sizes: dict[str, int] | None = None) -> _FbSig:
        """Translate a small block ``fn`` (marked by :func:`plc_block`) as a FUNCTION_BLOCK.

        ``sizes``: the length of each list parameter (its ARRAY's bounds).
        """
        sizes = sizes or {}
        key = (fn, tuple(sorted(sizes.items())))
        if key in self._fb_sigs:
            return self._fb_sigs[key]
        short, results, hidden = fn.plc_block  # type: ignore[attr-defined]
        # the array sizes are part of the type's name: one name, one text, in every export
        pou_name = iec_name("_".join([self.prefix + short, *(str(n) for n in sizes.values())]))
        node = _source(fn)[0]
        params = [a.arg for a in node.args.args]
        names = _iec_names({n: n.upper() for n in (*params, *results)})
        tr = _Translator(self, fn, {}, fb=(results, names), sizes=sizes)
        body, fbvars, temps, instances = tr.translate_fb()
        state = {p for p in params if p in results}
        pou = FbPou(
            name=pou_name,
            doc=tr.doc(),
            inputs=[(names[p], fbvars[names[p]]) for p in params if p not in state],
            outputs=[(names[r], fbvars[names[r]]) for r in results if r not in hidden],
            state=[(names[r], fbvars[names[r]]) for r in results if r in hidden],
            instances=instances,
            temps=temps,
            body=body,
            source=f"{fn.__module__}.{fn.__qualname__}",
        )
        self.fbs[pou.name] = pou
        sig = _FbSig(pou.name, short, params, state, tuple(results), set(hidden), names, fbvars)
        self._fb_sigs[key] = sig
        return sig

    def function(self, fn: Callable[..., Any], consts: dict[str, Any] | None = None) -> _Sig:
        """Translate ``fn`` (specialised for constant arguments ``consts``) as a FUNCTION."""
        consts = consts or {}
        key = (fn, tuple(sorted(consts.items())))
        if key not in self._sigs:
            tr = _Translator(self, fn, consts, fb=None)
            self._sigs[key] = tr.translate_function()
        return self._sigs[key]

    def fb_body(
        self,
        fn: Callable[..., Any],
        results: tuple[str, ...],
        names: dict[str, str],
        sizes: dict[str, int] | None = None,
    ) -> tuple[list[str], dict[str, str], dict[str, str], dict[str, str]]:
        """Translate ``fn`` as the body of a FUNCTION_BLOCK.

        ``names`` maps every parameter and result of ``fn`` to its FB variable
        name; ``results`` names the values of the final ``return``.  Returns
        ``(body lines, {FB var: type}, {temp: type}, {instance: FB type})``;
        a parameter that is the memory of a small block's instance is not an
        FB variable (the instance holds it).  ``sizes``: the length of each
        list parameter.
        """
        tr = _Translator(self, fn, {}, fb=(results, names), sizes=sizes)
        return tr.translate_fb()

    def ordered(self) -> list[Pou]:
        """The POUs, callees before callers (some compilers need that order)."""
        done: list[str] = []

        def visit(n: str) -> None:
            if n in done:
                return
            for c in self.pous[n].calls:
                visit(c)
            done.append(n)

        for n in list(self.pous):
            visit(n)
        return [self.pous[n] for n in done]


@functools.cache
def _source(fn: Callable[..., Any]) -> tuple[ast.FunctionDef, str, int, dict[int, str]]:
    """The parsed source of ``fn`` (cached: the translator reads a callee at each call site;
    the tree is never modified)."""
    try:
        src = inspect.getsource(fn)
        first = inspect.getsourcelines(fn)[1]
    except (OSError, TypeError) as exc:  # pragma: no cover - built-ins
        raise TranslationError(f"no Python source for {fn!r}") from exc
    src = textwrap.dedent(src)
    tree = ast.parse(src)
    node = tree.body[0]
    if not isinstance(node, ast.FunctionDef):
        raise TranslationError(f"{fn.__qualname__} is not a plain function")
    comments: dict[int, str] = {}
    for tok in tokenize.generate_tokens(io.StringIO(src).readline):
        if tok.type == tokenize.COMMENT:
            text = tok.string.lstrip("#").strip()
            if text and not text.startswith(("fmt:", "type:", "noqa", "pragma")):
                comments[tok.start[0]] = text
    return node, src, first, comments


class _Translator:
    def __init__(
        self,
        prog: Program,
        fn: Callable[..., Any],
        consts: dict[str, Any],
        fb: tuple[tuple[str, ...], dict[str, str]] | None,
        sizes: dict[str, int] | None = None,
    ) -> None:
        self.sizes = sizes or {}
        self.prog = prog
        self.fn = fn
        self.consts = dict(consts)
        self.fb = fb
        self.node, self.src, self.first, self.comments = _source(fn)
        self.glb = fn.__globals__
        self.types: dict[str, str] = {}  # python name -> ST type
        self.st: dict[str, str] = {}  # python name -> ST variable name
        self.locals: dict[str, str] = {}  # ST local -> type
        self.tuples: dict[str, list[ast.expr]] = {}
        self.version: dict[str, int] = {}
        self.tuple_versions: dict[str, dict[str, int]] = {}
        self.calls: list[str] = []
        self.lines: list[str] = []
        self.indent = 0
        self.last_line = 0
        self.ret_name = ""
        self.outputs: list[tuple[str, str]] = []
        self.ret_type: str | None = None
        # small blocks' instances: python name of a memory -> (instance, output or None)
        self.owned: dict[str, tuple[str, str | None]] = {}
        self.instances: dict[str, str] = {}  # instance -> FB type
        self.fb_calls: dict[int, tuple[str, _FbSig, dict[str, str]]] = {}
        self.reserved_names: set[str] = set()  # names this POU declares besides self.st
        self._expr_cache: dict[tuple[int, str | None], tuple[ast.expr, tuple[str, int, str]]] = {}

    def scan_instances(self) -> None:
        """Find the calls of small blocks: one instance per set of memories passed."""
        by_state: dict[tuple[str, ...], str] = {}
        for st in ast.walk(self.node):
            if not (isinstance(st, ast.Assign) and isinstance(st.value, ast.Call)):
                continue
            c = st.value
            fn = self.resolve(c.func)
            if not hasattr(fn, "plc_block"):
                continue
            if self.fb is None:
                raise self.err(st, "a FUNCTION cannot hold a FUNCTION_BLOCK instance")
            assert fn is not None
            params = [a.arg for a in _source(fn)[0].args.args]
            if len(c.args) != len(params) or c.keywords:
                raise self.err(c, f"{fn.__name__} takes {len(params)} positional arguments")
            state_args: dict[str, str] = {}
            sizes: dict[str, int] = {}
            for p, a in zip(params, c.args, strict=True):
                if p in fn.plc_block[1]:
                    if not isinstance(a, ast.Name):
                        raise self.err(c, f"the memory {p!r} of {fn.__name__} must be a name")
                    state_args[p] = a.id
                    info = array_info(self.types.get(a.id, ""))
                    if info is not None:
                        sizes[p] = info[0]
            sig = self.prog.fb_type(fn, sizes)
            key = tuple(state_args.values())
            if key not in by_state:
                inst = iec_name(f"{sig.short}_{key[0]}" if key else sig.short, self.taken())
                by_state[key] = inst
                self.instances[inst] = sig.pou
            inst = by_state[key]
            for p, x in state_args.items():
                if x in self.owned and self.owned[x][0] != inst:
                    raise self.err(c, f"{x!r} is the memory of two instances")
                self.owned[x] = (inst, None if p in sig.hidden else sig.st[p])
            self.fb_calls[id(c)] = (inst, sig, state_args)

    def fb_call(self, target: ast.expr, c: ast.Call, s: ast.stmt) -> None:
        """``y, x = block(u, ..., y, x)``: call the instance, read its outputs."""
        inst, sig, state_args = self.fb_calls[id(c)]
        if isinstance(target, ast.Tuple):
            targets = [e.id if isinstance(e, ast.Name) else "" for e in target.elts]
        else:
            targets = [target.id if isinstance(target, ast.Name) else ""]
        if len(targets) != len(sig.results) or "" in targets:
            raise self.err(s, f"{sig.pou} gives {len(sig.results)} values to names")
        args = zip(sig.params, c.args, strict=True)
        params = [f"{sig.st[p]} := {self.coerce(a, sig.types[sig.st[p]])}"
                  for p, a in args if p not in sig.state]  # fmt: skip
        self.emit_call(var(inst), params)
        for r, t in zip(sig.results, targets, strict=True):
            if r in sig.state:
                if t != state_args[r]:
                    raise self.err(s, f"the memory {r!r} of {sig.pou} must go back to {t!r}")
                continue
            typ = sig.types[sig.st[r]]
            st = self.declare(t, self.types.get(t, typ), s)
            self.emit(f"{var(st)} := {var(inst)}.{sig.st[r]};")
            self.bump(t)

    # -- errors and comments ---------------------------------------------------

    def err(self, node: ast.AST, msg: str) -> TranslationError:
        line = self.first + getattr(node, "lineno", 1) - 1
        mod = self.fn.__module__
        return TranslationError(f"{mod}.{self.fn.__qualname__}, line {line}: {msg}")

    def emit(self, text: str) -> None:
        self.lines.append("    " * self.indent + text)

    def emit_comments(self, node: ast.stmt) -> None:
        end = getattr(node, "end_lineno", node.lineno)
        for ln in sorted(self.comments):
            if self.last_line < ln <= end and ln != self.node.lineno:
                self.emit("(* " + self.comments[ln].replace("*)", "* )") + " *)")
        self.last_line = max(self.last_line, end)

    # -- names and types -----------------------------------------------------------

    def declare(self, name: str, typ: str, node: ast.AST, want: str = "") -> str:
        """The ST variable of the Python name ``name`` (declared as a local of type ``typ``
        the first time, as an IEC identifier made from ``want`` or ``name``)."""
        if name in self.st and name not in self.types:
            self.types[name] = typ  # a result variable of the FB, named beforehand
            return self.st[name]
        if name in self.st:
            old = self.types[name]
            if old != typ and not (old == REAL and typ == DINT):
                raise self.err(node, f"{name!r} changes type from {old} to {typ}")
            return self.st[name]
        st = iec_name(want or name, self.taken())
        self.st[name] = st
        self.types[name] = typ
        self.locals[st] = typ
        return st

    def taken(self) -> set[str]:
        """The ST names of this POU's scope: variables, instances, the function's own name."""
        return {*self.st.values(), *self.instances, *self.reserved_names, self.ret_name}

    def bump(self, name: str) -> None:
        self.version[name] = self.version.get(name, 0) + 1

    # -- entry points ----------------------------------------------------------------

    def _params(self) -> list[tuple[str, str | None]]:
        out = []
        for a in self.node.args.args:
            ann = ast.unparse(a.annotation) if a.annotation is not None else ""
            out.append((a.arg, _ANN.get(ann)))
        return out

    def _body_statements(self) -> list[ast.stmt]:
        body = list(self.node.body)
        if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
            body = body[1:]
        return body

    def doc(self) -> str:
        doc = ast.get_docstring(self.node) or ""
        doc = doc.strip().split("\n\n")[0].replace("\n", " ")
        doc = re.sub(r":\w+:`[~.]?(?:[\w.]*\.)?(\w+)`", r"\1", doc)  # :class:`~a.B` -> B
        return doc.replace("``", "")

    def translate_function(self) -> _Sig:
        fn = self.fn
        name = iec_name("_".join([self.prog.prefix + fn.__name__.upper(),
                                  *(str(v).upper() for v in self.consts.values())]))  # fmt: skip
        self.ret_name = name
        self.scan_instances()
        body = self._body_statements()
        params = self._params()
        assigned = {
            t.id
            for st in ast.walk(self.node)
            if isinstance(st, ast.Assign | ast.AugAssign)
            for t in ([st.target] if isinstance(st, ast.AugAssign) else st.targets)
            for t in ([t] if isinstance(t, ast.Name) else getattr(t, "elts", []))
            if isinstance(t, ast.Name)
        }
        inputs: list[tuple[str, str]] = []
        sig_inputs: dict[str, list[str]] = {}
        copy_in: list[tuple[str, str]] = []
        for pname, ptype in params:
            if pname in self.consts:
                continue
            if ptype is None:
                # a parameter tuple: expanded by ``a, b, c = pname`` at the top
                unpack = next(
                    (
                        s
                        for s in body
                        if isinstance(s, ast.Assign)
                        and isinstance(s.value, ast.Name)
                        and s.value.id == pname
                        and isinstance(s.targets[0], ast.Tuple)
                    ),
                    None,
                )
                if unpack is None:
                    # a parameter tuple only passed on to a callee: its values are inputs
                    # named as the callee unpacks them (keys no Python name has)
                    wanted = self.lookahead_names(pname)
                    if not wanted:
                        raise self.err(self.node, f"parameter {pname!r} needs a type annotation")
                    names = [f"{pname}.{j}" for j in range(len(wanted))]
                    for n, want in zip(names, wanted, strict=True):
                        self.declare(n, REAL, self.node, want)
                else:
                    body.remove(unpack)
                    target = unpack.targets[0]
                    assert isinstance(target, ast.Tuple)
                    names = [e.id for e in target.elts if isinstance(e, ast.Name)]
                    for n in names:
                        self.declare(n, REAL, unpack)
                st_names = []
                for n in names:
                    del self.locals[self.st[n]]
                    inputs.append((self.st[n], REAL))
                    st_names.append(self.st[n])
                sig_inputs[pname] = st_names
                # passed on as a whole: the tuple of its inputs (unchanged since, checked)
                self.tuples[pname] = [ast.Name(n) for n in names]
                self.tuple_versions[pname] = dict.fromkeys(names, 0)
                continue
            st = self.declare(pname, ptype, self.node)
            del self.locals[st]
            if pname in assigned:
                # an input the body writes: the input is copied to a local of the same name
                inp = iec_name(pname + "_in", self.taken())
                self.reserved_names.add(inp)
                inputs.append((inp, ptype))
                self.locals[st] = ptype
                copy_in.append((st, inp))
                sig_inputs[pname] = [inp]
            else:
                inputs.append((st, ptype))
                sig_inputs[pname] = [st]
        ret = self.node.returns
        ann = ast.unparse(ret) if ret is not None else ""
        tuple_ret = ann not in _ANN
        if not tuple_ret:
            self.ret_type = _ANN[ann]
        else:
            # a tuple: its first value is the function's value, the others VAR_OUTPUTs
            first, *self.outputs = self._tuple_outputs(body, ann)
            self.ret_type = first[1]
        for st, inp in copy_in:
            self.emit(f"{var(st)} := {var(inp)};")
        self.block(body, top=True)
        pou = Pou(
            name=name,
            doc=self.doc(),
            inputs=inputs,
            outputs=self.outputs,
            locals={k: v for k, v in self.locals.items() if k not in dict(self.outputs)},
            ret_type=self.ret_type,
            body=self.lines,
            source=f"{fn.__module__}.{fn.__qualname__}",
            calls=self.calls,
        )
        self.prog.pous[name] = pou
        return _Sig(
            pou=name,
            params=[p for p, _ in params if p not in self.consts],
            inputs=sig_inputs,
            ret_type=self.ret_type,
            outputs=self.outputs,
            tuple_ret=tuple_ret,
        )

    def _tuple_outputs(self, body: list[ast.stmt], ann: str) -> list[tuple[str, str]]:
        """(ST name, type) of each value of the returned tuples; a value returned as a
        local's name names its output (and that local *is* the output), else ``r<j>``."""
        rets = [
            n
            for s in body
            for n in ast.walk(s)
            if isinstance(n, ast.Return) and n.value is not None
        ]
        if not rets or not all(isinstance(r.value, ast.Tuple) for r in rets):
            raise self.err(self.node, "returns neither a scalar annotation nor tuples")
        last = rets[-1].value
        assert isinstance(last, ast.Tuple)
        if len(last.elts) < 2:
            raise self.err(self.node, "a tuple of one value (return the value itself)")
        params = {a.arg for a in self.node.args.args}
        elt_types: list[str | None] = []
        if ann.startswith("tuple[") and "..." not in ann:
            elt_types = [_ANN.get(t.strip()) for t in ann[6:-1].split(",")]
        outs: list[tuple[str, str]] = []
        for j, e in enumerate(last.elts):
            typ = elt_types[j] if j < len(elt_types) else None
            typ = typ or REAL
            nm = e.id if isinstance(e, ast.Name) else ""
            own = j > 0 and bool(nm) and nm not in params and nm not in self.st
            oname = iec_name(nm if nm else f"r{j}", self.taken())
            self.reserved_names.add(oname)
            if own:  # the local returned here is the output itself
                self.st[nm] = oname
                self.types[nm] = typ
            outs.append((oname, typ))
        return outs

    def translate_fb(self) -> tuple[list[str], dict[str, str], dict[str, str], dict[str, str]]:
        assert self.fb is not None
        results, names = self.fb
        params = self._params()
        fbvars: dict[str, str] = {}
        anns = {a.arg: ast.unparse(a.annotation) if a.annotation else ""
                for a in self.node.args.args}  # fmt: skip
        for pname, ptype in params:
            if ptype is None and anns[pname] in _ELEM and pname in self.sizes:
                ptype = array_type(self.sizes[pname], _ELEM[anns[pname]])
            if ptype is None:
                raise self.err(self.node, f"FB parameter {pname!r} needs a scalar annotation "
                                          "(or list[...] with its size)")  # fmt: skip
            st = names[pname]
            self.st[pname] = st
            self.types[pname] = ptype
            fbvars[st] = ptype
        for rname in results:
            if rname not in self.st:
                self.st[rname] = names[rname]
        self.scan_instances()
        for x in self.owned:
            fbvars.pop(self.st.get(x, ""), None)  # the instance holds it
        body = self._body_statements()
        final = body[-1]
        if not isinstance(final, ast.Return) or final.value is None:
            raise self.err(final, "the cycle function must end with 'return <values>'")
        self.block(body[:-1], top=False)
        self.emit_comments(final)
        elts = final.value.elts if isinstance(final.value, ast.Tuple) else [final.value]
        if len(elts) != len(results):
            raise self.err(final, f"returns {len(elts)} values, the results name {len(results)}")
        # result variables named like locals are the same ST variables
        pending: list[tuple[str, str, str]] = []
        for rname, e in zip(results, elts, strict=True):
            st = names[rname]
            if rname in self.owned:
                if not (isinstance(e, ast.Name) and e.id == rname):
                    raise self.err(final, f"{rname!r} is the memory of an instance")
                continue
            text, _, typ = self.expr(e)
            if rname not in dict(params):
                fbvars[st] = self.types.get(rname, typ)
            if isinstance(e, ast.Name) and self.st.get(e.id) == st:
                continue
            pending.append((st, text, typ))
        written: set[str] = set()
        for st, text, _typ in pending:
            if any(var(w) in text for w in written):
                raise self.err(final, f"result {st} reads a result assigned before it")
            self.emit(f"{var(st)} := {text};")
            written.add(st)
        temps = {k: v for k, v in self.locals.items() if k not in fbvars}
        return self.lines, fbvars, temps, self.instances

    # -- statements ----------------------------------------------------------------------

    def block(self, stmts: list[ast.stmt], top: bool) -> None:
        """The statements up to the first that always returns (the rest is dead code, in
        Python as in ST); ``top``: nothing follows this block in the POU, so its last
        statement needs no RETURN."""
        live: list[ast.stmt] = []
        for s in stmts:
            live.append(s)
            if self.returns(s):
                break
        for i, s in enumerate(live):
            self.emit_comments(s)
            self.stmt(s, top and i == len(live) - 1)
        if len(live) < len(stmts):  # the dead statements' comments go with them
            self.last_line = max(self.last_line, getattr(stmts[-1], "end_lineno", 0) or 0)

    def returns(self, s: ast.stmt) -> bool:
        """True if ``s`` returns on every path (after translation-time constant folding)."""
        if isinstance(s, ast.Return):
            return True
        if isinstance(s, ast.If):
            c = self.const_test(s.test)
            if c is not None:
                return any(self.returns(x) for x in (s.body if c else s.orelse))
            return any(self.returns(x) for x in s.body) and any(
                self.returns(x) for x in s.orelse
            )
        return False

    def stmt(self, s: ast.stmt, last: bool) -> None:
        self._expr_cache.clear()  # the names and types may change from statement to statement
        if isinstance(s, ast.Expr) and isinstance(s.value, ast.Constant):
            return
        if isinstance(s, ast.Assign):
            if len(s.targets) != 1:
                raise self.err(s, "chained assignment")
            self.assign(s.targets[0], s.value, s)
        elif isinstance(s, ast.AugAssign):
            if not isinstance(s.target, ast.Name):
                raise self.err(s, "augmented assignment to a non-name")
            self.assign(s.target, ast.BinOp(left=ast.Name(s.target.id), op=s.op, right=s.value), s)
        elif isinstance(s, ast.If):
            self.if_stmt(s, last)
        elif isinstance(s, ast.Return):
            self.return_stmt(s, last)
        elif isinstance(s, ast.For):
            self.for_stmt(s)
        else:
            raise self.err(s, f"statement {type(s).__name__} is not translated")

    def for_stmt(self, s: ast.For) -> None:
        """``for j in range(a[, b]):`` -> ``FOR j := a TO b - 1 DO`` (the bounds are DINT)."""
        it = s.iter
        if not (
            isinstance(s.target, ast.Name)
            and isinstance(it, ast.Call)
            and isinstance(it.func, ast.Name)
            and it.func.id == "range"
            and 1 <= len(it.args) <= 2
            and not s.orelse
        ):
            raise self.err(s, "only 'for name in range(a[, b])' loops are translated")
        lo = self.coerce(it.args[0], DINT) if len(it.args) == 2 else "0"
        hi = it.args[-1]
        if isinstance(hi, ast.Constant):
            top = str(int(hi.value) - 1)  # type: ignore[arg-type]
        else:
            top = f"{self.wrap(self.expr(hi), PREC_ADD + 1)} - 1"
            if self.expr(hi)[2] != DINT:
                raise self.err(s, "range() of a non-DINT")
        j = self.declare(s.target.id, DINT, s)
        self.emit(f"FOR {var(j)} := {lo} TO {top} DO")
        self.indent += 1
        self.block(s.body, top=False)
        self.indent -= 1
        self.emit("END_FOR;")

    def const_test(self, e: ast.expr) -> bool | None:
        try:
            v = self.fold(e)
        except TranslationError:
            return None
        return bool(v) if isinstance(v, bool | int | float | str) else None

    def if_stmt(self, s: ast.If, last: bool) -> None:
        c = self.const_test(s.test)
        if c is not None:
            self.block(s.body if c else s.orelse, top=last)
            return
        # the branches of the POU's last statement end the POU: no RETURN at their ends
        self.emit(f"IF {self.expr(s.test)[0]} THEN")
        self.indent += 1
        self.block(s.body, top=last)
        self.indent -= 1
        orelse = s.orelse
        while len(orelse) == 1 and isinstance(orelse[0], ast.If):
            sub = orelse[0]
            if self.const_test(sub.test) is not None:
                break  # a folded elif: its live branch is the ELSE
            self.emit_comments(sub)
            self.emit(f"ELSIF {self.expr(sub.test)[0]} THEN")
            self.indent += 1
            self.block(sub.body, top=last)
            self.indent -= 1
            orelse = sub.orelse
        if orelse:
            self.emit("ELSE")
            self.indent += 1
            self.block(orelse, top=last)
            self.indent -= 1
        self.emit("END_IF;")

    def return_stmt(self, s: ast.Return, last: bool) -> None:
        if self.fb is not None:
            raise self.err(s, "an early return in the cycle function")
        if s.value is None:
            raise self.err(s, "a bare return")
        if not self.outputs:
            self.assign_value(self.ret_name, self.ret_type or REAL, s.value, s)
        else:
            if not isinstance(s.value, ast.Tuple) or len(s.value.elts) != len(self.outputs) + 1:
                raise self.err(s, "returns a different number of values")
            pending = [(self.ret_name, self.ret_type or REAL, s.value.elts[0])]
            for (oname, otype), e in zip(self.outputs, s.value.elts[1:], strict=True):
                if isinstance(e, ast.Name) and self.st.get(e.id) == oname:
                    continue
                pending.append((oname, otype, e))
            written: list[str] = []
            for oname, otype, e in pending:
                text = self.coerce(e, otype)
                if any(var(w) in text for w in written):
                    raise self.err(s, f"output {oname} reads an output assigned before it")
                self.emit(f"{var(oname)} := {text};")
                written.append(oname)
        if not last:
            self.emit("RETURN;")

    def assign(self, target: ast.expr, value: ast.expr, s: ast.stmt) -> None:
        if isinstance(value, ast.Call) and id(value) in self.fb_calls:
            self.fb_call(target, value, s)
            return
        if isinstance(target, ast.Subscript):
            text, elem = self.element(target)
            self.emit(f"{text} := {self.coerce(value, elem)};")
            return
        for t in target.elts if isinstance(target, ast.Tuple) else [target]:
            if isinstance(t, ast.Name) and t.id in self.owned:
                raise self.err(s, f"{t.id!r} is the memory of {self.owned[t.id][0]}: "
                                  "only the instance's call writes it")  # fmt: skip
        if isinstance(target, ast.Name):
            if isinstance(value, ast.Tuple):
                self.bind_tuple(target.id, value, s)
                return
            if isinstance(value, ast.Call) and self.is_tuple_call(value):
                raise self.err(s, "a tuple-returning call assigned to one name")
            typ = self.expr(value)[2]
            st = self.declare(target.id, self.types.get(target.id, typ), s)
            self.assign_value(st, self.types[target.id], value, s)
            self.bump(target.id)
            return
        if isinstance(target, ast.Tuple):
            names = [e.id for e in target.elts if isinstance(e, ast.Name)]
            if len(names) != len(target.elts):
                raise self.err(s, "tuple targets must be names")
            if isinstance(value, ast.Call):
                self.call_statement(names, value, s)
                return
            if isinstance(value, ast.Tuple) and len(value.elts) == len(names):
                texts = [self.expr(e) for e in value.elts]
                for n, (text, _p, typ) in zip(names, texts, strict=True):
                    if any(
                        var(self.st[m]) in text for m in names[: names.index(n)] if m in self.st
                    ):
                        raise self.err(s, "parallel tuple assignment that reads its own targets")
                    st = self.declare(n, self.types.get(n, typ), s)
                    self.emit(f"{var(st)} := {text};")
                    self.bump(n)
                return
        raise self.err(s, "assignment form not translated")

    def assign_value(self, st: str, typ: str, value: ast.expr, s: ast.stmt) -> None:
        if isinstance(value, ast.IfExp):
            c = self.const_test(value.test)
            if c is not None:
                self.assign_value(st, typ, value.body if c else value.orelse, s)
                return
            self.emit(f"IF {self.expr(value.test)[0]} THEN")
            self.indent += 1
            self.assign_value(st, typ, value.body, s)
            self.indent -= 1
            orelse = value.orelse
            while isinstance(orelse, ast.IfExp):
                self.emit(f"ELSIF {self.expr(orelse.test)[0]} THEN")
                self.indent += 1
                self.assign_value(st, typ, orelse.body, s)
                self.indent -= 1
                orelse = orelse.orelse
            self.emit("ELSE")
            self.indent += 1
            self.assign_value(st, typ, orelse, s)
            self.indent -= 1
            self.emit("END_IF;")
            return
        self.emit(f"{var(st)} := {self.coerce(value, typ)};")

    def bind_tuple(self, name: str, value: ast.Tuple, s: ast.stmt) -> None:
        """``prm = (a, b, c)``: a compile-time tuple; non-trivial elements get locals."""
        callee_names = self.lookahead_names(name)
        elts: list[ast.expr] = []
        for j, e in enumerate(value.elts):
            if isinstance(e, ast.Name | ast.Constant):
                elts.append(e)
                continue
            # a local of its own (a key no Python name has), named after the callee's parameter
            nm = f"{name}.{j}"
            want = callee_names[j] if j < len(callee_names) else f"{name}_{j}"
            typ = self.expr(e)[2]
            st = self.declare(nm, typ, s, want)
            self.assign_value(st, typ, e, s)
            self.bump(nm)
            elts.append(ast.Name(nm))
        self.tuples[name] = elts
        self.tuple_versions[name] = {
            e.id: self.version.get(e.id, 0) for e in elts if isinstance(e, ast.Name)
        }

    def lookahead_names(self, tuple_name: str) -> list[str]:
        for n in ast.walk(self.node):
            if not isinstance(n, ast.Call):
                continue
            fn = self.resolve(n.func)
            if not isinstance(fn, types.FunctionType):
                continue
            for j, a in enumerate(n.args):
                if isinstance(a, ast.Name) and a.id == tuple_name:
                    node = _source(fn)[0]
                    pname = node.args.args[j].arg
                    for st in node.body:
                        if (
                            isinstance(st, ast.Assign)
                            and isinstance(st.value, ast.Name)
                            and st.value.id == pname
                            and isinstance(st.targets[0], ast.Tuple)
                        ):
                            return [e.id for e in st.targets[0].elts if isinstance(e, ast.Name)]
        return []

    # -- calls -----------------------------------------------------------------------------

    def resolve(self, func: ast.expr) -> Any:
        if isinstance(func, ast.Name):
            if func.id in self.st:
                return None
            return self.glb.get(func.id, getattr(__builtins__, func.id, None) if False else None)
        if isinstance(func, ast.Attribute) and isinstance(func.value, ast.Name):
            mod = self.glb.get(func.value.id)
            return getattr(mod, func.attr, None) if mod is not None else None
        return None

    def is_tuple_call(self, c: ast.Call) -> bool:
        fn = self.resolve(c.func)
        if isinstance(fn, types.FunctionType) and fn.__module__.startswith("ctrlblocks."):
            return self.user_sig(c, fn).tuple_ret
        return False

    def user_sig(self, c: ast.Call, fn: types.FunctionType) -> _Sig:
        node = _source(fn)[0]
        consts = {}
        for j, a in enumerate(c.args):
            if isinstance(a, ast.Constant) and isinstance(a.value, str):
                consts[node.args.args[j].arg] = a.value
        return self.prog.function(fn, consts)

    def call_args(self, c: ast.Call, sig: _Sig) -> list[str]:
        if c.keywords:
            raise self.err(c, "keyword arguments")
        args = [a for a in c.args if not (isinstance(a, ast.Constant) and isinstance(a.value, str))]
        if len(args) != len(sig.params):
            raise self.err(c, f"{sig.pou} takes {len(sig.params)} arguments, got {len(args)}")
        pou = self.prog.pous[sig.pou]
        types_in = dict(pou.inputs)
        out = []
        for pname, a in zip(sig.params, args, strict=True):
            st_inputs = sig.inputs[pname]
            if isinstance(a, ast.Name) and a.id in self.tuples:
                elts = self.tuples[a.id]
                for nm, ver in self.tuple_versions[a.id].items():
                    if self.version.get(nm, 0) != ver:
                        raise self.err(c, f"{nm!r} changed after tuple {a.id!r} was built")
                if len(elts) != len(st_inputs):
                    raise self.err(
                        c, f"tuple {a.id!r} has {len(elts)} values, needs {len(st_inputs)}"
                    )
                for inp, e in zip(st_inputs, elts, strict=True):
                    out.append(f"{inp} := {self.coerce(e, types_in[inp])}")
            else:
                if len(st_inputs) != 1:
                    raise self.err(c, f"{pname!r} of {sig.pou} must be a tuple built here")
                out.append(f"{st_inputs[0]} := {self.coerce(a, types_in[st_inputs[0]])}")
        return out

    def call_statement(self, names: list[str], c: ast.Call, s: ast.stmt) -> None:
        fn = self.resolve(c.func)
        if not (isinstance(fn, types.FunctionType) and fn.__module__.startswith("ctrlblocks.")):
            raise self.err(s, "a tuple assignment from something other than a block function")
        sig = self.user_sig(c, fn)
        if not sig.tuple_ret or len(sig.outputs) + 1 != len(names):
            n_values = len(sig.outputs) + 1 if sig.tuple_ret else 1
            raise self.err(s, f"{sig.pou} returns {n_values} values, {len(names)} targets")
        args = self.call_args(c, sig)
        outs, targets = [], []
        results = [(sig.pou, sig.ret_type or REAL), *sig.outputs]
        for n, (oname, otype) in zip(names, results, strict=True):
            st = self.declare(n, self.types.get(n, otype), s)
            if self.types[n] != otype:  # an output (=>) is not converted
                raise self.err(s, f"{n!r} is {self.types[n]}, {sig.pou}.{oname} is {otype}")
            targets.append(st)
            self.bump(n)
        if len(set(targets)) != len(targets):
            raise self.err(s, "one name for two results")
        for st, (oname, _otype) in zip(targets[1:], sig.outputs, strict=True):
            outs.append(f"{oname} => {var(st)}")
        if sig.pou not in self.calls:
            self.calls.append(sig.pou)
        # the function's value is assigned: IEC 61131-3 has no call statement of a FUNCTION
        # that discards its value
        self.emit_call(pou_ref(sig.pou), args + outs, f"{var(targets[0])} := ")

    def emit_call(self, name: str, params: list[str], assign: str = "") -> None:
        """``[assign]name(p1, ...);``, one parameter a line."""
        if not params:
            self.emit(f"{assign}{name}();")
            return
        self.emit(f"{assign}{name}(")
        for j, p in enumerate(params):
            self.emit("    " + p + ("," if j < len(params) - 1 else ");"))

    # -- expressions: (text, precedence, type) -------------------------------------------

    def element(self, e: ast.Subscript) -> tuple[str, str]:
        """``a[i]`` of an array of this POU: ``(ST text, element type)``."""
        if not isinstance(e.value, ast.Name) or e.value.id in self.owned:
            raise self.err(e, "a subscript of something other than this block's array")
        info = array_info(self.types.get(e.value.id, ""))
        if info is None:
            raise self.err(e, f"{e.value.id!r} is not an array")
        return f"{var(self.st[e.value.id])}[{self.coerce(e.slice, DINT)}]", info[1]

    def fold(self, e: ast.expr) -> Any:
        """Evaluate a constant expression (string constants, module constants)."""
        if isinstance(e, ast.Constant):
            return e.value
        if isinstance(e, ast.Name):
            if e.id in self.consts:
                return self.consts[e.id]
            if e.id not in self.st:
                v = self.glb.get(e.id)
                if isinstance(v, bool | int | float | str):
                    return v
        if isinstance(e, ast.Compare) and len(e.ops) == 1:
            a, b = self.fold(e.left), self.fold(e.comparators[0])
            op = e.ops[0]
            if isinstance(op, ast.Eq):
                return a == b
            if isinstance(op, ast.NotEq):
                return a != b
        raise TranslationError("not a constant")

    def coerce(self, e: ast.expr, typ: str) -> str:
        text, _p, t = self.expr(e, want=typ)
        if t == typ:
            return text
        if typ == REAL and t == DINT:
            return f"DINT_TO_REAL({text})"
        raise self.err(e, f"a {t} value where {typ} is needed")

    def wrap(self, sub: tuple[str, int, str], prec: int) -> str:
        return sub[0] if sub[1] >= prec else f"({sub[0]})"

    def expr(self, e: ast.expr, want: str | None = None) -> tuple[str, int, str]:
        """``(ST text, precedence, type)`` of ``e``; cached within a statement (the type and
        text of a sub-expression are asked for several times on the way up; the node is
        kept with its entry, so that its id is not reused)."""
        key = (id(e), want)
        hit = self._expr_cache.get(key)
        if hit is None:
            hit = self._expr_cache[key] = (e, self._expr(e, want))
        return hit[1]

    def _expr(self, e: ast.expr, want: str | None = None) -> tuple[str, int, str]:
        if isinstance(e, ast.Constant) or (
            isinstance(e, ast.Name) and e.id not in self.st and e.id not in self.tuples
        ):
            try:
                v = self.fold(e)
            except TranslationError:
                raise self.err(e, f"unknown name {getattr(e, 'id', e)!r}") from None
            if isinstance(v, bool):
                return ("TRUE" if v else "FALSE"), PREC_ATOM, BOOL
            if isinstance(v, int):
                if want == REAL:
                    return real_literal(float(v)), PREC_ATOM if v >= 0 else PREC_UNARY, REAL
                return str(int(v)), PREC_ATOM if v >= 0 else PREC_UNARY, DINT
            if isinstance(v, float):
                return real_literal(v), PREC_ATOM if v >= 0 else PREC_UNARY, REAL
            raise self.err(e, f"constant {v!r} has no ST type here")
        if isinstance(e, ast.Subscript):
            text, elem = self.element(e)
            return text, PREC_ATOM, elem
        if isinstance(e, ast.Name) and e.id in self.owned:
            inst, out = self.owned[e.id]
            if out is None:
                raise self.err(e, f"{e.id!r} is hidden in the instance {inst}")
            return f"{var(inst)}.{out}", PREC_ATOM, self.types[e.id]
        if isinstance(e, ast.Name):
            if e.id in self.tuples:
                raise self.err(e, f"tuple {e.id!r} used as a value")
            return var(self.st[e.id]), PREC_ATOM, self.types[e.id]
        if isinstance(e, ast.UnaryOp):
            if isinstance(e.op, ast.Not):
                sub = self.expr(e.operand)
                return f"NOT {self.wrap(sub, PREC_UNARY)}", PREC_UNARY, BOOL
            if isinstance(e.op, ast.USub):
                if isinstance(e.operand, ast.Constant):
                    return self.expr(ast.Constant(-e.operand.value), want)  # type: ignore[operator]
                sub = self.expr(e.operand, want)
                return f"-{self.wrap(sub, PREC_ATOM)}", PREC_UNARY, sub[2]
            raise self.err(e, "unary operator")
        if isinstance(e, ast.BinOp):
            return self.binop(e, want)
        if isinstance(e, ast.BoolOp):
            op, prec = ("AND", PREC_AND) if isinstance(e.op, ast.And) else ("OR", PREC_OR)
            # comparisons inside AND/OR always in parentheses (readable in every dialect)
            parts = [self.wrap(self.expr(v), PREC_UNARY) for v in e.values]
            return f" {op} ".join(parts), prec, BOOL
        if isinstance(e, ast.Compare):
            return self.compare(e)
        if isinstance(e, ast.IfExp):
            c = self.const_test(e.test)
            if c is not None:
                return self.expr(e.body if c else e.orelse, want)
            a = self.expr(e.body, want)
            b = self.expr(e.orelse, want)
            typ = REAL if REAL in (a[2], b[2]) else a[2]
            test = self.expr(e.test)[0]
            return (
                f"SEL({test}, {self.coerce(e.orelse, typ)}, {self.coerce(e.body, typ)})",
                PREC_ATOM,
                typ,
            )
        if isinstance(e, ast.Call):
            return self.call_expr(e, want)
        raise self.err(e, f"expression {type(e).__name__} is not translated")

    def binop(self, e: ast.BinOp, want: str | None) -> tuple[str, int, str]:
        if isinstance(e.op, ast.RShift) and isinstance(e.right, ast.Constant):
            left = self.expr(e.left)
            if left[2] != DINT:
                raise self.err(e, ">> needs an integer")
            shift = int(e.right.value)  # type: ignore[arg-type]
            return f"{self.wrap(left, PREC_MUL)} / {2**shift}", PREC_MUL, DINT
        if (
            isinstance(e.op, ast.BitAnd)
            and isinstance(e.right, ast.Constant)
            and e.right.value == 1
        ):
            left = self.expr(e.left)
            return f"{self.wrap(left, PREC_MUL)} MOD 2", PREC_MUL, DINT
        if isinstance(e.op, ast.Mod):
            # DINT only; the kernels keep both operands >= 0, where % and MOD agree
            left, right = self.expr(e.left), self.expr(e.right)
            if left[2] != DINT or right[2] != DINT:
                raise self.err(e, "% needs integers")
            text = f"{self.wrap(left, PREC_MUL)} MOD {self.wrap(right, PREC_MUL + 1)}"
            return text, PREC_MUL, DINT
        ops = {ast.Add: ("+", PREC_ADD), ast.Sub: ("-", PREC_ADD), ast.Mult: ("*", PREC_MUL),
               ast.Div: ("/", PREC_MUL)}  # fmt: skip
        if isinstance(e.op, ast.Pow):
            typ = REAL
            return (
                f"EXPT({self.coerce(e.left, REAL)}, {self.coerce(e.right, REAL)})",
                PREC_ATOM,
                typ,
            )
        if type(e.op) not in ops:
            raise self.err(e, f"operator {type(e.op).__name__}")
        op, prec = ops[type(e.op)]
        lt = self.expr(e.left)[2]
        rt = self.expr(e.right)[2]
        typ = REAL if REAL in (lt, rt) or isinstance(e.op, ast.Div) else lt
        if typ == REAL:
            left = self.expr_as(e.left, REAL)
            right = self.expr_as(e.right, REAL)
        else:
            left, right = self.expr(e.left), self.expr(e.right)
        return f"{self.wrap(left, prec)} {op} {self.wrap(right, prec + 1)}", prec, typ

    def expr_as(self, e: ast.expr, typ: str) -> tuple[str, int, str]:
        sub = self.expr(e, want=typ)
        if sub[2] == typ:
            return sub
        return self.coerce(e, typ), PREC_ATOM, typ

    def compare(self, e: ast.Compare) -> tuple[str, int, str]:
        sym = {ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">=", ast.Eq: "=", ast.NotEq: "<>"}
        c = self.const_test(e)
        if c is not None:
            return ("TRUE" if c else "FALSE"), PREC_ATOM, BOOL
        if len(e.ops) == 1 and isinstance(e.ops[0], ast.In):
            # ``x in (A, B)`` with constants: ``(x = A) OR (x = B)``
            if not isinstance(e.comparators[0], ast.Tuple):
                raise self.err(e, "'in' needs a tuple of values")
            alts = [ast.Compare(left=e.left, ops=[ast.Eq()], comparators=[v])
                    for v in e.comparators[0].elts]  # fmt: skip
            return " OR ".join(f"({self.compare(a)[0]})" for a in alts), PREC_OR, BOOL
        parts = []
        left = e.left
        for op, right in zip(e.ops, e.comparators, strict=True):
            if type(op) not in sym:
                raise self.err(e, f"comparison {type(op).__name__}")
            lt, rt = self.expr(left)[2], self.expr(right)[2]
            typ = REAL if REAL in (lt, rt) else lt
            a, b = self.expr_as(left, typ), self.expr_as(right, typ)
            prec = PREC_EQ if isinstance(op, ast.Eq | ast.NotEq) else PREC_CMP
            parts.append(
                (f"{self.wrap(a, prec + 1)} {sym[type(op)]} {self.wrap(b, prec + 1)}", prec)
            )
            left = right
        if len(parts) == 1:
            return parts[0][0], parts[0][1], BOOL
        return " AND ".join(f"({p})" for p, _ in parts), PREC_AND, BOOL

    def call_expr(self, c: ast.Call, want: str | None) -> tuple[str, int, str]:
        f = c.func
        name = ""
        if isinstance(f, ast.Name):
            name = f.id
        elif isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name):
            name = f"{f.value.id}.{f.attr}"
        std = {"abs": "ABS", "math.exp": "EXP", "math.sqrt": "SQRT", "math.log": "LN"}
        if name in std:
            a = self.expr(c.args[0], want)
            typ = a[2] if name == "abs" else REAL
            text = self.coerce(c.args[0], typ)
            return f"{std[name]}({text})", PREC_ATOM, typ
        if name in ("min", "max"):
            typ = REAL if any(self.expr(a)[2] == REAL for a in c.args) else DINT
            return (
                f"{name.upper()}({', '.join(self.coerce(a, typ) for a in c.args)})",
                PREC_ATOM,
                typ,
            )
        if name == "float":
            return self.coerce(c.args[0], REAL), PREC_ATOM, REAL
        if name == "len":
            arg = c.args[0]
            info = array_info(self.types.get(arg.id, "")) if isinstance(arg, ast.Name) else None
            if info is None:
                raise self.err(c, "len() of something other than an array")
            return str(info[0]), PREC_ATOM, DINT  # the bounds are fixed at export
        if name == "int":
            a = self.expr(c.args[0])
            if a[2] == DINT:
                return a
            return f"TRUNC({a[0]})", PREC_ATOM, DINT
        if name == "bool":
            a = self.expr(c.args[0])
            if a[2] != BOOL:
                raise self.err(c, "bool() of a number")
            return a
        fn = self.resolve(f)
        if not (isinstance(fn, types.FunctionType) and fn.__module__.startswith("ctrlblocks.")):
            raise self.err(c, f"call of {name or ast.unparse(f)!r} is not translated")
        sig = self.user_sig(c, fn)
        if sig.tuple_ret:
            raise self.err(c, f"{sig.pou} returns a tuple: assign it to names")
        if sig.pou not in self.calls:
            self.calls.append(sig.pou)
        args = self.call_args(c, sig)
        return f"{pou_ref(sig.pou)}({', '.join(args)})", PREC_ATOM, sig.ret_type or REAL
