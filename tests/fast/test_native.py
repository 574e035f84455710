"""Native modules of kernels (``ctrlblocks.fast._jit.native``): built once, loaded without numba.

Fresh processes on a temporary cache folder (never the user's) build a small
kernel's native module, load it in a later process without importing numba,
and never load it for changed sources (the folder is keyed by them).  The
test suite itself runs with ``CTRLBLOCKS_NATIVE=0`` (tests/conftest.py) so
that its processes compile with numba instead of building native modules.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from ctrlblocks.fast._jit import HAVE_NUMBA

from .test_cache import _run as run_script
from .test_cache import package_copy  # noqa: F401 - the fixture

pytestmark = pytest.mark.skipif(not HAVE_NUMBA, reason="native modules are built by numba")

KERNEL = """
import json, sys
import numpy as np
from ctrlblocks.fast import _jit

@_jit.native("f8(f8[::1], i8)")
def _halves(a, n):
    s = 0.0
    for i in range(n):
        s += 0.5 * a[i]
    return s

got = _halves(np.arange(4.0), 4)
folder = _jit.cache_dir() / "native"
print(json.dumps({"got": got, "numba": "numba" in sys.modules, "key": _jit.source_key(),
                  "files": sorted(p.name for p in folder.glob("*")) if folder.exists() else []}))
"""


def _run(cache: Path, src: Path | None = None, native: str = "1") -> dict:
    return run_script(KERNEL, src, CTRLBLOCKS_NUMBA_CACHE=str(cache), CTRLBLOCKS_NATIVE=native)


def test_a_native_module_is_built_once_and_then_loaded_without_numba(
    tmp_path: Path,
    package_copy: Path,  # noqa: F811 - the fixture
):
    cache = tmp_path / "cache"
    first = _run(cache, package_copy)
    assert first["got"] == 3.0
    if not first["files"]:
        pytest.skip("no native module could be built here (no C compiler?)")
    assert len(first["files"]) == 1 and first["files"][0].startswith("_cbn___main___halves.")
    warm = _run(cache, package_copy)
    assert warm == {**first, "numba": False}  # loaded, not compiled: numba not even imported
    # a change of a source the kernels can reach gives a new key: the old module is not used
    pid_py = package_copy / "ctrlblocks" / "blocks" / "pid.py"
    pid_py.write_text(pid_py.read_text(encoding="utf-8") + "\n# edited\n", encoding="utf-8")
    edited = _run(cache, package_copy, native="0")
    assert edited["key"] != first["key"] and edited["files"] == []
    assert edited["numba"] and edited["got"] == 3.0  # compiled by numba, same result


def test_native_off_compiles_with_numba(tmp_path: Path):
    got = _run(tmp_path / "cache", native="0")
    assert got["got"] == 3.0 and got["numba"] and got["files"] == []
