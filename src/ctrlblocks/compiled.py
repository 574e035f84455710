"""The compiled build of the PID and ADRC blocks (``pip install``, ``ctrlblocks compile``).

The interpreted package is the reference and stays the fallback.  The build
compiles four modules of ``blocks/`` -- ``base``, ``signals``, ``pid`` and
``adrc`` -- from the same ``.py`` files with Cython, in its pure-Python mode:
the ``.pxd`` files next to them make ``Block``, ``PID`` and ``ADRC`` extension
types whose float state is C doubles and declare the per-call law functions
with C arguments.  A full ``PID`` call then costs about a third of a
simple-pid call, and an ``ADRC`` call under a tenth of a pyadrc call
(docs/performance.md, "Compiled blocks"), with every output bit-equal to the
interpreted blocks.

Where the build lives and when it is used
-----------------------------------------
``pip install`` builds it into the package itself: ``setup.py`` runs
:func:`build_packaged` after ``build_py``, into ``ctrlblocks/_compiled/<key>``
(in the source tree for an editable install).  Without a C compiler that step
warns once and the package is the pure-Python one.  ``import ctrlblocks`` looks
there first, then in ``ctrlblocks compile``'s folder.

``ctrlblocks compile`` writes the extension modules to the user's cache folder
(``$XDG_CACHE_HOME`` or ``~/.cache``)``/ctrlblocks/compiled/<key>``, or
``$CTRLBLOCKS_COMPILED_DIR/<key>``, never into the installed package.  The key
is a hash of the four ``.py`` and ``.pxd`` files and of this Python's ABI, so
a build is only ever used with the very source it was compiled from: after an
upgrade or an edit there is simply no build for the new key, and the
interpreted blocks run until ``ctrlblocks compile`` is run again.

``import ctrlblocks`` loads the build of the current key when there is one
(:func:`install`, called first thing by ``ctrlblocks.blocks``).
``$CTRLBLOCKS_COMPILED`` chooses:

* ``auto`` (default): the build if there is one; a build that fails to load is
  left (one ``RuntimeWarning`` that says why) and the interpreted blocks run;
* ``off``: never the build;
* ``require``: the build or an ``ImportError`` (the tests of the build use it).

Two kinds of code need the interpreted law functions whatever is loaded:
numba compiles them (:mod:`ctrlblocks.fast`) and the float32 cycle and the PLC
export rebuild and translate them (:mod:`ctrlblocks.blocks.plc_cycle`,
:mod:`ctrlblocks.plc`).  They take their modules from :func:`interpreted`.

What differs in the compiled build (besides the speed)
-------------------------------------------------------
* ``inspect.signature(PID.__call__)`` is ``(*args, **kwargs)``: a special method
  of an extension type keeps no signature (``compute_output`` keeps its own).
* A float state attribute refuses what is not a number (``pid.out = "x"``
  raises ``TypeError``); the inputs a user writes (``manual_value``,
  ``track_value``, ...) stay Python objects, and process data still never
  raises.
* The classes cannot be changed (``PID.x = 1`` raises ``TypeError``);
  subclasses work as before.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import inspect
import json
import logging
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import time
import types
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)

MODULES = ("base", "signals", "pid", "adrc")
"""The compiled modules of ``blocks/``, in the order they are loaded (each
cimports only those before it)."""

INTERPRETED = ("signals", "pid", "adrc", "leadlag")
"""The modules :func:`interpreted` gives as interpreted copies when the build is
loaded: the compiled three whose functions numba and the float32 cycle need,
and ``leadlag``, whose functions call ``signals.clamp``."""

FORMAT = 1
"""The build's layout and compiler options; part of the key."""

_BLOCKS = Path(__file__).resolve().parent / "blocks"
_PACKAGED = Path(__file__).resolve().parent / "_compiled"
_SHADOW = "ctrlblocks._interpreted_blocks"
_MANIFEST = "build.json"

_state: dict[str, Any] = {"active": False, "folder": None, "reason": "not loaded yet"}


# ---------------------------------------------------------------------------
# the key and the folder
# ---------------------------------------------------------------------------


