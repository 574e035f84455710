"""MATIEC (``iec2c``, the IEC 61131-3 compiler of Beremiz and OpenPLC) as the tests' oracle.

MATIEC is GPL-3 and is not part of the project: ``tests/plc/build_matiec.sh``
builds it from a source archive outside the repository into a cache directory
(``.ci/run`` does so and sets :data:`MATIEC_ENV`).  This module

* finds that build (:func:`matiec_dir`): the directory named by
  ``CTRLBLOCKS_MATIEC``, else the build script's default cache directory;
  where neither holds a build the tests skip with a message -- unless
  ``CTRLBLOCKS_REQUIRE_MATIEC=1`` (CI), where they fail;
* compiles ST *strictly* (:func:`iec2c`: no ``-b``, so only standard syntax)
  after adding a ``CONFIGURATION`` that instantiates the function blocks and
  programs (MATIEC generates code only for what a configuration reaches);
* builds the generated C with ``gcc -O2 -fsingle-precision-constant
  -ffp-contract=off`` (REAL literals as float constants, no fused
  multiply-add: REAL arithmetic as a PLC does it) into a shared library with a
  generated harness, and drives each FB or PROGRAM through :mod:`ctypes`
  (:class:`Instance`): REAL inputs and outputs by their bit patterns (NaN,
  inf and denormals pass unchanged), one call per cycle, which returns the
  floating-point exception flags (``FE_INVALID``, ``FE_DIVBYZERO``,
  ``FE_OVERFLOW``) the cycle raised -- where a runtime that traps them
  would have stopped the task.

The POU structs are read from MATIEC's ``POUS.h`` (``__DECLARE_VAR(REAL,SP)``
...), so the harness knows nothing of the export's internals.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import re
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

MATIEC_ENV = "CTRLBLOCKS_MATIEC"
REQUIRE_ENV = "CTRLBLOCKS_REQUIRE_MATIEC"
CFLAGS = ("-O2", "-fsingle-precision-constant", "-ffp-contract=off")

FE_INVALID, FE_DIVBYZERO, FE_OVERFLOW = 1, 4, 8  # <fenv.h> on x86-64 (checked in the harness)
_SCALARS = {"REAL": "uint32_t", "DINT": "int32_t", "BOOL": "uint8_t"}
_ROOT = Path(__file__).resolve().parents[2]


class CompileError(AssertionError):
    """MATIEC or gcc refused the code: the message holds their output."""


def _cache_default() -> list[Path]:
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "ctrlblocks"
    return sorted(base.glob("matiec-*/matiec"), reverse=True)


def matiec_dir() -> Path | None:
    """The MATIEC build (a directory with ``iec2c`` and ``lib/``), or None."""
    env = os.environ.get(MATIEC_ENV)
    for d in [Path(env)] if env else _cache_default():
        if (d / "iec2c").is_file() and (d / "lib" / "C" / "iec_std_lib.h").is_file():
            return d
    return None


def require_matiec() -> Path:
    """The MATIEC build; skips the test where there is none (fails under
    ``CTRLBLOCKS_REQUIRE_MATIEC=1``)."""
    d = matiec_dir()
    if d is not None:
        return d
    msg = (f"MATIEC not built: run tests/plc/build_matiec.sh (needs the matiec source archive "
           f"and flex, bison, autoconf, automake, libtool) or set {MATIEC_ENV}")  # fmt: skip
    if os.environ.get(REQUIRE_ENV) == "1":
        pytest.fail(msg)
    pytest.skip(msg)


def configuration(types: list[str], programs: list[str] = ()) -> str:  # type: ignore[assignment]
    """A program holding one instance of each FB type, and the configuration running it
    and ``programs`` (MATIEC compiles what a configuration reaches)."""
    inst = "\n".join(f"    fb{j} : {t};" for j, t in enumerate(types))
    calls = "\n".join(f"    fb{j}();" for j in range(len(types)))
    holder = f"PROGRAM cb_holder\nVAR\n{inst}\nEND_VAR\n{calls}\nEND_PROGRAM\n" if types else ""
    progs = [f"        PROGRAM p{j} WITH t : {p};" for j, p in enumerate(programs)]
    if types:
        progs.insert(0, "        PROGRAM holder WITH t : cb_holder;")
    nl = "\n"
    return f"""
{holder}
CONFIGURATION cb_config
    RESOURCE cb_resource ON PLC
        TASK t(INTERVAL := T#100ms, PRIORITY := 0);
{nl.join(progs)}
    END_RESOURCE
END_CONFIGURATION
"""


def iec2c(source: str, out: Path) -> Path:
    """Compile ST strictly (no ``-b``) into ``out``; its POUS.c. Raises CompileError."""
    m = require_matiec()
    out.mkdir(parents=True, exist_ok=True)
    (out / "program.st").write_text(source, encoding="utf-8")
    r = subprocess.run(
        [str(m / "iec2c"), "-f", "-I", str(m / "lib"), "-T", str(out), "program.st"],
        cwd=out, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    if r.returncode != 0 or not (out / "POUS.c").is_file():
        raise CompileError(f"iec2c (strict) refused the code (exit {r.returncode}):\n"
                           f"{r.stdout}{r.stderr}")  # fmt: skip
    return out / "POUS.c"


@dataclass
class Pou:
    """A FUNCTION_BLOCK or PROGRAM of the generated C: its scalar members (upper case)."""

    name: str
    fields: dict[str, str]  # member -> REAL / DINT / BOOL


def pous(header: str) -> dict[str, Pou]:
    """The FB and PROGRAM structs of MATIEC's POUS.h (those with a ``_body__``)."""
    out = {}
    for m in re.finditer(r"typedef struct \{(.*?)\} (\w+);", header, re.S):
        name = m.group(2)
        if f"void {name}_body__(" not in header:
            continue
        fields = {f: t for t, f in re.findall(r"__DECLARE_VAR\((\w+),(\w+)\)", m.group(1))
                  if t in _SCALARS}  # fmt: skip
        out[name] = Pou(name, fields)
    return out


def _harness(units: dict[str, Pou]) -> str:
    lines = [
        "#define _GNU_SOURCE", "#include <dlfcn.h>", "#include <fenv.h>", "#include <setjmp.h>",
        "#include <signal.h>",
        "#include <stdint.h>", "#include <stdlib.h>", "#include <string.h>",
        '#include "iec_std_lib.h"', '#include "accessor.h"', '#include "POUS.h"',
        "TIME __CURRENT_TIME;", "BOOL __DEBUG;",
        "#define H_FE (FE_INVALID | FE_DIVBYZERO | FE_OVERFLOW)",
        "int h_fe_invalid(void) { return FE_INVALID; }",
        "int h_fe_divbyzero(void) { return FE_DIVBYZERO; }",
        "int h_fe_overflow(void) { return FE_OVERFLOW; }",
        # a trapped cycle: SIGFPE's handler jumps back out of the body with the si_code
        "static sigjmp_buf h_jmp; static volatile int h_code; static void *volatile h_addr;",
        "static void h_on_fpe(int s, siginfo_t *si, void *u) { (void)s; (void)u;",
        "  h_code = si->si_code; h_addr = si->si_addr; siglongjmp(h_jmp, 1); }",
        # where the last trap happened: the offset in this library (for addr2line)
        "long h_trap_offset(void) { Dl_info i; if (!h_addr || !dladdr(h_addr, &i)) return -1;",
        "  return (long)((char *)h_addr - (char *)i.dli_fbase); }",
    ]  # fmt: skip
    for p in units.values():
        n = p.name
        lines += [
            # each instance its own memory (calloc'd, freed by the Python object)
            f"void *{n}_h_new(void) {{ {n} *p = calloc(1, sizeof *p); if (p) {n}_init__(p, 0);",
            "  return p; }",
            f"void {n}_h_free(void *p) {{ free(p); }}",
            # the FB's code is in another translation unit: the flags are those of its body.
            # trap: with the exceptions unmasked, -si_code of the SIGFPE that stopped the body
            f"int {n}_h_step({n} *p, int trap) {{ int f; struct sigaction sa, old;",
            "  feclearexcept(FE_ALL_EXCEPT);",
            f"  if (!trap) {{ {n}_body__(p); f = fetestexcept(H_FE);",
            "    feclearexcept(FE_ALL_EXCEPT); return f; }",
            "  memset(&sa, 0, sizeof sa); sa.sa_sigaction = h_on_fpe; sa.sa_flags = SA_SIGINFO;",
            "  sigaction(SIGFPE, &sa, &old);",
            "  if (sigsetjmp(h_jmp, 1)) { fedisableexcept(FE_ALL_EXCEPT);",
            "    feclearexcept(FE_ALL_EXCEPT); sigaction(SIGFPE, &old, 0); return -h_code; }",
            f"  feenableexcept(H_FE); {n}_body__(p); fedisableexcept(FE_ALL_EXCEPT);",
            "  feclearexcept(FE_ALL_EXCEPT); sigaction(SIGFPE, &old, 0); return 0; }",
        ]
        for f, t in p.fields.items():
            c = _SCALARS[t]
            lines += [
                f"void {n}_h_set_{f}({n} *p, {c} x) {{ {t} v; memcpy(&v, &x, sizeof v); "
                f"__SET_VAR(p->, {f}, , v); }}",
                f"{c} {n}_h_get_{f}({n} *p) {{ {t} v = __GET_VAR(p->{f}); {c} x; "
                f"memcpy(&x, &v, sizeof x); return x; }}",
            ]
    return "\n".join(lines) + "\n"


def _run(cmd: list[str], cwd: Path) -> None:
    r = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=600, check=False)
    if r.returncode != 0:
        raise CompileError(f"{' '.join(cmd)} failed:\n{r.stdout}{r.stderr}")


