"""The cascade, override, feed-forward and Smith structures on the compiled lane.

Each structure runs with ``engine="auto"`` (which must take the lane: no
"Python path" line in the DEBUG log) and ``engine="python"`` (the
reference); every signal must agree to 1e-12, and the metrics must be the
same.  The scenarios exercise what the wiring adds: the cascade's AW
handshake with the secondary at its limit (and without it), an ADRC
secondary, loads between the plants; the override's min and max selectors
with tracking (Åström 1987, Fig. 3.9), fixed setpoints and blocks on ``y``
and ``y2``; the feed-forward lead-lag during the warm-up and after input
loads; the Smith predictor with an exact and a wrong model (Nowak et al.
2018, section 3.1).  Mode and manual-value events, noise and the warm-up
act on every structure.
"""

from __future__ import annotations

import logging
import math
import re

import numpy as np
import pytest

from ctrlblocks.fast._jit import HAVE_NUMBA
from ctrlblocks.sim import parse_scenario, run_scenario
from ctrlblocks.sim.report import load_shipped

from ..toml_text import toml_table as _table
from ..toml_text import toml_value as _toml

pytestmark = pytest.mark.skipif(not HAVE_NUMBA, reason="the compiled lane needs numba")

HEAD = """
[scenario]
name = "lane"
title = "lane"
source = "test"
structure = "{structure}"
ts = 0.1
duration = {duration}
seed = 3
[sensor]
noise = 0.01
[initial]
{initial}
"""


def _events(sp1: float, load: float, um: float, sp2: float, *more: dict) -> str:
    """Setpoint steps and a ramp, an input load, manual with a new manual value, auto."""
    evs = [dict(t=2.0, do="setpoint", value=sp1), dict(t=20.0, do="load", value=load),
           dict(t=35.0, do="mode", mode="manual"), dict(t=38.0, do="manual_value", value=um),
           dict(t=42.0, do="mode", mode="auto"),
           dict(t=50.0, do="setpoint", value=sp2, ramp=0.05), *more]  # fmt: skip
    return "".join(_table("[events]", **ev) for ev in evs)


def _pid(kp: float, ti: float, lo: float, hi: float, aw: str = "clamping", **extra) -> str:
    more = "".join(f"{k} = {v}\n" for k, v in extra.items())
    return (f'type = "PID"\nkp = {kp}\nti = {ti}\nu_min = {lo}\nu_max = {hi}\n'
            f'anti_windup = "{aw}"\n{more}')  # fmt: skip


def _same(text, caplog, duration: float | None = None):
    """Run ``text`` (or a scenario) on both engines; the lane ran every run and equals Python."""
    sc = parse_scenario(text) if isinstance(text, str) else text
    with caplog.at_level(logging.DEBUG, logger="ctrlblocks.sim.dispatch"):
        caplog.clear()
        auto = run_scenario(sc, duration=duration)
    assert "Python path" not in caplog.text, caplog.text
    ref = run_scenario(sc, duration=duration, engine="python")
    assert [(r.controller, r.case) for r in auto.runs] == [(r.controller, r.case) for r in ref.runs]
    for ra, rb in zip(auto.runs, ref.runs, strict=True):
        assert list(ra.signals) == list(rb.signals)
        for name, x in ra.signals.items():
            np.testing.assert_allclose(x, rb.signals[name], rtol=0.0, atol=1e-12, err_msg=name)
    assert auto.metrics == ref.metrics and auto.claims == ref.claims
    return auto


# -- cascade -------------------------------------------------------------------------

CASCADE = (
    HEAD.format(structure="cascade", duration=70.0, initial="y = 0.5\nwarmup = 2.0")
    + _table("inner_plant", type="PT1", k=1.0, t=1.5)
    + _table("plant", type="FOPDT", k=1.5, t=8.0, dead_time=1.0)
    + _table("actuator", u_min=0.0, u_max=1.2, rate=2.0)
    + _events(1.6, -0.2, 0.4, 1.0, dict(t=28.0, do="load", at="inner", value=0.1))
)


