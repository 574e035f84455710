"""The blocks compiled from their own source, per call (issue 18, goal 6).

Usage (from the repository root; needs a C compiler and the ``bench`` extra:
Cython and the peers)::

    python benchmarks/compiled_blocks.py             # build, check, time: a few minutes
    python benchmarks/compiled_blocks.py --rounds 9 --steps 20000
    python benchmarks/compiled_blocks.py --mypyc     # also try mypyc on the same files
    python benchmarks/compiled_blocks.py --cdef double --float32-seeds 3 --keep cdef-build
    python benchmarks/compiled_blocks.py --cdef double --keep cdef-build --reuse --rounds 9

What it does, in a temporary folder (the package itself is never touched):

1. copies ``src/ctrlblocks`` and compiles every module of ``blocks/`` (but the
   package ``__init__`` and the fuzz driver) with Cython in pure-Python mode:
   the ``.py`` files as they are, ``-ffp-contract=off`` so that the C
   compiler fuses no multiply-add the interpreter would round twice;
2. runs the fuzz campaign's seeded random actions (``ctrlblocks.blocks.fuzz``:
   inputs with NaN/inf, modes, limits, reconfiguration, snapshot/restore,
   reset) on every exported block with the interpreted and with the compiled
   blocks and compares ``out`` and ``error_id`` after every action (1e-12),
   against an uncompiled copy of the same files;
3. times one call of ``PID`` and ``ADRC`` against simple-pid and pyadrc, in
   fresh processes, interpreted and compiled rounds interleaved, and prints
   the medians and the ratios with the load average.

With ``--mypyc`` it also runs mypyc on the same modules and prints what it
refuses.

With ``--cdef object`` or ``--cdef double`` it compiles only ``base``, ``pid``
and ``adrc`` (``double``: and ``signals``), with ``Block``, ``PID`` and ``ADRC``
as Cython extension types (cdef classes): augmenting ``.pxd`` files next to the
``.py`` files (:func:`cdef_pxd`) declare the attributes of the per-call path in
the C struct (their float state as Python objects or as C doubles) and, at the
double level, the per-call law functions with C arguments.  The source changes
this needs are applied to the copy as text changes, each with its reason
(:data:`CDEF_PATCHES`, :data:`CDEF_DOUBLE_PATCHES`, :func:`_cython_annotations`);
the changed source interpreted is traced and timed as well (``changed,
interpreted``), to show that the changes alone alter nothing.  The results, and
why the package ships no compiled build, are in docs/performance.md ("Compiled
blocks (goal 6)").
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PY = sys.executable
SKIP = ("__init__.py", "fuzz.py")  # the package's re-exports and the campaign's driver

BUILD = """
import sys
from setuptools import Extension, setup
from Cython.Build import cythonize
import json
directives, mods = json.loads(sys.argv[1]), sys.argv[2:]
sys.argv[1:] = ["build_ext", "--inplace"]
exts = [Extension(m[:-3].replace("/", "."), [m], extra_compile_args=["-ffp-contract=off", "-O2"])
        for m in mods]
directives["language_level"] = 3
setup(ext_modules=cythonize(exts, compiler_directives=directives, nthreads=2, quiet=True))
"""

TRACES = """
import json, math, sys
import ctrlblocks.blocks.pid as pid_module
from ctrlblocks.blocks.fuzz import BLOCKS, RandomRun
steps, seeds, f32 = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
out = {"compiled": not pid_module.__file__.endswith(".py"), "traces": {}, "float32": 0}
def f32_seeds(spec):  # the first seeds whose block starts in precision="float32"
    found, seed = [], 1000
    while len(found) < f32:
        if RandomRun(spec, seed).driver.block.config.precision == "float32":
            found.append(seed)
        seed += 1
    return found
for name, spec in sorted(BLOCKS.items()):
    extra = f32_seeds(spec) if name in ("PID", "ADRC") else []
    for seed in [*range(seeds), *extra]:
        run = RandomRun(spec, seed)
        trace = []
        for _ in range(steps):
            run.step()
            b = run.driver.block
            trace.append((b.out, int(b.error_id)))
            out["float32"] += getattr(b.config, "precision", "") == "float32"
        out["traces"][f"{name}/{seed}"] = trace
