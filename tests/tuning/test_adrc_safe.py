"""Safe defaults: the searched ADRC tuning, refused fragile settling times, the CLI round trips."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from ctrlblocks import ADRC, PID
from ctrlblocks.blocks.base import ErrorCode, ParameterError
from ctrlblocks.cli import main
from ctrlblocks.plants.linear import FOPDT as PlantFOPDT
from ctrlblocks.plants.linear import PT2
from ctrlblocks.tuning import SOPDT, adrc_tuning
from ctrlblocks.tuning.cli import ADRC_INFO_KEYS, PID_INFO_KEYS

# FOPDT with L/T 0.05, 0.17, 0.5, 0.9 and an SOPDT: (gain, T, L[, T2])
PROCESSES = {
    "L/T=0.05": (1.5, 20.0, 1.0),
    "L/T=0.17": (2.0, 30.0, 5.0),
    "L/T=0.5": (0.8, 12.0, 6.0),
    "L/T=0.9": (1.0, 10.0, 9.0),
    "sopdt": (0.56, 9.5, 1.0, 4.2),
}

_CACHE: dict = {}


def _tuned(name: str, order: int):
    key = (name, order)
    if key not in _CACHE:
        p = PROCESSES[name]
        if len(p) == 4:  # the SOPDT: b0 from its half-rule FOPDT, margins on the SOPDT itself
            k, t1, L, t2 = p
            _CACHE[key] = adrc_tuning(k, t1 + t2 / 2, L + t2 / 2, order, model=SOPDT(k, t1, L, t2))
        else:
            _CACHE[key] = adrc_tuning(*p, order)
    return _CACHE[key]


def _plant(name: str, ts: float):
    p = PROCESSES[name]
    if len(p) == 4:
        return PT2(p[0], p[1], p[3], ts, p[2])
    return PlantFOPDT(p[0], p[1], p[2], ts)


CASES = [(name, n) for name in PROCESSES for n in (1, 2, 3) if not (name == "L/T=0.9" and n == 2)]


@pytest.mark.parametrize(("name", "order"), CASES, ids=[f"{a}-n{b}" for a, b in CASES])
def test_default_adrc_is_stable_with_ms_within_2_percent_of_target_and_settles(name, order):
    tun = _tuned(name, order)
    mg = tun.margins
    assert mg.stable and 0.98 * 1.6 <= mg.ms <= 1.6
    assert mg.gm > 2.0 and mg.pm > 30.0
    # closed loop with the real block on the real plant: set-point step, settles
    block = ADRC(**tun.config(u_min=-1e6, u_max=1e6))
    plant = _plant(name, tun.ts)
    block(0.0, 0.0)
    ys = []
    n = int(1.2 * tun.settling_time_loop / tun.ts) + 10
    for _ in range(n):
        y = plant.y
        plant.step(block(1.0, y))
        ys.append(y)
    ys = np.array(ys)
    tail = ys[int(tun.settling_time_loop / tun.ts) + 1 :]
    assert np.all(np.abs(tail - 1.0) <= 0.02)
    assert np.max(ys) < 1.25  # Ms <= 1.6: no large overshoot


def test_a_settling_time_with_ms_above_2_is_refused_with_the_fastest_safe_one():
    with pytest.raises(ParameterError) as info:
        adrc_tuning(2.0, 30.0, 5.0, 2, settling_time=61.0, ts=0.2)
    assert info.value.code == ErrorCode.BAD_BANDWIDTH
    msg = str(info.value)
    assert "unstable" in msg and "fastest settling time with Ms <= 2" in msg
    fastest = float(msg.split("fastest settling time with Ms <= 2 at ts = 0.2 s is ")[1].split()[0])
    ok = adrc_tuning(2.0, 30.0, 5.0, 2, settling_time=fastest * 1.001, ts=0.2)
    assert ok.margins.stable and 1.9 < ok.margins.ms <= 2.0
    forced = adrc_tuning(2.0, 30.0, 5.0, 2, settling_time=61.0, ts=0.2, force=True)
    assert not forced.margins.stable and any("(forced)" in w for w in forced.warnings)
    assert forced.fastest_settling_time == pytest.approx(fastest, rel=1e-3)


def test_no_adrc_of_the_order_reaching_the_target_usefully_points_to_the_smith_predictor():
    """L/T = 0.9, n = 3: Ms 1.6 only at a bandwidth whose loop is slower than the process."""
    tun = _tuned("L/T=0.9", 3)
    assert tun.settling_time_loop > 9.0 + 4 * 10.0
    assert any("Smith predictor" in w and "lower order than 3" in w for w in tun.warnings)
    fast = _tuned("L/T=0.05", 1)
    assert not any("Smith predictor" in w for w in fast.warnings)


def test_sample_time_bound_lowers_the_observer_ratio_and_says_so():
    tun = adrc_tuning(1.5, 20.0, 1.0, 1, ts=1.0)
    assert tun.omega_o * 1.0 <= 0.2 + 1e-12
    assert any("observer ratio lowered" in w or "limited by the sample time" in w
               for w in tun.warnings)  # fmt: skip


def _run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def test_cli_tune_adrc_prints_margins_and_round_trips_into_the_block(tmp_path):
    png = tmp_path / "adrc.png"
    r = _run("tune", "adrc", "--gain", 2, "--time-constant", 30, "--dead-time", 5, "--order", 2,
             "--json", "--plot", png)  # fmt: skip
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    for k in ("ms", "gm", "pm", "wc_crossover", "stable"):
        assert k in d
    assert d["stable"] is True and 0.98 * 1.6 <= d["ms"] <= 1.6
    assert png.stat().st_size > 20000
    cfg = {k: v for k, v in d.items() if k not in ADRC_INFO_KEYS}
    block = ADRC(**cfg, u_min=0.0, u_max=1.0)
    assert block.config.omega_c == d["omega_c"] and block.config.discretisation == "euler"


def test_cli_tune_adrc_refuses_the_issues_settling_time_unless_forced():
    base = ["tune", "adrc", "--gain", 2, "--time-constant", 30, "--dead-time", 5, "--order", 2,
            "--settling-time", 61]  # fmt: skip
    r = _run(*base)
    assert r.exit_code == 1 and "fastest settling time" in r.output and "Traceback" not in r.output
    forced = json.loads(_run(*base, "--force", "--json").output)
    assert forced["stable"] is False and forced["ms"] is None


def test_cli_tune_pid_margins_json_round_trip_into_the_block(tmp_path):
    r = _run("tune", "pid", "--gain", 2, "--time-constant", 30, "--dead-time", 5, "--rule",
             "amigo", "--json", "--plot", tmp_path / "pid.png")  # fmt: skip
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    assert d["form"] == "isa" and d["stable"] is True and 1.3 < d["ms"] < 1.6
    assert d["gm"] > 2.5 and 45 < d["pm"] < 75 and d["wc_crossover"] > 0
    pid = PID(**{k: v for k, v in d.items() if k not in PID_INFO_KEYS}, ts=0.5, u_min=0, u_max=1)
    assert pid.config.kp == d["kp"] and pid.config.b == 0.0


@pytest.mark.parametrize(
    ("rule", "expected"),
    [("zn", (0.6 * 4.0, 10.0 / 2, 10.0 / 8)), ("tyreus-luyben", (4.0 / 2.2, 22.0, 10.0 / 6.3))],
)
def test_cli_tune_pid_ultimate_gain_rules(rule, expected):
    r = _run("tune", "pid", "--ku", 4, "--pu", 10, "--rule", rule, "--json")
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    assert (d["kp"], d["ti"], d["td"]) == pytest.approx(expected)
    assert "ms" not in d and "margins need" in d["warnings"][0]
    with_model = json.loads(
        _run(
            "tune",
            "pid",
            "--ku",
            4,
            "--pu",
            10,
            "--rule",
            rule,
            "--gain",
            1,
            "--time-constant",
            10,
            "--dead-time",
            2,
            "--json",
        ).output
    )
    assert isinstance(with_model["stable"], bool)  # fmt: skip


@pytest.mark.parametrize(
    "args",
    [["--rule", "tyreus-luyben", "--gain", 1, "--time-constant", 5, "--dead-time", 1],
     ["--rule", "simc", "--ku", 4, "--pu", 10], ["--rule", "zn", "--ku", 4],
     ["--rule", "zn", "--gain", 1]],
)  # fmt: skip
def test_cli_tune_pid_bad_option_combinations_are_usage_errors(args):
    r = _run("tune", "pid", *args)
    assert r.exit_code == 2 and "Traceback" not in r.output


def test_margins_keys_are_json_null_when_infinite():
    r = _run("tune", "pid", "--gain", 1, "--time-constant", 10, "--dead-time", 1, "--rule", "simc",
             "--controller", "pi", "--json")  # fmt: skip
    d = json.loads(r.output)
    assert d["gm"] is None or math.isfinite(d["gm"])