def _cascade(name: str, primary: str, secondary: str, extra: str = "") -> str:
    return (f'[[controllers]]\nname = "{name}"\n{extra}[controllers.primary]\n{primary}'
            f"[controllers.secondary]\n{secondary}")  # fmt: skip


def test_cascade_on_the_lane_equals_the_python_path(caplog):
    sec = _pid(2.0, 1.0, 0.0, 1.2)
    adrc = ('type = "ADRC"\norder = 1\nb0 = 0.7\nomega_c = 1.0\nomega_o = 5.0\n'
            "u_min = 0.0\nu_max = 1.2\n")  # fmt: skip
    text = CASCADE + "\n".join([
        _cascade("handshake", _pid(1.5, 8.0, -1.0, 3.0), sec),
        _cascade("no handshake", _pid(1.5, 8.0, -1.0, 3.0, "back_calc_model"), sec,
                 "aw_handshake = false\n"),
        _cascade("ADRC secondary", _pid(1.2, 6.0, -1.0, 3.0), adrc),
    ])  # fmt: skip
    res = _same(text, caplog)
    sig = {r.controller: r.signals for r in res.runs}
    # the secondary reached its limit (the handshake's case) and the events acted
    assert sig["handshake"]["u"].max() == pytest.approx(1.2)
    t = sig["handshake"]["t"]
    assert sig["handshake"]["u"][np.searchsorted(t, 40.0)] == 0.4
    # the handshake changed the primary's course
    assert not np.array_equal(sig["handshake"]["sp2"], sig["no handshake"]["sp2"])


# the secondary in MAN for 60 s while the primary's setpoint steps (a primary error)
CASCADE_MAN = (
    HEAD.format(structure="cascade", duration=120.0, initial="y = 0.5\nwarmup = 2.0")
    + _table("inner_plant", type="PT1", k=1.0, t=1.5)
    + _table("plant", type="FOPDT", k=1.5, t=8.0, dead_time=1.0)
    + _table("actuator", u_min=0.0, u_max=1.2)
    + "".join(_table("[events]", **ev) for ev in [
        dict(t=10.0, do="mode", mode="manual", manual_value=0.5),
        dict(t=20.0, do="setpoint", value=1.4), dict(t=40.0, do="load", at="inner", value=0.1),
        dict(t=45.0, do="manual_value", value=0.6),
        dict(t=70.0, do="mode", mode="auto")])
)  # fmt: skip


@pytest.mark.parametrize("primary", ["PID", "ADRC"])
def test_cascade_primary_tracks_y2_while_the_secondary_is_in_manual(primary, caplog):
    """The cascade opened by the operator: no windup of the primary, bumpless back.

    Before the fix the primary integrated its error of 60 s and the return to
    AUTO (secondary bumpless, primary not) drove the secondary's setpoint
    from its limit.  Now (both engines) the primary's output equals ``y2``
    in every sample in MAN, and the first sample back in AUTO moves neither
    the MV nor the secondary's setpoint.
    """
    prim = (_pid(1.5, 8.0, -1.0, 3.0) if primary == "PID" else
            'type = "ADRC"\norder = 1\nb0 = 0.2\nomega_c = 0.3\nomega_o = 1.5\n'
            "u_min = -1.0\nu_max = 3.0\n")  # fmt: skip
    text = CASCADE_MAN + _cascade("c", prim, _pid(2.0, 1.0, 0.0, 1.2), "aw_handshake = false\n")
    sig = _same(text, caplog).runs[0].signals
    t, u, sp2, y2, sp, ym = (sig[k] for k in ("t", "u", "sp2", "y2", "sp", "ym"))
    man = (t >= 10.0 - 1e-9) & (t < 70.0 - 1e-9)
    assert set(u[man]) == {0.5, 0.6} and np.all(sp2[man] == y2[man])
    assert np.ptp(y2[man]) > 0.09  # y2 moved and the primary followed it
    assert sp[man][-1] - ym[man][-1] > 0.3  # the primary's error was there all along
    k = int(np.searchsorted(t, 70.0 - 1e-9))
    assert abs(u[k] - u[k - 1]) < 1e-9 and abs(sp2[k] - sp2[k - 1]) < 1e-9
    assert sp2[k + 20] > sp2[k] + 0.1  # then the primary acts on its error again


