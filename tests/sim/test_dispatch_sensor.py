"""Faults of the measurement ``y`` (``sensor`` events) on the compiled lane, every structure.

``ok = false`` flags ``y`` bad (the controllers get ``pv_ok``/``y_ok``
false: ``BAD_MEASUREMENT``), ``nan = true`` replaces the measurement by NaN
(``BAD_INPUT``; recorded as ``ym``); the plants run on the true values
(``y`` is recorded finite).  Each structure runs with ``engine="auto"``,
which must take the lane (no "Python path" line in the DEBUG log, and
``engine="compiled"`` does not refuse), and with ``engine="python"``; every
signal must agree to 1e-12 (NaN where the Python path has NaN) and the
metrics must be the same.  The cases: overlapping and repeated faults (flag
and NaN at once, each cleared apart, a repeated ``ok = false``), a setpoint
step and a manual stretch during a fault, a fault from ``t = 0`` (before the
first sample, with and without the warm-up) and one that lasts to the end.
"""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest

from ctrlblocks.fast._jit import HAVE_NUMBA
from ctrlblocks.sim import parse_scenario, run_scenario

from ..toml_text import toml_table as _table
from ..toml_text import toml_value as _toml

pytestmark = pytest.mark.skipif(not HAVE_NUMBA, reason="the compiled lane needs numba")

HEAD = """
[scenario]
name = "faults"
title = "faults"
source = "test"
structure = "{structure}"
ts = 0.1
duration = 80.0
seed = 7
[sensor]
noise = 0.01
[initial]
{initial}
"""


def _case(name: str, *events: dict, duration: float | None = None) -> str:
    head = _table("[cases]", name=name, **({} if duration is None else {"duration": duration}))
    return head + "".join(_table("[cases.events]", **ev) for ev in events)


def _cases(sp1: float, sp2: float, um: float, *more: str) -> str:
    """The fault cases (module docstring); ``um`` a manual value during a fault."""
    overlap = _case(
        "overlap",
        dict(t=5.0, do="setpoint", value=sp1),
        dict(t=15.0, do="sensor", ok=False),
        dict(t=20.0, do="setpoint", value=sp2),  # an error builds up behind the fault
        dict(t=25.0, do="sensor", nan=True),  # flagged and NaN
        dict(t=30.0, do="sensor", ok=True),  # still NaN
        dict(t=35.0, do="sensor", nan=False),  # good again
        dict(t=45.0, do="sensor", ok=False),
        dict(t=47.0, do="sensor", ok=False),  # repeated
        dict(t=50.0, do="mode", mode="manual"),
        dict(t=53.0, do="manual_value", value=um),
        dict(t=55.0, do="sensor", ok=True),  # good in manual
        dict(t=60.0, do="mode", mode="auto"),
        dict(t=64.0, do="sensor", ok=False, nan=True),  # both in one event
        dict(t=64.0, do="setpoint", value=sp1),
        dict(t=70.0, do="sensor", ok=True, nan=False),
    )
    start = _case(
        "from the start",
        dict(t=0.0, do="sensor", nan=True),
        dict(t=3.0, do="setpoint", value=sp1),
        dict(t=10.0, do="sensor", nan=False),
        duration=40.0,
    )
    start_flag = _case(
        "flagged from the start",
        dict(t=0.0, do="sensor", ok=False),
        dict(t=6.0, do="sensor", ok=True),
        dict(t=8.0, do="setpoint", value=sp1),
        duration=30.0,
    )
    end = _case(
        "to the end",
        dict(t=5.0, do="setpoint", value=sp1),
        dict(t=40.0, do="sensor", ok=False),
        dict(t=45.0, do="setpoint", value=sp2),
        dict(t=50.0, do="sensor", nan=True),
        duration=60.0,
    )
    return overlap + start + start_flag + end + "".join(more)


# the samples of each case where y is flagged bad, and where ym is NaN
BAD = {
    "overlap": [(15.0, 35.0), (45.0, 55.0), (64.0, 70.0)],
    "from the start": [(0.0, 10.0)],
    "flagged from the start": [(0.0, 6.0)],
    "to the end": [(40.0, 60.0)],
}
NAN = {
    "overlap": [(25.0, 35.0), (64.0, 70.0)],
    "from the start": [(0.0, 10.0)],
    "flagged from the start": [],
    "to the end": [(50.0, 60.0)],
    "y and y2": [(28.0, 38.0)],  # (the cascade's case)
    "y2 faults": [(15.0, 30.0)],  # (the override's case)
}


def _mask(t, spans):
    m = np.zeros(t.shape, dtype=bool)
    for t0, t1 in spans:
        m |= (t >= t0 - 1e-9) & (t < t1 - 1e-9)
    return m


