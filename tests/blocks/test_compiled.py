"""The optional compiled build of PID and ADRC (ctrlblocks.compiled, ``ctrlblocks compile``).

Three kinds of test:

* the ``.pxd`` files in step with the ``.py`` files they declare (no compiler);
* the loader: no build, a broken build, ``off``/``auto``/``require`` -- with fake
  builds, in fresh processes (no compiler);
* the build itself (Cython and a C compiler; skipped with the reason without
  them): it is made once for the module in a temporary folder, must compute
  every action of the fuzz campaign bit for bit as the interpreted blocks do,
  and must pass the block tests.  With ``CTRLBLOCKS_COMPILED=require`` the
  whole suite runs against the build (README, "Compiled blocks").
"""

from __future__ import annotations

import ast
import fcntl
import importlib.util
import inspect
import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

import ctrlblocks
from ctrlblocks import compiled
from ctrlblocks.blocks import adrc, base, pid, signals

BLOCKS_DIR = Path(compiled.__file__).parent / "blocks"
ROOT = Path(__file__).resolve().parents[2]


def _pxd_attributes(name: str) -> dict[str, str]:
    """``cdef public <type> a, b`` declarations of ``<name>.pxd``: {attribute: type}."""
    found = {}
    for line in (BLOCKS_DIR / f"{name}.pxd").read_text().splitlines():
        m = re.match(r"\s+cdef public (\w+) (.+)$", line)
        if m:
            found.update({a.strip(): m.group(1) for a in m.group(2).split(",")})
    return found


def _pxd_functions(name: str) -> dict[str, list[str]]:
    """``cpdef`` functions of ``<name>.pxd`` at module level: {name: parameter names}.

    A parameter may be a C tuple (``(double, double) prm``): its parentheses are skipped.
    """
    text = (BLOCKS_DIR / f"{name}.pxd").read_text()
    found = {}
    for m in re.finditer(r"^cpdef (?:\([^)]*\)|\w+)\s*(\w+)\(", text, re.M):
        depth, start, j = 1, m.end(), m.end()
        while depth:
            depth += {"(": 1, ")": -1}.get(text[j], 0)
            j += 1
        inner = re.sub(r"\([^()]*\)", "tuple", text[start : j - 1].replace("\n", " "))
        params = [p.split()[-1].split("=")[0] for p in inner.split(",")]
        found[m.group(1)] = [p for p in params if p and p != "self"]
    return found


def _class_annotations(module, cls: str) -> set[str]:
    """The bare class-level annotations (``name: type``) in the source of ``cls``."""
    tree = ast.parse(_source(module.__name__.rpartition(".")[2]).read_text())
    node = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == cls)
    return {
        s.target.id
        for s in node.body
        if isinstance(s, ast.AnnAssign) and s.value is None and isinstance(s.target, ast.Name)
    }


def _source(name: str) -> Path:
    return BLOCKS_DIR / f"{name}.py"


# ---------------------------------------------------------------------------
# the .pxd files in step with the .py files
# ---------------------------------------------------------------------------


@pytest.mark.parametrize(("module", "cls"), [(pid, "PID"), (adrc, "ADRC")])
def test_declared_attributes_are_the_pxd_declarations(module, cls) -> None:
    klass = getattr(compiled.interpreted(module.__name__.rpartition(".")[2]), cls)
    declared = set(klass._declared.split())
    in_pxd = set(_pxd_attributes(module.__name__.rpartition(".")[2])) | set(_pxd_attributes("base"))
    # configure's rollback saves exactly what the C struct holds
    assert declared == in_pxd
    # Cython reads a bare class annotation as a C attribute: each must be declared
    assert _class_annotations(module, cls) <= in_pxd
    assert _class_annotations(base, "Block") <= set(_pxd_attributes("base"))


