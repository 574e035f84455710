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
ones) and of the numba version: the cache lives in a folder named after that
hash, and the same hash is the source stamp numba checks, so any change of
those sources compiles anew.

Native modules
--------------
Loading a cached kernel still costs a new process numba's import and the
set-up of its type system (about a second, more on a loaded machine).  A
kernel declared with :func:`native` (its argument types spelt out, arrays and
scalars only) is therefore also built ahead of time, on its first call, into
an extension module of its own (``numba.pycc``) in the same keyed folder
(``native/``); a later process imports that module (milliseconds) and
neither imports numba nor compiles.  Without a C compiler (or with
``CTRLBLOCKS_NATIVE=0``) such a kernel is compiled by numba as any other.
numba itself is imported only when something is compiled: the other kernels
are compiled on their first call (as numba does), the parallel ones when
their module is imported.

Where: ``$CTRLBLOCKS_NUMBA_CACHE`` if set (``off`` disables the cache), else
``$NUMBA_CACHE_DIR/ctrlblocks`` when numba's own cache folder is set, else
the user's cache folder (``$XDG_CACHE_HOME`` or ``~/.cache``)
``/ctrlblocks/numba`` -- never inside the installed package.  A folder that
cannot be created or written means no cache (compiled in memory, as before),
with one DEBUG log line.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.machinery
import importlib.util
import logging
import os
import shutil
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any, ClassVar, TypeVar

__all__ = [
    "HAVE_NUMBA",
    "cache_dir",
    "jit",
    "jit_parallel",
    "jitable",
    "native",
    "numba_prange",
    "python_function",
    "source_key",
]

log = logging.getLogger("ctrlblocks.fast")

F = TypeVar("F", bound=Callable[..., Any])

if os.environ.get("CTRLBLOCKS_NO_NUMBA", "") not in ("", "0"):
    HAVE_NUMBA = False
    log.info("ctrlblocks.fast: CTRLBLOCKS_NO_NUMBA is set; fast paths run interpreted")
else:
    HAVE_NUMBA = importlib.util.find_spec("numba") is not None
    if not HAVE_NUMBA:  # pragma: no cover - depends on the environment
        log.info(
            "ctrlblocks.fast: numba is not installed; the compiled loops and banks run "
            "the same functions interpreted (slower). Install the extra: "
            "pip install 'ctrlblocks[fast]'"
        )
"""True when the fast paths are compiled by numba (installed; imported when first needed)."""

_numba: Any = None
_pending: list[Callable[..., Any]] = []  # jitable functions to register when numba is imported


def _import_numba() -> Any:
    """numba, imported on first need; the :func:`jitable` functions are registered then."""
    global _numba
    if _numba is None:
        import numba
        from numba.extending import register_jitable

        for fn in _pending:
            register_jitable(fn)
        _pending.clear()
        _numba = numba
    return _numba


class _Kernel:
    """A function compiled on its first call: the native module, else numba (:func:`jit`)."""

    def __init__(self, fn: Callable[..., Any], parallel: bool, signature: str | None) -> None:
        functools.update_wrapper(self, fn)
        self.py_func = fn
        self._parallel = parallel
        self.signature = signature
        self._impl: Any = None

    def _resolve(self) -> Any:
        if self._impl is None:
            impl = _load_native(self) if self.signature is not None else None
            if impl is None:
                nb = _import_numba()
                impl = _cached(nb.njit(fastmath=False, cache=False, nogil=True,
                                       parallel=self._parallel)(self.py_func))  # fmt: skip
            self._impl = impl
        return self._impl

    def __call__(self, *args: Any) -> Any:
        impl = self._impl
        return (impl if impl is not None else self._resolve())(*args)

    def __getattr__(self, name: str) -> Any:  # the dispatcher's own attributes (``stats``)
        if name.startswith("__") or name == "_impl":
            raise AttributeError(name)
        return getattr(self._resolve(), name)


def jit(fn: F) -> F:
    """``numba.njit(fn)`` (no fastmath: results equal the interpreted blocks), or ``fn``.

    Compiled (or loaded from the disk cache) on the first call.
    """
    if not HAVE_NUMBA:
        return fn
    return _Kernel(fn, False, None)  # type: ignore[return-value]


