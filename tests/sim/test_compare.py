"""``ctrlblocks compare``: identify, tune with margins, simulate, judge; numbers as by hand."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from ctrlblocks.cli import main
from ctrlblocks.plants.linear import FOPDT as PlantFOPDT
from ctrlblocks.sim.compare import compare, scenario_toml
from ctrlblocks.sim.runner import run_scenario
from ctrlblocks.sim.scenario import load_scenario, parse_scenario
from ctrlblocks.tuning import adrc_tuning, amigo, fit_fopdt
from ctrlblocks.tuning.bump import block_margins


def _bump(k=1.2, t=12.0, L=3.0, noise=0.002, ts=0.5, seed=3):
    plant = PlantFOPDT(k, t, L, ts)
    plant.reset(1.0)
    tt = np.arange(0.0, 120.0, ts)
    u = np.where(tt >= 10.0, 1.5, 1.0)
    y = []
    for uk in u:
        y.append(plant.y)
        plant.step(float(uk))
    rng = np.random.default_rng(seed)
    return tt, u, np.array(y) + rng.normal(0.0, noise, len(tt))


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    out = tmp_path_factory.mktemp("cmp")
    t, u, y = _bump()
    return out, (t, u, y), compare(t, u, y, out, corners=False)


def test_compare_identifies_tunes_and_margins_as_by_hand(result):
    _out, (t, u, y), s = result
    fo = fit_fopdt(t, u, y)
    assert s["model_used"] == "fopdt" and "FOPDT" in s["why"]
    assert s["fopdt"]["gain"] == pytest.approx(fo.gain, rel=1e-9)
    ctrls = {c["name"]: c for c in s["controllers"]}
    am = amigo(fo.gain, fo.time_constant, fo.dead_time)
    assert ctrls["PID AMIGO"]["params"]["kp"] == pytest.approx(am.kp, rel=1e-9)
    a2 = adrc_tuning(fo.gain, fo.time_constant, fo.dead_time, 2, ts=s["ts"], model=fo)
    assert ctrls["ADRC n=2"]["params"]["omega_c"] == pytest.approx(a2.omega_c, rel=1e-9)
    mg = block_margins(fo, "ADRC", ctrls["ADRC n=2"]["params"], s["ts"])
    assert ctrls["ADRC n=2"]["margins"]["ms"] == pytest.approx(mg["ms"], rel=1e-9)
    for c in ctrls.values():
        m = c["margins"]
        assert c["eligible"] == bool(m and m["stable"] and m["ms"] <= 2.0)


def test_compare_metrics_equal_running_the_written_scenario_by_hand(result):
    out, _, s = result
    sc = load_scenario(out / "compare.toml")
    r = run_scenario(sc)
    for name, m in s["metrics"].items():
        assert m["model"]["iae_tracking"] == pytest.approx(
            r.metric(name, "main", "iae", 1), rel=1e-9
        )
        assert m["model"]["iae_load"] == pytest.approx(r.metric(name, "main", "iae", 2), rel=1e-9)
    assert (out / "compare.md").read_text().count("|") > 40
    assert (out / "fit.png").stat().st_size > 10000 and (out / "main.png").stat().st_size > 10000


def test_every_verdict_sentence_quotes_its_metric_from_the_json(result):
    out, _, _s = result
    data = json.loads((out / "compare.json").read_text())
    assert data["verdict"]
    for st in data["verdict"]:
        if st["metric"] == "ms":
            continue
        v = data["metrics"][st["controller"]]["model"][st["metric"]]
        assert f"{v:.4g}" in st["text"], st


def test_a_process_where_pid_wins_says_so(result):
    _, _, s = result
    texts = [x["text"] for x in s["verdict"]]
    assert any(x.startswith("PID wins on iae_load") for x in texts), texts
    ms = s["metrics"]
    best_pid = min(v["model"]["iae_load"] for n, v in ms.items() if n.startswith("PI"))
    best_adrc = min(v["model"]["iae_load"] for n, v in ms.items() if n.startswith("ADRC"))
    assert best_pid < best_adrc


def test_corner_scenarios_change_the_plant_by_the_factors():
    fo = fit_fopdt(*_bump())
    ctrl = [{"name": "P", "type": "PID", "params": {"kp": 1.0}}]
    text = scenario_toml(fo, ctrl, ts=0.5, step=1.0, load=-0.25, noise=0.0, u_min=-1.0,
                         u_max=1.0, duration=100.0, corner=(1.2, 0.7, 1.3))  # fmt: skip
    p = parse_scenario(text).plant.params
    assert p["k"] == pytest.approx(1.2 * fo.gain)
    assert p["t"] == pytest.approx(0.7 * fo.time_constant)
    assert p["dead_time"] == pytest.approx(1.3 * fo.dead_time)


def test_cli_compare_on_the_shipped_example_without_corners(tmp_path):
    r = CliRunner().invoke(main, ["compare", "docs/examples/bump_k2.csv", "--time", "time_s",
                                  "--u", "p_supply_bar", "--y", "p3_bar", "--out",
                                  str(tmp_path), "--no-corners", "--json"])  # fmt: skip
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    assert d["model_used"] in ("fopdt", "sopdt") and d["verdict"]
    assert all(math.isfinite(c["margins"]["ms"]) for c in d["controllers"] if c["eligible"])
    bad = CliRunner().invoke(main, ["compare", str(tmp_path / "nope.csv"), "--time", "t",
                                    "--u", "u", "--y", "y"])  # fmt: skip
    assert bad.exit_code == 1 and "Traceback" not in bad.output


def test_cli_compare_reads_the_csv_formats_identify_reads(tmp_path):
    t, u, y = _bump()
    rows = [f"{a:.1f};{b:.3f};{c:.6f}".replace(".", ",") for a, b, c in zip(t, u, y, strict=True)]
    csv = tmp_path / "bump.csv"
    csv.write_text("t;mv;pv\n" + "\n".join(rows) + "\n", encoding="cp1252")
    args = ["compare", str(csv), "--time", "t", "--u", "mv", "--y", "pv", "--delimiter", ";",
            "--decimal", ",", "--encoding", "cp1252", "--out", str(tmp_path / "o"),
            "--no-corners", "--json"]  # fmt: skip
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    assert d["fopdt"]["gain"] == pytest.approx(1.2, rel=0.05)


def test_compare_on_a_three_tank_bump_test_with_corners_reports_the_spread(tmp_path):
    """The paper's kind of process: a bump test on the three-tank model, with noise."""
    from ctrlblocks.plants import ThreeTank
    from ctrlblocks.tuning import bump_test

    plant = ThreeTank(ts=0.1)
    t, u, y = bump_test(plant, 0.5, u0=2.2, duration=60.0)
    y = y + np.random.default_rng(5).normal(0.0, 0.002, len(y))
    s = compare(t[::5], u[::5], y[::5], tmp_path, ts=0.1)
    assert s["fopdt"]["gain"] == pytest.approx(fit_fopdt(t[::5], u[::5], y[::5]).gain, rel=1e-9)
    for m in s["metrics"].values():
        lo, hi = m["corners"]["iae_load"]
        assert lo <= m["model"]["iae_load"] * 1.5 and hi >= lo
    assert "Spread over the uncertainty corners" in (tmp_path / "compare.md").read_text()