class Library:
    """The generated C of one ST source, compiled and loaded (:func:`build`)."""

    def __init__(self, path: Path, units: dict[str, Pou]) -> None:
        self.path = path
        self.dll = ctypes.CDLL(str(path))
        self.units = units
        fe = (self.dll.h_fe_invalid(), self.dll.h_fe_divbyzero(), self.dll.h_fe_overflow())
        assert fe == (FE_INVALID, FE_DIVBYZERO, FE_OVERFLOW), fe

    def trap_site(self) -> str:
        """``function at file:line`` of the instruction the last trapped cycle stopped at."""
        fn = self.dll.h_trap_offset
        fn.restype = ctypes.c_long
        off = fn()
        if off < 0:
            return "?"
        r = subprocess.run(["addr2line", "-f", "-e", str(self.path), hex(off)],
                           capture_output=True, text=True, check=False)  # fmt: skip
        func, _, line = r.stdout.strip().partition("\n")
        return f"{func} at {line}"

    def instance(self, name: str) -> Instance:
        """A fresh instance of the FB or PROGRAM ``name`` (its VAR at their initial values)."""
        return Instance(self, self.units[name.upper()])


def build(source: str, cache: Path, types: list[str], programs: list[str] = ()) -> Library:  # type: ignore[assignment]
    """Compile ``source`` (plus a configuration instantiating ``types`` and running
    ``programs``) with iec2c strictly and the C with gcc; cached in ``cache`` by content."""
    m = require_matiec()
    text = source + configuration(types, programs)
    # the key: the source, the flags and this module (the harness it writes)
    key = hashlib.sha256(text.encode() + Path(__file__).read_bytes()).hexdigest()[:16]
    out = cache / key
    lib = out / "fb.so"
    if not lib.is_file():
        iec2c(text, out)
        units = pous((out / "POUS.h").read_text(encoding="utf-8"))
        (out / "fbs.c").write_text('#include "iec_std_lib.h"\n#include "accessor.h"\n'
                                   '#include "POUS.h"\n#include "POUS.c"\n')  # fmt: skip
        (out / "harness.c").write_text(_harness(units))
        inc = ["-I", str(m / "lib" / "C"), "-I", str(out)]
        for unit in ("fbs", "harness"):  # two translation units: nothing moves across the call
            _run(["gcc", *CFLAGS, "-g", "-fPIC", "-w", *inc, "-c", f"{unit}.c", "-o", f"{unit}.o"],
                 out)  # fmt: skip
        _run(["gcc", "-shared", "fbs.o", "harness.o", "-o", "fb.tmp.so", "-lm", "-ldl"], out)
        os.replace(out / "fb.tmp.so", lib)
    units = pous((out / "POUS.h").read_text(encoding="utf-8"))
    return Library(lib, units)


