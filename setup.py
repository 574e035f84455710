"""The install-time build of the compiled PID and ADRC blocks.

``pip install`` (editable or not) compiles ``blocks/`` ``base``, ``signals``,
``pid`` and ``adrc`` with Cython into the package's ``_compiled/<key>/``
folder, where ``import ctrlblocks`` finds them (``ctrlblocks.compiled``: the
key is a hash of the sources and the Python ABI, so an edited source simply
has no build until the next install or ``ctrlblocks compile``).  Without a C
compiler, or with ``CTRLBLOCKS_BUILD_COMPILED=off``, the build is skipped with
one warning and the package is the pure-Python one -- the reference, always
complete.  Everything else is declared in ``pyproject.toml``.
"""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

from setuptools import setup
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

    def run(self) -> None:
        super().run()
        if os.environ.get("CTRLBLOCKS_BUILD_COMPILED", "auto").strip().lower() in (
            "off", "0", "no", "false",
        ):  # fmt: skip
            print("ctrlblocks: CTRLBLOCKS_BUILD_COMPILED=off: the interpreted blocks only")
            return
        # an editable install runs the source tree: the build goes next to it
        lib = HERE / "src" if self.editable_mode else Path(self.build_lib)
        package = lib / "ctrlblocks"
        compiled = _compiled_module()
        try:
            folder = compiled.build_packaged(package / "_compiled", say=print)
        except Exception as exc:  # no compiler, no Cython, no headers: the fallback
            self.warn(
                f"ctrlblocks: the compiled blocks were not built ({type(exc).__name__}: "
                f"{str(exc)[-400:]}); the interpreted blocks are used (ctrlblocks compile "
                "builds them later)"
            )
            return
        print(f"ctrlblocks: compiled blocks in {folder or 'place already'}")


setup(cmdclass={"build_py": BuildPyWithCompiledBlocks})
