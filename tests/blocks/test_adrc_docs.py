"""The examples of docs/blocks/adrc.md and of the ADRC module run and print their numbers."""

from __future__ import annotations

import doctest
from pathlib import Path

import ctrlblocks
from ctrlblocks.blocks import adrc

DOCS = Path(__file__).resolve().parents[2] / "docs" / "blocks" / "adrc.md"


def test_module_docstring_examples_run() -> None:
    result = doctest.testmod(adrc)
    assert result.attempted > 0 and result.failed == 0


def test_docs_page_examples_run() -> None:
    result = doctest.testfile(str(DOCS), module_relative=False, globs=dict(vars(ctrlblocks)))
    assert result.attempted >= 15 and result.failed == 0