def test_cascade_with_an_adrc_primary_and_the_handshake_on_the_lane_equals_python(caplog):
    """The ADRC primary's awin (x4 frozen, Nowak et al. 2018, section 5) on the lane."""
    adrc = ('type = "ADRC"\norder = 1\nb0 = 0.2\nomega_c = 0.3\nomega_o = 1.5\n'
            "u_min = -1.0\nu_max = 3.0\n")  # fmt: skip
    sec, sec_adrc = _pid(2.0, 1.0, 0.0, 1.2), adrc.replace("b0 = 0.2", "b0 = 0.7")
    text = CASCADE + "\n".join([
        _cascade("handshake", adrc, sec),
        _cascade("no handshake", adrc, sec, "aw_handshake = false\n"),
        _cascade("ADRC / ADRC", adrc.replace("omega_c = 0.3", "omega_c = 0.4"),
                 sec_adrc.replace("u_min = -1.0\nu_max = 3.0", "u_min = 0.0\nu_max = 1.2")),
    ])  # fmt: skip
    sig = {r.controller: r.signals for r in _same(text, caplog).runs}
    assert sig["handshake"]["u"].max() == pytest.approx(1.2)  # the secondary at its limit
    assert sig["ADRC / ADRC"]["u"].max() == pytest.approx(1.2)
    # the handshake froze the primary's x4: another course than without it
    assert np.max(np.abs(sig["handshake"]["sp2"] - sig["no handshake"]["sp2"])) > 0.05


@pytest.mark.parametrize("primary", ["PID", "ADRC"])
@pytest.mark.parametrize("secondary", ["PID", "PID safe", "ADRC"])
@pytest.mark.parametrize("compiled", [True, False], ids=["compiled", "interpreted"])
def test_lane_cascade_on_a_bad_y2_equals_the_controller_side(primary, secondary, compiled):
    """The lane's controller side (``_controllers``) on a bad ``y2`` equals ``ControllerSide``.

    Flagged bad (finite) or NaN, the secondary in AUTO or in manual: the
    primary holds its last output (``Wiring.follow``; before: it computed
    its law on its error, 0.8 here) and the secondary runs its
    bad-measurement cycle (``_bad``: hold, its ``safe_value``, the ADRC's
    ``u_sf``; the manual value in manual).  Before, a NaN ``y2`` with the
    secondary in AUTO gave a non-finite MV (the lane stopped) and a flagged
    ``y2`` was not seen at all.  The lane reads the cascade from its wiring
    (``_codes``), as the Python path does.
    """
    from ctrlblocks.fast._jit import python_function
    from ctrlblocks.fast.simlane import _codes, _controllers, _safe_value, _slot
    from ctrlblocks.sim import ControllerSide
    from ctrlblocks.sim.scenario import parse_controller

    lim = {"u_min": -100.0, "u_max": 100.0}
    adrc = {"type": "ADRC", "order": 1, "b0": 0.5, "omega_c": 1.0, "omega_o": 5.0, **lim}
    prim = {"type": "PID", "kp": 2.0, "ti": 1.0, **lim} if primary == "PID" else adrc
    sec = {"PID": {"type": "PID", "kp": 1.0, "ti": 2.0, **lim},
           "PID safe": {"type": "PID", "kp": 1.0, "ti": 2.0, "safe_value": 7.0, **lim},
           "ADRC": dict(adrc, u_sf=-3.0)}[secondary]  # fmt: skip
    entry = {"name": "c", "primary": prim, "secondary": sec}
    side = ControllerSide("cascade", parse_controller(entry, "cascade", 0.1, key="c"), 0.1)
    for _ in range(20):
        side.step(1.0, 0.2, y2=0.3)
    pb, sb = side.blocks["primary"], side.blocks["secondary"]
    slots = [_slot(b, b.manual_value) for b in (pb, sb)]
    kinds = np.array([s[0] for s in slots], dtype=np.int64)
    pprm, aprm, cst = (np.array([s[i] for s in slots]) for i in (1, 2, 3))
    safe = np.array([_safe_value(b, s[0]) for b, s in zip((pb, sb), slots, strict=True)])
    wire, sp_fix, mv_src, _src, names = _codes(side)
    assert names == ("sp2",) and mv_src == 1  # the secondary makes the MV
    fn = _controllers if compiled else python_function(_controllers)
    # the MV in AUTO: the secondary's last output held, its safe value; in manual: its manual value
    want = {False: {"PID": cst[1, 4], "PID safe": 7.0, "ADRC": -3.0}[secondary], True: cst[1, 9]}
    for y2, ok2 in ((math.nan, True), (0.3, False)):
        for m1 in (False, True):  # the secondary in AUTO, in manual
            st, v = cst.copy(), np.empty(2)
            awin, aw, good, track = (np.zeros(2, dtype=np.bool_) for _ in range(4))
            u, ok = fn(kinds, pprm, aprm, st, wire, sp_fix, safe, mv_src,
                       np.array([False, m1]), 1.0, (0.2, y2, math.nan), (True, ok2), 0.0,
                       awin, v, aw, good, track, np.empty(2), np.zeros((2, 9)))  # fmt: skip
            sb.manual = m1
            u_ref = side.compute(1.0, 0.2, y2=y2, y2_ok=ok2)
            assert ok is True and v[0] == pb.out  # the primary held, as the Python path
            assert side.tracking == {"primary": "hold"}
            assert abs(side.values["sp2"] - v[0]) < 1e-12 and abs(u - u_ref) < 1e-12
            assert u == want[m1]