class Instance:
    """One FB or PROGRAM instance in the compiled C: ``inst(SP=1.0, ...)`` writes the inputs
    and runs one cycle (returns the FP exception flags it raised); ``inst["MV"]`` reads."""

    def __init__(self, lib: Library, pou: Pou) -> None:
        self.pou = pou
        self.trap = False
        d, n = lib.dll, pou.name
        new, self._free = getattr(d, f"{n}_h_new"), getattr(d, f"{n}_h_free")
        new.restype, new.argtypes = ctypes.c_void_p, []
        self._free.restype, self._free.argtypes = None, [ctypes.c_void_p]
        self._p = ctypes.c_void_p(new())
        if not self._p.value:
            raise MemoryError(f"no memory for an instance of {n}")
        self._step = getattr(d, f"{n}_h_step")
        self._step.restype = ctypes.c_int
        self._step.argtypes = [ctypes.c_void_p, ctypes.c_int]
        ctype = {"REAL": ctypes.c_uint32, "DINT": ctypes.c_int32, "BOOL": ctypes.c_uint8}
        self._set: dict[str, Any] = {}
        self._get: dict[str, Any] = {}
        for f, t in pou.fields.items():
            s, g = getattr(d, f"{n}_h_set_{f}"), getattr(d, f"{n}_h_get_{f}")
            s.argtypes, s.restype = [ctypes.c_void_p, ctype[t]], None
            g.argtypes, g.restype = [ctypes.c_void_p], ctype[t]
            self._set[f], self._get[f] = s, g

    def __del__(self) -> None:
        p = getattr(self, "_p", None)
        if p is not None and p.value:
            self._free(p)
            p.value = None

    def set(self, name: str, value: Any) -> None:
        f = name.upper()
        t = self.pou.fields[f]
        if t == "REAL":
            with np.errstate(over="ignore"):  # 1.7e308 is inf as a REAL
                self._set[f](self._p, int(np.array(value, dtype=np.float32).view(np.uint32)))
        elif t == "BOOL":
            self._set[f](self._p, 1 if value else 0)
        else:
            self._set[f](self._p, int(value))

    def __call__(self, **inputs: Any) -> int:
        """Write ``inputs``, run one cycle: the FP exception flags it raised, or with
        :attr:`trap` (exceptions unmasked) ``-si_code`` of the SIGFPE that stopped it."""
        for k, v in inputs.items():
            self.set(k, v)
        return int(self._step(self._p, 1 if self.trap else 0))

    def __getitem__(self, name: str) -> Any:
        f = name.upper()
        t = self.pou.fields[f]
        v = self._get[f](self._p)
        if t == "REAL":
            return np.array(v, dtype=np.uint32).view(np.float32)[()]
        return bool(v) if t == "BOOL" else int(v)
