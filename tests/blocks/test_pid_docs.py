"""The examples of the PID docs page and module docstrings run and print their numbers."""

from __future__ import annotations

import doctest
import importlib
from pathlib import Path

import pytest

import ctrlblocks

DOCS = Path(__file__).resolve().parents[2] / "docs" / "blocks" / "pid.md"


@pytest.mark.parametrize("module", ["pid", "pid_forms"])
def test_docstring_examples_run(module: str) -> None:
    mod = importlib.import_module(f"ctrlblocks.blocks.{module}")
    result = doctest.testmod(mod)
    assert result.attempted > 0 and result.failed == 0


def test_docs_page_examples_run() -> None:
    result = doctest.testfile(str(DOCS), module_relative=False, globs=dict(vars(ctrlblocks)))
    assert result.attempted >= 10 and result.failed == 0
