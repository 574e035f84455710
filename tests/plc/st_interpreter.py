"""A test-only interpreter of the Structured Text that ctrlblocks.plc emits.

It parses with blark (the TwinCAT/CODESYS ST grammar; a test dependency,
GPL) and executes the transformed tree with PLC semantics:

* REAL is IEEE single precision (numpy float32: every operation rounds to
  single); DINT a Python int (``/`` truncates towards zero); BOOL a bool;
  mixing REAL and DINT without a conversion is an error (as for an IEC
  compiler);
* a FUNCTION_BLOCK instance keeps its VAR / VAR_INPUT / VAR_OUTPUT between
  calls; inputs the caller does not pass keep their last value; an FB may
  hold instances of other FBs (declared in its VAR), call them and read
  their outputs (``inst.OUT``; reading an instance's VAR from outside is an
  error, as in CODESYS);
* ``ARRAY[lo..hi] OF REAL|DINT|BOOL`` variables with DINT subscripts (an
  index outside the bounds is an error) and ``FOR i := a TO b DO``;
* VAR_TEMP and the locals and outputs of a FUNCTION are *poisoned* at every
  call (None), so reading a variable before it is written in this call
  fails -- the translated code must never rely on a leftover value;
* the standard functions the export uses: ABS, EXP, LN, SQRT, TRUNC,
  DINT_TO_REAL, SEL, MIN, MAX, EXPT.

Nothing here is shipped: the library never imports it.
"""

from __future__ import annotations

import contextlib
import functools
import re
from collections.abc import Callable
from typing import Any

import numpy as np
from blark import parse_source_code
from blark import transform as tf

from ctrlblocks.blocks.precision import real_exp, real_ln, real_sqrt

REAL, DINT, BOOL = "REAL", "DINT", "BOOL"


class STError(RuntimeError):
    """The program did something an IEC 61131-3 compiler or runtime would refuse."""


class _Return(Exception):
    pass


def _f32(x: Any) -> np.float32:
    with np.errstate(all="ignore"):
        return np.float32(x)


def _type_of(init: Any) -> Any:
    """REAL, DINT, BOOL; ``("ARRAY", lo, hi, element type)``; or the name of an FB type."""
    spec = getattr(init, "spec", init)
    if isinstance(spec, tf.ArraySpecification):
        if len(spec.subranges) != 1:
            raise STError("only one-dimensional arrays")
        sub = spec.subranges[0]
        elem = str(spec.type.type_name).upper()
        if elem not in (REAL, DINT, BOOL):
            raise STError(f"ARRAY OF {elem} not supported by the test interpreter")
        return ("ARRAY", int(str(sub.start.value)), int(str(sub.stop.value)), elem)
    tok = getattr(spec, "type", spec)
    t = str(tok).upper()
    if t in (REAL, DINT, BOOL):
        return t
    if getattr(tok, "type", "") == "IDENTIFIER":
        return t  # a FUNCTION_BLOCK type, resolved when an instance is made
    raise STError(f"type {t} not supported by the test interpreter")


class Array:
    """An ARRAY[lo..hi] OF a scalar type: subscripts checked against the bounds."""

    def __init__(self, lo: int, hi: int, typ: str) -> None:
        self.lo, self.hi, self.typ = lo, hi, typ
        zero = {REAL: np.float32(0.0), DINT: 0, BOOL: False}[typ]
        self.items = [zero] * (hi - lo + 1)

    def index(self, i: Any, what: str) -> int:
        if type(i) is not int:
            raise STError(f"subscript of {what} is {type(i).__name__}, not DINT")
        if not self.lo <= i <= self.hi:
            raise STError(f"subscript {i} of {what} outside {self.lo}..{self.hi}")
        return i - self.lo


def split_pous(source: str) -> list[str]:
    """The POUs of a source file, each from its FUNCTION line to its END_ line.

    Text between POUs (the header comment) is its own chunk.  Each chunk is
    a complete IEC 61131-3 declaration, so it parses on its own; blark's
    Earley parser is slow, and the functions are the same for every block
    configuration, so parsing them one by one lets :func:`parse` cache them.
    """
    chunks, cur = [], []
    for line in source.splitlines():
        if re.match(r"(FUNCTION|FUNCTION_BLOCK)\s", line) and cur:
            chunks.append("\n".join(cur))
            cur = []
        cur.append(line)
        if re.match(r"END_FUNCTION(_BLOCK)?\s*$", line):
            chunks.append("\n".join(cur))
            cur = []
    if "\n".join(cur).strip():
        chunks.append("\n".join(cur))
    return [c for c in chunks if c.strip()]