print(json.dumps(out))
"""

TIMING = """
import json, sys, time
import ctrlblocks.blocks.pid as pid_module
from ctrlblocks import ADRC, PID
from simple_pid import PID as SimplePID
from pyadrc import StateSpace
pid = PID(kp=2.0, ti=10.0, td=0.5, ts=0.1, u_min=0.0, u_max=100.0)
peer = SimplePID(2.0, 0.2, 1.0, setpoint=1.0, sample_time=None, output_limits=(0.0, 100.0))
adrc = ADRC(order=2, b0=0.05, omega_c=0.35, omega_o=1.75, ts=0.1, u_min=0.0, u_max=5.0)
peer_adrc = StateSpace(2, 0.1, 0.05, 0.35, 5.0, m_lim=(0.0, 5.0))

def per_call(fn, number):
    best = float("inf")
    for _ in range(5):
        t0 = time.perf_counter_ns()
        for _ in range(number):
            fn()
        best = min(best, (time.perf_counter_ns() - t0) / number)
    return best

for _ in range(3):
    pid(1.0, 0.5); peer(0.5, dt=0.1); adrc(1.0, 0.5); peer_adrc(0.5, 1.0, 1.0)
print(json.dumps({
    "compiled": not pid_module.__file__.endswith(".py"),
    "pid": per_call(lambda: pid(1.0, 0.5), 20000),
    "simple_pid": per_call(lambda: peer(0.5, dt=0.1), 20000),
    "adrc": per_call(lambda: adrc(1.0, 0.5), 20000),
    "pyadrc": per_call(lambda: peer_adrc(0.5, 1.0, 1.0), 5000),
}))
"""


# ---------------------------------------------------------------------------
# --cdef: PID and ADRC as Cython extension types (cdef classes) from the same .py
# files plus augmenting .pxd files, with the source changes Cython needs
# ---------------------------------------------------------------------------

CDEF_MODULES = ("base", "pid", "adrc")
CDEF_DOUBLE_MODULES = ("signals",)
"""And at the double level: signals, for a C ``clamp`` (the float32 cycle then takes the
law functions from interpreted copies, :func:`apply_cdef_patches`)."""
"""What is compiled: the base class and the two blocks.  signals, leadlag, ... stay
interpreted: the float32 cycle (plc_cycle) rebuilds their functions with float32
``math``/``float``, which it cannot do for a compiled function."""

_CALL_PID = '''    def __call__(
        self,
        sp: float,
        pv: float,
        *,
        ff: float = 0.0,
        dv: float = 0.0,
        dt: float | None = None,
        pv_ok: bool = True,
    ) -> float:
        """Run one cycle: '''
_COMPUTE_PID = _CALL_PID.replace("__call__", "compute_output").replace(
    "Run one cycle: ", "ComputeOutput of"
)
_CALL_ADRC = '''    def __call__(
        self,
        sp: float,
        y: float,
        *,
        pv_ok: bool = True,
        y_ok: bool = True,
        u_real: float | None = None,
        dt: float | None = None,
    ) -> float:
        """Run one cycle;'''
_COMPUTE_ADRC = '''    def compute_output(
        self,
        sp: float,
        y: float,
        *,
        pv_ok: bool = True,
        y_ok: bool = True,
        dt: float | None = None,
    ) -> float:
        """Compute this cycle's'''


def _split(head: str, name: str, params: str, args: str) -> str:
    """``head`` (a guarded step's signature) as a thin step that guards itself explicitly
    and calls the old body, renamed ``_name`` with positional parameters."""
    sig, doc = head.split(") -> float:\n")
    return (f"{sig}) -> float:\n        return self._checked(self.out, self._{name}({args}))\n\n"
            f"    def _{name}(self, {params}) -> float:  # the unguarded step\n{doc}")  # fmt: skip