# y2 flagged bad for 20 s with a setpoint step in it (a primary error), then NaN for 20 s
# with the secondary in manual for part of it and a load between the plants
CASCADE_Y2 = (
    HEAD.format(structure="cascade", duration=110.0, initial="y = 0.5\nwarmup = 2.0")
    + _table("inner_plant", type="PT1", k=1.0, t=1.5)
    + _table("plant", type="FOPDT", k=1.5, t=8.0, dead_time=1.0)
    + _table("actuator", u_min=0.0, u_max=1.2, rate=2.0)
    + "".join(_table("[events]", **ev) for ev in [
        dict(t=5.0, do="setpoint", value=1.0),
        dict(t=20.0, do="sensor", target="y2", ok=False),
        dict(t=30.0, do="setpoint", value=1.4),
        dict(t=40.0, do="sensor", target="y2", ok=True),
        dict(t=60.0, do="sensor", target="y2", nan=True),
        dict(t=64.0, do="mode", mode="manual", manual_value=0.6),
        dict(t=70.0, do="load", at="inner", value=0.1),
        dict(t=74.0, do="mode", mode="auto"),
        dict(t=80.0, do="sensor", target="y2", nan=False)])
)  # fmt: skip
Y2_FAULTS = ((20.0, 40.0), (60.0, 80.0))
_ADRC_P = ('type = "ADRC"\norder = 1\nb0 = 0.2\nomega_c = 0.3\nomega_o = 1.5\n'
           "u_min = -1.0\nu_max = 3.0\n")  # fmt: skip
_ADRC_S = ('type = "ADRC"\norder = 1\nb0 = 0.7\nomega_c = 1.0\nomega_o = 5.0\n'
           "u_min = 0.0\nu_max = 1.2\nu_sf = 0.2\n")  # fmt: skip
