"""ControllerSide: the structure wiring shared by the simulator and the runtime, by hand.

P-only PIDs (``ti = 0``: ``v = kp (sp - y) + ff``) make every output a
hand-evaluated number.
"""

from __future__ import annotations

import math

import pytest

from ctrlblocks.sim import ControllerSide, ScenarioError
from ctrlblocks.sim.scenario import parse_controller


def p_only(kp: float, **extra) -> dict:
    return {"type": "PID", "kp": kp, "ti": 0.0, "u_min": -100.0, "u_max": 100.0, **extra}


def side(structure: str, entry: dict, ts: float = 0.1, u0: float = 0.0) -> ControllerSide:
    spec = parse_controller({"name": "c", **entry}, structure, ts, key="controllers[0]")
    return ControllerSide(structure, spec, ts, u0=u0)


def test_cascade_primary_output_is_the_secondary_setpoint():
    s = side("cascade", {"primary": p_only(2.0), "secondary": p_only(3.0)})
    assert s.measurements == ("y", "y2")
    u = s.step(1.0, 0.5, y2=0.2)
    # v1 = 2 (1 - 0.5) = 1.0; u = 3 (1.0 - 0.2) = 2.4
    assert s.values["sp2"] == pytest.approx(1.0, abs=1e-15)
    assert u == pytest.approx(2.4, abs=1e-14)
    assert s.main is s.blocks["secondary"] and s.mv_blocks == [s.blocks["secondary"]]


def test_cascade_bad_secondary_measurement_gives_the_secondary_safe_value():
    s = side("cascade", {"primary": p_only(2.0), "secondary": p_only(3.0, safe_value=-1.0)})
    assert s.step(1.0, 0.5, y2=math.nan, y2_ok=False) == -1.0


def test_cascade_aw_handshake_passes_the_secondary_awout_to_the_primary():
    s = side("cascade", {"primary": p_only(2.0), "secondary": p_only(3.0, u_max=1.0)})
    s.step(1.0, 0.5, y2=0.2)  # wants 2.4, limited to 1.0
    assert s.blocks["secondary"].awout is True and s.blocks["primary"].awin is True
    off = side(
        "cascade",
        {"primary": p_only(2.0), "secondary": p_only(3.0, u_max=1.0), "aw_handshake": False},
    )
    off.step(1.0, 0.5, y2=0.2)
    assert off.blocks["primary"].awin is False


@pytest.mark.parametrize(("selector", "expected"), [("min", 0.1), ("max", 0.5)])
def test_override_selector_picks_and_every_block_tracks(selector, expected):
    blocks = [p_only(1.0, measure="y"), p_only(1.0, measure="y2", sp=0.2)]
    s = side("override", {"selector": selector, "blocks": blocks})
    u = s.step(1.0, 0.5, y2=0.1)
    # v1 = 1 (1 - 0.5) = 0.5; v2 = 1 (0.2 - 0.1) = 0.1
    assert (s.values["v1"], s.values["v2"]) == pytest.approx((0.5, 0.1), abs=1e-15)
    assert u == pytest.approx(expected, abs=1e-15)
    assert len(s.mv_blocks) == 2
    for b in s.mv_blocks:  # UpdateState with the selected value
        assert b.manual_value == pytest.approx(expected, abs=1e-15)


def test_feedforward_goes_into_ff_and_holds_on_a_bad_disturbance():
    s = side(
        "feedforward",
        {
            "main": p_only(1.0),
            "feedforward": {"type": "LeadLag", "k": -0.5, "t_lead": 1.0, "t_lag": 1.0},
        },
    )
    assert s.measurements == ("y", "dv")
    # t_lead = t_lag: a static gain; ff = -0.5 * 2 = -1; u = 1 (0.3 - 0.1) + ff = -0.8
    assert s.step(0.3, 0.1, dv=2.0) == pytest.approx(-0.8, abs=1e-14)
    assert s.values["ff"] == pytest.approx(-1.0, abs=1e-15)
    s.step(0.3, 0.1, dv=math.nan, dv_ok=False)
    assert s.values["ff"] == pytest.approx(-1.0, abs=1e-15)  # the last good ff is kept


def test_smith_predictor_in_steady_state_feeds_back_the_measurement():
    model = {"type": "FOPDT", "k": 1.0, "t": 5.0, "dead_time": 1.0}
    s = side("smith", {"main": p_only(1.0), "model": model}, u0=0.3)
    u = s.step(1.0, 0.3)
    # both models start at the steady state of u0 = 0.3: y_pred = y + 0.3 - 0.3
    assert s.values["y_pred"] == pytest.approx(0.3, abs=1e-15)
    assert u == pytest.approx(0.7, abs=1e-15)


def test_parse_controller_names_the_key_path():
    with pytest.raises(ScenarioError) as ei:
        parse_controller(
            {"name": "c", "primary": p_only(2.0), "secondary": p_only(-3.0)},
            "cascade",
            0.1,
            key="loops[2]",
            file="rt.toml",
        )
    assert ei.value.key == "loops[2].secondary.kp"
