"""mypy is clean on the blocks (the configuration is ``[tool.mypy]`` in pyproject.toml)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_mypy_reports_no_error_on_the_blocks(tmp_path: Path):
    pytest.importorskip("mypy", reason="mypy is in the test extra: pip install -e '.[test]'")
    # the checked files come from pyproject.toml; a fresh cache: no stale result
    out = subprocess.run(
        [sys.executable, "-m", "mypy", "--cache-dir", str(tmp_path / "cache")],
        cwd=ROOT, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert out.returncode == 0, out.stdout + out.stderr
    assert "Success: no issues found" in out.stdout