CASCADE_Y2_CONTROLLERS = "\n".join([
    _cascade("PID / PID holds", _pid(1.5, 8.0, -1.0, 3.0), _pid(2.0, 1.0, 0.0, 1.2)),
    _cascade("PID / PID safe value", _pid(1.5, 8.0, -1.0, 3.0),
             _pid(2.0, 1.0, 0.0, 1.2, "back_calc_model", safe_value=0.3, td=0.2)),
    _cascade("ADRC / PID", _ADRC_P, _pid(2.0, 1.0, 0.0, 1.2), "aw_handshake = false\n"),
    _cascade("ADRC / ADRC", _ADRC_P, _ADRC_S),
])  # fmt: skip


def test_cascade_with_y2_faults_on_the_lane_equals_the_python_path(caplog):
    """A flagged and a NaN ``y2`` in a scenario: the compiled lane runs them, equal to 1e-12.

    ``_same`` checks that no run left the lane and every signal against the
    Python path; ``engine="compiled"`` must not refuse any run either.
    Before, the scenario language had no fault of ``y2``; and the lane
    stopped at a NaN ``y2`` with the secondary in AUTO and did not see a
    flagged one.
    """
    sc = parse_scenario(CASCADE_Y2 + CASCADE_Y2_CONTROLLERS)
    res = _same(sc, caplog)
    assert len(res.runs) == 4
    comp = run_scenario(sc, engine="compiled")
    for ra, rb in zip(res.runs, comp.runs, strict=True):
        for name, x in ra.signals.items():
            assert np.array_equal(x, rb.signals[name]), name
    sig = {r.controller: r.signals for r in res.runs}
    t = sig["PID / PID holds"]["t"]
    first = (t >= 20.0 - 1e-9) & (t < 40.0 - 1e-9)
    assert np.all(sig["PID / PID safe value"]["u"][first] == 0.3)  # its safe value
    assert np.all(sig["ADRC / ADRC"]["u"][first] == 0.2)  # u_sf
    # the secondary's manual value in manual during the NaN stretch
    man = (t >= 64.0 - 1e-9) & (t < 74.0 - 1e-9)
    assert all(np.all(s["u"][man] == 0.6) for s in sig.values())


@pytest.mark.parametrize(
    "name", ["PID / PID holds", "PID / PID safe value", "ADRC / PID", "ADRC / ADRC"]
)
def test_cascade_primary_holds_during_a_y2_fault_and_returns_bumplessly(name, caplog):
    """The cascade's bad-``y2`` rule end to end (``Cascade.follow_value``), both engines.

    During each stretch of a bad ``y2`` (flagged, then NaN) the primary's
    output ``sp2`` is constant although its error is there (a setpoint step
    in the first stretch); at the first good sample neither the MV nor
    ``sp2`` moves by 1e-9; then the primary acts on its error again.
    """
    sc = parse_scenario(CASCADE_Y2 + CASCADE_Y2_CONTROLLERS)
    for engine in ("auto", "python"):
        run = next(r for r in run_scenario(sc, engine=engine).runs if r.controller == name)
        t, u, sp2, sp, ym = (run.signals[k] for k in ("t", "u", "sp2", "sp", "ym"))
        for t0, t1 in Y2_FAULTS:
            bad = (t >= t0 - 1e-9) & (t < t1 - 1e-9)
            assert np.ptp(sp2[bad]) == 0.0, (engine, t0)
            k = int(np.searchsorted(t, t1 - 1e-9))  # the first good sample
            assert abs(u[k] - u[k - 1]) < 1e-9 and abs(sp2[k] - sp2[k - 1]) < 1e-9, (engine, t0)
        k = int(np.searchsorted(t, 40.0 - 1e-9))
        assert sp[k - 1] - ym[k - 1] > 0.2  # the primary's error during the first stretch
        assert sp2[k + 30] > sp2[k] + 0.05  # then it acts on it again