_INIT = re.compile(r"^(\s+)(\w+) : (REAL|DINT|BOOL) := ([^;]+);", re.M)
_ARRAY_INIT = re.compile(
    r"^(\s+)(\w+) : (ARRAY\[\d+\.\.\d+\] OF (?:REAL|DINT|BOOL)) := (\[[^\]]*\]);", re.M
)


def strip_initial_values(chunk: str) -> tuple[str, dict[str, str]]:
    """``chunk`` without the ``:= value`` of its declarations, and those values by name.

    The exported FB of two configurations of a block differs only in these
    initial values, so the stripped text (the same for every configuration)
    is parsed once and the values are read here; test_export parses the
    complete files.
    """
    inits = {m.group(2).lower(): m.group(4).strip() for m in _INIT.finditer(chunk)}
    chunk = _INIT.sub(r"\1\2 : \3;", chunk)
    # ARRAY initial values [v0, v1, ...] (the coefficients of a cycle block's sections)
    inits.update((m.group(2).lower(), m.group(4).strip()) for m in _ARRAY_INIT.finditer(chunk))
    return _ARRAY_INIT.sub(r"\1\2 : \3;", chunk), inits


def literal(typ: str, text: str) -> Any:
    """The value of an initial-value literal of type ``typ`` (REAL, DINT, BOOL)."""
    if typ == BOOL and text in ("TRUE", "FALSE"):
        return text == "TRUE"
    if typ == DINT and re.fullmatch(r"-?\d+", text):
        return int(text)
    if typ == DINT and re.fullmatch(r"16#[0-9A-F]+", text):
        return int(text[3:], 16)
    if typ == REAL and re.fullmatch(r"-?\d+\.\d+(E-?\d+)?", text):
        return _f32(float(text))
    raise STError(f"initial value {text!r} is not a {typ} literal")


@functools.lru_cache(maxsize=256)
def parse(chunk: str) -> Any:
    """blark's transformed tree of one chunk of ST (cached); STError if blark refuses it."""
    result = parse_source_code(chunk)
    if result.exception is not None:
        raise STError(f"blark refuses the source: {result.exception}")
    return result.transform()


class Pou:
    """A parsed FUNCTION or FUNCTION_BLOCK: its variables by section and its compiled body."""

    def __init__(self, node: Any, interp: Interpreter) -> None:
        self.node = node
        self.name = str(node.name).lower()
        self.kind = "function" if isinstance(node, tf.Function) else "fb"
        self.vars: dict[str, tuple[str, str, Any]] = {}  # name -> (section, type, init expr)
        for decl in node.declarations:
            section = type(decl).__name__
            for item in decl.items:
                typ = _type_of(item.init)
                value = getattr(item.init, "value", None)
                for dv in item.variables:
                    self.vars[str(dv.variable.name).lower()] = (section, typ, value)
        if self.kind == "function":
            self.vars[self.name] = ("Return", _type_of(node.return_type), None)
        self.stmts = node.body.statements if node.body is not None else []
        self.interp = interp
        self.body: Callable[[dict[str, Any]], None] | None = None
        self.inits: dict[str, str] = {}  # name -> initial value literal (strip_initial_values)

    def section(self, name: str) -> str:
        return self.vars[name.lower()][0]

    def run(self, frame: dict[str, Any]) -> None:
        if self.body is None:
            self.body = self.interp.compile_block(self.stmts, self)
        with contextlib.suppress(_Return):
            self.body(frame)


