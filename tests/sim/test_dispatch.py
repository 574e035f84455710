"""The simulator's engines: a run dispatched to the compiled lane equals the Python path.

Every case the lane covers (PID and ADRC; first-order, second-order with dead
time, third-order and the three-tank plant; setpoint steps and ramps, input and
output loads, the outlet switch, mode and manual-value events, the warm-up;
white and coloured noise; actuator range and rate, sensor range) is run with
``engine="auto"`` (which must take the lane) and ``engine="python"`` (the
reference) and compared signal by signal to 1e-12.  Runs the lane cannot do
go to the Python path with the reason logged; ``engine="compiled"`` refuses them.
"""

from __future__ import annotations

import json
import logging
import math

import numpy as np
import pytest

from ctrlblocks.fast._jit import HAVE_NUMBA
from ctrlblocks.plants import Noise
from ctrlblocks.sim import parse_scenario, run_scenario
from ctrlblocks.sim.dispatch import CompiledLaneError, simulate
from ctrlblocks.sim.report import load_shipped, shipped_scenarios

needs_numba = pytest.mark.skipif(not HAVE_NUMBA, reason="the compiled lane needs numba")

PID = """
[[controllers]]
name = "PI"
type = "PID"
kp = 1.2
ti = 9.0
td = 1.0
u_min = 0.0
u_max = 100.0
anti_windup = "{aw}"
"""

ADRC = """
[[controllers]]
name = "ADRC"
type = "ADRC"
order = {order}
b0 = {b0}
omega_o = 2.0
omega_c = 0.5
u_min = 0.0
u_max = 100.0
"""

PLANTS = {
    "first order": '[plant]\ntype = "PT1"\nk = 1.5\nt = 12.0\n',
    "FOPDT": '[plant]\ntype = "FOPDT"\nk = 1.5\nt = 20.0\ndead_time = 4.0\n',
    "SOPDT": '[plant]\ntype = "PTn"\nk = 1.2\nt = [8.0, 3.0]\ndead_time = 1.5\n',
    "third order": '[plant]\ntype = "PTn"\nk = 1.0\nt = [5.0, 2.0, 1.0]\n',
}


def _scenario(plant: str, controllers: str, *, events: str, extra: str = "") -> str:
    return f"""
[scenario]
name = "lane"
title = "lane"
source = "test"
ts = 0.1
duration = 120.0
seed = 5
{plant}
[actuator]
u_min = 0.0
u_max = 100.0
rate = 20.0
[sensor]
noise = 0.3
y_min = 0.0
y_max = 100.0
{extra}
[initial]
y = 40.0
warmup = 3.0
{controllers}
{events}
"""


EVENTS = """
[[events]]
t = 5.0
do = "setpoint"
value = 50.0
[[events]]
t = 40.0
do = "setpoint"
value = 45.0
ramp = 0.5
[[events]]
t = 60.0
do = "load"
value = -8.0
[[events]]
t = 75.0
do = "load"
at = "output"
value = 2.0
[[events]]
t = 90.0
do = "mode"
mode = "manual"
[[events]]
t = 95.0
do = "manual_value"
value = 30.0
[[events]]
t = 100.0
do = "mode"
mode = "auto"
[[events]]
t = 105.0
do = "mode"
mode = "manual"
manual_value = 35.0
[[events]]
t = 110.0
do = "mode"
mode = "auto"
"""


def _assert_same(a, b):
    assert [(r.controller, r.case) for r in a.runs] == [(r.controller, r.case) for r in b.runs]
    for ra, rb in zip(a.runs, b.runs, strict=True):
        assert list(ra.signals) == list(rb.signals)
        for name in ra.signals:
            x, y = ra.signals[name], rb.signals[name]
            assert x.shape == y.shape
            np.testing.assert_allclose(x, y, rtol=0.0, atol=1e-12, err_msg=name)
        assert ra.events == rb.events and ra.duration == rb.duration
    assert a.metrics == b.metrics


def _both(text: str, caplog):
    sc = parse_scenario(text)
    with caplog.at_level(logging.DEBUG, logger="ctrlblocks.sim.dispatch"):
        caplog.clear()
        auto = run_scenario(sc)
    assert "Python path" not in caplog.text, caplog.text  # every run took the lane
    _assert_same(auto, run_scenario(sc, engine="python"))
    return auto


@needs_numba
@pytest.mark.parametrize("plant", sorted(PLANTS))
@pytest.mark.parametrize("aw", ["clamping", "back_calc_model"])
def test_pid_on_the_lane_equals_the_python_path(plant, aw, caplog):
    run = _both(_scenario(PLANTS[plant], PID.format(aw=aw), events=EVENTS), caplog).runs[0]
    # the events acted: ramp, loads, manual value 30 then 35 held in manual
    t, u = run.signals["t"], run.signals["u"]
    assert run.signals["sp"][np.searchsorted(t, 45.0)] == pytest.approx(47.5)
    assert u[np.searchsorted(t, 97.0)] == 30.0 and u[np.searchsorted(t, 107.0)] == 35.0
    assert np.max(run.signals["ym"]) <= 100.0