def _pid(kp: float, ti: float, lo: float, hi: float, aw: str = "clamping", **extra) -> str:
    more = "".join(f"{k} = {_toml(v)}\n" for k, v in extra.items())
    return (f'type = "PID"\nkp = {kp}\nti = {ti}\nu_min = {lo}\nu_max = {hi}\n'
            f'anti_windup = "{aw}"\n{more}')  # fmt: skip


def _adrc(b0: float, wc: float, wo: float, lo: float, hi: float, order: int = 1, **extra) -> str:
    more = "".join(f"{k} = {_toml(v)}\n" for k, v in extra.items())
    return (f'type = "ADRC"\norder = {order}\nb0 = {b0}\nomega_c = {wc}\nomega_o = {wo}\n'
            f"u_min = {lo}\nu_max = {hi}\n{more}")  # fmt: skip


def _same(text: str, caplog, nan_spans: dict | None = None):
    """Both engines on every run: the lane ran each, equal to Python; returns the runs.

    ``ym`` must be NaN exactly in the spans ``nan_spans`` (default :data:`NAN`) of each case.
    """
    nan_spans = NAN if nan_spans is None else nan_spans
    sc = parse_scenario(text)
    with caplog.at_level(logging.DEBUG, logger="ctrlblocks.sim.dispatch"):
        caplog.clear()
        auto = run_scenario(sc)
    assert "Python path" not in caplog.text, caplog.text
    comp = run_scenario(sc, engine="compiled")  # refuses nothing
    ref = run_scenario(sc, engine="python")
    assert [(r.controller, r.case) for r in auto.runs] == [(r.controller, r.case) for r in ref.runs]
    for ra, rb, rc in zip(auto.runs, ref.runs, comp.runs, strict=True):
        assert list(ra.signals) == list(rb.signals)
        for name, x in ra.signals.items():
            where = f"{ra.controller} / {ra.case}: {name}"
            np.testing.assert_array_equal(np.isnan(x), np.isnan(rb.signals[name]), err_msg=where)
            np.testing.assert_allclose(x, rb.signals[name], rtol=0.0, atol=1e-12, err_msg=where)
            assert np.array_equal(x, rc.signals[name], equal_nan=True), where
    assert auto.metrics == ref.metrics and auto.claims == ref.claims
    for r in auto.runs:  # the faults acted: ym NaN exactly in the NaN spans, y never
        t, ym = r.signals["t"], r.signals["ym"]
        assert np.array_equal(np.isnan(ym), _mask(t, nan_spans[r.case])), (r.controller, r.case)
        assert np.all(np.isfinite(r.signals["y"]))
    return {(r.controller, r.case): r.signals for r in auto.runs}


def _held(sig, case: str, value: float | None = None) -> None:
    """In AUTO through each bad span of ``case``: the MV constant (``value`` when given)."""
    t, u = sig["t"], sig["u"]
    for t0, t1 in BAD[case]:
        if case == "overlap" and t0 == 45.0:
            continue  # the manual stretch inside it
        bad = _mask(t, [(t0, t1)])
        if value is None:
            assert np.ptp(u[bad]) == 0.0, (case, t0)
        else:
            assert np.all(u[bad] == value), (case, t0)


# -- single loop ---------------------------------------------------------------------

SINGLE = (
    HEAD.format(structure="single", initial="y = 0.5\nwarmup = 2.0")
    + _table("plant", type="FOPDT", k=1.5, t=8.0, dead_time=1.0)
    + _table("actuator", u_min=0.0, u_max=2.0, rate=1.0)
)


def _single(name: str, body: str) -> str:
    return f'[[controllers]]\nname = "{name}"\n{body}'


SINGLE_CONTROLLERS = "".join([
    _single("PI holds", _pid(1.2, 6.0, 0.0, 2.0)),
    _single("PID safe value", _pid(1.2, 6.0, 0.0, 2.0, "back_calc_model", td=0.5,
                                   safe_value=0.25)),
    _single("ADRC", _adrc(0.2, 0.4, 2.0, 0.0, 2.0, u_sf=0.3)),
    _single("ADRC n = 2", _adrc(0.05, 0.5, 2.5, 0.0, 2.0, order=2, u_sf=0.6, t_ref=2.0)),
])  # fmt: skip