def ext_suffix() -> str:
    """The file ending of this Python's extension modules (``.cpython-311-x86_64-linux-gnu.so``)."""
    return str(sysconfig.get_config_var("EXT_SUFFIX") or ".so")


def source_key(blocks: Path = _BLOCKS) -> str:
    """The hash of the compiled modules' ``.py`` and ``.pxd`` files and of this Python's ABI."""
    h = hashlib.sha256(f"ctrlblocks compiled {FORMAT} {ext_suffix()}".encode())
    for name in MODULES:
        for ending in (".py", ".pxd"):
            h.update(f"\0{name}{ending}\0".encode())
            h.update((blocks / f"{name}{ending}").read_bytes())
    return h.hexdigest()[:20]


def build_root() -> Path:
    """The folder that holds the builds, one sub-folder per key."""
    env = os.environ.get("CTRLBLOCKS_COMPILED_DIR", "")
    if env:
        return Path(env).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME", "")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "ctrlblocks" / "compiled"


def build_folder(key: str | None = None) -> Path:
    """The folder of the build of ``key`` (default: the current source's key)."""
    return build_root() / (key or source_key())


def packaged_folder(key: str | None = None) -> Path:
    """The folder of the install-time build of ``key`` inside the package (``setup.py``)."""
    return _PACKAGED / (key or source_key())


def _complete(folder: Path) -> bool:
    return all((folder / f"{name}{ext_suffix()}").is_file() for name in MODULES)


def mode() -> str:
    """``$CTRLBLOCKS_COMPILED``: ``auto`` (default), ``off`` or ``require``."""
    value = os.environ.get("CTRLBLOCKS_COMPILED", "auto").strip().lower() or "auto"
    aliases = {"0": "off", "no": "off", "false": "off", "1": "require", "yes": "require"}
    value = aliases.get(value, value)
    if value not in ("auto", "off", "require"):
        warnings.warn(
            f"CTRLBLOCKS_COMPILED={value!r} is none of auto, off, require: taken as auto",
            RuntimeWarning,
            stacklevel=3,
        )
        return "auto"
    return value


# ---------------------------------------------------------------------------
# loading
# ---------------------------------------------------------------------------


def active() -> bool:
    """True when the compiled PID and ADRC are the ones ``ctrlblocks`` uses."""
    return bool(_state["active"])


def status() -> dict[str, Any]:
    """What is loaded and why: ``active``, ``folder``, ``reason``, ``mode``, ``key``."""
    return {**_state, "mode": mode(), "key": source_key()}


def install() -> bool:
    """Load the build of the current source, if there is one and ``$CTRLBLOCKS_COMPILED`` allows.

    Called once by ``ctrlblocks.blocks`` before it imports any block.  Returns
    whether the compiled blocks are in use.  Nothing is left half-loaded: if
    one module fails, every module this call imported is taken back out of
    ``sys.modules`` and the interpreted blocks are imported as usual.
    """
    if _state["active"] or _state["reason"] != "not loaded yet":
        return active()
    how = mode()
    if how == "off":
        _state["reason"] = "CTRLBLOCKS_COMPILED=off"
        return False
    try:
        key = source_key()
    except OSError as exc:  # the sources cannot be read: a broken installation
        folder, missing = None, f"the sources cannot be read ({exc})"
    else:
        # the install's own build first (pip install built it), then ctrlblocks compile's;
        # $CTRLBLOCKS_COMPILED_DIR names the one place to look
        places = [build_folder(key)]
        if not os.environ.get("CTRLBLOCKS_COMPILED_DIR", ""):
            places.insert(0, packaged_folder(key))
        found = [p for p in places if _complete(p)]
        folder = found[0] if found else None
        where = " or ".join(str(p) for p in places)
        missing = "" if found else f"no build for this source in {where}"
    if missing:
        _state["reason"] = missing + " (pip install or ctrlblocks compile builds one)"
        if how == "require":
            raise ImportError(
                f"CTRLBLOCKS_COMPILED=require: {_state['reason']}; build it with "
                "CTRLBLOCKS_COMPILED=auto ctrlblocks compile"
            )
        log.debug("ctrlblocks.compiled: %s", _state["reason"])
        return False
    assert folder is not None
    before = set(sys.modules)
    try:
        for name in MODULES:
            _load(f"ctrlblocks.blocks.{name}", folder / f"{name}{ext_suffix()}")
    except Exception as exc:
        for name in set(sys.modules) - before:
            if name.startswith("ctrlblocks."):
                del sys.modules[name]
        _state["reason"] = f"the build in {folder} failed to load: {type(exc).__name__}: {exc}"
        if how == "require":
            raise ImportError(f"CTRLBLOCKS_COMPILED=require: {_state['reason']}") from exc
        warnings.warn(
            f"ctrlblocks: {_state['reason']}; the interpreted blocks are used "
            "(ctrlblocks compile builds it again)",
            RuntimeWarning,
            stacklevel=2,
        )
        return False
    _state.update(active=True, folder=str(folder), reason=f"loaded from {folder}")
    log.debug("ctrlblocks.compiled: %s", _state["reason"])
    return True


