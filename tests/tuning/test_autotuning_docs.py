"""The example of docs/autotuning.md runs as written."""

from __future__ import annotations

import doctest
from pathlib import Path

DOC = Path(__file__).resolve().parents[2] / "docs" / "autotuning.md"


def test_the_autotuning_example_runs() -> None:
    result = doctest.testfile(str(DOC), module_relative=False)
    assert result.attempted >= 5
    assert result.failed == 0
