"""LiveTuner: step pretuning and relay fine tuning on a running loop, with safety bounds."""

from __future__ import annotations

import math

import pytest

from ctrlblocks import PID, ErrorCode, ParameterError
from ctrlblocks.plants import FOPDT, ThreeTank
from ctrlblocks.tuning import relay_autotune, step_pretune
from ctrlblocks.tuning.live import LiveTuner, TunerState


def _run(tuner: LiveTuner, plant, n: int = 200_000) -> list[float]:
    """Drive ``plant`` with the tuner as a running loop would: read PV, apply MV."""
    us = []
    for _ in range(n):
        u = tuner.step(plant.y)
        us.append(u)
        plant.step(u)
        if not tuner.running:
            break
    return us


def test_a_live_step_test_on_the_three_tank_process_equals_the_offline_pretune() -> None:
    offline = step_pretune(ThreeTank(ts=0.1), 0.5, u0=2.0)
    plant = ThreeTank(ts=0.1)
    plant.reset(2.0)  # the running loop sits at its operating point
    tuner = LiveTuner("step", ts=0.1, u0=2.0, amplitude=0.5, mv_min=0.0, mv_max=5.0, pre_time=1.0)
    _run(tuner, plant)
    assert tuner.state is TunerState.DONE
    m = tuner.result.model
    assert m["gain"] == pytest.approx(offline.model.gain, rel=0.05)
    assert m["time_constant"] == pytest.approx(offline.model.time_constant, rel=0.05)
    assert m["dead_time"] == pytest.approx(offline.model.dead_time, rel=0.05)
    pid = tuner.result.proposals["PID_AMIGO"]
    assert pid["kp"] == pytest.approx(offline.pid.kp, rel=0.05)
    assert pid["ti"] == pytest.approx(offline.pid.ti, rel=0.05)
    assert set(tuner.result.proposals) >= {"PID_AMIGO", "PI_SIMC", "PID_MIGO", "ADRC_2"}
    # every proposal builds a block as it stands
    PID(**{k: v for k, v in pid.items() if k != "type"}, ts=0.1)
    # one design path: PID_MIGO and ADRC_2 are compare's designs on the identified FOPDT
    import numpy as np

    from ctrlblocks.tuning.design import design_adrc, design_pid
    from ctrlblocks.tuning.identify import FOPDT

    fo = FOPDT(m["gain"], m["time_constant"], m["dead_time"])
    assert "PID_MIGO" in tuner.result.proposals
    kw = tuner.result.proposals["PID_MIGO"]
    # the budget: 5 % of the step; the noise: none on this simulated plant (fit residuals)
    ref = design_pid(fo, 0.1, noise_std=kw_noise(tuner), mv_noise_max=0.025)
    for key in ("kp", "ti", "td", "n", "b"):
        assert kw[key] == pytest.approx(ref.params[key], rel=1e-9)
    ref2 = design_adrc(fo, 2, 0.1, noise_std=kw_noise(tuner), mv_noise_max=0.025)
    for key in ("b0", "omega_c", "omega_o"):
        assert tuner.result.proposals["ADRC_2"][key] == pytest.approx(ref2.params[key], rel=1e-9)
    assert np.isfinite(ref.margins.ms) and ref.margins.ms <= 1.6 * 1.001


def kw_noise(tuner: LiveTuner) -> float:
    """The PV noise the live proposals were designed for: the FOPDT fit's residuals."""
    import numpy as np

    from ctrlblocks.tuning.identify import fit_fopdt

    t, u, y = tuner.record()  # the experiment's record, as the tuner fitted it
    return float(np.std(np.asarray(y) - fit_fopdt(t, u, y).response(t, u)))


