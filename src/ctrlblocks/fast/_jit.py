"""Optional numba compilation of the blocks' own pure functions.

numba is an optional extra (``pip install ctrlblocks[fast]``).  When it is
importable, :func:`jit` compiles a function with ``numba.njit`` and
:func:`jitable` registers one of the blocks' module-level pure functions
(``ctrlblocks.blocks.pid.derivative_step``, ``...adrc.eso_euler``, ...) so
that compiled code calls -- and LLVM inlines -- *that same function*: no
second copy of a control law exists (one implementation of each law).  ``jitable``
returns the function unchanged, so the blocks keep calling it interpreted.

Without numba both decorators return the function unchanged: every fast path
then runs the very same Python code interpreted (correct, just slower), and
one log message at INFO level says so.  Setting the environment variable
``CTRLBLOCKS_NO_NUMBA=1`` forces that fallback (used by tests and benchmarks).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ["HAVE_NUMBA", "jit", "jit_parallel", "jitable", "prange", "python_function"]

log = logging.getLogger("ctrlblocks.fast")

F = TypeVar("F", bound=Callable[..., Any])

_numba: Any
if os.environ.get("CTRLBLOCKS_NO_NUMBA", "") not in ("", "0"):
    _numba = None
    log.info("ctrlblocks.fast: CTRLBLOCKS_NO_NUMBA is set; fast paths run interpreted")
else:
    try:
        import numba as _numba
        from numba.extending import register_jitable as _register_jitable
    except ImportError:  # pragma: no cover - depends on the environment
        _numba = None
        log.info(
            "ctrlblocks.fast: numba is not installed; the compiled loops and banks run "
            "the same functions interpreted (slower). Install the extra: "
            "pip install 'ctrlblocks[fast]'"
        )

HAVE_NUMBA: bool = _numba is not None
"""True when the fast paths are compiled by numba."""


def jit(fn: F) -> F:
    """``numba.njit(fn)`` (no fastmath: results equal the interpreted blocks), or ``fn``."""
    if _numba is None:
        return fn
    return _numba.njit(fastmath=False, cache=False, nogil=True)(fn)  # type: ignore[no-any-return]


def jit_parallel(fn: F) -> F:
    """``numba.njit(fn, parallel=True)``: ``prange`` loops run on all cores; or ``fn``."""
    if _numba is None:
        return fn
    return _numba.njit(fastmath=False, cache=False, nogil=True, parallel=True)(fn)  # type: ignore[no-any-return]


def jitable(fn: F) -> F:
    """Make ``fn`` callable from compiled code; return ``fn`` itself (unchanged)."""
    if _numba is not None:
        _register_jitable(fn)
    return fn


prange: Any = range if _numba is None else _numba.prange
"""``numba.prange`` (parallel loop in :func:`jit_parallel` code), ``range`` without numba."""


def python_function(fn: Callable[..., Any]) -> Callable[..., Any]:
    """The interpreted Python function behind ``fn`` (``fn.py_func`` of a numba dispatcher)."""
    return getattr(fn, "py_func", fn)
