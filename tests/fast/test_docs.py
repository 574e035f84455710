"""The examples in the fast modules' docstrings run and print what they say."""

from __future__ import annotations

import doctest

import pytest

from ctrlblocks.fast import bank, loops


@pytest.mark.parametrize("mod", [loops, bank], ids=lambda m: m.__name__)
def test_module_examples_run(mod):
    result = doctest.testmod(mod, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0
