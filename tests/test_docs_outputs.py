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


def _line_pattern(expected: str) -> re.Pattern[str]:
    """An expected line as a pattern: ``...`` inside it stands for any text (shortened)."""
    return re.compile(".*".join(re.escape(part) for part in expected.split("...")) + r"\Z")


def _matches(got: list[str], expected: list[str]) -> bool:
    """``got`` equals ``expected`` where a line ``...`` stands for any number of lines."""
    if not expected:
        return not got
    if expected[0].strip() == "...":
        return any(_matches(got[i:], expected[1:]) for i in range(len(got) + 1))
    return (
        bool(got)
        and _line_pattern(expected[0]).match(got[0]) is not None
        and _matches(got[1:], expected[1:])
    )


def test_the_sample_matcher_understands_shortened_samples() -> None:
    assert _matches(["a", "b", "c"], ["a", "  ...", "c"])
    assert _matches(["Error: x 1; y 2 (e)"], ["Error: x ...; ... (e)"])
    assert not _matches(["a", "b"], ["a"])
    assert not _matches(["a", "b"], ["a", "c"])


@pytest.mark.parametrize(("command", "expected"), TUNING, ids=[c for c, _ in TUNING])
def test_docs_tuning_sample_output_is_what_the_cli_prints(
    command, expected, tmp_path, monkeypatch
) -> None:
    monkeypatch.chdir(ROOT)
    args = shlex.split(command)[1:]
    outputs = {}
    for opt in ("--plot", "--out"):  # write into tmp_path, not into the repository
        if opt in args:
            given = args[args.index(opt) + 1]
            args[args.index(opt) + 1] = outputs[given] = str(tmp_path / given)
    res = CliRunner().invoke(main, args)
    assert res.exit_code == (1 if expected[0].startswith("Error:") else 0), res.output
    text = res.output
    for given, real in outputs.items():
        text = text.replace(real, given)
    got = text.splitlines()
    assert _matches(got, expected), "\n".join(got)


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
