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


def test_tdf_is_the_codesys_derivative_filter_time() -> None:
    """``tdf`` (controltheplant 2024, irTdF) is the filter time: n = Td/tdf, also after a retune."""
    import numpy as np

    from ctrlblocks import PID

    a = PID(kp=2.0, ti=5.0, td=1.0, tdf=0.5, ts=0.1, u_min=-1e9, u_max=1e9)
    b = PID(kp=2.0, ti=5.0, td=1.0, n=2.0, ts=0.1, u_min=-1e9, u_max=1e9)
    pv = np.sin(0.37 * np.arange(200))
    assert [a(1.0, y) for y in pv] == [b(1.0, y) for y in pv]
    a.configure(td=1.5)
    assert a.config.n == 3.0  # Tf stays 0.5 s
    assert PID(kp=1.0, tdf=0.5).config.n == 10.0  # no derivative: n as given


def test_the_codesys_defaults_table_names_every_default_the_seed_states() -> None:
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "docs/blocks/pid.md").read_text(encoding="utf-8")
    section = text.split("## The CODESYS defaults")[1].split("\\n## ")[0]
    for name in ("irKP", "irTdF", "ixInverted", "irDeadband", "itSetpointFilterTime",
                 "irSetpointRampRate", "irDeviationTolerance", "irStabilizationTime",
                 "irOutLimitL", "irBackCalcFactor", "irResetValue", "iwAntiWindupMethod",
                 "iwBumplessTransferMethod", "rangeHi"):  # fmt: skip
        assert f"`{name}" in section, name
