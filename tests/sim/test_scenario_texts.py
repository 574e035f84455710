"""The numbers the shipped scenarios' texts state: quoted from the run, or checked here.

A number a run produces is written in a scenario's description, notes or claim
texts as a quote the report fills from the run (``{iae:tracking:PID_FT}``,
:mod:`ctrlblocks.sim.quotes`) -- ``nowak_fig7``'s notes had typed PID_FT's
tracking IAE as 4.8 and its overshoot as 14 % where the run gave 4.445 and
7.3 %.  Every other number in those texts is an input of the scenario (a value
of its tables), a reference to the source (a figure, a section, a year), or
listed in ``TYPED`` with the reason it may be typed and, for numbers computed
outside the run, the test below that recomputes them.  A new typed number
fails ``test_scenario_texts_type_no_number_a_run_produces`` until it is quoted
or listed.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest
import tomllib

from ctrlblocks.sim import parse_scenario, run_scenario
from ctrlblocks.sim.report import load_shipped, shipped_scenarios
from ctrlblocks.sim.scenario import ScenarioError

ROOT = Path(__file__).resolve().parents[2]
HAND = "hand-evaluated from the scenario's inputs; a claim checks the run against it"
TYPED: dict[str, dict[str, str]] = {
    "astrom_fig31_33": {"10": "Åström 1987, Fig. 3.1: where the figure's error changes sign"},
    "astrom_fig52": {"0.51832": HAND, "1.02400": HAND},
    "codesys_bumpless": {"33.3": "the MV at PV 50 % (50 / 1.5): input arithmetic",
                         "10": "the deviation 60 - 50 %: input arithmetic"},
    "gain_schedule_three_tank": {
        **dict.fromkeys(("0.65", "14.7", "4.6", "2.8", "0.74", "5.2", "1.6", "1.0"),
                        "the linearisations: test_gain_schedule_linearisations_and_tunings"),
        **dict.fromkeys(("1.7", "2.33", "3.96", "0.06"), HAND),
    },
    "nowak_fig1": {"3.5": "Nowak et al. 2018, (12): tau_wait = 3.5/omega_o"},
    "nowak_fig6": {"0.73": "Nowak et al. 2018, (10b): the gain of the process"},
    "nowak_smith": {"1e-12": "a test's tolerance", "20": "the model's gain error 1.2: input"},
    "nowak_table2_b0": {"30": "the claim's criterion below = 0.3, in percent",
                        "3": "0.3 / 0.099: input arithmetic"},
    "pulse_width_heater": {
        "2.08": "the ripple formula: test_the_pulse_width_ripples_of_the_notes",
        "0.42": "the ripple formula: test_the_pulse_width_ripples_of_the_notes",
        "30": "T/30 = 4 s: input arithmetic", "6": "T/6 = 20 s: input arithmetic",
        "50": "full power 0.5 K/% x 100 %: input arithmetic",
        "0.4": "duty 20 K / 50 K: input arithmetic",
    },
    "tuned_three_tank": {"1.6": "the safe default's Ms target (ctrlblocks.tuning.adrc)"},
    "two_point_thermostat": dict.fromkeys(
        ("41.44", "37.10", "42.39", "36.15", "4.3", "6.2"),
        "the limit cycle's extremes: test_the_two_point_extremes_of_the_notes",
    ),
}  # fmt: skip
NUMBER = re.compile(r"(?<![\w.])\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")
SOURCE_REF = re.compile(
    r"(Figs?\.|[Ss]ections?|Tables?|Appendix)\s*[\dA-Z.]+(?:\s*(?:and|-)\s*[\d.]+)?"
    r"|\((?:1[0-2]|[1-9])[ab]?\)|\b(?:19|20)\d\d\b"
)


def _inputs(x, out: set[float]) -> set[float]:
    if isinstance(x, dict):
        for v in x.values():
            _inputs(v, out)
    elif isinstance(x, list):
        for v in x:
            _inputs(v, out)
    elif isinstance(x, (int, float)) and not isinstance(x, bool):
        out.add(abs(float(x)))
    return out


def typed_numbers(path: Path) -> set[str]:
    """The numbers of a scenario's texts that are no input, no source reference, no quote."""
    doc = tomllib.loads(path.read_text(encoding="utf-8"))
    inputs = _inputs(doc, set())
    texts = [doc["scenario"].get("description", ""), doc["scenario"].get("notes", "")]
    texts += [c["text"] for c in doc.get("claims", [])]
    found = set()
    for text in texts:
        text = SOURCE_REF.sub(" ", re.sub(r"\{[^{}]*\}", " ", text))
        for m in NUMBER.finditer(text):
            x = float(m.group(0))
            if not any(math.isclose(x, v, rel_tol=1e-9) for v in inputs):
                found.add(m.group(0))
    return found