CDEF_PATCHES: list[tuple[str, str, str, str]] = [
    # (module, old text, new text, why)
    ("base", '''    def __init_subclass__(cls, **kwargs: Any) -> None:
        """Put the output guard (:func:`_guard`) around the step methods a subclass defines."""
        super().__init_subclass__(**kwargs)
        for name in cls._guarded_steps:
            fn = cls.__dict__.get(name)
            if fn is not None and not getattr(fn, "_output_guard", False):
                setattr(cls, name, _guard(fn))
''', '''    __init_subclass__ = classmethod(_guard_steps)
''', "Cython refuses a method __init_subclass__ in an extension type ('not supported by "
     "extension class'); as a classmethod class attribute it still runs for every "
     "interpreted subclass (PT1, ...), but never for a cdef subclass"),
    ("base", '''class Block:
    """Base class''', '''def _guard_steps(cls: type[Block], **kwargs: Any) -> None:
    """Put the output guard (:func:`_guard`) around the step methods a subclass defines."""
    super(Block, cls).__init_subclass__(**kwargs)
    for name in cls._guarded_steps:
        fn = vars(cls).get(name)
        if fn is not None and not getattr(fn, "_output_guard", False):
            setattr(cls, name, _guard(fn))


class Block:
    """Base class''', "the same function at module level; vars(cls), because Cython "
                      "refuses cls.__dict__ in a cdef class ('Illegal use of special "
                      "attribute __dict__')"),
    ("base", '''        prev = self.out
        result = step(self, *args, **kwargs)
        y = self.out
        lo, hi = self.output_limits()
        if lo <= y <= hi and _NINF < y < _INF:
            return result
        held = self._contain(prev, y, lo, hi)
        return held if isinstance(result, float) else result
''', '''        prev = self.out
        return self._checked(prev, step(self, *args, **kwargs))
''', "the output rule as a method (_checked) that a cdef block calls explicitly: a cdef "
     "subclass is not made through type.__new__, so nothing wraps its steps"),
    ("base", '''    # -- the output guard ------------------------------------------------------
''', '''    # -- the output guard ------------------------------------------------------

    def _checked(self, prev: float, result: Any) -> Any:
        """The output rule after a step that started from ``out == prev`` (:func:`_guard`)."""
        y = self.out
        lo, hi = self.output_limits()
        if lo <= y <= hi and _NINF < y < _INF:
            return result
        held = self._contain(prev, y, lo, hi)
        return held if isinstance(result, float) else result
''', "(the method of the previous change)"),
    ("base", '''        saved = dict(self.__dict__)
        self._config = new
        try:
            self._apply_config(old)
        except Exception:
            self.__dict__.clear()
            self.__dict__.update(saved)
            raise
''', '''        saved = dict(vars(self))
        kept = [getattr(self, name) for name in self._declared]
        self._config = new
        try:
            self._apply_config(old)
        except Exception:
            vars(self).clear()
            vars(self).update(saved)
            for name, value in zip(self._declared, kept, strict=True):
                setattr(self, name, value)
            raise
''', "the rollback of a refused configure: the attributes a .pxd declares live in the C "
     "struct, not in __dict__, so they are saved and put back by name (_declared)"),
    ("base", '''    _guarded_steps: ClassVar[tuple[str, ...]] = ("__call__", "compute_output")
''', '''    _guarded_steps: ClassVar[tuple[str, ...]] = ("__call__", "compute_output")
    _declared: ClassVar[tuple[str, ...]] = ()  # attributes outside __dict__ (compiled)
''', "(the names of the previous change)"),
    ("pid", _CALL_PID, _split(_CALL_PID, "call", "sp, pv, ff, dv, dt, pv_ok",
                              "sp, pv, ff, dv, dt, pv_ok"),
     "the explicit guard: __call__ calls _checked around the old body (renamed _call)"),
    ("pid", _COMPUTE_PID, _split(_COMPUTE_PID, "compute_output", "sp, pv, ff, dv, dt, pv_ok",
                                 "sp, pv, ff, dv, dt, pv_ok"), "the same for compute_output"),
    ("pid", "    Config = PIDConfig\n", "    Config = PIDConfig\n    _guarded_steps = ()\n"
     "    _declared = DECLARED\n",
     "the steps guard themselves (not twice when interpreted); the declared attributes"),
    ("adrc", _CALL_ADRC, _split(_CALL_ADRC, "call", "sp, y, pv_ok, y_ok, u_real, dt",
                                "sp, y, pv_ok, y_ok, u_real, dt"), "as for the PID"),
    ("adrc", _COMPUTE_ADRC, _split(_COMPUTE_ADRC, "compute_output", "sp, y, pv_ok, y_ok, dt",
                                   "sp, y, pv_ok, y_ok, dt"), "as for the PID"),
    ("adrc", "    Config = ADRCConfig\n", "    Config = ADRCConfig\n    _guarded_steps = ()\n"
     "    _declared = DECLARED\n", "as for the PID"),
]  # fmt: skip

