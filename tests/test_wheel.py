"""The wheel ``pip wheel .`` builds: binary with the compiled blocks, pure without them.

The compiled PID and ADRC are built by ``build_py`` (setup.py), not declared as
``ext_modules``, so setuptools would tag a wheel that carries them
``py3-none-any`` -- a wheel that claims to fit every platform while holding
CPython extension modules of one.  ``setup.py``'s ``bdist_wheel`` tags it for
this interpreter and platform instead; with ``CTRLBLOCKS_BUILD_COMPILED=off``
(or no compiler) the wheel stays pure.  A binary wheel is what users without a
C compiler install (docs/performance.md, "Compiled blocks").
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

from ctrlblocks import compiled

from .blocks.test_compiled import _compiler_missing

ROOT = Path(__file__).resolve().parents[1]


def _source_copy(dest: Path) -> Path:
    """The tracked files of the repository (a clean checkout, no build of the tree's own)."""
    files = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True,
                           check=True).stdout.decode().split("\0")  # fmt: skip
    for name in filter(None, files):
        (dest / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / name, dest / name)
    return dest


def _wheel(src: Path, out: Path, **env: str) -> Path:
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation",
         "-w", str(out), str(src)],
        check=True, timeout=1200, env={**os.environ, **env}, cwd=out.parent,
    )  # fmt: skip
    (wheel,) = out.glob("*.whl")
    return wheel


@pytest.mark.slow  # compiles the blocks, about a minute on 2 cores (pytest -m slow)
@pytest.mark.timeout(1800)
def test_the_wheel_is_binary_with_the_compiled_blocks_and_pure_without(tmp_path: Path) -> None:
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs the repository's git checkout")
    why = _compiler_missing()
    if why:
        pytest.skip(why)
    src = _source_copy(tmp_path / "src")
    pure = _wheel(src, tmp_path / "pure", CTRLBLOCKS_BUILD_COMPILED="off")
    assert pure.name.endswith("-py3-none-any.whl"), pure.name
    with zipfile.ZipFile(pure) as z:
        assert not [n for n in z.namelist() if "/_compiled/" in n]
    binary = _wheel(src, tmp_path / "binary")
    tag = f"cp{sys.version_info.major}{sys.version_info.minor}"
    platform = sysconfig.get_platform().replace("-", "_").replace(".", "_")
    assert binary.name.endswith(f"-{tag}-{tag}-{platform}.whl"), binary.name
    key = compiled.source_key()
    with zipfile.ZipFile(binary) as z:
        names = z.namelist()
        wheel_meta = next(z.read(n).decode() for n in names if n.endswith(".dist-info/WHEEL"))
        z.extractall(tmp_path / "site")
    assert "Root-Is-Purelib: false" in wheel_meta
    # the modules sit in the package (the wheel's root), under this source's key
    for module in compiled.MODULES:
        assert f"ctrlblocks/_compiled/{key}/{module}{compiled.ext_suffix()}" in names
    # installed (unpacked on the path), it loads them: the user without a compiler gets them
    probe = ("import json, ctrlblocks, ctrlblocks.compiled as c; "
             "print(json.dumps({'file': ctrlblocks.__file__, **c.status()}))")  # fmt: skip
    got = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, timeout=300,
        cwd=tmp_path, check=True,
        env={**os.environ, "PYTHONPATH": str(tmp_path / "site"), "CTRLBLOCKS_COMPILED": "require"},
    )  # fmt: skip
    status = json.loads(got.stdout.strip().splitlines()[-1])
    assert status["file"].startswith(str(tmp_path / "site"))
    assert status["active"] and status["folder"].startswith(str(tmp_path / "site"))
    # and what the release CI runs on every binary wheel it builds (pyproject.toml's
    # [tool.cibuildwheel] test-command): in use, and bit-equal to the interpreted blocks
    checked = subprocess.run(
        [sys.executable, "-m", "ctrlblocks", "compile", "--check"], capture_output=True,
        text=True, timeout=900, cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(tmp_path / "site"), "CTRLBLOCKS_COMPILED": "auto"},
    )  # fmt: skip
    assert checked.returncode == 0, checked.stderr[-2000:]
    assert "every block bit-equal to the interpreted blocks over 54 runs" in checked.stdout