@pytest.mark.parametrize("warmup", [2.0, 0.0])
def test_single_loop_with_faults_of_y_on_the_lane_equals_python(warmup, caplog):
    text = SINGLE.replace("warmup = 2.0", f"warmup = {warmup}")
    sig = _same(text + _cases(1.0, 1.3, 0.4) + SINGLE_CONTROLLERS, caplog)
    for case in BAD:
        _held(sig["PI holds", case], case)
        _held(sig["PID safe value", case], case, 0.25)
        _held(sig["ADRC", case], case, 0.3)
        _held(sig["ADRC n = 2", case], case, 0.6)
    # the manual value during the fault (the operator's value, t = 53..55 flagged bad)
    s = sig["PI holds", "overlap"]
    assert np.all(s["u"][_mask(s["t"], [(53.0, 60.0)])] == 0.4)
    # bumpless recovery: the first good sample continues from the held output (the PID's
    # integrator re-initialised, the ADRC's x4 re-solved), then the law acts on the error
    for name in ("PI holds", "ADRC"):
        s = sig[name, "overlap"]
        k = int(np.searchsorted(s["t"], 35.0 - 1e-9))
        assert abs(s["u"][k] - s["u"][k - 1]) < 1e-9, name
        assert abs(s["u"][k + 30] - s["u"][k]) > 0.01, name


# -- cascade -------------------------------------------------------------------------

CASCADE = (
    HEAD.format(structure="cascade", initial="y = 0.5\nwarmup = 2.0")
    + _table("inner_plant", type="PT1", k=1.0, t=1.5)
    + _table("plant", type="FOPDT", k=1.5, t=8.0, dead_time=1.0)
    + _table("actuator", u_min=0.0, u_max=1.2, rate=2.0)
)
# y and y2 bad at once and apart, the secondary in manual with y bad (the primary then
# tracks y2 on a bad y)
Y_AND_Y2 = _case(
    "y and y2",
    dict(t=5.0, do="setpoint", value=1.0),
    dict(t=10.0, do="sensor", ok=False),
    dict(t=14.0, do="sensor", target="y2", nan=True),
    dict(t=18.0, do="sensor", ok=True),
    dict(t=22.0, do="sensor", target="y2", nan=False),
    dict(t=26.0, do="sensor", target="y2", ok=False),
    dict(t=28.0, do="sensor", nan=True),
    dict(t=32.0, do="sensor", target="y2", ok=True),
    dict(t=34.0, do="mode", mode="manual", manual_value=0.6),
    dict(t=38.0, do="sensor", nan=False),
    dict(t=40.0, do="sensor", ok=False),
    dict(t=44.0, do="mode", mode="auto"),
    dict(t=48.0, do="sensor", ok=True),
    duration=60.0,
)


def _cascade(name: str, primary: str, secondary: str, extra: str = "") -> str:
    return (f'[[controllers]]\nname = "{name}"\n{extra}[controllers.primary]\n{primary}'
            f"[controllers.secondary]\n{secondary}")  # fmt: skip


CASCADE_CONTROLLERS = "".join([
    _cascade("PID / PID", _pid(1.5, 8.0, -1.0, 3.0), _pid(2.0, 1.0, 0.0, 1.2)),
    _cascade("PID safe / PID", _pid(1.5, 8.0, -1.0, 3.0, "back_calc_model", safe_value=0.7),
             _pid(2.0, 1.0, 0.0, 1.2, safe_value=0.3)),
    _cascade("ADRC / PID", _adrc(0.2, 0.3, 1.5, -1.0, 3.0, u_sf=0.8), _pid(2.0, 1.0, 0.0, 1.2),
             "aw_handshake = false\n"),
    _cascade("ADRC / ADRC", _adrc(0.2, 0.3, 1.5, -1.0, 3.0),
             _adrc(0.7, 1.0, 5.0, 0.0, 1.2, u_sf=0.2)),
])  # fmt: skip


def test_cascade_with_faults_of_y_on_the_lane_equals_python(caplog):
    """The primary measures ``y``: it runs its bad cycle, the secondary follows its output."""
    sig = _same(CASCADE + _cases(1.0, 1.4, 0.6, Y_AND_Y2) + CASCADE_CONTROLLERS, caplog)
    for case in BAD:  # the secondary's setpoint: the primary's held output or its safe value
        _held({"t": sig["PID / PID", case]["t"], "u": sig["PID / PID", case]["sp2"]}, case)
        _held({"t": sig["PID safe / PID", case]["t"], "u": sig["PID safe / PID", case]["sp2"]},
              case, 0.7)  # fmt: skip
        _held({"t": sig["ADRC / PID", case]["t"], "u": sig["ADRC / PID", case]["sp2"]}, case,
              0.8)  # fmt: skip
    # the secondary in manual with y bad: the primary tracks y2 (sp2 = y2)
    s = sig["PID / PID", "y and y2"]
    man = _mask(s["t"], [(40.0, 44.0)])
    assert np.all(s["sp2"][man] == s["y2"][man]) and np.all(s["u"][man] == 0.6)


# -- override ------------------------------------------------------------------------

