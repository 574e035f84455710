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

Disk cache
----------
Compiling every kernel anew costs seconds per process (every sweep worker,
every CLI call), so compiled code is cached on disk.  numba's own cache
(``cache=True``) would check only the source file of the decorated function,
not the blocks' functions it inlines (``blocks/pid.py``, ...), and would
happily load a stale kernel after such a change.  Here the cache key is a hash
of every source file compiled code can reach (``blocks/``, ``plants/``,
``fast/`` and, once it exists, ``loops/``; lower layers never import higher
ones), of the numba version and of whether the compiled blocks are loaded
(:mod:`ctrlblocks.compiled`: with them numba compiles the interpreted copies
of the law functions, which live under another module name, so a kernel
cached by one kind of process would not load in the other -- it raised
``ModuleNotFoundError: ctrlblocks._interpreted_blocks`` in a process run
with ``CTRLBLOCKS_COMPILED=off`` after one with the build): the cache lives
in a folder named after that hash, and the same hash is the source stamp
numba checks, so any change of those sources compiles anew.

Where: ``$CTRLBLOCKS_NUMBA_CACHE`` if set (``off`` disables the cache), else
``$NUMBA_CACHE_DIR/ctrlblocks`` when numba's own cache folder is set, else
the user's cache folder (``$XDG_CACHE_HOME`` or ``~/.cache``)
``/ctrlblocks/numba`` -- never inside the installed package.  A folder that
cannot be created or written means no cache (compiled in memory, as before),
with one DEBUG log line.
"""

from __future__ import annotations

import hashlib
import logging
import os
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any, ClassVar, TypeVar

from .. import compiled as _compiled

__all__ = [
    "HAVE_NUMBA",
    "cache_dir",
    "jit",
    "jit_parallel",
    "jitable",
    "prange",
    "python_function",
    "source_key",
]

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


def _skip_blas_probe() -> None:
    """Import numba's array functions without their BLAS probe (``scipy.linalg``).

    The first compiled call of a process imports ``numba.np.arraymath``,
    which probes for BLAS by importing ``scipy.linalg`` -- about half of a
    warm process's first call (2.2 of 4.9 s measured on the loaded machine)
    when nothing else needs scipy (the three-tank process).  The kernels use
    no BLAS; with the probe failing, numba's ``np.convolve``/``np.correlate``
    use its own inner product and ``np.dot`` still imports BLAS when it is
    compiled.  Nothing is skipped once scipy.linalg is imported.
    """
    if "scipy.linalg" in sys.modules or "numba.np.arraymath" in sys.modules:
        return
    sys.modules["scipy.linalg"] = None  # type: ignore[assignment] # the probe's import fails
    try:
        import numba.np.arraymath  # noqa: F401
    except ImportError as exc:  # pragma: no cover - a numba that needs scipy.linalg here
        log.debug("ctrlblocks.fast: numba.np.arraymath not imported early (%s)", exc)
    finally:
        if "scipy.linalg" in sys.modules and sys.modules["scipy.linalg"] is None:
            del sys.modules["scipy.linalg"]


if HAVE_NUMBA:
    _skip_blas_probe()


def jit(fn: F) -> F:
    """``numba.njit(fn)`` (no fastmath: results equal the interpreted blocks), or ``fn``."""
    if _numba is None:
        return fn
    return _cached(_numba.njit(fastmath=False, cache=False, nogil=True)(fn))


def jit_parallel(fn: F) -> F:
    """``numba.njit(fn, parallel=True)``: ``prange`` loops run on all cores; or ``fn``."""
    if _numba is None:
        return fn
    return _cached(_numba.njit(fastmath=False, cache=False, nogil=True, parallel=True)(fn))


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


# ---------------------------------------------------------------------------
# disk cache keyed by the sources compiled code can reach
# ---------------------------------------------------------------------------

_PACKAGE = Path(__file__).resolve().parent.parent
_KEYED_PACKAGES = ("blocks", "plants", "fast", "loops")
_cache_state: dict[str, Any] = {}


def source_key() -> str:
    """Hex hash of the numba version and every ``.py`` file compiled kernels can reach."""
    if "key" not in _cache_state:
        h = hashlib.sha256(f"numba {getattr(_numba, '__version__', '-')}".encode())
        # the law functions numba compiles are the interpreted copies when the build is
        # loaded (another module name): one cache per kind of process
        h.update(b"blocks compiled\0" if _compiled.active() else b"blocks interpreted\0")
        for sub in _KEYED_PACKAGES:
            for path in sorted((_PACKAGE / sub).rglob("*.py")):
                h.update(str(path.relative_to(_PACKAGE)).encode())
                h.update(b"\0" + path.read_bytes() + b"\0")
        _cache_state["key"] = h.hexdigest()
    return str(_cache_state["key"])


def cache_dir() -> Path | None:
    """The folder of the compiled kernels of these sources, or None (no disk cache)."""
    if "dir" in _cache_state:
        return _cache_state["dir"]  # type: ignore[no-any-return]
    base_env = os.environ.get("CTRLBLOCKS_NUMBA_CACHE", "")
    numba_dir = str(getattr(getattr(_numba, "config", None), "CACHE_DIR", "") or "")
    if base_env.lower() in ("off", "0", "no", "false"):
        base = None
    elif base_env:
        base = Path(base_env)
    elif numba_dir:
        base = Path(numba_dir) / "ctrlblocks"
    else:
        xdg = os.environ.get("XDG_CACHE_HOME", "")
        base = (Path(xdg) if xdg else Path.home() / ".cache") / "ctrlblocks" / "numba"
    folder: Path | None = None
    if base is not None:
        folder = base / f"kernels-{source_key()[:16]}"
        try:
            folder.mkdir(parents=True, exist_ok=True)
            tempfile.TemporaryFile(dir=folder).close()
        except OSError as exc:
            log.debug("ctrlblocks.fast: no disk cache for compiled kernels (%s: %s)", folder, exc)
            folder = None
    _cache_state["dir"] = folder
    return folder


def _cached(disp: Any) -> Any:
    """Give the numba dispatcher ``disp`` the disk cache of :func:`cache_dir` (if any)."""
    folder = cache_dir()
    if folder is None:
        return disp
    try:
        disp._cache = _cache_class()(disp.py_func)
    except Exception as exc:  # pragma: no cover - a numba without these classes
        log.debug("ctrlblocks.fast: numba's cache classes are not usable (%s)", exc)
    return disp


def _cache_class() -> Any:
    """numba's ``FunctionCache`` located in :func:`cache_dir`, stamped by :func:`source_key`."""
    if "cls" in _cache_state:
        return _cache_state["cls"]
    from numba.core import caching

    class Locator(caching._CacheLocator):  # type: ignore[misc,name-defined]
        def __init__(self, py_func: Any, py_file: str) -> None:
            self._lineno = py_func.__code__.co_firstlineno
            sub = self.get_suitable_cache_subpath(py_file)
            self._path = str(cache_dir() / sub)  # type: ignore[operator]

        def get_cache_path(self) -> str:
            return self._path

        def get_source_stamp(self) -> str:
            return source_key()

        def get_disambiguator(self) -> str:
            return str(self._lineno)

        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> Locator | None:
            self = cls(py_func, py_file)
            try:
                self.ensure_cache_path()
            except OSError:
                return None
            return self

    class Impl(caching.CompileResultCacheImpl):  # type: ignore[misc,name-defined]
        _locator_classes: ClassVar[list[Any]] = [Locator]

    class Cache(caching.FunctionCache):  # type: ignore[misc,name-defined]
        _impl_class = Impl

    _cache_state["cls"] = Cache
    return Cache
