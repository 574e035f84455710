"""The disk cache of the compiled kernels: keyed by the sources they inline, safe to fall back.

Every test runs fresh processes (the cache is read when a process compiles),
on a copy of the package or a temporary cache folder, never the user's cache.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import ctrlblocks
from ctrlblocks.fast._jit import HAVE_NUMBA

needs_numba = pytest.mark.skipif(not HAVE_NUMBA, reason="the disk cache is numba's")

PACKAGE = Path(ctrlblocks.__file__).resolve().parent

# builds a small bank: compiles (or loads) bank._fill_rows, which inlines
# blocks.pid.derivative_coefficients and friends from another module
BANK = """
import json
from ctrlblocks.fast import bank as b, _jit
res = b.PIDBank.from_arrays(kp=[1.0, 2.0], ti=5.0, td=1.0, ts=0.1, plant_k=1.0,
                            plant_t=[[1.0, 2.0], [2.0, 3.0]])
st = b._fill_rows.stats
print(json.dumps({"hits": sum(st.cache_hits.values()), "misses": sum(st.cache_misses.values()),
                  "dir": str(_jit.cache_dir()), "key": _jit.source_key(),
                  "kp": res.prm[:, 0].tolist()}))
"""

WHERE = """
import json
from ctrlblocks.fast import _jit
print(json.dumps({"dir": str(_jit.cache_dir())}))
"""


def _run(script: str, src: Path | None = None, **env: str) -> dict:
    drop = ("NUMBA_CACHE_DIR", "CTRLBLOCKS_NUMBA_CACHE", "CTRLBLOCKS_NO_NUMBA")
    e = {k: v for k, v in os.environ.items() if k not in drop}
    if src is not None:
        e["PYTHONPATH"] = str(src)
    # a changed copy of the package has no compiled build: the numba cache is independent of it
    e["CTRLBLOCKS_COMPILED"] = "auto"
    e.update(env)
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=e,
                         check=True, timeout=300, cwd=src or None)  # fmt: skip
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.fixture
def package_copy(tmp_path: Path) -> Path:
    """A copy of the ctrlblocks sources under ``tmp_path/src`` (what a user would edit)."""
    src = tmp_path / "src"
    shutil.copytree(PACKAGE, src / "ctrlblocks", ignore=shutil.ignore_patterns("__pycache__"))
    return src


@needs_numba
def test_warm_process_loads_the_kernel_and_a_changed_block_source_recompiles_it(
    tmp_path: Path, package_copy: Path
):
    cache = tmp_path / "cache"
    cold = _run(BANK, package_copy, CTRLBLOCKS_NUMBA_CACHE=str(cache))
    warm = _run(BANK, package_copy, CTRLBLOCKS_NUMBA_CACHE=str(cache))
    assert (cold["hits"], cold["misses"]) == (0, 1)
    assert (warm["hits"], warm["misses"]) == (1, 0)
    assert Path(cold["dir"]).parent == cache and warm["dir"] == cold["dir"]
    # a change in a block module the kernel inlines (not the kernel's own file,
    # which is all numba checks) gives a new key and a fresh compilation
    pid_py = package_copy / "ctrlblocks" / "blocks" / "pid.py"
    pid_py.write_text(pid_py.read_text(encoding="utf-8") + "\n# edited\n", encoding="utf-8")
    edited = _run(BANK, package_copy, CTRLBLOCKS_NUMBA_CACHE=str(cache))
    assert edited["key"] != cold["key"] and edited["dir"] != cold["dir"]
    assert (edited["hits"], edited["misses"]) == (0, 1)
    assert edited["kp"] == cold["kp"] == [1.0, 2.0]


@needs_numba
def test_cache_folder_that_cannot_be_made_means_no_disk_cache(tmp_path: Path):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    got = _run(BANK, CTRLBLOCKS_NUMBA_CACHE=str(blocker / "cache"))
    assert got["dir"] == "None"
    assert (got["hits"], got["misses"]) == (0, 1)  # compiled in memory, still runs
    assert got["kp"] == [1.0, 2.0]


@needs_numba
def test_cache_respects_numba_cache_dir_and_can_be_switched_off(tmp_path: Path):
    got = _run(WHERE, NUMBA_CACHE_DIR=str(tmp_path / "nc"))
    assert Path(got["dir"]).parent == tmp_path / "nc" / "ctrlblocks"
    assert _run(WHERE, CTRLBLOCKS_NUMBA_CACHE="off")["dir"] == "None"


@needs_numba
def test_default_cache_is_in_the_user_cache_folder_not_in_the_package(tmp_path: Path):
    got = _run(WHERE, XDG_CACHE_HOME=str(tmp_path / "xdg"))
    folder = Path(got["dir"])
    assert folder.parent == tmp_path / "xdg" / "ctrlblocks" / "numba"
    assert PACKAGE not in folder.parents


THREE_TANK = """
import json, sys
import numpy as np
from ctrlblocks import PID
from ctrlblocks.plants import ThreeTank
from ctrlblocks.fast import closed_loop
res = closed_loop(PID(kp=2.0, ti=20.0, ts=0.1, u_min=0.0, u_max=1.0), ThreeTank(ts=0.1),
                  np.full(50, 0.1))
before = "scipy.linalg" in sys.modules
import scipy.linalg
print(json.dumps({"before": before, "path": res.path,
                  "expm": float(scipy.linalg.expm(np.zeros((1, 1)))[0, 0])}))
"""


@needs_numba
def test_a_compiled_call_does_not_import_scipy_linalg_for_numbas_blas_probe(tmp_path: Path):
    # numba's array functions probe for BLAS by importing scipy.linalg (seconds on a loaded
    # machine); the kernels need none: a three-tank loop runs without it, and it imports after
    got = _run(THREE_TANK, CTRLBLOCKS_NUMBA_CACHE=str(tmp_path / "cache"))
    assert got == {"before": False, "path": "compiled", "expm": 1.0}


def test_the_cache_key_differs_with_and_without_the_compiled_blocks(monkeypatch) -> None:
    """A kernel cached by a process with the compiled blocks (numba compiled the interpreted
    copies, ``ctrlblocks._interpreted_blocks``) must not be loaded by one without them: it
    raised ModuleNotFoundError there (CTRLBLOCKS_COMPILED=off after a run with the build)."""
    from ctrlblocks import compiled
    from ctrlblocks.fast import _jit

    keys = {}
    for active in (True, False):
        monkeypatch.setattr(compiled, "active", lambda a=active: a)
        monkeypatch.setattr(_jit, "_cache_state", {})
        keys[active] = _jit.source_key()
    assert keys[True] != keys[False]