@needs_numba
@pytest.mark.parametrize("plant", sorted(PLANTS))
def test_adrc_on_the_lane_equals_the_python_path(plant, caplog):
    order = 1 if plant == "first order" else 2
    ctrl = ADRC.format(order=order, b0=0.12 if order == 1 else 0.05)
    _both(_scenario(PLANTS[plant], ctrl, events=EVENTS), caplog)


@needs_numba
def test_coloured_noise_manual_start_and_no_warmup_on_the_lane_equal_the_python_path(caplog):
    ctrls = PID.format(aw="clamping") + ADRC.format(order=1, b0=0.1)
    coloured = 'noise_t_corr = 2.0\nnoise_kind = "gaussian"'
    text = _scenario(PLANTS["FOPDT"], ctrls, events=EVENTS, extra=coloured)
    _both(text.replace("warmup = 3.0", 'warmup = 0.0\nmode = "manual"'), caplog)
    _both(text.replace("warmup = 3.0", "warmup = 0.0"), caplog)


@needs_numba
def test_three_tank_scenarios_on_the_lane_equal_the_python_path(caplog):
    # Nowak et al. 2018, Fig. 7 (outlet valve switch, gaussian noise) and Fig. 6 (mode events)
    for name in ("nowak_fig7", "nowak_fig6"):
        (sc,) = load_shipped([name])
        with caplog.at_level(logging.DEBUG, logger="ctrlblocks.sim.dispatch"):
            caplog.clear()
            auto = run_scenario(sc, duration=200.0)
        assert "Python path" not in caplog.text
        _assert_same(auto, run_scenario(sc, duration=200.0, engine="python"))


OPEN_LOOP = """
[scenario]
name = "open"
title = "open"
source = "test"
structure = "open_loop"
ts = 0.1
duration = 5.0
[[controllers]]
name = "J"
type = "JumpAndRate"
jlow = -0.5
jhigh = 1.0
rlow = -0.5
rhigh = 1.0
[[events]]
t = 1.0
do = "setpoint"
value = 2.0
"""


def test_a_run_the_lane_cannot_do_takes_the_python_path_and_logs_why(caplog):
    sc = parse_scenario(OPEN_LOOP)
    with caplog.at_level(logging.DEBUG, logger="ctrlblocks.sim.dispatch"):
        auto = run_scenario(sc)
    assert "open / J / main: Python path (structure 'open_loop' has no compiled loop)" in (
        caplog.text
    )
    _assert_same(auto, run_scenario(sc, engine="python"))
    with pytest.raises(CompiledLaneError, match="structure 'open_loop' has no compiled loop"):
        run_scenario(sc, engine="compiled")


@pytest.mark.parametrize(
    ("change", "reason"),
    [
        ('do = "setpoint"\nvalue = 50.0', None),
        ('do = "limits"\nu_min = 0.0\nu_max = 50.0', None),
        ('do = "sensor"\nok = false', None),
        ('do = "set"\nattr = "kp"\nvalue = 2.0', "(set): not covered"),
        ('do = "plant"\nparam = "k"\nvalue = 2.0', "plant parameter 'k' switched"),
    ],
)
def test_events_outside_the_lane_are_named(change, reason, caplog):
    text = _scenario(PLANTS["FOPDT"], PID.format(aw="clamping"),
                     events=f"[[events]]\nt = 1.0\n{change}\n")  # fmt: skip
    sc = parse_scenario(text.replace("duration = 120.0", "duration = 3.0"))
    if reason is None and not HAVE_NUMBA:
        reason = "numba is not installed"
    if reason is None:
        simulate(sc, "PI", engine="compiled")
        return
    with pytest.raises(CompiledLaneError, match=reason.replace("(", r"\(").replace(")", r"\)")):
        simulate(sc, "PI", engine="compiled")
    assert simulate(sc, "PI").signals["u"].shape == (30,)  # auto: the Python path


def test_block_options_outside_the_kernels_are_named():
    text = _scenario(PLANTS["FOPDT"], PID.format(aw="clamping") + "deadband = 1.0\n", events="")
    sc = parse_scenario(text.replace("duration = 120.0", "duration = 1.0"))
    with pytest.raises(CompiledLaneError, match="main: deadband"):
        simulate(sc, "PI", engine="compiled")


@needs_numba
def test_a_non_finite_measurement_falls_back_to_the_python_path(caplog):
    # an unstable plant (pole at +1/s, MV pinned at its limit) overflows at t ~ 700 s:
    # the Python path's quality handling decides what follows, so the run is redone there
    plant = '[plant]\ntype = "LinearPlant"\nnum = [1.0]\nden = [1.0, -1.0]\n'
    text = _scenario(plant, PID.format(aw="clamping"), events="").replace("ts = 0.1", "ts = 1.0")
    text = text.replace("u_max = 100.0", "u_max = inf").replace("y_max = 100.0", "y_max = inf")
    text = text.replace("y = 40.0", "u = 0.0\nsp = 1.0")
    text = text.replace("duration = 120.0", "duration = 800.0")
    sc = parse_scenario(text.replace("noise = 0.3", "noise = 0.0"))
    with caplog.at_level(logging.DEBUG, logger="ctrlblocks.sim.dispatch"):
        auto = simulate(sc, "PI")
    assert "non-finite" in caplog.text
    assert not np.all(np.isfinite(auto.signals["y"]))
    ref = simulate(sc, "PI", engine="python")
    assert list(auto.signals) == list(ref.signals)
    for name, x in auto.signals.items():
        np.testing.assert_array_equal(x, ref.signals[name])


