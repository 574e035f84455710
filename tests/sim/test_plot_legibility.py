"""Every shipped scenario's figure as a reader sees it: no legend on the data, no raw TeX.

Before: the split-range legend covered the MV traces, and the dead-band
scenario drew the held MV inside the other controller's noisy one (now one
lower axes per controller, ``[plot] lower_per_controller``).
"""

from __future__ import annotations

import matplotlib
import pytest

from ctrlblocks.sim.plot import case_figure
from ctrlblocks.sim.report import load_shipped, shipped_scenarios
from ctrlblocks.sim.runner import run_scenario

from ..figure_checks import figure_problems

matplotlib.use("Agg", force=False)


# the scenarios whose figures had a legend on the data (the default run); all of them
# behind -m slow
FOUND = ("split_range_heat_cool", "pulse_width_heater", "ratio_blend", "nowak_fig1")
SCENARIOS = [
    pytest.param(p.stem, marks=() if p.stem in FOUND else pytest.mark.slow)
    for p in shipped_scenarios()
]


@pytest.mark.parametrize("name", SCENARIOS)
def test_no_legend_covers_data_and_no_label_shows_raw_tex(name):
    import matplotlib.pyplot as plt

    (sc,) = load_shipped([name])
    result = run_scenario(sc, quick=True)
    for case in sc.cases:
        fig = case_figure(result, case.name)
        try:
            assert figure_problems(fig) == [], case.name
        finally:
            plt.close(fig)


def test_the_dead_band_scenario_shows_each_mv_in_its_own_axes():
    import matplotlib.pyplot as plt

    (sc,) = load_shipped(["codesys_deadband"])
    fig = case_figure(run_scenario(sc, quick=True), "main")
    try:
        assert len(fig.axes) == 3
        legends = [[t.get_text() for t in ax.get_legend().get_texts()] for ax in fig.axes[1:]]
        assert legends == [["no dead band"], ["adaptive dead band 1 %"]]
    finally:
        plt.close(fig)


def test_the_checker_finds_a_legend_on_the_data_and_raw_tex():
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1], label="L(e^{jωh})")
    ax.plot([0, 1], [1, 0.9], label="$L(e^{j\\omega h})$")
    ax.legend(loc="upper right")
    try:
        problems = figure_problems(fig)
    finally:
        plt.close(fig)
    assert "raw TeX in a text: 'L(e^{jωh})'" in problems
    assert any("covers" in p for p in problems)
    assert not any("raw TeX" in p and "omega" in p for p in problems)