@pytest.mark.parametrize(("module", "cls"), [(pid, "PID"), (adrc, "ADRC")])
def test_every_declared_attribute_is_set_by_a_block(module, cls) -> None:
    # a declaration nobody assigns would read 0.0 / None in the build only
    source = _source(module.__name__.rpartition(".")[2]).read_text() + _source("base").read_text()
    for name in _pxd_attributes(module.__name__.rpartition(".")[2]):
        assert re.search(rf"self\.{re.escape(name)}\b[^=\n]*=(?!=)", source), name


def test_double_attributes_hold_floats_in_the_interpreted_blocks() -> None:
    # what the build keeps as C doubles must be numbers in the reference too
    kinds = {**_pxd_attributes("pid"), **_pxd_attributes("adrc")}
    blocks = [
        ctrlblocks.PID(kp=2.0, ti=5.0, td=1.0, ts=0.1, sp_filter=1.0, out_rate=5.0),
        ctrlblocks.ADRC(order=2, b0=0.05, omega_c=0.35, omega_o=1.75, ts=0.1, u_min=0.0),
    ]
    for block in blocks:
        block(1.0, 0.5)
        block(1.0, float("nan"))
        for name, kind in kinds.items():
            if kind == "double" and hasattr(block, name) and name in block._declared.split():
                assert isinstance(getattr(block, name), float | int), (type(block), name)


@pytest.mark.parametrize("name", ["pid", "adrc", "signals"])
def test_pxd_functions_are_the_modules_functions(name: str) -> None:
    module = compiled.interpreted(name)
    for fn, params in _pxd_functions(name).items():
        assert fn in vars(module), fn
        expected = list(inspect.signature(getattr(module, fn)).parameters)
        assert params == expected, fn


def test_the_source_key_follows_every_compiled_file(tmp_path: Path) -> None:
    copy = tmp_path / "blocks"
    copy.mkdir()
    for name in compiled.MODULES:
        for ending in (".py", ".pxd"):
            shutil.copy(BLOCKS_DIR / f"{name}{ending}", copy)
    key = compiled.source_key(copy)
    assert key == compiled.source_key()
    for name in compiled.MODULES:
        for ending in (".py", ".pxd"):
            f = copy / f"{name}{ending}"
            old = f.read_bytes()
            f.write_bytes(old + b"\n")
            assert compiled.source_key(copy) != key, f.name
            f.write_bytes(old)


SUBCLASSED = {
    "PID": dict(kp=2.0, ti=5.0, ts=0.1, u_max=10.0),
    "ADRC": dict(order=1, b0=1.0, omega_c=1.0, omega_o=4.0, ts=0.1, u_min=0.0, u_max=10.0),
}


@pytest.mark.parametrize("name", sorted(SUBCLASSED))
def test_a_subclass_that_overrides_the_step_is_still_guarded(name: str) -> None:
    # PID and ADRC guard their own steps explicitly (_guarded_steps = ()); the override of
    # a user's subclass is wrapped as every other block's step is
    class Broken(getattr(ctrlblocks, name)):  # type: ignore[misc]
        def __call__(self, sp, pv, **kw):
            super().__call__(sp, pv, **kw)
            self.out = float("inf")  # a law gone wrong
            return self.out

    block = Broken(**SUBCLASSED[name])
    assert block(1.0, 0.5) == block.out
    assert 0.0 <= block.out <= 10.0
    assert block.error_id == ctrlblocks.ErrorCode.BAD_RESULT


# ---------------------------------------------------------------------------
# the loader, with fake builds
# ---------------------------------------------------------------------------

PROBE = """
import json, warnings
warnings.simplefilter("always")
with warnings.catch_warnings(record=True) as caught:
    import ctrlblocks
    from ctrlblocks import compiled
    from ctrlblocks.blocks import pid
    out = ctrlblocks.PID(kp=2.0, ti=5.0, ts=0.1)(1.0, 0.5)
print(json.dumps({"active": compiled.active(), "reason": compiled.status()["reason"],
                  "file": pid.__file__, "out": out,
                  "warnings": [str(w.message) for w in caught]}))
"""