def test_unknown_engine_is_refused():
    sc = parse_scenario(OPEN_LOOP)
    with pytest.raises(ValueError, match="engine must be one of auto, compiled, python"):
        run_scenario(sc, engine="numba")


@pytest.mark.parametrize("kind", ["uniform", "gaussian"])
@pytest.mark.parametrize("t_corr", [0.0, 0.7])
@pytest.mark.parametrize("first", [0, 3, 256])
def test_noise_samples_are_the_values_of_repeated_sample_calls(kind, t_corr, first):
    a = Noise(0.2, kind=kind, t_corr=t_corr, ts=0.1, seed=11)
    b = Noise(0.2, kind=kind, t_corr=t_corr, ts=0.1, seed=11)
    for _ in range(first):
        a.sample(), b.sample()
    want = [a.sample() for _ in range(1000)]
    got = np.concatenate((b.samples(1), b.samples(0), b.samples(998), b.samples(1)))
    assert got.tolist() == want
    assert b.sample() == a.sample() and math.isfinite(b.sample())  # the state continues


def test_cli_engine_python_and_auto_write_the_same_metrics_and_compiled_refuses_open_loop(tmp_path):
    from click.testing import CliRunner

    from ctrlblocks.cli import main

    scenario = next(p for p in shipped_scenarios() if p.stem == "nowak_fig6")
    out = {}
    for engine in ("python", "auto"):
        d = tmp_path / engine
        res = CliRunner().invoke(main, ["run", str(scenario), "--out", str(d), "--quick",
                                        "--format", "csv", "--engine", engine])  # fmt: skip
        assert res.exit_code == 0, res.output
        out[engine] = json.loads((d / "nowak_fig6" / "metrics.json").read_text())
    assert out["python"] == out["auto"]
    other = tmp_path / "open.toml"
    other.write_text(OPEN_LOOP, encoding="utf-8")
    res = CliRunner().invoke(main, ["run", str(other), "--out", str(tmp_path / "s"),
                                    "--engine", "compiled"])  # fmt: skip
    assert res.exit_code == 1
    assert "the compiled lane cannot run this: structure 'open_loop'" in res.output
    assert "Traceback" not in res.output


def test_the_cli_offers_the_engines_of_the_dispatcher():
    from ctrlblocks.sim import cli, dispatch

    assert cli.ENGINES == dispatch.ENGINES


GUARD_PID = """
[scenario]
name = "guard"
title = "output guard"
source = "test"
ts = 0.1
duration = 1.0
[plant]
type = "PT1"
k = 1.0
t = 2.0
[[controllers]]
name = "PID"
type = "PID"
kp = 1e308
u_min = 0.0
u_max = 5.0
[[events]]
t = 0.5
do = "setpoint"
value = 10.0
"""

# an observer 2500 times faster than the sample rate (omega_o ts = 100): the primary's
# states grow until its law result overflows at t = 29.4 s, while its output is limited
GUARD_ADRC = """
[scenario]
name = "guard"
title = "output guard"
source = "test"
structure = "cascade"
ts = 0.2
duration = 29.6
[plant]
type = "FOPDT"
k = 1.0
t = 1.2107
dead_time = 0.27
[inner_plant]
type = "PT2Osc"
k = 1.0
t = 0.7196
zeta = 0.1
dead_time = 1.837
[initial]
u = -0.361
[[controllers]]
name = "ADRC"
[controllers.primary]
type = "ADRC"
order = 1
omega_o = 50000.0  # beyond the sub-stepped observer's bound (100 trusted steps): diverges
u_max = 4.0
[controllers.secondary]
type = "ADRC"
u_min = 0.0
u_max = 0.189
"""


@needs_numba
@pytest.mark.parametrize("text", [GUARD_PID, GUARD_ADRC], ids=["PID", "ADRC primary"])
def test_a_law_result_that_overflows_behind_the_limits_falls_back_to_the_python_path(text):
    """A law result that is not finite (a PID's ``v_raw``, an ADRC's ``u_raw``) is the
    blocks' output guard (``BAD_RESULT``: the last output held), even when the limited
    output is finite.  Before, the lane limited +inf to ``u_max`` and went on (PID: u = 5
    against 0 held; ADRC: sp2 = 4 against -3.3e307 held); now it stops there and the run
    is redone on the Python path.  Found by tests/sim/test_dispatch_campaign.py."""
    from .test_dispatch_campaign import check_case

    runs, lane, lines = check_case(text)
    assert (runs, lane) == (1, 0)
    assert "non-finite" in lines[0]