def native(signature: str) -> Callable[[F], F]:
    """:func:`jit` with a native module built ahead of time (module docstring).

    ``signature`` is the numba signature of the only call made, e.g.
    ``"i8(f8[::1], f8[:, ::1])"`` (C-contiguous arrays and scalars).
    """

    def deco(fn: F) -> F:
        if not HAVE_NUMBA:
            return fn
        return _Kernel(fn, False, signature)  # type: ignore[return-value]

    return deco


def jit_parallel(fn: F) -> F:
    """``numba.njit(fn, parallel=True)``: ``prange`` loops run on all cores; or ``fn``.

    Imports numba now (its ``prange`` must be the module's global when it compiles).
    """
    if not HAVE_NUMBA:
        return fn
    _import_numba()
    return _Kernel(fn, True, None)  # type: ignore[return-value]


def jitable(fn: F) -> F:
    """Make ``fn`` callable from compiled code; return ``fn`` itself (unchanged)."""
    if HAVE_NUMBA:
        if _numba is None:
            _pending.append(fn)
        else:
            from numba.extending import register_jitable

            register_jitable(fn)
    return fn


def numba_prange() -> Any:
    """``numba.prange`` (parallel loop in :func:`jit_parallel` code), ``range`` without numba."""
    return range if not HAVE_NUMBA else _import_numba().prange


def python_function(fn: Callable[..., Any]) -> Callable[..., Any]:
    """The interpreted Python function behind ``fn`` (``fn.py_func`` of a compiled kernel)."""
    return getattr(fn, "py_func", fn)


# ---------------------------------------------------------------------------
# disk cache keyed by the sources compiled code can reach
# ---------------------------------------------------------------------------

_PACKAGE = Path(__file__).resolve().parent.parent
_KEYED_PACKAGES = ("blocks", "plants", "fast", "loops")
_cache_state: dict[str, Any] = {}


def _numba_version() -> str:
    """numba's version without importing it ("-" without numba)."""
    if not HAVE_NUMBA:
        return "-"
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("numba")
    except PackageNotFoundError:  # pragma: no cover - numba importable but not installed
        return _import_numba().__version__  # type: ignore[no-any-return]


def source_key() -> str:
    """Hex hash of the numba version and every ``.py`` file compiled kernels can reach."""
    if "key" not in _cache_state:
        h = hashlib.sha256(f"numba {_numba_version()}".encode())
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
    numba_dir = os.environ.get("NUMBA_CACHE_DIR", "")  # numba's own cache folder (its config)
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


# ---------------------------------------------------------------------------
# native modules (numba.pycc) of the kernels declared with ``native``
# ---------------------------------------------------------------------------


def _native_name(kernel: _Kernel) -> str:
    mod = kernel.py_func.__module__.rsplit(".", 1)[-1]
    return f"_cbn_{mod}_{kernel.py_func.__name__.strip('_')}"


def _load_native(kernel: _Kernel) -> Any:
    """The kernel's function from its native module (built now if missing), or None."""
    folder = cache_dir()
    if folder is None or os.environ.get("CTRLBLOCKS_NATIVE", "") in ("0", "off"):
        return None
    name = _native_name(kernel)
    path = folder / "native" / (name + importlib.machinery.EXTENSION_SUFFIXES[0])
    if not path.exists() and not _build_native(kernel, name, path):
        return None
    try:
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)  # type: ignore[arg-type]
        spec.loader.exec_module(module)  # type: ignore[union-attr]
        return module.run
    except (ImportError, AttributeError, OSError) as exc:  # pragma: no cover - a broken file
        log.debug("ctrlblocks.fast: native module %s not usable (%s)", path, exc)
        return None


def _build_native(kernel: _Kernel, name: str, path: Path) -> bool:
    """Build the native module of ``kernel`` at ``path`` (atomically); False if it cannot."""
    path.parent.mkdir(exist_ok=True)
    tmp = tempfile.mkdtemp(dir=path.parent)
    try:
        _import_numba()
        with warnings.catch_warnings():  # numba.pycc is deprecated (it still works)
            warnings.simplefilter("ignore")
            from numba.pycc import CC

            cc = CC(name)
            cc.output_dir = tmp
            cc.export("run", kernel.signature)(kernel.py_func)
            cc.compile()
        (built,) = Path(tmp).glob(name + ".*")
        os.replace(built, path)
        log.debug("ctrlblocks.fast: built the native module %s", path)
        return True
    except Exception as exc:  # no C compiler, no pycc: numba compiles as for any kernel
        log.debug("ctrlblocks.fast: no native module for %s (%s)", name, exc)
        return False
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