def _probe(root: Path, how: str) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, CTRLBLOCKS_COMPILED=how, CTRLBLOCKS_COMPILED_DIR=str(root))
    return subprocess.run(
        [sys.executable, "-c", PROBE], capture_output=True, text=True, env=env, timeout=120
    )


def test_without_a_build_the_blocks_run_interpreted_and_require_refuses(tmp_path: Path) -> None:
    for how in ("auto", "off"):
        got = json.loads(_probe(tmp_path, how).stdout)
        assert not got["active"] and got["file"].endswith("pid.py") and not got["warnings"]
        assert got["out"] == pytest.approx(ctrlblocks.PID(kp=2.0, ti=5.0, ts=0.1)(1.0, 0.5))
    assert "no build for this source" in json.loads(_probe(tmp_path, "auto").stdout)["reason"]
    refused = _probe(tmp_path, "require")
    assert refused.returncode != 0
    assert "ImportError: CTRLBLOCKS_COMPILED=require: no build for this source" in refused.stderr
    assert "ctrlblocks compile builds one" in refused.stderr


def test_a_broken_build_is_left_with_a_warning_and_nothing_half_loaded(tmp_path: Path) -> None:
    folder = tmp_path / compiled.source_key()
    folder.mkdir()
    for name in compiled.MODULES:  # files with the right names that are no extension modules
        (folder / f"{name}{compiled.ext_suffix()}").write_bytes(b"\x7fELF not really")
    got = json.loads(_probe(tmp_path, "auto").stdout)
    assert not got["active"] and got["file"].endswith("pid.py")
    assert got["out"] == pytest.approx(ctrlblocks.PID(kp=2.0, ti=5.0, ts=0.1)(1.0, 0.5))
    assert len(got["warnings"]) == 1 and "failed to load" in got["warnings"][0]
    assert "the interpreted blocks are used" in got["warnings"][0]
    refused = _probe(tmp_path, "require")
    assert refused.returncode != 0 and "failed to load" in refused.stderr


INSTALLED = """
import json, ctrlblocks, ctrlblocks.compiled as c
print(json.dumps(c.status()))
"""


def test_auto_takes_the_install_time_build_from_the_package_when_pip_made_one() -> None:
    env = {k: v for k, v in os.environ.items() if k != "CTRLBLOCKS_COMPILED_DIR"}
    env["CTRLBLOCKS_COMPILED"] = "auto"
    got = subprocess.run(
        [sys.executable, "-c", INSTALLED], capture_output=True, text=True, env=env, timeout=120
    )
    assert got.returncode == 0, got.stderr
    status = json.loads(got.stdout)
    packaged = compiled.packaged_folder()
    if (packaged / "build.json").is_file():  # this environment's pip install compiled them
        assert status["active"] and status["folder"] == str(packaged)
        manifest = json.loads((packaged / "build.json").read_text())
        assert manifest["key"] == compiled.source_key() == status["key"]
    else:  # no compiler at install (or an edited source): both places are named
        assert not status["active"]
        assert str(packaged) in status["reason"]
        assert str(compiled.build_folder()) in status["reason"]


def test_an_install_time_build_without_a_compiler_raises_a_build_error(tmp_path: Path) -> None:
    if importlib.util.find_spec("Cython") is None:
        pytest.skip("Cython is not installed (pip install 'ctrlblocks[compiled]')")
    old = os.environ.get("CC")
    os.environ["CC"] = "false"  # a compiler that always fails: what setup.py turns into a warning
    try:
        with pytest.raises(compiled.BuildError, match="the compiler failed"):
            compiled.build_packaged(tmp_path / "_compiled", say=lambda _msg: None)
    finally:
        if old is None:
            del os.environ["CC"]
        else:
            os.environ["CC"] = old
    assert not any((tmp_path / "_compiled").glob("*/*.so"))  # nothing half-made is left


def test_an_unknown_mode_is_taken_as_auto_with_a_warning(tmp_path: Path) -> None:
    got = json.loads(_probe(tmp_path, "sometimes").stdout)
    assert not got["active"]
    assert any("none of auto, off, require" in w for w in got["warnings"])