OVERRIDE = (
    HEAD.format(structure="override", initial="y = 0.3\nwarmup = 1.0")
    + _table("inner_plant", type="PT1", k=1.0, t=1.0)
    + _table("plant", type="PT2", k=2.0, t1=4.0, t2=1.0)
    + _table("actuator", u_min=-0.5, u_max=1.0)
)
Y2_ONLY = _case(
    "y2 faults",
    dict(t=5.0, do="setpoint", value=1.2),
    dict(t=10.0, do="sensor", target="y2", ok=False),
    dict(t=15.0, do="sensor", nan=True),
    dict(t=20.0, do="sensor", target="y2", ok=True),
    dict(t=25.0, do="sensor", target="y2", nan=True),
    dict(t=30.0, do="sensor", nan=False),
    dict(t=35.0, do="sensor", target="y2", nan=False),
    duration=50.0,
)


@pytest.mark.parametrize("selector", ["min", "max"])
def test_override_with_faults_of_y_and_y2_on_the_lane_equals_python(selector, caplog):
    """Every block runs its bad cycle while ``y`` or ``y2`` is bad (``Override.compute``
    passes ``y_ok and y2_ok`` to all), and commits with the selected MV."""
    limit = 0.45 if selector == "min" else 0.1
    text = (
        OVERRIDE
        + _cases(1.5, 1.0, 0.2, Y2_ONLY)
        + f"""
[[controllers]]
name = "{selector}"
selector = "{selector}"
[[controllers.blocks]]
measure = "y"
{_pid(1.0, 3.0, -0.5, 1.0, "back_calc_model", b=0.5, safe_value=0.2)}
[[controllers.blocks]]
measure = "y2"
sp = {limit}
{_pid(6.0, 0.5, -0.5, 1.0)}
[[controllers.blocks]]
measure = "y"
sp = 1.8
{_adrc(0.3, 0.5, 2.5, -0.5, 1.0, u_sf=0.4)}
"""
    )
    sig = _same(text, caplog)
    s = sig[selector, "y2 faults"]
    bad = _mask(s["t"], [(10.0, 35.0)])
    pick = 0.2 if selector == "min" else 0.4  # the safe values; the PID on y2 holds
    assert np.all(s["v1"][bad] == 0.2) and np.all(s["v3"][bad] == 0.4)
    held = s["v2"][bad][0]
    assert np.all(s["u"][bad] == (min if selector == "min" else max)(pick, held))


# -- feed-forward and Smith predictor --------------------------------------------------

FEEDFORWARD = (
    HEAD.format(structure="feedforward", initial="y = 1.0\nload = 0.3\nwarmup = 3.0")
    + _table("plant", type="PTn", k=2.0, t=[3.0, 1.0], dead_time=0.5)
    + _table("actuator", u_min=-2.0, u_max=2.0)
    + _table("[events]", t=22.0, do="load", value=-0.4)
)


def test_feedforward_with_faults_of_y_on_the_lane_equals_python(caplog):
    text = FEEDFORWARD + _cases(1.5, 0.8, 0.1)
    for name, safe in (("holds", {}), ("safe value", {"safe_value": -0.5})):
        text += (f'[[controllers]]\nname = "{name}"\n[controllers.main]\n'
                 f"{_pid(0.8, 4.0, -2.0, 2.0, td=0.5, **safe)}"
                 '[controllers.feedforward]\ntype = "LeadLag"\nk = -1.0\nt_lead = 2.0\n'
                 "t_lag = 1.0\n")  # fmt: skip
    sig = _same(text, caplog)
    for case in BAD:
        _held(sig["holds", case], case)
        _held(sig["safe value", case], case, -0.5)
    s = sig["holds", "overlap"]  # the lead-lag ran on through the fault (the load at t = 22)
    bad = _mask(s["t"], [(15.0, 35.0)])
    assert np.ptp(s["ff"][bad]) > 0.1


SMITH = HEAD.format(structure="smith", initial="y = 0.2\nwarmup = 2.0") + _table(
    "plant", type="FOPDT", k=1.0, t=5.0, dead_time=3.0
)


def test_smith_predictor_with_faults_of_y_on_the_lane_equals_python(caplog):
    text = SMITH + _cases(1.0, 0.6, 0.5)
    for name, main in (("PI", _pid(1.0, 5.0, -5.0, 5.0)),
                       ("ADRC", _adrc(0.2, 0.8, 4.0, -5.0, 5.0, u_sf=0.1))):  # fmt: skip
        text += f'[[controllers]]\nname = "{name}"\n[controllers.main]\n{main}' + _table(
            "controllers.model", type="FOPDT", k=0.9, t=6.0, dead_time=3.0
        )
    sig = _same(text, caplog)
    for case in BAD:
        _held(sig["PI", case], case)
        _held(sig["ADRC", case], case, 0.1)
        s = sig["PI", case]  # the predictor's feedback is NaN with the measurement
        assert np.array_equal(np.isnan(s["y_pred"]), np.isnan(s["ym"]))
    assert math.isnan(sig["ADRC", "from the start"]["y_pred"][0])