@pytest.mark.parametrize("path", shipped_scenarios(), ids=lambda p: p.stem)
def test_scenario_texts_type_no_number_a_run_produces(path):
    assert typed_numbers(path) <= set(TYPED.get(path.stem, {})), path.stem


def test_the_guard_finds_the_typed_numbers_of_the_old_fig7_notes(tmp_path):
    old = (ROOT / "src/ctrlblocks/scenarios/nowak_fig7.toml").read_text(encoding="utf-8")
    old = re.sub(r'notes = """.*?"""', 'notes = """PID_FT 4.8 and 14 %"""', old, flags=re.S)
    (tmp_path / "nowak_fig7.toml").write_text(old, encoding="utf-8")
    assert typed_numbers(tmp_path / "nowak_fig7.toml") == {"4.8", "14"}


def test_fig7_notes_quote_the_run():
    (sc,) = load_shipped(["nowak_fig7"])
    r = run_scenario(sc)
    notes = r.quoted(" ".join(sc.notes.split()))
    ft = r.metric("PID_FT", "tracking", "iae")
    over = r.metric("PID_FT", "tracking", "overshoot", 1)
    assert f"PID_FT {ft:.3g}," in notes and f"{100 * over:.2g} % for PID_FT" in notes
    assert "{" not in notes


def test_a_quote_that_names_nothing_is_refused_at_its_key():
    base = """
[scenario]
name = "q"
title = "t"
ts = 0.1
duration = 5.0
notes = "{NOTE}"
[plant]
type = "PT1"
k = 1.0
t = 2.0
[[controllers]]
name = "P"
type = "PID"
kp = 1.0
[[events]]
t = 1.0
do = "setpoint"
value = 1.0
"""
    ok = parse_scenario(base.replace("{NOTE}", "IAE {iae:main:P|.3g}, peak {max(y):main:P:1}"))
    r = run_scenario(ok)
    assert re.fullmatch(r"IAE [\d.]+, peak [\d.]+", r.quoted(ok.notes))
    for bad, says in [("{iae:main:Q}", "no controller 'Q'"), ("{iae:other:P}", "no case"),
                      ("{ise2:main:P}", "unknown metric"), ("{iae:main:P:2}", "windows 0..1"),
                      ("{iae:main:P|xx}", "no number format")]:  # fmt: skip
        with pytest.raises(ScenarioError, match=r"scenario\.notes") as e:
            parse_scenario(base.replace("{NOTE}", bad))
        assert says in str(e.value)


# -- numbers computed outside the run, recomputed ------------------------------------------


def test_gain_schedule_linearisations_and_tunings():
    from ctrlblocks.plants import ThreeTank
    from ctrlblocks.tuning import half_rule, simc

    path = ROOT / "src/ctrlblocks/scenarios/gain_schedule_three_tank.toml"
    text = " ".join(tomllib.loads(path.read_text())["scenario"]["description"].split())
    tank = ThreeTank(ts=0.1)
    tunings = {}
    for p3 in (0.3, 1.0, 1.5, 2.0, 2.5):
        k, taus = tank.linear_model(tank.u_for_y(p3))
        if p3 in (0.3, 2.5):
            lin = f"{k:.2f}/(" + "".join(f"({t:.1f}s+1)" for t in taus) + ")"
            assert lin in text, lin
        f = half_rule(k, taus)
        tunings[p3] = simc(f.gain, f.time_constant, f.dead_time)
    assert f"kp = {tunings[0.3].kp:.2g}, Ti = {tunings[0.3].ti:.2g} s at 0.3 bar" in text
    assert f"kp = {tunings[2.5].kp:.2g}, Ti = {tunings[2.5].ti:.1g} s at 2.5 bar" in text
    doc = tomllib.loads(path.read_text())
    table = doc["controllers"][2]["schedule"]
    for p3, kp, ti in zip(table["breakpoints"], table["kp"], table["ti"], strict=True):
        line = 2.6 + (2.3 - 2.6) * (p3 - 0.3) / 2.2  # straight between the ends
        assert kp == pytest.approx(line, rel=0.015)
        assert ti == pytest.approx(tunings[p3].ti, rel=0.015)