class Instance:
    """A FUNCTION_BLOCK instance: call it with keyword inputs, read outputs by name."""

    def __init__(self, pou: Pou) -> None:
        self.pou = pou
        self.frame: dict[str, Any] = {}
        self.temps = [n for n, (sec, _t, _i) in pou.vars.items()
                      if sec == "TemporaryVariableDeclarations"]  # fmt: skip
        for name, (section, typ, init) in pou.vars.items():
            if isinstance(typ, tuple):
                self.frame[name] = Array(typ[1], typ[2], typ[3])
                text = pou.inits.get(name)
                if text is not None:
                    items = [literal(typ[3], v.strip()) for v in text[1:-1].split(",")]
                    self.frame[name].items = items
            elif typ not in (REAL, DINT, BOOL):
                if section != "VariableDeclarations":
                    raise STError(f"{pou.name}.{name}: an instance outside VAR")
                self.frame[name] = pou.interp.instance(typ)
            elif section != "TemporaryVariableDeclarations":
                text = pou.inits.get(name)
                self.frame[name] = (
                    literal(typ, text) if text is not None else pou.interp.initial(typ, init)
                )

    def __call__(self, **inputs: Any) -> None:
        for name, value in inputs.items():
            self.set_input(name, value)
        self.run()

    def set_input(self, name: str, value: Any) -> None:
        key = name.lower()
        pou = self.pou
        if key not in pou.vars or pou.vars[key][0] != "InputDeclarations":
            raise STError(f"{pou.name} has no input {name}")
        self.frame[key] = convert(pou.vars[key][1], value, name)

    def run(self) -> None:
        for name in self.temps:
            self.frame[name] = None
        with np.errstate(all="ignore"):
            self.pou.run(self.frame)

    def output(self, name: str) -> Any:
        """An output read by the caller (``inst.NAME``); VAR and VAR_INPUT are not readable."""
        key = name.lower()
        if key not in self.pou.vars or self.pou.vars[key][0] != "OutputDeclarations":
            raise STError(f"{self.pou.name}.{name} is not an output")
        return self.frame[key]

    def __getitem__(self, name: str) -> Any:
        return self.frame[name.lower()]


def convert(typ: str, value: Any, what: str) -> Any:
    """``value`` as a value of the IEC type ``typ``; a wrong kind is an error."""
    t = type(value)
    if typ == REAL:
        if t is np.float32:
            return value
        if isinstance(value, bool | np.bool_):
            raise STError(f"BOOL assigned to REAL {what}")
        return _f32(value)
    if t is int and typ == DINT:
        return value
    if typ == BOOL:
        if not isinstance(value, bool | np.bool_):
            raise STError(f"{type(value).__name__} assigned to BOOL {what}")
        return bool(value)
    if isinstance(value, bool | np.bool_ | float | np.floating):
        raise STError(f"{type(value).__name__} assigned to DINT {what}")
    return int(value)


def _truth(v: Any) -> bool:
    if type(v) is not bool:
        if isinstance(v, np.bool_):
            return bool(v)
        raise STError(f"condition of type {type(v).__name__}")
    return v


def _num(a: Any, b: Any, op: str) -> bool:
    """True for REAL operands, False for DINT; refuses BOOL and mixed operands."""
    ta, tb = type(a), type(b)
    if ta is np.float32 and tb is np.float32:
        return True
    if ta is int and tb is int:
        return False
    raise STError(f"operands {ta.__name__} and {tb.__name__} of {op}")


def _div(a: Any, b: Any) -> Any:
    if _num(a, b, "/"):
        return a / b
    if b == 0:
        raise STError("integer division by zero")
    q = abs(a) // abs(b)
    return q if (a >= 0) == (b >= 0) else -q


def _mod(a: Any, b: Any) -> Any:
    if _num(a, b, "MOD"):
        raise STError("MOD of REAL")
    return a - b * _div(a, b)


def _eq(a: Any, b: Any, negate: bool) -> bool:
    if isinstance(a, bool) and isinstance(b, bool):
        return (a == b) != negate
    _num(a, b, "=")
    return bool(a == b) != negate


def _arith(op: str) -> Callable[[Any, Any], Any]:
    fns: dict[str, Callable[[Any, Any], Any]] = {
        "+": lambda a, b: a + b, "-": lambda a, b: a - b, "*": lambda a, b: a * b,
        "<": lambda a, b: bool(a < b), ">": lambda a, b: bool(a > b),
        "<=": lambda a, b: bool(a <= b), ">=": lambda a, b: bool(a >= b),
    }  # fmt: skip
    f = fns[op]

    def checked(a: Any, b: Any) -> Any:
        _num(a, b, op)
        return f(a, b)

    return checked


_BIN: dict[str, Callable[[Any, Any], Any]] = {
    **{op: _arith(op) for op in ("+", "-", "*", "<", ">", "<=", ">=")},
    "/": _div,
    "MOD": _mod,
    "=": lambda a, b: _eq(a, b, False),
    "<>": lambda a, b: _eq(a, b, True),
}


def _real(name: str, x: Any) -> np.float32:
    if type(x) is not np.float32:
        raise STError(f"{name.upper()} needs REAL, got {type(x).__name__}")
    return x