CDEF_DOUBLE_PATCHES: list[tuple[str, str, str, str]] = [
    ("pid", "self._call(sp, pv, ff, dv, dt, pv_ok)",
     "self._call(as_input(sp), as_input(pv), as_input(ff), as_input(dv), dt, pv_ok)",
     "the step converts its inputs before the typed body (_call takes C doubles; as_input "
     "of a float is the float, so the body's own conversion changes nothing)"),
    ("adrc", "self._call(sp, y, pv_ok, y_ok, u_real, dt)",
     "self._call(as_input(sp), as_input(y), pv_ok, y_ok, u_real, dt)", "as for the PID"),
    ("plc_cycle", "from .adrc import (", "from ._py_adrc import (",
     "the float32 cycle rebuilds the law functions with float32 math/float: it needs them "
     "as Python functions, so it takes them from interpreted copies of the same files "
     "(_py_pid, _py_adrc, _py_signals, _py_leadlag); a compiled function with C double "
     "arguments would compute the REAL cycle in double"),
    ("plc_cycle", "from .pid import (", "from ._py_pid import (", "(the same)"),
    ("plc_cycle", "from .leadlag import", "from ._py_leadlag import", "(the same)"),
    ("plc_cycle", "from .signals import", "from ._py_signals import", "(the same)"),
    ("../fast/kernels", "from ..blocks import adrc as _adrc",
     "from ..blocks import _py_adrc as _adrc",
     "numba compiles the law functions (ctrlblocks.fast): it refuses a Cython function "
     "('Implementation function returned by @overload has an unexpected type')"),
    ("../fast/kernels", "from ..blocks import pid as _pid", "from ..blocks import _py_pid as _pid",
     "(the same)"),
    ("../fast/bank", "from ..blocks import pid as _pid", "from ..blocks import _py_pid as _pid",
     "(the same)"),
    ("../fast/simlane", "from ..blocks.leadlag import", "from ..blocks._py_leadlag import",
     "(the same)"),
    ("../fast/simlane", "from ..blocks.signals import", "from ..blocks._py_signals import",
     "(the same)"),
]  # fmt: skip
PY_COPIES = ("pid", "adrc", "signals", "leadlag")
"""Interpreted copies for the float32 cycle at the double level, importing each other."""

# The attributes each .pxd declares (in the C struct); the rest stays in __dict__.
# Inputs a user writes (manual, track_value, manual_value, u_man, awin, ...) and the
# float32 cycle's _plc_state stay Python objects at every level.
BASE_ATTRS = ("error_id", "_config")  # not out: GainSchedule makes it a property
PID_OBJ = ("manual", "track", "hold", "reset_active", "awin", "manual_value", "_lean",
           "_mode_prev", "_cold", "_reinit", "_pending", "_prm", "limits_active",
           "_limits_status", "_lean_ran", "_law_in_force", "deadband_active",
           "p_suppressed")  # fmt: skip
PID_FLOAT = ("out", "_h", "_ts", "_i", "_d", "_w_prev", "_e_prev", "p", "i", "d", "e", "sp_w",
             "pv_f", "ff", "_lo", "_hi", "_x", "_bias", "_ff_prev")  # fmt: skip
ADRC_OBJ = ("manual", "awin", "u_man", "_lean", "_started", "_pending", "_track", "_prm",
            "_sat", "_limits_bad", "_warn", "awout", "_eso", "_eso_coef", "_gains", "_law",
            "_sens")  # fmt: skip
ADRC_FLOAT = ("out", "_h", "_ts", "_yh", "_x2", "_x3", "_x4", "_u_prev", "_ref", "u_raw", "y", "e",
              "y_ref", "_u_lo", "_u_hi")  # fmt: skip


def _locals(names: str, extra: str = "") -> str:
    """``@cython.locals(...)``: the locals ``names`` as C doubles (and ``extra``)."""
    decl = ", ".join([f"{n}=cython.double" for n in names.split()] + ([extra] if extra else []))
    return "@cython.locals(" + textwrap.fill(decl, 90, subsequent_indent=" " * 15) + ")"


