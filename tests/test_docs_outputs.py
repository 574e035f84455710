"""Numbers and sample outputs in the docs are what the code gives."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
from click.testing import CliRunner

from ctrlblocks.cli import main

ROOT = Path(__file__).resolve().parents[1]


def _console_commands(md: str) -> list[tuple[str, list[str]]]:
    """``(command, expected output lines)`` of every ``$ ctrlblocks ...`` in console blocks."""
    out = []
    for block in re.findall(r"```console\n(.*?)```", md, flags=re.S):
        current: tuple[str, list[str]] | None = None
        for line in block.splitlines():
            if line.startswith("$ "):
                current = (line[2:], [])
                out.append(current)
            elif current is not None and line.strip():
                current[1].append(line)
    return [c for c in out if c[0].startswith("ctrlblocks ")]


TUNING = _console_commands((ROOT / "docs" / "tuning.md").read_text(encoding="utf-8"))


@pytest.mark.parametrize(("command", "expected"), TUNING, ids=[c for c, _ in TUNING])
def test_docs_tuning_sample_output_is_what_the_cli_prints(
    command, expected, tmp_path, monkeypatch
) -> None:
    monkeypatch.chdir(ROOT)
    args = shlex.split(command)[1:]
    if "--plot" in args:
        args[args.index("--plot") + 1] = str(tmp_path / "fit.png")
    res = CliRunner().invoke(main, args)
    assert res.exit_code == 0, res.output
    got = res.output.replace(str(tmp_path / "fit.png"), "fit.png").splitlines()
    assert len(got) == len(expected), "\n".join(got)
    for g, e in zip(got, expected, strict=True):
        if e.endswith("..."):  # shortened in the docs
            assert g.startswith(e[:-3]), (g, e)
        else:
            assert g == e


def test_docs_tuning_has_the_tune_pid_sample() -> None:
    assert any(c.startswith("ctrlblocks tune pid") for c, _ in TUNING)


def test_performance_md_states_the_fig7_sample_count_of_the_scenario() -> None:
    from ctrlblocks.sim.report import load_shipped

    (sc,) = load_shipped(("nowak_fig7",))
    samples = sum(round(c.duration / sc.ts) for c in sc.cases) * len(sc.controllers)
    runs = len(sc.cases) * len(sc.controllers)
    assert (runs, samples) == (6, 12_000)
    text = (ROOT / "docs" / "performance.md").read_text(encoding="utf-8")
    assert f"Fig. 7 scenario ({runs} runs, {samples:,} samples)" in text
    assert "24,000" not in text


def test_performance_md_says_what_the_bank_is_compared_with() -> None:
    text = (ROOT / "docs" / "performance.md").read_text(encoding="utf-8")
    assert "C -O2 one loop at a time (latency-bound)" in text
    assert "*one loop at a time*" in text and "was not\nwritten or measured" in text


def test_bank_docstring_states_the_state_bytes_it_has() -> None:
    import numpy as np

    import ctrlblocks.fast.bank as bank_mod
    from ctrlblocks.fast import PIDBank

    n = 3
    bank = PIDBank.from_arrays(
        kp=np.full(n, 2.0), ti=np.full(n, 8.0), td=np.zeros(n), ts=0.1,
        plant_k=np.ones(n), plant_t=np.ones((n, 3)),
    )  # fmt: skip
    doc = " ".join(bank_mod.__doc__.split())
    assert f": {bank.state_bytes} bytes (10 floats" in doc
    assert f"{bank.param_bytes} bytes" in doc
    assert bank.state_bytes == 80
