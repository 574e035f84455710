"""The C preprocessor as the oracle of the C macros an exported identifier must not be.

MATIEC (Beremiz, OpenPLC) writes every ST identifier into C in upper case,
next to the headers its library and a soft-PLC runtime include; a variable
named like one of their macros (``x_ok`` -> ``X_OK`` of ``<unistd.h>``) does
not compile.  :func:`live_macros` asks this machine's ``gcc -dM -E`` for the
macros of :data:`HEADERS` (and of MATIEC's ``lib/C`` when given) that an IEC
identifier can spell; ``ctrlblocks.plc.c_macros.C_MACROS`` is that set,
written down.  Run this file to print the set for a new ``c_macros.py``.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

_HEADERS = (
    "assert.h ctype.h dlfcn.h errno.h fcntl.h fenv.h float.h inttypes.h limits.h locale.h "
    "math.h pthread.h sched.h semaphore.h setjmp.h signal.h stdarg.h stdbool.h stddef.h "
    "stdint.h stdio.h stdlib.h string.h sys/mman.h sys/stat.h sys/time.h sys/types.h time.h "
    "unistd.h"
)
HEADERS = _HEADERS.split()
"""The C standard and POSIX headers a MATIEC build and a soft-PLC runtime include."""

_UPPER_IEC = re.compile(r"[A-Z](?:_?[A-Z0-9])*")


def live_macros(matiec_lib: Path | None = None) -> frozenset[str] | None:
    """The upper-case, IEC-identifier-shaped macros of :data:`HEADERS` (None: no gcc)."""
    gcc = shutil.which("gcc")
    if gcc is None:
        return None
    lines = ["#define _GNU_SOURCE", *(f"#include <{h}>" for h in HEADERS)]
    inc: list[str] = []
    if matiec_lib is not None:
        lines += ['#include "iec_std_lib.h"', '#include "accessor.h"']
        inc = ["-I", str(matiec_lib)]
    with tempfile.TemporaryDirectory() as d:
        src = Path(d) / "h.c"
        src.write_text("\n".join(lines) + "\n", encoding="ascii")
        out = subprocess.run([gcc, "-dM", "-E", *inc, str(src)], capture_output=True,
                             text=True, timeout=120, check=True).stdout  # fmt: skip
    names = (line.split()[1].split("(")[0] for line in out.splitlines() if line.count(" ") >= 1)
    return frozenset(n for n in names if _UPPER_IEC.fullmatch(n))


if __name__ == "__main__":  # print the set, wrapped, for src/ctrlblocks/plc/c_macros.py
    lib = Path(sys.argv[1]) if len(sys.argv) > 1 else None
    words = sorted(live_macros(lib) or ())
    line = ""
    for w in words:
        if len(line) + len(w) + 1 > 92:
            print(line)
            line = ""
        line = f"{line} {w}" if line else w
    print(line)