def _load(name: str, path: Path) -> types.ModuleType:
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ImportError(f"{path} is no extension module")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def interpreted(name: str) -> types.ModuleType:
    """The interpreted module ``ctrlblocks.blocks.<name>``, whether or not the build is loaded.

    Without the build this is the module itself.  With it, the modules of
    :data:`INTERPRETED` are executed once more from their ``.py`` files as
    ``ctrlblocks._interpreted_blocks.<name>``; they import each other there and
    share every other module (``base``'s error codes, ``precision``, ...) with
    the package.  Only their functions are meant to be used.
    """
    if not _state["active"] or name not in INTERPRETED:
        return importlib.import_module(f"ctrlblocks.blocks.{name}")
    if _SHADOW not in sys.modules:
        shadow = types.ModuleType(_SHADOW, "interpreted copies of compiled block modules")
        shadow.__path__ = [str(_BLOCKS)]
        shadow.__package__ = _SHADOW
        sys.modules[_SHADOW] = shadow
    for other in ("base", "precision", "pid_forms"):  # shared with the package
        sys.modules.setdefault(
            f"{_SHADOW}.{other}", importlib.import_module(f"ctrlblocks.blocks.{other}")
        )
    module = importlib.import_module(f"{_SHADOW}.{name}")
    if not str(getattr(module, "__file__", "")).endswith(".py"):
        raise ImportError(f"{module.__name__} is not interpreted: {module.__file__}")
    return module


def signature(cls: type, name: str = "__call__") -> inspect.Signature:
    """``inspect.signature`` of the method ``name`` of the block class ``cls``.

    A compiled class's special methods (``__call__``, ``__init__``) keep no
    signature; their signature is then read from the same class of the
    interpreted source (:func:`interpreted`).
    """
    try:
        return inspect.signature(getattr(cls, name))
    except ValueError:
        module = cls.__module__.rpartition(".")[2]
        if not cls.__module__.startswith("ctrlblocks.blocks.") or module not in INTERPRETED:
            raise
        return inspect.signature(getattr(getattr(interpreted(module), cls.__name__), name))


# ---------------------------------------------------------------------------
# building
# ---------------------------------------------------------------------------

_BUILD_SCRIPT = """
import json, sys
from setuptools import Extension, setup
from Cython.Build import cythonize
args, mods = json.loads(sys.argv[1]), sys.argv[2:]
exts = [Extension("ctrlblocks.blocks." + m, ["ctrlblocks/blocks/" + m + ".py"],
                  extra_compile_args=args["cflags"]) for m in mods]
directives = {"language_level": 3, "annotation_typing": False, "infer_types": None}
setup(ext_modules=cythonize(exts, compiler_directives=directives, nthreads=args["jobs"],
                            quiet=True),
      script_args=["build_ext", "--inplace", "--parallel", str(args["jobs"])])
"""
# annotation_typing off: a ``float`` annotation stays a Python object, so an int beyond the
# float range reaches the block's own input check (a typed argument would raise first);
# the C types are the .pxd's.  -ffp-contract=off: the C compiler fuses no multiply-add that
# the interpreter rounds twice, so the outputs are bit-equal.