def test_a_y2_fault_of_an_override_and_a_y_fault_of_a_cascade_run_on_the_lane(caplog):
    """Both were refused by the lane ("a fault of y2 is covered for
    the cascade only", "(sensor): not covered"); now they run on it, equal to Python."""
    override = (
        HEAD.format(structure="override", duration=30.0, initial="y = 0.5")
        + _table("inner_plant", type="PT1", k=1.0, t=1.5)
        + _table("plant", type="FOPDT", k=1.5, t=8.0, dead_time=1.0)
        + _table("[events]", t=10.0, do="sensor", target="y2", nan=True)
        + '[[controllers]]\nname = "o"\n[[controllers.blocks]]\n' + _pid(1.0, 5.0, 0.0, 2.0)
        + '[[controllers.blocks]]\nmeasure = "y2"\n' + _pid(2.0, 1.0, 0.0, 2.0)
    )  # fmt: skip
    cascade_y = CASCADE_Y2.replace('target = "y2"\nok = false', "ok = false").replace(
        'target = "y2"\nok = true', "ok = true"
    ) + _cascade("c", _pid(1.5, 8.0, -1.0, 3.0), _pid(2.0, 1.0, 0.0, 1.2))
    for text in (override, cascade_y):
        sc = parse_scenario(text)
        run_scenario(sc, engine="compiled")  # not refused
        _same(sc, caplog)


def test_an_event_the_lane_does_not_cover_is_refused_with_the_reason(caplog):
    """What the lane does not run it names (``compiled_blockers``) and the Python path runs."""
    from ctrlblocks.sim.dispatch import CompiledLaneError

    text = CASCADE_Y2.replace('do = "setpoint"\nvalue = 1.4',
                              'do = "set"\nattr = "kp"\nvalue = 1.0')  # fmt: skip
    text += _cascade("c", _pid(1.5, 8.0, -1.0, 3.0), _pid(2.0, 1.0, 0.0, 1.2))
    sc = parse_scenario(text)
    why = "event at t=30 (set): not covered"
    with pytest.raises(CompiledLaneError, match=re.escape(why)):
        run_scenario(sc, engine="compiled")
    with caplog.at_level(logging.DEBUG, logger="ctrlblocks.sim.dispatch"):
        caplog.clear()
        auto = run_scenario(sc)
    assert "Python path" in caplog.text and why in caplog.text
    ref = run_scenario(sc, engine="python")
    for name, x in auto.runs[0].signals.items():
        assert np.array_equal(x, ref.runs[0].signals[name], equal_nan=True), name


# -- override -----------------------------------------------------------------------


def test_override_of_astrom_fig39_on_the_lane_equals_the_python_path(caplog):
    _same(load_shipped(["astrom_fig39"])[0], caplog)


OVERRIDE = (
    HEAD.format(structure="override", duration=70.0, initial="y = 0.3\nwarmup = 1.0")
    + _table("inner_plant", type="PT1", k=1.0, t=1.0)
    + _table("plant", type="PT2", k=2.0, t1=4.0, t2=1.0)
    + _table("actuator", u_min=-0.5, u_max=1.0)
    + _events(1.5, 0.2, 0.2, 0.5)
)


@pytest.mark.parametrize("selector", ["min", "max"])
def test_override_on_the_lane_equals_the_python_path(selector, caplog):
    limit = 0.45 if selector == "min" else 0.1
    text = (
        OVERRIDE
        + f"""
[[controllers]]
name = "{selector}"
selector = "{selector}"
[[controllers.blocks]]
measure = "y"
{_pid(1.0, 3.0, -0.5, 1.0, "back_calc_model", b=0.5)}
[[controllers.blocks]]
measure = "y2"
sp = {limit}
{_pid(6.0, 0.5, -0.5, 1.0)}
"""
    )
    res = _same(text, caplog)
    v1, v2, u = (res.runs[0].signals[k] for k in ("v1", "v2", "u"))
    # both blocks were selected at some time
    pick = np.minimum(v1, v2) if selector == "min" else np.maximum(v1, v2)
    auto = np.isclose(u, pick)
    assert np.any(auto & (v1 != v2) & (u == v1)) and np.any(auto & (v1 != v2) & (u == v2))


