"""``ctrlblocks identify`` and ``ctrlblocks tune`` through click's CliRunner."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from ctrlblocks.cli import main

DATA = Path(__file__).parent / "data" / "bump_k2.csv"
COLS = ["--time", "time_s", "--u", "p_supply_bar", "--y", "p3_bar"]


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.mark.parametrize("method", ["two-point", "sk", "lsq", "lsq-sopdt", "integrating"])
def test_identify_json_has_the_model_keys(method):
    r = run("identify", DATA, *COLS, "--method", method, "--json")
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    keys = {"gain", "dead_time", "fit"}
    if method != "integrating":
        keys.add("time_constant")
    if method == "lsq-sopdt":
        keys.add("time_constant_2")
    assert keys <= set(d)
    if method != "integrating":
        assert d["gain"] == pytest.approx(0.73, rel=0.01)


def test_identify_lsq_matches_the_library_and_writes_a_plot(tmp_path):
    from ctrlblocks.tuning import fit_fopdt, read_step_csv

    png = tmp_path / "fit.png"
    r = run("identify", DATA, *COLS, "--json", "--plot", png)
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    data = read_step_csv(DATA, time="time_s", u="p_supply_bar", y="p3_bar")
    m = fit_fopdt(data.t, data.u, data.y)
    assert (d["gain"], d["time_constant"], d["dead_time"]) == (m.gain, m.time_constant, m.dead_time)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_identify_table_output_is_readable():
    r = run("identify", DATA, *COLS)
    assert r.exit_code == 0
    assert "FOPDT model (lsq)" in r.output and "time_constant" in r.output


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        ("t,u\n0,1\n", "line 1, column 'y': no such column"),
        (
            "t,u,y\n" + "".join(f"{i},1,{i}\n" for i in range(11)) + "11,2,x\n",
            "line 13, column 'y'",
        ),
        ("t,u,y\n" + "".join(f"{i % 6},{i > 2},{i}\n" for i in range(12)), "column 'u'"),
        (
            "t,u,y\n" + "".join(f"{i % 6},{int(i > 2)},{i}\n" for i in range(12)),
            "line 8, column 't'",
        ),
        ("t,u,y\n0,1,0\n1,2,1\n", "only 2 data row"),
        (
            "t,u,y\n" + "".join(f"{i},1,{i}\n" for i in range(12)),
            "column 'u': the MV never changes",
        ),
    ],
    ids=[
        "missing-column",
        "non-numeric",
        "non-numeric-bool",
        "non-monotonic",
        "too-few",
        "no-step",
    ],
)
def test_identify_bad_file_exits_non_zero_with_one_clear_message(tmp_path, content, expected):
    p = tmp_path / "bad.csv"
    p.write_text(content)
    r = run("identify", p, "--time", "t", "--u", "u", "--y", "y")
    assert r.exit_code == 1
    assert expected in r.output
    assert str(p) in r.output
    assert "Traceback" not in r.output


def test_identify_missing_file_exits_non_zero(tmp_path):
    r = run("identify", tmp_path / "none.csv", "--time", "t", "--u", "u", "--y", "y")
    assert r.exit_code == 1 and "cannot read" in r.output


def test_tune_adrc_table1_k2_json():
    r = run("tune", "adrc", "--gain", 0.73, "--time-constant", 8.3, "--dead-time", 3, "--order", 3,
            "--settling-time", 15, "--ts", 0.1, "--force", "--json")  # fmt: skip
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    assert (round(d["b0_min"], 4), round(d["b0_max"], 4), d["b0"]) == (0.0236, 0.1022, d["b0_min"])
    assert d["omega_c"] == pytest.approx(1 / 3) and d["omega_o"] == pytest.approx(5 / 3)


def test_tune_adrc_second_order_has_b0_range_collapsed():
    """The paper's rule (a settling time): Table 1's b0 for K1, one value."""
    r = run("tune", "adrc", "--gain", 0.56, "--time-constant", 11, "--dead-time", 3.3, "--order", 2,
            "--settling-time", 60, "--force", "--json")  # fmt: skip
    d = json.loads(r.output)
    assert round(d["b0"], 3) == 0.011 and d["b0_min"] == d["b0_max"] == d["b0"]


def test_tune_adrc_unbounded_b0_max_is_null_in_json():
    r = run("tune", "adrc", "--gain", 1, "--time-constant", 30, "--dead-time", 3, "--order", 3,
            "--settling-time", 200, "--force", "--json")  # fmt: skip
    assert r.exit_code == 0
    assert json.loads(r.output)["b0_max"] is None


def test_tune_adrc_without_settling_time_is_the_design_of_compare():
    """One design path: tune adrc gives what ctrlblocks.tuning.design (compare's) gives."""
    from ctrlblocks.tuning.design import design_adrc
    from ctrlblocks.tuning.identify import SOPDT

    r = run("tune", "adrc", "--gain", 0.73, "--time-constant", 7.1, "--time-constant-2", 2.9,
            "--dead-time", 0.9, "--order", 2, "--ts", 0.05, "--json")  # fmt: skip
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    ref = design_adrc(SOPDT(0.73, 7.1, 0.9, 2.9), 2, 0.05)
    for key in ("b0", "omega_c", "omega_o"):
        assert d[key] == pytest.approx(ref.params[key], rel=1e-12)
    assert d["ms"] == pytest.approx(ref.margins.ms, rel=1e-12) and d["ms"] <= 1.6 * 1.001
    assert d["model"] == "sopdt" and 3.0 <= d["omega_o"] / d["omega_c"] <= 10.0


def test_tune_pid_migo_is_the_design_of_compare_and_round_trips_into_the_block():
    from ctrlblocks import PID
    from ctrlblocks.tuning.cli import PID_INFO_KEYS
    from ctrlblocks.tuning.design import design_pid
    from ctrlblocks.tuning.identify import FOPDT
    from ctrlblocks.tuning.margins import margins

    r = run("tune", "pid", "--gain", 2, "--time-constant", 30, "--dead-time", 5, "--json")
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    ref = design_pid(FOPDT(2.0, 30.0, 5.0), d["margins_ts"])
    for key in ("kp", "ti", "td", "n", "b"):
        assert d[key] == pytest.approx(ref.params[key], rel=1e-12)
    rest = {k: v for k, v in d.items() if k not in PID_INFO_KEYS}
    block = PID(**rest, ts=d["margins_ts"], u_min=-1e9, u_max=1e9)
    assert margins(FOPDT(2.0, 30.0, 5.0), block).ms == pytest.approx(d["ms"], rel=1e-9)


@pytest.mark.parametrize("rule", ["amigo", "zn", "lambda"])
def test_every_pid_rule_uses_the_second_time_constant(rule):
    """AMIGO, ZN and lambda take the SOPDT's half-rule FOPDT (and say so), not the FOPDT
    the first time constant alone would be; the margins are on the SOPDT."""
    from ctrlblocks.tuning import pid_rules

    fn = {"amigo": pid_rules.amigo, "zn": pid_rules.ziegler_nichols_open,
          "lambda": pid_rules.lambda_tuning}[rule]  # fmt: skip
    args = ["tune", "pid", "--gain", 1.5, "--time-constant", 10, "--dead-time", 1, "--rule", rule,
            "--controller", "pid", "--json"]  # fmt: skip
    plain = json.loads(run(*args).output)
    with_t2 = json.loads(run(*args, "--time-constant-2", 4).output)
    ref = fn(1.5, 10 + 2.0, 1 + 2.0, controller="pid")
    assert (with_t2["kp"], with_t2["ti"], with_t2["td"]) == pytest.approx((ref.kp, ref.ti, ref.td))
    assert (with_t2["kp"], with_t2["ti"]) != pytest.approx((plain["kp"], plain["ti"]))
    assert "half-rule" in with_t2["note"]


def test_the_ultimate_point_rules_refuse_a_second_time_constant():
    r = run("tune", "pid", "--ku", 3, "--pu", 10, "--rule", "zn", "--time-constant-2", 2)
    assert r.exit_code == 2 and "--time-constant-2" in r.output and "Traceback" not in r.output


@pytest.mark.parametrize(
    ("rule", "expected"),
    [("simc", (1.25, 10.0, 0.0)), ("amigo", (1.225, 8.8 / 1.5, 10 / 10.6)), ("zn", (3.0, 4.0, 1.0)),
     ("lambda", (0.5, 11.0, 20 / 22))],
)  # fmt: skip
def test_tune_pid_json_equals_the_rule(rule, expected):
    r = run("tune", "pid", "--gain", 2, "--time-constant", 10, "--dead-time", 2, "--rule", rule,
            "--json")  # fmt: skip
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    assert (d["kp"], d["ti"], d["td"]) == pytest.approx(expected)


@pytest.mark.parametrize(
    "args",
    [
        ["tune", "adrc", "--gain", "1", "--time-constant", "5", "--dead-time", "1", "--order", "4"],
        ["tune", "adrc", "--gain", "1", "--time-constant", "2", "--dead-time", "3", "--order", "2",
         "--settling-time", "10"],
        ["tune", "pid", "--gain", "0", "--time-constant", "5", "--dead-time", "1"],
        [
            "tune",
            "pid",
            "--gain",
            "0",
            "--time-constant",
            "5",
            "--dead-time",
            "1",
            "--rule",
            "simc",
        ],
        [
            "tune",
            "pid",
            "--gain",
            "1",
            "--time-constant",
            "5",
            "--dead-time",
            "0",
            "--rule",
            "amigo",
        ],
    ],
)
def test_tune_impossible_model_exits_1_with_a_message(args):
    r = run(*args)
    assert r.exit_code == 1
    assert r.output.startswith("Error: ") and "Traceback" not in r.output


def test_tune_unknown_rule_is_a_usage_error():
    r = run("tune", "pid", "--gain", 1, "--time-constant", 5, "--dead-time", 1, "--rule", "magic")
    assert r.exit_code == 2


def test_tune_adrc_noise_options_lower_omega_o():
    """The paper's rule (a settling time): the observer slowed for the noise."""
    base = ["tune", "adrc", "--gain", 0.73, "--time-constant", 8.3, "--dead-time", 3, "--order", 2,
            "--ts", 0.1, "--settling-time", 30, "--force", "--json"]  # fmt: skip
    free = json.loads(run(*base).output)
    limited = json.loads(run(*base, "--noise-std", 0.002, "--u-noise-max", 0.0006).output)
    assert limited["omega_o"] < free["omega_o"]
    assert limited["omega_c"] == free["omega_c"]
    r = run(*base, "--noise-std", 0.002)
    assert r.exit_code == 1 and "give both or neither" in r.output


def test_tune_adrc_design_keeps_the_mv_noise_budget():
    base = ["tune", "adrc", "--gain", 0.73, "--time-constant", 8.3, "--dead-time", 3, "--order", 2,
            "--ts", 0.1, "--json"]  # fmt: skip
    free = json.loads(run(*base).output)
    limited = json.loads(run(*base, "--noise-std", 0.002, "--u-noise-max", 0.0006).output)
    assert limited["mv_noise"] <= 0.0006 * (1 + 1e-6)
    assert limited["ki"] < free["ki"] and limited["ms"] <= 1.6 * 1.001
    r = run(*base, "--noise-std", 0.002)
    assert r.exit_code == 2 and "give both --noise-std and --u-noise-max" in r.output