_CHECK_SCRIPT = """
import os, ctrlblocks, ctrlblocks.compiled as c
from ctrlblocks.blocks import pid
want = os.environ["CTRLBLOCKS_COMPILED"] == "require"
assert c.active() == want and pid.__file__.endswith(".py") != want, c.status()
p = ctrlblocks.PID(kp=2.0, ti=10.0, td=0.5, ts=0.1)
a = ctrlblocks.ADRC(order=2, b0=0.05, omega_c=0.35, omega_o=1.75, ts=0.1, u_min=0.0, u_max=5.0)
print(repr((p(1.0, 0.5), p(1.0, float("nan")), a(1.0, 0.5), a(1.0, 0.25))))
"""


class BuildError(RuntimeError):
    """The build failed; the message says what and where to look."""


def _say(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def compile_modules(
    dest: Path, key: str, *, jobs: int | None = None, say: Callable[[str], None] = _say
) -> float:
    """Compile :data:`MODULES` of this source with Cython into ``dest``; return the seconds.

    ``dest`` gets one extension module per name (``pid`` + :func:`ext_suffix`)
    and the manifest; nothing is checked here (:func:`build` checks in a fresh
    process; the install-time build of ``setup.py`` cannot, as the package's
    dependencies are not installed yet).  Raises :class:`BuildError`.
    """
    try:
        import Cython  # noqa: F401
        import setuptools  # noqa: F401
    except ImportError as exc:
        raise BuildError(
            f"the compiled build needs Cython and setuptools ({exc.name} is missing): "
            "pip install 'ctrlblocks[compiled]'"
        ) from None
    jobs = max(1, min(jobs or os.cpu_count() or 1, len(MODULES)))
    cflags = ["-O2", "-ffp-contract=off"] if os.name == "posix" else []
    t0 = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="ctrlblocks-compile-") as tmp_name:
        tmp = Path(tmp_name)
        pkg = tmp / "ctrlblocks" / "blocks"
        pkg.mkdir(parents=True)
        (tmp / "ctrlblocks" / "__init__.py").write_text("")
        (pkg / "__init__.py").write_text("")
        for name in MODULES:
            for ending in (".py", ".pxd"):
                shutil.copy2(_BLOCKS / f"{name}{ending}", pkg / f"{name}{ending}")
        if source_key(pkg) != key:
            raise BuildError("the sources changed while they were copied; run it again")
        say(f"compiling {', '.join(MODULES)} with Cython on {jobs} core(s) (about 1-3 minutes) ...")
        cmd = [sys.executable, "-c", _BUILD_SCRIPT, json.dumps({"jobs": jobs, "cflags": cflags})]
        log_file = tmp / "build.log"
        with log_file.open("w") as out:
            proc = subprocess.Popen([*cmd, *MODULES], cwd=tmp, stdout=out, stderr=out)
            while True:  # a line every 15 s, also into a file or a pipe
                try:
                    proc.wait(timeout=15)
                    break
                except subprocess.TimeoutExpired:
                    say(f"  ... still compiling ({time.monotonic() - t0:.0f} s)")
        if proc.returncode:
            tail = "\n".join(log_file.read_text(errors="replace").strip().splitlines()[-15:])
            raise BuildError(f"the compiler failed (exit {proc.returncode}):\n{tail}")
        dest.mkdir(parents=True, exist_ok=True)
        for name in MODULES:
            built = sorted(pkg.glob(f"{name}.*{ext_suffix().rsplit('.', 1)[-1]}"))
            if not built:
                raise BuildError(f"the compiler made no extension module for {name}")
            shutil.copy2(built[0], dest / f"{name}{ext_suffix()}")
    secs = time.monotonic() - t0
    import Cython as _cython

    (dest / _MANIFEST).write_text(
        json.dumps(
            {
                "key": key,
                "modules": list(MODULES),
                "python": sys.version.split()[0],
                "ext_suffix": ext_suffix(),
                "cython": _cython.__version__,
                "built": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                "seconds": round(secs, 1),
            },
            indent=2,
        )
        + "\n"
    )
    return secs


