"""The tuning plots as a reader sees them: no raw TeX, no legend on the data, a title that
says what the command printed.

Before: the Nyquist legend printed ``L(e^{jωh})`` as typed, and ``tune pid --plot`` titled
``kp = -1.61`` for a reverse-acting process where the command printed ``kp 1.61, reverse
True``.
"""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from ctrlblocks.cli import main

from ..figure_checks import watch_savefig

CSV = ["docs/examples/bump_k2.csv", "--time", "time_s", "--u", "p_supply_bar", "--y", "p3_bar"]
MODELS = [
    ("-2", "30", "5"),  # reverse acting (the default run)
    pytest.param("0.731", "8.42", "2.88", marks=pytest.mark.slow),
    pytest.param("1.5", "3", "12", marks=pytest.mark.slow),  # dead-time dominant
]


@pytest.mark.parametrize("method", ["lsq", "lsq-sopdt", "integrating", "two-point"])
def test_identify_plots_are_legible(tmp_path, monkeypatch, method):
    found = watch_savefig(monkeypatch)
    r = CliRunner().invoke(main, ["identify", *CSV, "--method", method, "--plot",
                                  str(tmp_path / "fit.png")])  # fmt: skip
    assert r.exit_code == 0, r.output
    assert found == []


@pytest.mark.parametrize(("k", "t", "dead"), MODELS)
def test_tune_plots_are_legible(tmp_path, monkeypatch, k, t, dead):
    found = watch_savefig(monkeypatch)
    model = ["--gain", k, "--time-constant", t, "--dead-time", dead]
    runs = [["pid", "--rule", "simc"], ["pid", "--rule", "amigo"]]
    if k != "-2":  # the slow models also draw an ADRC tuning (a search of about 10 s)
        runs.append(["adrc", "--order", "2" if float(dead) < float(t) else "1"])
    for args in runs:
        r = CliRunner().invoke(main, ["tune", *args, *model, "--plot", str(tmp_path / "l.png")])
        assert r.exit_code == 0, r.output
    assert found == []


def test_the_pid_plot_title_gives_kp_as_the_command_prints_it(tmp_path, monkeypatch):
    import matplotlib.figure

    titles = []
    real = matplotlib.figure.Figure.savefig

    def spy(self, *a, **kw):
        titles.append(self.get_suptitle())
        return real(self, *a, **kw)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", spy)
    args = ["tune", "pid", "--rule", "simc", "--gain", "-2", "--time-constant", "30",
            "--dead-time", "5", "--json", "--plot", str(tmp_path / "p.png")]  # fmt: skip
    r = CliRunner().invoke(main, args)
    out = json.loads(r.stdout)
    assert out["reverse"] is True and out["kp"] > 0
    assert f"kp = {out['kp']:.4g}, reverse" in titles[0]
    assert f"kp = -{out['kp']:.4g}" not in titles[0]
