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


# -- the cascade while the secondary is not in AUTO ---------------------------------


def pi(kp: float, ti: float, **extra) -> dict:
    return {"type": "PID", "kp": kp, "ti": ti, "u_min": -100.0, "u_max": 100.0, **extra}


ADRC_PRIMARY = {"type": "ADRC", "order": 1, "b0": 0.5, "omega_c": 1.0, "omega_o": 5.0,
                "u_min": -100.0, "u_max": 100.0}  # fmt: skip


@pytest.mark.parametrize("primary", [pi(2.0, 1.0), ADRC_PRIMARY], ids=["PID", "ADRC"])
def test_cascade_primary_tracks_y2_while_the_secondary_is_in_manual(primary):
    """Secondary in MAN with a primary error: the primary tracks y2, no windup, bumpless back."""
    s = side("cascade", {"primary": primary, "secondary": pi(1.0, 2.0)})
    prim, sec = s.blocks["primary"], s.blocks["secondary"]
    for _ in range(20):  # in auto: y2 settles where the plant is held
        s.step(1.0, 0.2, y2=0.3)
    s.set_manual(True, 0.5)
    assert sec.manual and not prim.manual
    y2 = [0.3 + 0.01 * math.sin(0.1 * k) for k in range(2000)]
    for k, y2k in enumerate(y2):  # 200 s with the primary's error 1.0 - 0.2 = 0.8
        u = s.step(1.0, 0.2, y2=y2k)
        assert u == 0.5
        # the primary's output is the secondary's measurement: no windup
        assert s.values["sp2"] == y2k, k
    # the mode inputs are the user's again after every sample
    assert prim.mode.name == "AUTO" and not getattr(prim, "track", False)
    assert prim.manual_value == pytest.approx(y2[-1], abs=1e-15)  # In/Out follows the output
    s.set_manual(False)
    u = s.step(1.0, 0.2, y2=y2[-1])
    assert abs(u - 0.5) < 1e-9  # the MV does not move in the first sample back in AUTO
    assert abs(s.values["sp2"] - y2[-1]) < 1e-9  # the primary continues from y2
    for _ in range(5):  # then the primary acts on its error again
        s.step(1.0, 0.2, y2=y2[-1])
    assert s.values["sp2"] > y2[-1] + 1e-3


def test_cascade_primary_in_manual_by_the_user_keeps_its_manual_value():
    s = side("cascade", {"primary": pi(2.0, 1.0), "secondary": pi(1.0, 2.0)})
    prim = s.blocks["primary"]
    s.step(1.0, 0.2, y2=0.3)
    prim.manual, prim.manual_value = True, 0.7
    s.set_manual(True, 0.5)
    for _ in range(50):
        s.step(1.0, 0.2, y2=0.3)
        assert s.values["sp2"] == 0.7  # not overridden by the tracking
    assert prim.manual and prim.manual_value == 0.7 and not prim.track
    s.set_manual(False)  # the secondary back in AUTO: the primary stays in manual
    s.step(1.0, 0.2, y2=0.3)
    assert s.values["sp2"] == 0.7 and prim.manual


def test_cascade_primary_holds_on_a_bad_y2_while_the_secondary_is_in_manual():
    s = side("cascade", {"primary": pi(2.0, 1.0), "secondary": pi(1.0, 2.0)})
    s.set_manual(True, 0.5)
    s.step(1.0, 0.2, y2=0.3)
    assert s.values["sp2"] == 0.3
    for _ in range(20):
        s.step(1.0, 0.2, y2=math.nan, y2_ok=False)
        assert s.values["sp2"] == 0.3  # the last output held: no windup, no error
    assert s.blocks["primary"].error_id == 0


def test_cascade_the_secondary_in_manual_makes_the_primary_windup_free_in_a_runaway_case():
    """200 s of a primary error of 0.8: the old wiring integrated the primary to its limit 100."""
    s = side("cascade", {"primary": pi(2.0, 1.0), "secondary": pi(1.0, 2.0)})
    s.set_manual(True, 0.5)
    for _ in range(2000):
        s.step(1.0, 0.2, y2=0.3)
    assert abs(s.blocks["primary"].out - 0.3) < 1e-12


# -- the cascade while the secondary's measurement is bad -----------------------------


@pytest.mark.parametrize("primary", [pi(2.0, 1.0), ADRC_PRIMARY], ids=["PID", "ADRC"])
@pytest.mark.parametrize("safe", [0.1, None], ids=["safe value", "hold"])
def test_cascade_primary_holds_while_y2_is_bad_with_the_secondary_in_auto(primary, safe):
    """200 s of a bad y2 with a primary error of 0.8: the primary holds, no windup.

    The secondary outputs its safe value (or holds, ``safe_value = None``): the
    inner loop is open.  Before the fix the primary integrated its error for
    the whole stretch (the PID to its limit 100) and the cascade came back
    with the secondary's setpoint there.  Now the primary's output and
    integrator stay put, and the first good sample moves neither the MV nor
    the secondary's setpoint (< 1e-9).
    """
    s = side("cascade", {"primary": primary, "secondary": pi(1.0, 2.0, safe_value=safe)})
    prim, sec = s.blocks["primary"], s.blocks["secondary"]
    for _ in range(20):
        s.step(1.0, 0.2, y2=0.3)
    held, u_before = s.values["sp2"], s.values["v"]
    u_bad, integrator = [], []
    for k in range(2000):  # the primary's own measurement stays good: error 1.0 - 0.2
        y2, ok = (math.nan, True) if k % 2 else (0.3, False)  # non-finite, or flagged
        u_bad.append(s.step(1.0, 0.2, y2=y2, y2_ok=ok))
        assert s.values["sp2"] == held, k  # the primary holds its last output
        assert s.tracking == {"primary": "hold"}
        integrator.append(getattr(prim, "_i", 0.0))  # the PID's I term
    assert prim.out == held and not prim.manual  # held in AUTO (the user's mode)
    assert max(integrator) - min(integrator) < 1e-12  # the integrator stayed put
    assert sec.error_id != 0 and not sec.manual
    assert set(u_bad) == ({0.1} if safe is not None else {u_before})
    u = s.step(1.0, 0.2, y2=0.3)  # y2 good again
    assert s.tracking == {}
    assert abs(u - u_bad[-1]) < 1e-9  # the secondary continues from the MV it applied
    assert abs(s.values["sp2"] - held) < 1e-9  # the primary from the output it held
    for _ in range(5):  # then both act on their errors again
        s.step(1.0, 0.2, y2=0.3)
    assert s.values["sp2"] > held + 1e-3
    assert abs(s.values["sp2"] - held) < 5.0  # no wound-up setpoint


def test_cascade_tracking_status_names_what_the_primary_follows():
    s = side("cascade", {"primary": pi(2.0, 1.0), "secondary": pi(1.0, 2.0)})
    s.step(1.0, 0.2, y2=0.3)
    assert s.tracking == {}
    s.set_manual(True, 0.5)
    s.step(1.0, 0.2, y2=0.3)
    assert s.tracking == {"primary": "y2"}
    s.step(1.0, 0.2, y2=0.3, y2_ok=False)
    assert s.tracking == {"primary": "hold"}
    s.blocks["primary"].manual = True  # the user's manual primary is not tracking
    s.step(1.0, 0.2, y2=0.3)
    assert s.tracking == {}
