"""The install-time build of the compiled PID and ADRC blocks.

``pip install`` (editable or not) compiles ``blocks/`` ``base``, ``signals``,
``pid`` and ``adrc`` with Cython into the package's ``_compiled/<key>/``
folder, where ``import ctrlblocks`` finds them (``ctrlblocks.compiled``: the
key is a hash of the sources and the Python ABI, so an edited source simply
has no build until the next install or ``ctrlblocks compile``).  Without a C
compiler, or with ``CTRLBLOCKS_BUILD_COMPILED=off``, the build is skipped with
one warning and the package is the pure-Python one -- the reference, always
complete.  ``CTRLBLOCKS_BUILD_COMPILED=require`` (the release CI's) makes a
failed build fail the install instead.  Everything else is declared in ``pyproject.toml``.
"""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

from setuptools import setup
from setuptools.command.bdist_wheel import bdist_wheel
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent


def _compiled_module():
    """``ctrlblocks/compiled.py`` loaded on its own (it imports only the standard library)."""
    spec = importlib.util.spec_from_file_location(
        "_ctrlblocks_compiled_setup", HERE / "src" / "ctrlblocks" / "compiled.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class BuildPyWithCompiledBlocks(build_py):
    """``build_py``, then the compiled blocks into the package (never fatal)."""

    compiled = False
    """Whether the package holds the compiled blocks for this Python (the wheel's tag)."""

    def run(self) -> None:
        super().run()
        how = os.environ.get("CTRLBLOCKS_BUILD_COMPILED", "auto").strip().lower()
        if how in ("off", "0", "no", "false"):
            print("ctrlblocks: CTRLBLOCKS_BUILD_COMPILED=off: the interpreted blocks only")
            return
        # an editable install runs the source tree: the build goes next to it
        lib = HERE / "src" if self.editable_mode else Path(self.build_lib)
        package = lib / "ctrlblocks"
        compiled = _compiled_module()
        try:
            folder = compiled.build_packaged(package / "_compiled", say=print)
        except Exception as exc:  # no compiler, no Cython, no headers: the fallback
            if how == "require":  # the release CI: a binary wheel or none
                raise RuntimeError(f"ctrlblocks: the compiled blocks failed: {exc}") from exc
            self.warn(
                f"ctrlblocks: the compiled blocks were not built ({type(exc).__name__}: "
                f"{str(exc)[-400:]}); the interpreted blocks are used (ctrlblocks compile "
                "builds them later)"
            )
            return
        print(f"ctrlblocks: compiled blocks in {folder or 'place already'}")
        self.compiled = True


class BdistWheelTagged(bdist_wheel):
    """A wheel that holds the compiled blocks is a binary wheel of this Python and platform.

    The blocks are built by ``build_py`` (not declared as ``ext_modules``), so
    setuptools would tag the wheel ``py3-none-any`` although it carries
    CPython extension modules: the build runs first here, and a package that
    got them is tagged ``cpXY-cpXY-<platform>`` (``Root-Is-Purelib: false``).
    Without a compiler (or with ``CTRLBLOCKS_BUILD_COMPILED=off``) the wheel
    stays the pure-Python ``py3-none-any`` one.
    """

    def run(self) -> None:
        if not self.skip_build:
            self.run_command("build")  # run once: bdist_wheel's own call is then a no-op
        if self.get_finalized_command("build_py").compiled:
            self.root_is_pure = False
            # the package then installs to platlib, the wheel's root (not its .data/purelib)
            self.distribution.has_ext_modules = lambda: True  # type: ignore[method-assign]
        super().run()


setup(cmdclass={"build_py": BuildPyWithCompiledBlocks, "bdist_wheel": BdistWheelTagged})