PXD_PID_LAW = """cimport cython
from .signals cimport clamp

cdef double _INF, _NINF
cpdef double derivative_step(double a, double bd, double d_prev, double w, double w_prev)
cpdef double integral_increment(double ki_h, double alpha, double beta, double e_prev, double e)
cpdef bint clamping_blocks(double di, double v, double lo, double hi)
cpdef double clamping_integral(double i, double di, double rest, double lo, double hi)
LOCALS
cpdef (double, double, double, double, double, double, double, double) pid_step(
    double sp, double pv, double ff, bint manual, double u_man, bint cold, bint transfer,
    double i, double d, double w_prev, double e_prev, double out_prev, object prm)

""".replace(
    "LOCALS", _locals("k sgn b c ad bd ki_h alpha beta lo hi aw g e p w dn out i_new i_k di v_raw")
)
PXD_ADRC_LAW = """cimport cython
from .signals cimport clamp

cdef double _INF, _NINF
cpdef (double, double, double, double) eso_euler(
    double yh, double x2, double x3, double x4, double u_prev, double y, double w4, double ts,
    double b0, double l1, double l2, double l3, double l4, double p1, double p2, double k1,
    double k2, double k3)
cpdef double control_law(double r, double yh, double x2, double x3, double x4, double b0,
                         double kp, double kd1, double kd2)
cpdef double x4_update_allowed(long rule, bint awin, long sat, double du)
cpdef (double, double, double, double) solve_x4(
    double u_target, double u_law, double yh, double x2, double x3, double x4, double s_yh,
    double s_x2, double s_x3, double s_u)
LOCALS
cpdef (double, double, double, double, double, double, double, bint, long) adrc_step(
    double sp, double y, bint manual, double u_man, bint started, bint track, long sat,
    double yh, double x2, double x3, double x4, double u_prev, double ref, object prm,
    bint awin=*)

""".replace(
    "LOCALS",
    _locals(
        "ts b0 l1 l2 l3 l4 p1 p2 k1 k2 k3 kp kd1 kd2 s_yh s_x2 s_x3 s_u lo hi rule a_ref target "
        "z0 z1 z2 z3 u_free du u_raw u",
        "sat_next=cython.long",
    ),
)


def cdef_pxd(level: str) -> dict[str, str]:
    """The augmenting .pxd files; ``level`` "object" or "double" (the float state's C type).

    "double" also gives the per-call law functions C arguments (:data:`PXD_PID_LAW`,
    :data:`PXD_ADRC_LAW`) and compiles ``signals`` for a C ``clamp``.
    """

    def attrs(names: tuple[str, ...], kind: str) -> str:
        return f"    cdef public {kind} " + ", ".join(names) + "\n"

    double = level == "double"
    inputs = "double sp, double pv, double ff, double dv" if double else "sp, pv, ff, dv"
    adrc_in = "double sp, double y" if double else "sp, y"
    pxd = {
        "base": "cdef class Block:\n    cdef dict __dict__\n" + attrs(BASE_ATTRS, "object")
        + "    cpdef _checked(self, prev, result)\n"
        "    cpdef output_limits(self)\n\ncpdef object as_input(object x)\n",
        "pid": (PXD_PID_LAW if double else "")
        + "from .base cimport Block, as_input\n\ncdef class PID(Block):\n"
        + attrs(PID_OBJ, "object") + attrs(PID_FLOAT, level)
        + "    cpdef output_limits(self)\n"
        f"    cdef _call(self, {inputs}, dt, pv_ok)\n"
        "    cdef _compute_output(self, sp, pv, ff, dv, dt, pv_ok)\n",
        "adrc": (PXD_ADRC_LAW if double else "")
        + "from .base cimport Block, as_input\n\ncdef class ADRC(Block):\n"
        + attrs(ADRC_OBJ, "object") + attrs(ADRC_FLOAT, level)
        + "    cpdef output_limits(self)\n"
        f"    cdef _call(self, {adrc_in}, pv_ok, y_ok, u_real, dt)\n"
        "    cdef _compute_output(self, sp, y, pv_ok, y_ok, dt)\n"
        f"    cdef _fast_cycle(self, {adrc_in})\n",
    }  # fmt: skip
    if double:
        pxd["signals"] = "cpdef double clamp(double x, double lo, double hi)\n"
    return pxd


