"""The release CI that builds the binary wheels (.github/workflows/wheels.yml).

It cannot run here (it needs the other platforms' machines), so what can be
checked offline is: cibuildwheel, reading pyproject.toml's
``[tool.cibuildwheel]``, selects exactly the wheels the docs promise; every
wheel is checked after its build by ``ctrlblocks compile --check``, which
fails without the compiled blocks and on any difference from the interpreted
ones; a failed build fails instead of shipping a pure wheel; and the workflow
runs one native job per platform and publishes only from a tag.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import tomllib
import yaml
from click.testing import CliRunner

from ctrlblocks import compiled
from ctrlblocks.blocks.cli import compile_command
from ctrlblocks.testing.buildcheck import compare_traces

ROOT = Path(__file__).resolve().parents[1]
PYTHONS = ["cp310", "cp311", "cp312", "cp313", "cp314"]


def _config() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["cibuildwheel"]


def _workflow() -> dict:
    return yaml.safe_load((ROOT / ".github" / "workflows" / "wheels.yml").read_text())


@pytest.mark.parametrize(
    ("platform", "arch", "suffix"),
    [
        ("linux", "x86_64", "manylinux_x86_64"),
        ("linux", "aarch64", "manylinux_aarch64"),
        ("macos", "x86_64", "macosx_x86_64"),
        ("macos", "arm64", "macosx_arm64"),
        ("windows", "AMD64", "win_amd64"),
    ],
)
def test_cibuildwheel_selects_cpython_310_to_314_per_platform(platform, arch, suffix) -> None:
    exe = shutil.which("cibuildwheel", path=os.path.dirname(sys.executable))
    if exe is None:
        pytest.skip("cibuildwheel is not installed (pip install -e '.[test]')")
    env = {k: v for k, v in os.environ.items() if not k.startswith("CIBW_")}
    done = subprocess.run(
        [exe, "--print-build-identifiers", "--platform", platform, "--archs", arch, str(ROOT)],
        capture_output=True, text=True, env=env, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == [f"{py}-{suffix}" for py in PYTHONS]


def test_every_wheel_is_checked_and_a_failed_build_fails() -> None:
    config = _config()
    assert config["test-command"] == "python -m ctrlblocks compile --check"
    assert config["environment"] == {"CTRLBLOCKS_BUILD_COMPILED": "require"}
    setup = (ROOT / "setup.py").read_text()
    assert 'if how == "require":' in setup  # the install-time build's switch


def test_the_workflow_builds_natively_on_each_platform_and_publishes_only_from_a_tag() -> None:
    flow = _workflow()
    assert flow[True]["push"]["tags"] == ["v*"]  # YAML 1.1 reads the key "on" as True
    jobs = flow["jobs"]
    oses = jobs["wheels"]["strategy"]["matrix"]["os"]
    # one runner per (platform, arch): the wheels are tested where they are built
    assert {o.split("-")[0] for o in oses} == {"ubuntu", "macos", "windows"}
    assert any(o.endswith("-arm") for o in oses)  # Linux aarch64
    assert {"macos-13", "macos-14"} <= set(oses)  # x86_64 and arm64
    uses = [s.get("uses", "") for s in jobs["wheels"]["steps"]]
    assert any(u.startswith("pypa/cibuildwheel@v4.") for u in uses)
    publish = jobs["publish"]
    assert set(publish["needs"]) == {"wheels", "sdist"}
    assert publish["if"] == "startsWith(github.ref, 'refs/tags/v')"
    assert publish["permissions"] == {"id-token": "write"}  # trusted publishing, no secret


def test_check_without_a_build_is_one_error_line(tmp_path: Path, monkeypatch) -> None:
    if compiled.active():
        pytest.skip("this run uses the compiled blocks")
    result = CliRunner().invoke(compile_command, ["--check"])
    assert result.exit_code == 1
    assert result.output.startswith("Error: the compiled blocks are not in use: ")
    assert "Traceback" not in result.output


def test_compare_traces_names_the_first_difference() -> None:
    same = {"PID/0": [["1.0", 0], ["2.0", 0]], "ADRC/0": [["3.0", 0]]}
    compare_traces(same, {k: [list(x) for x in v] for k, v in same.items()})
    first = r"PID/0: action 1: .* \['2\.5', 0\], .* \['2\.0', 0\]"
    with pytest.raises(compiled.BuildError, match=first):
        compare_traces({**same, "PID/0": [["1.0", 0], ["2.5", 0]]}, same)
    with pytest.raises(compiled.BuildError, match="ADRC/0: 2 actions compiled, 1 interpreted"):
        compare_traces({**same, "ADRC/0": [["3.0", 0], ["4.0", 0]]}, same)
    with pytest.raises(compiled.BuildError, match="the runs differ"):
        compare_traces({"PID/0": same["PID/0"]}, same)
