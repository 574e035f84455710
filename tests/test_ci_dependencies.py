"""In CI every optional test dependency is installed: no test module skips for a missing one.

Test modules skip themselves when an optional package is missing
(``pytest.importorskip``), so that a user with a partial install can run the
rest.  In CI that convenience hides lost tests: when the web tests moved from
``httpx`` to ``httpx2``, ``tests/web/test_defences.py`` kept asking for
``httpx``, which the test extra no longer installed, and CI skipped its 45
tests of the faceplate's defences without failing.  Here every module the
suite imports with ``importorskip`` (found in the test files themselves) must
import when ``CI`` is set.
"""

from __future__ import annotations

import importlib
import os
import re
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parent


def _optional_modules() -> set[str]:
    found = set()
    for path in TESTS.rglob("*.py"):
        found |= set(re.findall(r"importorskip\(\s*[\"']([\w.]+)[\"']", path.read_text("utf-8")))
    return found


def test_the_scan_finds_the_optional_modules():
    assert {"fastapi", "httpx2", "playwright", "asyncua", "distributed"} <= _optional_modules()
    assert "httpx" not in _optional_modules()  # the old client: the test extra has httpx2


@pytest.mark.skipif(not os.environ.get("CI"), reason="a partial install may skip them (not CI)")
@pytest.mark.parametrize("module", sorted(_optional_modules()))
def test_in_ci_every_optional_test_dependency_imports(module):
    importlib.import_module(module)