CDEF_CLASSES = {"base": "Block", "pid": "PID", "adrc": "ADRC"}
_BARE = re.compile(r"^    [A-Za-z_]\w*: [^=]*$")  # an annotation without a value


def _cython_annotations(text: str, cls: str, declared: tuple[str, ...]) -> tuple[str, list[str]]:
    """The class-level annotations of ``class cls`` as Cython accepts them; (text, dropped).

    In a class a .pxd declares ``cdef``, Cython reads a bare ``name: type`` in the
    body as a C attribute declaration: accepted for a name the .pxd declares
    (:data:`PID_OBJ` ... hold every annotated name), refused for any other ("C
    attributes cannot be added in implementation part of extension type defined in
    a pxd"), also under ``if TYPE_CHECKING:``.  ``config: XConfig`` (mypy's
    narrowing of the base's property) becomes a property that returns ``_config``;
    a name not declared (Block's ``out``) is dropped and returned.
    """
    lines = text.split("\n")
    start = lines.index(f"class {cls}(Block):" if cls != "Block" else "class Block:")
    end = next((i for i in range(start + 1, len(lines)) if lines[i][:1] not in ("", " ")),
               len(lines))  # fmt: skip
    doc_end = next(i for i in range(start + 2, end) if lines[i].strip().endswith('"""'))
    body, dropped = [], []
    for ln in lines[doc_end + 1 : end]:
        m = _BARE.match(ln)
        name = ln.split(":")[0].strip() if m else ""
        if name == "config":
            kind = ln.split(":")[1].strip()
            body += ["    @property", f"    def config(self) -> {kind}:",
                     '        """The configuration in force (:meth:`Block.config`)."""',
                     "        return self._config"]  # fmt: skip
        elif m and name not in declared:
            dropped.append(name)
        else:
            body.append(ln)
    return "\n".join(lines[: doc_end + 1] + body + lines[end:]), dropped


def apply_cdef_patches(pkg: Path, level: str) -> None:
    """The source changes of CDEF_PATCHES, in the copy ``pkg`` (each must match once)."""
    declared = {"pid": BASE_ATTRS + PID_OBJ + PID_FLOAT, "adrc": BASE_ATTRS + ADRC_OBJ + ADRC_FLOAT}
    blocks = pkg / "blocks"
    if level == "double":  # the interpreted copies, made from the unchanged files
        for mod in PY_COPIES:
            text = (blocks / f"{mod}.py").read_text()
            for other in PY_COPIES:
                text = text.replace(f"from .{other} import", f"from ._py_{other} import")
            (blocks / f"_py_{mod}.py").write_text(text)
    for mod, old, new, _why in CDEF_PATCHES + (CDEF_DOUBLE_PATCHES if level == "double" else []):
        path = blocks / f"{mod}.py"
        text = path.read_text()
        if text.count(old) != 1:
            raise RuntimeError(f"{mod}.py: a source change no longer applies: {old[:60]!r}")
        if "DECLARED" in new:
            new = new.replace("DECLARED", repr(declared[mod]))
        path.write_text(text.replace(old, new))
    for mod, cls in CDEF_CLASSES.items():
        path = blocks / f"{mod}.py"
        text, dropped = _cython_annotations(
            path.read_text(), cls, BASE_ATTRS + declared.get(mod, ())
        )
        assert dropped == (["out"] if mod == "base" else []), dropped
        path.write_text(text)


def load() -> str:
    return f"load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"


class RunFailed(RuntimeError):
    """A measuring process failed; the message is the last line of its error output."""


def run_json(script: str, src: Path, *args: str, timeout: float = 1800) -> dict:
    env = dict(os.environ, PYTHONPATH=str(src))
    out = subprocess.run([PY, "-c", script, *args], capture_output=True, text=True, env=env,
                         timeout=timeout, cwd=src)  # fmt: skip
    if out.returncode:
        raise RunFailed((out.stderr.strip().splitlines() or ["(no output)"])[-1])
    return json.loads(out.stdout.strip().splitlines()[-1])