def test_the_cli_says_whether_a_build_is_in_use(tmp_path: Path) -> None:
    env = dict(os.environ, CTRLBLOCKS_COMPILED="auto", CTRLBLOCKS_COMPILED_DIR=str(tmp_path))
    cli = [sys.executable, "-c", "from ctrlblocks.cli import main; main()"]
    out = subprocess.run([*cli, "compile", "--status"], capture_output=True, text=True, env=env)
    assert out.returncode == 0, out.stderr
    assert "compiled blocks: not in use: no build for this source" in out.stdout
    (tmp_path / "old-key").mkdir()
    out = subprocess.run([*cli, "compile", "--remove"], capture_output=True, text=True, env=env)
    assert out.returncode == 0 and "removed 1 build(s)" in out.stdout
    assert not (tmp_path / "old-key").exists()


def test_a_build_folder_that_cannot_be_made_is_an_error_line(tmp_path: Path) -> None:
    if importlib.util.find_spec("Cython") is None:
        pytest.skip("Cython is not installed (pip install 'ctrlblocks[compiled]')")
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    env = dict(os.environ, CTRLBLOCKS_COMPILED="auto", CTRLBLOCKS_COMPILED_DIR=str(blocker / "b"))
    cli = [sys.executable, "-c", "from ctrlblocks.cli import main; main()"]
    out = subprocess.run([*cli, "compile"], capture_output=True, text=True, env=env, timeout=120)
    assert out.returncode == 1 and "Traceback" not in out.stderr
    assert f"Error: cannot create {blocker / 'b'}" in out.stderr


def test_build_without_cython_says_what_to_install(monkeypatch) -> None:
    real = __import__

    def no_cython(name, *args, **kwargs):
        if name == "Cython":
            raise ImportError("No module named 'Cython'", name="Cython")
        return real(name, *args, **kwargs)

    monkeypatch.setattr("builtins.__import__", no_cython)
    with pytest.raises(compiled.BuildError, match=r"pip install 'ctrlblocks\[compiled\]'"):
        compiled.build(say=lambda _msg: None)


def test_interpreted_is_the_module_itself_without_the_build() -> None:
    if compiled.active():
        pytest.skip("the compiled build is loaded (CTRLBLOCKS_COMPILED=require)")
    for name in ("pid", "adrc", "signals", "leadlag"):
        assert compiled.interpreted(name) is sys.modules[f"ctrlblocks.blocks.{name}"]
    assert inspect.signature(ctrlblocks.PID.__call__) == compiled.signature(ctrlblocks.PID)


# ---------------------------------------------------------------------------
# the build itself
# ---------------------------------------------------------------------------


def _compiler_missing() -> str:
    if importlib.util.find_spec("Cython") is None:
        return "Cython is not installed (pip install 'ctrlblocks[compiled]')"
    cc = os.environ.get("CC", "cc").split()[0]
    if shutil.which(cc) is None:
        return f"no C compiler ({cc}) on this machine"
    if not (Path(sysconfig.get_paths()["include"]) / "Python.h").is_file():
        return "no Python headers (Python.h) for this Python"
    return ""