def test_the_pulse_width_ripples_of_the_notes():
    from ctrlblocks.blocks.pwm import pwm_ripple

    path = ROOT / "src/ctrlblocks/scenarios/pulse_width_heater.toml"
    notes = " ".join(tomllib.loads(path.read_text())["scenario"]["notes"].split())
    r4, r20 = pwm_ripple(50.0, 120.0, 4.0, 0.5), pwm_ripple(50.0, 120.0, 20.0, 0.5)
    assert f"R = {r4:.2f} K for P = 4 s and {r20:.2f} K for P = 20 s" in notes


def test_the_two_point_extremes_of_the_notes():
    """y_max = K - (K - y_hi) e^(-L/T), y_min = y_lo e^(-L/T), as the notes and claims say."""
    path = ROOT / "src/ctrlblocks/scenarios/two_point_thermostat.toml"
    doc = tomllib.loads(path.read_text())
    notes = " ".join(doc["scenario"]["notes"].split())
    k, t, dead = (doc["plant"][n] for n in ("k", "t", "dead_time"))
    a = math.exp(-dead / t)
    extremes = {}
    for h in (2.0, 4.0):
        hi, lo = 40.0 + h / 2.0, 40.0 - h / 2.0
        extremes[h] = (k - (k - hi) * a, lo * a)
    (x2, n2), (x4, n4) = extremes[2.0], extremes[4.0]
    assert f"y_max = {x2:.2f} K and y_min = {n2:.2f} K" in notes
    assert f"gives {x4:.2f} K and {n4:.2f} K" in notes
    assert f"{x2 - n2:.1f} K for H = 2 K, {x4 - n4:.1f} K for H = 4 K" in notes
    claims = {c["text"]: c for c in doc["claims"]}
    assert [c["approx"] for c in claims.values()] == pytest.approx([x2, n2, x4, n4], abs=5e-4)


def test_fig7_margins_in_the_comment_and_the_simulator_guide():
    from ctrlblocks.plants import PTn
    from ctrlblocks.tuning.bump import block_margins

    plant = PTn(k=0.73, t=(7.3, 2.2, 1.4), ts=0.1)  # (10b)
    pid = {"n": 5.0, "b": 1.0, "c": 0.0}
    pt = block_margins(plant, "PID", {**pid, "kp": 5.69, "ti": 16.65, "td": 2.91}, 0.1)
    ft = block_margins(plant, "PID", {**pid, "kp": 6.31, "ti": 5.40, "td": 1.36}, 0.1)
    weak = block_margins(plant, "PID", {**pid, "kp": 5.69 / 20, "ti": 16.65, "td": 2.91}, 0.1)
    assert pt and ft and weak
    toml = " ".join((ROOT / "src/ctrlblocks/scenarios/nowak_fig7.toml").read_text().split())
    guide = " ".join((ROOT / "docs/simulator.md").read_text().split())
    assert (f"gain margin {pt['gm']:.2g} / phase margin {pt['pm']:.0f}° for PID_PT, "
            f"{ft['gm']:.2g} / {ft['pm']:.0f}° for PID_FT") in toml.replace("# ", "")  # fmt: skip
    assert (f"gain margin {pt['gm']:.2g}, phase margin {pt['pm']:.0f}° for PID_PT; "
            f"{ft['gm']:.2g} and {ft['pm']:.0f}° for PID_FT") in guide  # fmt: skip
    assert f"gain margin {weak['gm']:.2g} for PID_PT" in toml.replace("# ", "")
    assert f"gain margin {weak['gm']:.2g} for PID_PT" in guide


def test_the_cascade_overshoots_of_the_simulator_guide():
    from .test_sim_structures import CASCADE

    r = run_scenario(parse_scenario(CASCADE))
    without = r.metric("without handshake", "main", "overshoot")
    with_ = r.metric("with handshake", "main", "overshoot")
    guide = " ".join((ROOT / "docs/simulator.md").read_text().split())
    assert with_ == 0.0
    assert f"saturating cascade from {100 * without:.2g} % to 0" in guide
