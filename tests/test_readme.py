"""The README's Python examples run and print what the README says."""

from __future__ import annotations

import doctest
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_examples_run_as_shown() -> None:
    result = doctest.testfile(
        str(README),
        module_relative=False,
        optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE,
        verbose=False,
    )
    assert result.attempted > 10
    assert result.failed == 0


def test_readme_figure_exists() -> None:
    assert (README.parent / "docs/figures/reproduced/nowak_fig7_disturbance.png").is_file()


def test_readme_states_the_measured_reproduce_time_and_the_run_count() -> None:
    """The README says how long ``reproduce`` took where it was measured, not "a few seconds"."""
    import re

    from ctrlblocks.sim.report import load_shipped

    text = " ".join(README.read_text(encoding="utf-8").split())
    assert "a few seconds" not in text
    scenarios = load_shipped(())
    runs = sum(len(s.controllers) * len(s.cases) for s in scenarios)
    assert f"runs the {len(scenarios)} shipped scenarios ({runs} runs)" in text
    m = re.search(r"Measured on .*?: (\d+) s wall clock, of which (\d+) s inside the command", text)
    assert m is not None and "2 cores" in text
    wall, inside = int(m.group(1)), int(m.group(2))
    assert 0 < inside <= wall