@pytest.mark.parametrize(("selector", "n"), [("min", 3), ("max", 4)])
def test_override_of_more_blocks_on_the_lane_equals_the_python_path(selector, n, caplog):
    """Three and four blocks (the lane's override kernel holds any number), each selected."""
    limits = [0.45, 0.2, 1.3] if selector == "min" else [0.35, 0.4, 0.9]
    blocks = [("y", "sp", _pid(1.0, 3.0, -0.5, 1.0, "back_calc_model", b=0.5)),
              ("y2", limits[0], _pid(6.0, 0.5, -0.5, 1.0)),
              ("y", limits[2], _pid(2.0, 2.0, -0.5, 1.0)),
              ("y2", limits[1], _pid(3.0, 1.0, -0.5, 1.0, "back_calc_model"))][:n]  # fmt: skip
    text = (
        OVERRIDE
        + f'[[controllers]]\nname = "{n}"\nselector = "{selector}"\n'
        + "".join(
            f'[[controllers.blocks]]\nmeasure = "{m}"\nsp = {_toml(sp)}\n{pid}'
            for m, sp, pid in blocks
        )
    )
    sig = _same(text, caplog).runs[0].signals
    vs = np.array([sig[f"v{j + 1}"] for j in range(n)])
    u = sig["u"]
    pick = vs.min(axis=0) if selector == "min" else vs.max(axis=0)
    auto = np.isclose(u, pick)
    np.testing.assert_array_equal(u[auto], pick[auto])
    chosen = {int(np.argmax(vs[:, k] == u[k])) for k in np.flatnonzero(auto)
              if np.unique(vs[:, k]).size == n}  # fmt: skip
    assert chosen == set(range(n))  # every block was selected at some time


# -- feed-forward -------------------------------------------------------------------

FEEDFORWARD = (
    HEAD.format(structure="feedforward", duration=70.0, initial="y = 1.0\nload = 0.3\nwarmup = 3.0")
    + _table("plant", type="PTn", k=2.0, t=[3.0, 1.0], dead_time=0.5)
    + _table("actuator", u_min=-2.0, u_max=2.0)
    + _events(1.5, -0.4, 0.1, 0.8, dict(t=30.0, do="load", value=0.5))
)


def test_feedforward_on_the_lane_equals_the_python_path(caplog):
    text = FEEDFORWARD
    for name, k, lead, lag, method in [("tustin", -1.0, 2.0, 1.0, "tustin"),
                                       ("euler", -0.8, 0.5, 2.0, "euler"),
                                       ("static", -0.5, 0.0, 0.0, "euler")]:  # fmt: skip
        text += (f'[[controllers]]\nname = "{name}"\n[controllers.main]\n'
                 f'{_pid(0.8, 4.0, -2.0, 2.0, td=0.5)}'
                 f'[controllers.feedforward]\ntype = "LeadLag"\nk = {k}\nt_lead = {lead}\n'
                 f't_lag = {lag}\nmethod = "{method}"\n')  # fmt: skip
    res = _same(text, caplog)
    ff = res.runs[0].signals["ff"]
    assert ff[0] != 0.0 and len(np.unique(ff)) > 10  # the lead-lag acted from the warm-up on


# -- Smith predictor -------------------------------------------------------------------


def test_smith_predictor_on_the_lane_equals_the_python_path(caplog):
    _same(load_shipped(["nowak_smith"])[0], caplog)  # ADRC n = 1, exact and wrong model
    text = (HEAD.format(structure="smith", duration=70.0, initial="y = 0.2\nwarmup = 2.0")
            + _table("plant", type="FOPDT", k=1.0, t=5.0, dead_time=3.0)
            + _events(1.0, 0.2, 0.5, 0.4)
            + '[[controllers]]\nname = "PI"\n[controllers.main]\n' + _pid(1.0, 5.0, -5.0, 5.0)
            + _table("controllers.model", type="FOPDT", k=0.9, t=6.0, dead_time=3.0))  # fmt: skip
    res = _same(text, caplog)
    assert not np.array_equal(res.runs[0].signals["y_pred"], res.runs[0].signals["ym"])