def build(tmp: Path, typing: bool, only: list[str], cdef: str | None = None,
          again: bool = True) -> tuple[Path, list[str], float]:  # fmt: skip
    """The copy of the package in ``tmp/src`` with blocks/ compiled; (src, modules, seconds).

    ``typing``: Cython's ``annotation_typing`` (its default): a ``float``
    annotation becomes a C double, converted when the function is entered.
    ``cdef``: "object" or "double": only ``CDEF_MODULES``, PID and ADRC as
    extension types (:func:`cdef_pxd`, :data:`CDEF_PATCHES`); the copy with the
    source changes but uncompiled goes to ``tmp/patched``.  ``again`` False
    reuses a build kept in ``tmp`` (``--keep``).
    """
    src = tmp / "src"
    if cdef:
        only = list(CDEF_MODULES) + (list(CDEF_DOUBLE_MODULES) if cdef == "double" else [])
    mods = sorted(f"ctrlblocks/blocks/{m}.py" for m in only) if only else []
    if not again and (src / "ctrlblocks").is_dir():
        return src, mods or sorted(str(p.relative_to(src)).replace(".c", ".py")
                                   for p in src.glob("ctrlblocks/blocks/*.c")), 0.0  # fmt: skip
    for d in ("src", "plain", "patched"):
        shutil.rmtree(tmp / d, ignore_errors=True)
    shutil.copytree(ROOT / "src" / "ctrlblocks", src / "ctrlblocks",
                    ignore=shutil.ignore_patterns("__pycache__", "*.so"))  # fmt: skip
    # the interpreted reference: the same files, uncompiled (the tree may change meanwhile)
    shutil.copytree(src / "ctrlblocks", tmp / "plain" / "ctrlblocks")
    directives: dict[str, object] = {"annotation_typing": typing}
    if cdef:
        apply_cdef_patches(src / "ctrlblocks", cdef)
        shutil.copytree(src / "ctrlblocks", tmp / "patched" / "ctrlblocks")
        for mod, text in cdef_pxd(cdef).items():
            (src / "ctrlblocks" / "blocks" / f"{mod}.pxd").write_text(text)
        # object: no type inference at all, so nothing the float32 cycle passes in is
        # turned into a C double; double: Cython's safe inference
        directives = {
            "annotation_typing": False,
            "infer_types": None if cdef == "double" else False,
        }
    if not mods:
        mods = sorted(
            f"ctrlblocks/blocks/{p.name}"
            for p in (src / "ctrlblocks" / "blocks").glob("*.py")
            if p.name not in SKIP
        )
    t0 = time.perf_counter()
    subprocess.run([PY, "-c", BUILD, json.dumps(directives), *mods], cwd=src, check=True,
                   capture_output=True, timeout=7200)  # fmt: skip
    return src, mods, time.perf_counter() - t0


def compare_traces(interp: dict, comp: dict) -> tuple[int, float, list[str]]:
    """(actions compared, largest |difference| of out, names whose error codes differ)."""
    n, worst, codes = 0, 0.0, []
    for key, a in interp["traces"].items():
        b = comp["traces"][key]
        for (ya, ea), (yb, eb) in zip(a, b, strict=True):
            n += 1
            if ea != eb and key not in codes:
                codes.append(key)
            if ya != yb:
                worst = max(worst, abs(ya - yb) if ya == ya and yb == yb else float("inf"))
    return n, worst, codes