@pytest.fixture(scope="module")
def build_root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with the build of the current source (made here unless one is loaded)."""
    if compiled.active():
        return Path(compiled.status()["folder"]).parent
    if (compiled.packaged_folder() / "build.json").is_file():
        return compiled.packaged_folder().parent  # pip install built it (setup.py)
    why = _compiler_missing()
    if why:
        pytest.skip(why)
    # one build for the whole run: the xdist workers share the parent of their temp folders
    root = tmp_path_factory.getbasetemp().parent / "compiled-blocks"
    root.mkdir(exist_ok=True)
    key = compiled.source_key()
    with (root / ".lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # the other worker waits for the build
        if not (root / key / "build.json").is_file():
            env = dict(os.environ, CTRLBLOCKS_COMPILED_DIR=str(root))
            cli = [sys.executable, "-c", "from ctrlblocks.cli import main; main()"]
            done = subprocess.run(
                [*cli, "compile", "--jobs", "2"], capture_output=True, text=True, env=env,
                timeout=900,
            )  # fmt: skip
            assert done.returncode == 0, done.stderr[-3000:]
            assert "checking that it loads and computes as the interpreted" in done.stderr
    manifest = json.loads((root / key / "build.json").read_text())
    assert manifest["key"] == key
    assert manifest["modules"] == list(compiled.MODULES)
    return root


TRACES = """
import json, sys
from ctrlblocks import compiled
from ctrlblocks.testing import traces
out = traces(*(int(a) for a in sys.argv[1:4]))
print(json.dumps({"active": compiled.active(), **out}))
"""


def _traces(root: Path, how: str, *args: str) -> dict:
    env = dict(os.environ, CTRLBLOCKS_COMPILED=how, CTRLBLOCKS_COMPILED_DIR=str(root))
    done = subprocess.run(
        [sys.executable, "-c", TRACES, *args], capture_output=True, text=True, env=env, timeout=600
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout)


@pytest.mark.slow  # builds the extension, about a minute (pytest -m slow)
@pytest.mark.timeout(1500)
def test_the_build_computes_every_campaign_action_bit_for_bit(build_root: Path) -> None:
    # the fuzz campaign's seeded actions (NaN/inf/huge inputs, modes, limits, refused
    # and accepted reconfiguration, snapshot/restore, reset) on every block, with PID and
    # ADRC runs that start in the float32 cycle; out compared as repr: bit for bit
    args = ("600", "2", "2")
    ref, got = _traces(build_root, "off", *args), _traces(build_root, "require", *args)
    assert not ref["active"] and got["active"]
    assert got["float32"] == ref["float32"] > 1000
    assert ref["traces"].keys() == got["traces"].keys()
    for key, trace in ref["traces"].items():
        for i, (a, b) in enumerate(zip(trace, got["traces"][key], strict=True)):
            assert a == b, f"{key}: action {i}: interpreted {a}, compiled {b}"


@pytest.mark.slow  # builds the extension, about a minute (pytest -m slow)
@pytest.mark.timeout(1500)
def test_the_block_tests_pass_against_the_build(build_root: Path) -> None:
    if compiled.active():
        pytest.skip("this whole run is against the build (CTRLBLOCKS_COMPILED=require)")
    env = dict(os.environ, CTRLBLOCKS_COMPILED="require", CTRLBLOCKS_COMPILED_DIR=str(build_root))
    cmd = [sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", "-n", "0"]
    done = subprocess.run(
        [*cmd, "tests/blocks", "--deselect", "tests/blocks/test_compiled.py"],
        capture_output=True, text=True, env=env, cwd=ROOT, timeout=1400,
    )  # fmt: skip
    tail = done.stdout[-3000:]
    assert done.returncode == 0, tail
    assert re.search(r"\d+ passed", tail) and "failed" not in tail


def test_in_a_compiled_run_the_build_is_what_is_loaded() -> None:
    if os.environ.get("CTRLBLOCKS_COMPILED") != "require":
        pytest.skip("only in a run against the build (CTRLBLOCKS_COMPILED=require)")
    assert compiled.active()
    for module in (base, signals, pid, adrc):
        assert not module.__file__.endswith(".py"), module.__file__
    assert not inspect.isfunction(pid.pid_step)  # compiled: a Cython function
    for name in compiled.INTERPRETED:  # what numba and the float32 cycle use
        assert compiled.interpreted(name).__file__.endswith(f"{name}.py")
    assert inspect.isfunction(compiled.interpreted("pid").pid_step)
    from ctrlblocks.blocks import plc_cycle

    assert plc_cycle.pid_law is compiled.interpreted("pid").pid_law
    # the call's parameters, from the interpreted source
    assert "pv_ok" in compiled.signature(ctrlblocks.PID).parameters
    assert "u_real" in compiled.signature(ctrlblocks.ADRC).parameters