def _dint_to_real(x: Any) -> np.float32:
    if type(x) is not int:
        raise STError("DINT_TO_REAL of a non-DINT")
    return _f32(x)


_STD: dict[str, Callable[..., Any]] = {
    "abs": lambda x: abs(x),
    # EXP, LN, SQRT as the float32 cycle defines them (ctrlblocks.blocks.precision.real_exp)
    "exp": lambda x: real_exp(_real("exp", x)),
    "ln": lambda x: real_ln(_real("ln", x)),
    "sqrt": lambda x: real_sqrt(_real("sqrt", x)),
    "expt": lambda x, y: _f32(np.power(_real("expt", x), _real("expt", y))),
    "trunc": lambda x: int(_real("trunc", x)),
    "dint_to_real": _dint_to_real,
    "sel": lambda g, a, b: b if _truth(g) else a,
    "min": lambda *a: min(a),
    "max": lambda *a: max(a),
}


class Interpreter:
    """Parse ST source with blark and run its POUs (compiled once to Python closures)."""

    def __init__(self, source: str, count: bool = False) -> None:
        self.pous: dict[str, Pou] = {}
        self.count = count
        self.counts: dict[str, int] = {}
        for chunk in split_pous(source):
            if not chunk.startswith("FUNCTION"):
                continue  # the header comment (test_export parses it)
            stripped, inits = strip_initial_values(chunk)
            for item in parse(stripped).items:
                if isinstance(item, tf.Function | tf.FunctionBlock):
                    pou = Pou(item, self)
                    pou.inits = inits
                    self.pous[pou.name] = pou

    def instance(self, name: str) -> Instance:
        pou = self.pous[name.lower()]
        if pou.kind != "fb":
            raise STError(f"{name} is not a FUNCTION_BLOCK")
        return Instance(pou)

    def initial(self, typ: str, init: Any) -> Any:
        if init is None:
            return {REAL: np.float32(0.0), DINT: 0, BOOL: False}[typ]
        return convert(typ, self.compile_expr(init, None)({}), "initial value")

    def _counted(self, kind: str, fn: Callable[[dict[str, Any]], Any]) -> Callable[..., Any]:
        counts = self.counts

        def counted(frame: dict[str, Any]) -> Any:
            counts[kind] = counts.get(kind, 0) + 1
            return fn(frame)

        return counted

    # -- statements ----------------------------------------------------------------

    def compile_block(self, stmts: list[Any], pou: Pou) -> Callable[[dict[str, Any]], None]:
        parts = [self.compile_stmt(s, pou) for s in stmts]

        def run(frame: dict[str, Any]) -> None:
            for p in parts:
                p(frame)

        return run

    def compile_stmt(self, s: Any, pou: Pou) -> Callable[[dict[str, Any]], None]:
        if isinstance(s, tf.AssignmentStatement):
            expr = self.compile_expr(s.expression, pou)
            stores = [self.compile_target(t, pou) for t in s.variables]

            def assign(frame: dict[str, Any]) -> None:
                v = expr(frame)
                for st in stores:
                    st(frame, v)

            return assign
        if isinstance(s, tf.IfStatement):
            branches = [(self.compile_expr(s.if_expression, pou),
                         self.compile_block(s.statements.statements, pou))]  # fmt: skip
            for clause in s.else_ifs:
                cond = self.compile_expr(clause.if_expression, pou)
                branches.append((cond, self.compile_block(clause.statements.statements, pou)))
            other = (self.compile_block(s.else_clause.statements.statements, pou)
                     if s.else_clause is not None else None)  # fmt: skip

            def if_(frame: dict[str, Any]) -> None:
                for cond, body in branches:
                    if _truth(cond(frame)):
                        body(frame)
                        return
                if other is not None:
                    other(frame)

            return if_
        if isinstance(s, tf.FunctionCallStatement):
            return self.compile_call(s, pou, statement=True)  # type: ignore[return-value]
        if isinstance(s, tf.ReturnStatement):

            def ret(frame: dict[str, Any]) -> None:
                raise _Return

            return ret
        if isinstance(s, tf.ForStatement):
            if s.step is not None:
                raise STError("FOR with BY")
            ctl = str(s.control.name).lower()
            if pou.vars.get(ctl, (None, None))[1] != DINT:
                raise STError(f"{pou.name}: FOR variable {ctl} is not a DINT")
            start, stop = self.compile_expr(s.from_, pou), self.compile_expr(s.to, pou)
            body = self.compile_block(s.statements.statements, pou)

            def for_(frame: dict[str, Any]) -> None:
                a, b = start(frame), stop(frame)
                if type(a) is not int or type(b) is not int:
                    raise STError("FOR bounds must be DINT")
                i = a
                while i <= b:
                    frame[ctl] = i
                    body(frame)
                    if frame[ctl] != i:
                        raise STError(f"the body of FOR writes {ctl}")
                    i += 1
                frame[ctl] = i

            return for_
        raise STError(f"statement {type(s).__name__} not supported")

    def compile_target(self, t: Any, pou: Pou) -> Callable[[dict[str, Any], Any], None]:
        """A store into a variable or an array element ``a[i]``."""
        if not isinstance(t, tf.MultiElementVariable):
            return self.compile_store(str(t.name), pou)
        key, index = self._subscript(t, pou)
        what = f"{pou.name}.{key}"

        def store(frame: dict[str, Any], v: Any) -> None:
            arr = frame[key]
            arr.items[arr.index(index(frame), what)] = convert(arr.typ, v, what)

        return store

    def _subscript(self, e: Any, pou: Pou) -> tuple[str, Callable[[dict[str, Any]], Any]]:
        key = str(e.name.name).lower()
        typ = pou.vars.get(key, (None, None))[1]
        if not isinstance(typ, tuple) or len(e.elements) != 1:
            raise STError(f"{pou.name}: {key} is not a one-dimensional array")
        sub = e.elements[0]
        if not isinstance(sub, tf.SubscriptList) or len(sub.subscripts) != 1:
            raise STError(f"{pou.name}: {key} needs one subscript")
        return key, self.compile_expr(sub.subscripts[0], pou)

    def compile_store(self, name: str, pou: Pou) -> Callable[[dict[str, Any], Any], None]:
        key = name.lower()
        if key not in pou.vars:
            raise STError(f"{pou.name}: assignment to undeclared {name}")
        typ = pou.vars[key][1]
        what = f"{pou.name}.{name}"

        def store(frame: dict[str, Any], v: Any) -> None:
            frame[key] = convert(typ, v, what)

        return store

    # -- expressions -----------------------------------------------------------------

    def compile_expr(self, e: Any, pou: Pou | None) -> Callable[[dict[str, Any]], Any]:
        if isinstance(e, tf.SimpleVariable):
            key = str(e.name).lower()
            if pou is not None and key not in pou.vars:
                raise STError(f"{pou.name}: unknown variable {e.name}")
            where = pou.name if pou else ""

            def load(frame: dict[str, Any]) -> Any:
                v = frame[key]
                if v is None:
                    raise STError(f"{where}: {key} read before it is written")
                return v

            return load
        if isinstance(e, tf.MultiElementVariable):
            assert pou is not None
            elem = e.elements[0] if len(e.elements) == 1 else None
            if isinstance(elem, tf.FieldSelector):
                key = str(e.name.name).lower()
                if pou.vars.get(key, (None, REAL))[1] in (REAL, DINT, BOOL):
                    raise STError(f"{pou.name}: {key} is not an FB instance")
                field = str(elem.field.name)
                return lambda frame: frame[key].output(field)
            key, index = self._subscript(e, pou)
            what = f"{pou.name}.{key}"

            def item(frame: dict[str, Any]) -> Any:
                arr = frame[key]
                return arr.items[arr.index(index(frame), what)]

            return item
        if isinstance(e, tf.Real | tf.HexInteger | tf.Integer | tf.Boolean):
            if isinstance(e, tf.Real):
                c: Any = _f32(float(str(e.value)))
            elif isinstance(e, tf.HexInteger):
                c = int(str(e.value), 16)
            elif isinstance(e, tf.Integer):
                c = int(str(e.value))
            else:
                c = str(e.value).upper() == "TRUE"
            return lambda frame: c
        if isinstance(e, tf.ParenthesizedExpression):
            return self.compile_expr(e.expr, pou)
        if isinstance(e, tf.UnaryOperation):
            sub = self.compile_expr(e.expr, pou)
            op = str(e.op).upper()
            if op == "NOT":
                return lambda frame: not _truth(sub(frame))
            if op == "-":

                def neg(frame: dict[str, Any]) -> Any:
                    v = sub(frame)
                    if type(v) is bool:
                        raise STError("minus of a BOOL")
                    return -v

                return neg
            raise STError(f"unary {op}")
        if isinstance(e, tf.BinaryOperation):
            op = str(e.op).upper()
            left, right = self.compile_expr(e.left, pou), self.compile_expr(e.right, pou)
            if op in ("AND", "OR", "XOR"):
                # both operands evaluated (IEC AND/OR do not short-circuit)
                if op == "AND":
                    return lambda f: _truth(left(f)) & _truth(right(f))
                if op == "OR":
                    return lambda f: _truth(left(f)) | _truth(right(f))
                return lambda f: _truth(left(f)) != _truth(right(f))
            fn = _BIN.get(op)
            if fn is None:
                raise STError(f"operator {op}")
            if self.count:
                kind = "arithmetic" if op in ("+", "-", "*", "/", "MOD") else "comparison"
                return self._counted(kind, lambda f: fn(left(f), right(f)))
            return lambda f: fn(left(f), right(f))
        if isinstance(e, tf.FunctionCall):
            return self.compile_call(e, pou, statement=False)
        raise STError(f"expression {type(e).__name__} not supported")

    def compile_instance_call(
        self, name: str, params: list[Any], pou: Pou
    ) -> Callable[[dict[str, Any]], Any]:
        """``inst(IN := x, ...)``: set the inputs, run the instance (its memory stays)."""
        if pou.vars[name][1] in (REAL, DINT, BOOL) or isinstance(pou.vars[name][1], tuple):
            raise STError(f"{pou.name}: {name} is not an FB instance")
        ins = []
        for p in params:
            if not isinstance(p, tf.InputParameterAssignment) or p.name is None:
                raise STError(f"call of {name}: only IN := value parameters")
            ins.append((str(p.name.name), self.compile_expr(p.value, pou)))
        count = self.count

        def call(frame: dict[str, Any]) -> None:
            inst = frame[name]
            for pname, fn in ins:
                inst.set_input(pname, fn(frame))
            if count:
                self.counts["FB call"] = self.counts.get("FB call", 0) + 1
            inst.run()

        return call

    def compile_call(
        self, e: Any, pou: Pou | None, statement: bool
    ) -> Callable[[dict[str, Any]], Any]:
        name = str(e.name.name).lower()
        params = e.parameters
        if pou is not None and name in pou.vars:
            return self.compile_instance_call(name, params, pou)
        if name not in self.pous:
            if name not in _STD:
                raise STError(f"unknown function {name.upper()}")
            std = _STD[name]
            args = [self.compile_expr(p.value, pou) for p in params]
            if self.count:
                return self._counted("standard function", lambda f: std(*(a(f) for a in args)))
            return lambda frame: std(*(a(frame) for a in args))
        callee = self.pous[name]
        if callee.kind != "function":
            raise STError(f"{name} is not a FUNCTION")
        ins: list[tuple[str, str, Callable[[dict[str, Any]], Any]]] = []
        outs: list[tuple[str, Callable[[dict[str, Any], Any], None]]] = []
        for p in params:
            if p.name is None:
                raise STError(f"call of {name} without formal parameter names")
            pname = str(p.name.name).lower()
            if pname not in callee.vars:
                raise STError(f"{name} has no parameter {pname}")
            if isinstance(p, tf.OutputParameterAssignment):
                if callee.section(pname) != "OutputDeclarations":
                    raise STError(f"{name}.{pname} is not an output")
                assert pou is not None
                outs.append((pname, self.compile_store(str(p.value.name), pou)))
                continue
            if callee.section(pname) != "InputDeclarations":
                raise STError(f"{name}.{pname} is not an input")
            ins.append((pname, callee.vars[pname][1], self.compile_expr(p.value, pou)))
        missing = {v for v, (s, _t, _i) in callee.vars.items() if s == "InputDeclarations"}
        missing -= {n for n, _t, _f in ins}
        if missing:
            raise STError(f"call of {name} leaves inputs {sorted(missing)} unassigned")
        names = list(callee.vars)
        count = self.count

        def call(frame: dict[str, Any]) -> Any:
            local = dict.fromkeys(names)
            for pname, typ, fn in ins:
                local[pname] = convert(typ, fn(frame), pname)
            if count:
                self.counts["function call"] = self.counts.get("function call", 0) + 1
            callee.run(local)
            for pname, store in outs:
                v = local[pname]
                if v is None:
                    raise STError(f"{name} returned without writing its output {pname}")
                store(frame, v)
            result = local[name]
            if result is None and not statement:
                raise STError(f"{name} returned without a value")
            return result

        return call