def build_packaged(folder: Path, *, say: Callable[[str], None] = _say) -> Path | None:
    """The install-time build (``setup.py``): compile into ``folder/<key>`` of the package.

    Returns the build's folder, or None when one for this source is already
    there.  An older key's build in ``folder`` is removed (an editable install
    rebuilt after an edit).  Raises :class:`BuildError`.
    """
    key = source_key()
    target = folder / key
    if all((target / f"{n}{ext_suffix()}").is_file() for n in MODULES):
        return None
    staged = folder / f".{key}.{os.getpid()}"
    shutil.rmtree(staged, ignore_errors=True)
    try:
        compile_modules(staged, key, say=say)
        if folder.is_dir():
            for old in folder.iterdir():
                if old.is_dir() and old != staged:
                    shutil.rmtree(old, ignore_errors=True)
        staged.rename(target)
    finally:
        shutil.rmtree(staged, ignore_errors=True)
    return target


def build(
    *, jobs: int | None = None, force: bool = False, say: Callable[[str], None] = _say
) -> Path:
    """Compile the four modules for this Python and source; return the build's folder.

    Needs Cython (``pip install 'ctrlblocks[compiled]'``) and a C compiler.
    Builds in a temporary folder and moves the result into place at the end, so
    an interrupted build leaves nothing half-made.  Checks the result in a
    fresh process: it must load and compute exactly what the interpreted
    blocks compute.
    """
    key = source_key()
    folder = build_folder(key)
    if folder.is_dir() and not force:
        say(f"a build for this source is already in {folder} (--force builds it again)")
        return folder
    root = build_root()
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise BuildError(f"cannot create {root}: {exc.strerror}") from None
    staged = root / f".{key}.{os.getpid()}"
    shutil.rmtree(staged, ignore_errors=True)
    staged.mkdir()
    try:
        secs = compile_modules(staged, key, jobs=jobs, say=say)
    except BaseException:
        shutil.rmtree(staged, ignore_errors=True)
        raise
    say(f"compiled in {secs:.0f} s; checking that it loads and computes as the interpreted ...")
    outputs = {}
    for how in ("require", "off"):
        env = dict(os.environ, CTRLBLOCKS_COMPILED=how, CTRLBLOCKS_COMPILED_DIR=str(root))
        if how == "require":  # the staged folder, under the key's name in a private root
            check_root = staged.parent / f".check.{os.getpid()}"
            shutil.rmtree(check_root, ignore_errors=True)
            check_root.mkdir()
            (check_root / key).symlink_to(staged, target_is_directory=True)
            env["CTRLBLOCKS_COMPILED_DIR"] = str(check_root)
        proc = subprocess.run(
            [sys.executable, "-c", _CHECK_SCRIPT], capture_output=True, text=True, env=env
        )
        if how == "require":
            shutil.rmtree(check_root, ignore_errors=True)
        if proc.returncode:
            shutil.rmtree(staged, ignore_errors=True)
            tail = "\n".join(proc.stderr.strip().splitlines()[-8:])
            raise BuildError(f"the build does not load ({how}):\n{tail}")
        outputs[how] = proc.stdout.strip()
    if outputs["require"] != outputs["off"]:
        shutil.rmtree(staged, ignore_errors=True)
        raise BuildError(
            f"the build computes {outputs['require']}, the interpreted blocks "
            f"{outputs['off']}: not used"
        )
    shutil.rmtree(folder, ignore_errors=True)
    try:
        staged.rename(folder)
    except OSError:  # another ctrlblocks compile of the same source finished first
        shutil.rmtree(staged, ignore_errors=True)
        if not (folder / _MANIFEST).is_file():
            raise
    say(f"done: {folder}")
    return folder


def remove() -> list[Path]:
    """Delete every build (of every key) under :func:`build_root`; return the folders."""
    root = build_root()
    gone = [p for p in sorted(root.iterdir()) if p.is_dir()] if root.is_dir() else []
    for p in gone:
        shutil.rmtree(p, ignore_errors=True)
    return gone