def try_mypyc(tmp: Path, mods: list[str]) -> str:
    """What mypyc says about the same modules (its first lines)."""
    src = tmp / "mypyc"
    shutil.copytree(ROOT / "src" / "ctrlblocks", src / "ctrlblocks",
                    ignore=shutil.ignore_patterns("__pycache__", "*.so"))  # fmt: skip
    out = subprocess.run([PY, "-m", "mypyc", *mods], cwd=src, capture_output=True, text=True,
                         timeout=3600)  # fmt: skip
    lines = [ln for ln in (out.stdout + out.stderr).splitlines() if "error" in ln]
    return f"exit {out.returncode}, {len(lines)} errors; first: " + "; ".join(lines[:3])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5, help="timing rounds (fresh processes)")
    ap.add_argument("--steps", type=int, default=3000, help="actions per block and seed")
    ap.add_argument("--seeds", type=int, default=3, help="seeds per block")
    ap.add_argument("--float32-seeds", type=int, default=0,
                    help="and this many seeds of PID and ADRC that start in float32")  # fmt: skip
    ap.add_argument("--mypyc", action="store_true", help="also try mypyc on the same modules")
    ap.add_argument("--no-annotation-typing", action="store_true",
                    help="Cython keeps float annotations as Python objects")  # fmt: skip
    ap.add_argument("--cdef", choices=("object", "double"),
                    help="PID and ADRC as cdef classes, float state of this type")  # fmt: skip
    ap.add_argument("--modules", default="", help="only these modules of blocks/ (a,b,...)")
    ap.add_argument("--keep", type=Path, help="build here and keep it (default: a temp folder)")
    ap.add_argument("--reuse", action="store_true", help="reuse the build kept in --keep")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = (args.keep or Path(tmp_name)).resolve()  # the runs change their directory
        print(f"compiling blocks/ with Cython ({load()}) ...", file=sys.stderr, flush=True)
        only = [m for m in args.modules.split(",") if m]
        src, mods, secs = build(tmp, not args.no_annotation_typing, only, args.cdef,
                                again=not (args.reuse and args.keep))  # fmt: skip
        builds = {"interpreted": tmp / "plain", "compiled": src}
        if args.cdef:  # the source changes alone, interpreted: their price for the fallback
            builds = {"interpreted": tmp / "plain", "changed, interpreted": tmp / "patched",
                      "compiled": src}  # fmt: skip
        print(f"  {len(mods)} modules in {secs:.0f} s", file=sys.stderr, flush=True)
        print("traces: the fuzz campaign's actions on every block ...", file=sys.stderr,
              flush=True)  # fmt: skip
        targs = (str(args.steps), str(args.seeds), str(args.float32_seeds))
        a = run_json(TRACES, builds["interpreted"], *targs)
        others = {}
        for name, where in list(builds.items())[1:]:
            try:
                others[name] = run_json(TRACES, where, *targs)
            except RunFailed as exc:  # the compiled blocks broke a promise of the contract
                print(f"compiled: {len(mods)} modules of blocks/ by Cython in {secs:.0f} s")
                print(f"traces: the {name} blocks failed the campaign: {exc}")
                return 1
        assert not a["compiled"] and others["compiled"]["compiled"], "not the compiled modules"
        res: dict[str, dict[str, list[float]]] = {name: {} for name in builds}
        for r in range(args.rounds):
            print(f"timing round {r + 1}/{args.rounds} ({load()})", file=sys.stderr, flush=True)
            for name, where in builds.items():
                t = run_json(TIMING, where)
                assert t.pop("compiled") == (name == "compiled")
                for k, v in t.items():
                    res[name].setdefault(k, []).append(v)
        mypyc = try_mypyc(tmp, mods) if args.mypyc else "not tried (--mypyc)"
    med = {name: {k: statistics.median(v) for k, v in d.items()} for name, d in res.items()}
    how = f"as cdef classes, float state {args.cdef}" if args.cdef else "in pure-Python mode"
    print(f"compiled: {len(mods)} modules of blocks/ by Cython {how} in {secs:.0f} s")
    ok = True
    for name, b in others.items():
        n, worst, codes = compare_traces(a, b)
        ok = ok and worst <= 1e-12 and not codes
        print(f"traces, {name} against interpreted: {n:,} actions on {len(a['traces'])} block "
              f"runs ({a['float32']:,} of the actions in float32); largest |out difference| "
              f"{worst:.3g}; error codes differ in: {codes or 'none'}")  # fmt: skip
    print(f"timing: medians of {args.rounds} rounds (best of 5 in each process); {load()}")
    print("| blocks | PID call | simple-pid | ratio | ADRC call | pyadrc | ratio |")
    print("|---|---|---|---|---|---|---|")
    for name, m in med.items():
        print(f"| {name} | {m['pid']:.0f} ns | {m['simple_pid']:.0f} ns | "
              f"{m['pid'] / m['simple_pid']:.2f}x | {m['adrc']:.0f} ns | {m['pyadrc']:.0f} ns | "
              f"{m['adrc'] / m['pyadrc']:.3f}x |")  # fmt: skip
    i, c = med["interpreted"], med["compiled"]
    print(f"compiled / interpreted: PID {c['pid'] / i['pid']:.2f}x, "
          f"ADRC {c['adrc'] / i['adrc']:.2f}x")  # fmt: skip
    print(f"mypyc: {mypyc}")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