def test_a_live_relay_test_on_the_three_tank_process_equals_the_offline_relay() -> None:
    offline = relay_autotune(ThreeTank(ts=0.1), 0.5, u0=2.0)
    plant = ThreeTank(ts=0.1)
    plant.reset(2.0)
    tuner = LiveTuner("relay", ts=0.1, u0=2.0, amplitude=0.5, mv_min=0.0, mv_max=5.0)
    us = _run(tuner, plant)
    assert tuner.state is TunerState.DONE, tuner.reason
    assert tuner.result.model["ku"] == pytest.approx(offline.ku, rel=0.05)
    assert tuner.result.model["pu"] == pytest.approx(offline.pu, rel=0.05)
    assert set(us) == {1.5, 2.5, 2.0}  # the relay levels, then back to u0
    assert us[-1] == 2.0


def test_an_experiment_that_would_leave_the_mv_bounds_does_not_start() -> None:
    with pytest.raises(ParameterError) as info:
        LiveTuner("relay", ts=0.1, u0=4.8, amplitude=0.5, mv_min=0.0, mv_max=5.0)
    assert info.value.code == ErrorCode.BAD_LIMITS
    with pytest.raises(ParameterError):
        LiveTuner("step", ts=0.1, u0=1.0, amplitude=-1.5, mv_min=0.0, mv_max=5.0)


def test_a_pv_bound_aborts_and_the_mv_returns_to_its_value_before_the_test() -> None:
    plant = FOPDT(k=2.0, t=10.0, dead_time=1.0, ts=0.1)
    plant.reset(1.0)  # PV 2.0
    tuner = LiveTuner("step", ts=0.1, u0=1.0, amplitude=2.0, mv_min=0.0, mv_max=5.0, pv_max=3.0)
    us = _run(tuner, plant)
    assert tuner.state is TunerState.ABORTED
    assert "left the bounds" in tuner.reason
    assert plant.y > 3.0 and us[-1] == 1.0
    assert tuner.step(2.0) == 1.0 and tuner.result is None  # stays ended: nothing to apply


@pytest.mark.parametrize("bad", [math.nan, math.inf, None, "x", 10**400])
def test_bad_pv_aborts(bad) -> None:
    tuner = LiveTuner("relay", ts=0.1, u0=1.0, amplitude=0.5, mv_min=0.0, mv_max=5.0)
    assert tuner.step(1.0) == 1.5
    assert tuner.step(bad) == 1.0
    assert tuner.state is TunerState.ABORTED and "PV not valid" in tuner.reason


def test_the_operator_can_abort_and_a_test_that_runs_out_of_time_fails() -> None:
    tuner = LiveTuner("step", ts=0.1, u0=1.0, amplitude=0.5, mv_min=0.0, mv_max=5.0)
    tuner.step(1.0)
    tuner.abort()
    assert tuner.state is TunerState.ABORTED and tuner.step(1.0) == 1.0
    plant = FOPDT(k=1.0, t=100.0, dead_time=5.0, ts=0.1)
    tuner = LiveTuner("relay", ts=0.1, u0=1.0, amplitude=0.5, mv_min=0.0, mv_max=5.0, max_time=20.0)
    plant.reset(1.0)
    _run(tuner, plant)
    assert tuner.state is TunerState.FAILED
    assert "no steady relay limit cycle" in tuner.reason
    assert tuner.status()["state"] == "failed"


def test_an_evaluation_that_raises_ends_the_test_failed_not_the_caller(monkeypatch) -> None:
    import ctrlblocks.tuning.live as live

    def broken(exp):
        raise ZeroDivisionError("division by zero")

    monkeypatch.setattr(live, "_step_result", broken)
    plant = FOPDT(k=2.0, t=1.0, dead_time=0.2, ts=0.1)
    plant.reset(1.0)
    tuner = LiveTuner("step", ts=0.1, u0=1.0, amplitude=0.5, mv_min=0.0, mv_max=5.0,
                      max_time=5.0)  # fmt: skip
    us = _run(tuner, plant)
    assert tuner.state is TunerState.FAILED
    assert tuner.reason == "ZeroDivisionError: division by zero"
    assert us[-1] == 1.0 and tuner.result is None
