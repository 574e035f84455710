"""``limits`` events (``set_limits`` at run time) on the compiled lane, every structure.

A ``limits`` event writes ``u_min``/``u_max`` to the MV blocks (the
cascade's secondary, every override block) or to the block named by
``target``: a valid pair is in force from its sample on and the PID's held
output is limited at once; a refused pair (reversed, NaN: the status
``BAD_LIMITS``) leaves the old limits.  Each structure runs with
``engine="auto"`` (which must take the lane) and ``engine="python"``; every
signal must agree to 1e-12 and the metrics must be the same.  The cases
narrow the limits below the output, refuse a reversed and a NaN pair, widen
them again, change them in manual and during a fault of ``y``, from
``t = 0`` and up to the end.
"""

from __future__ import annotations

import numpy as np
import pytest

from ctrlblocks.fast._jit import HAVE_NUMBA
from ctrlblocks.sim import parse_scenario, run_scenario

from .test_dispatch_sensor import (
    CASCADE,
    FEEDFORWARD,
    OVERRIDE,
    SINGLE,
    SMITH,
    _adrc,
    _cascade,
    _case,
    _mask,
    _pid,
    _same,
)

pytestmark = pytest.mark.skipif(not HAVE_NUMBA, reason="the compiled lane needs numba")

NAN = float("nan")
NO_NAN = {"steps": [], "from the start": [], "primary": [], "one block": []}


def _part(lo: float, hi: float, x: float) -> float:
    return lo + x * (hi - lo)


def _cases(sp1: float, sp2: float, lo: float, mid: float, hi: float, *more: str) -> str:
    """Limits ``lo..mid`` (below the output at ``sp1``), refused pairs, ``lo..hi`` again."""
    steps = _case(
        "steps",
        dict(t=2.0, do="setpoint", value=sp1),
        dict(t=10.0, do="limits", u_min=lo, u_max=mid),  # below the output: limited at once
        dict(t=20.0, do="setpoint", value=sp2),
        dict(t=30.0, do="limits", u_min=hi, u_max=lo),  # reversed: refused
        dict(t=35.0, do="limits", u_min=lo, u_max=NAN),  # NaN: refused
        dict(t=40.0, do="limits", u_min=lo, u_max=hi),
        dict(t=50.0, do="mode", mode="manual", manual_value=hi),
        dict(t=52.0, do="limits", u_min=lo, u_max=mid),  # the manual value limited
        # the last output limited at once: the bumpless transfers continue from it
        dict(t=56.0, do="mode", mode="auto"),
        dict(t=56.0, do="limits", u_min=lo, u_max=_part(lo, mid, 0.5)),
        dict(t=60.0, do="sensor", ok=False),
        dict(t=62.0, do="limits", u_min=lo, u_max=_part(lo, mid, 0.3)),  # the held output
        dict(t=66.0, do="sensor", ok=True),
        dict(t=66.0, do="limits", u_min=lo, u_max=_part(lo, mid, 0.2)),
        dict(t=70.0, do="limits", u_min=lo, u_max=hi),  # to the end
    )
    start = _case(
        "from the start",
        dict(t=0.0, do="limits", u_min=lo, u_max=mid),
        dict(t=0.0, do="setpoint", value=sp1),
        dict(t=25.0, do="limits", u_min=lo, u_max=hi),
        duration=40.0,
    )
    return steps + start + "".join(more)


def _within(sig, spans_limits, name: str = "u") -> None:
    """Where each ``(t0, t1, lo, hi)`` holds, the signal is inside ``[lo, hi]`` and reaches
    ``hi`` (the limits were in force and mattered)."""
    t, u = sig["t"], sig[name]
    for t0, t1, lo, hi in spans_limits:
        m = _mask(t, [(t0, t1)])
        assert np.all((u[m] >= lo) & (u[m] <= hi)), (name, t0)
        assert np.any(u[m] == hi), (name, t0)


# the single loop's output is about 0.8 at sp = 1.2 (FOPDT gain 1.5) and 0.93 at 1.4
SINGLE_STEPS = [(10.0, 40.0, 0.0, 0.6), (52.0, 56.0, 0.0, 0.6)]


@pytest.mark.parametrize("warmup", [2.0, 0.0])
def test_single_loop_with_limits_events_on_the_lane_equals_python(warmup, caplog):
    text = SINGLE.replace("warmup = 2.0", f"warmup = {warmup}") + _cases(1.2, 1.4, 0.0, 0.6, 2.0)
    text += "".join(
        f'[[controllers]]\nname = "{name}"\n{body}'
        for name, body in [
            ("PI", _pid(1.2, 6.0, 0.0, 2.0)),
            ("PID back-calc", _pid(1.2, 6.0, 0.0, 2.0, "back_calc_model", td=0.5)),
            ("ADRC", _adrc(0.2, 0.4, 2.0, 0.0, 2.0, u_sf=0.3)),
        ]
    )
    sig = _same(text, caplog, NO_NAN)
    for name in ("PI", "PID back-calc", "ADRC"):
        s = sig[name, "steps"]
        _within(s, SINGLE_STEPS)
        k = int(np.searchsorted(s["t"], 10.0 - 1e-9))
        assert s["u"][k - 1] > 0.6 and s["u"][k] == 0.6, name  # limited at once
        _within(sig[name, "from the start"], [(0.0, 25.0, 0.0, 0.6)])
    # the held output (PID: hold) limited at once during the fault of y
    s = sig["PI", "steps"]
    assert np.all(s["u"][_mask(s["t"], [(62.0, 66.0)])] == _part(0.0, 0.6, 0.3))


def test_cascade_with_limits_events_on_the_lane_equals_python(caplog):
    """The secondary's limits (the MV's) and, named by ``target``, the primary's."""
    primary = _case(
        "primary",
        dict(t=2.0, do="setpoint", value=1.4),
        dict(t=10.0, do="limits", target="primary", u_min=-1.0, u_max=0.8),
        dict(t=20.0, do="limits", target="primary", u_min=1.0, u_max=0.0),  # refused
        dict(t=30.0, do="limits", target="primary", u_min=-1.0, u_max=3.0),
        duration=45.0,
    )
    text = CASCADE + _cases(1.2, 1.4, 0.0, 0.6, 1.2, primary) + "".join([
        _cascade("PID / PID", _pid(1.5, 8.0, -1.0, 3.0), _pid(2.0, 1.0, 0.0, 1.2)),
        _cascade("ADRC / PID", _adrc(0.2, 0.3, 1.5, -1.0, 3.0, u_sf=0.8),
                 _pid(2.0, 1.0, 0.0, 1.2, "back_calc_model"), "aw_handshake = false\n"),
        _cascade("PID / ADRC", _pid(1.5, 8.0, -1.0, 3.0),
                 _adrc(0.7, 1.0, 5.0, 0.0, 1.2, u_sf=0.2)),
    ])  # fmt: skip
    sig = _same(text, caplog, NO_NAN)
    for name in ("PID / PID", "ADRC / PID", "PID / ADRC"):
        _within(sig[name, "steps"], [(10.0, 40.0, 0.0, 0.6)])
        _within(sig[name, "primary"], [(10.0, 30.0, -1.0, 0.8)], "sp2")


def test_override_with_limits_events_on_the_lane_equals_python(caplog):
    """Every block's limits, and one block's named by ``target``."""
    one = _case(
        "one block",
        dict(t=2.0, do="setpoint", value=1.5),
        dict(t=10.0, do="limits", target="blocks[1]", u_min=-0.5, u_max=0.2),
        dict(t=30.0, do="limits", target="blocks[1]", u_min=-0.5, u_max=1.0),
        duration=45.0,
    )
    text = OVERRIDE + _cases(1.5, 1.0, -0.5, 0.3, 1.0, one) + f"""
[[controllers]]
name = "min"
[[controllers.blocks]]
measure = "y"
{_pid(1.0, 3.0, -0.5, 1.0, "back_calc_model", b=0.5)}
[[controllers.blocks]]
measure = "y2"
sp = 0.6
{_pid(6.0, 0.5, -0.5, 1.0)}
[[controllers.blocks]]
measure = "y"
sp = 1.8
{_adrc(0.3, 0.5, 2.5, -0.5, 1.0, u_sf=0.4)}
"""  # fmt: skip
    sig = _same(text, caplog, NO_NAN)
    _within(sig["min", "steps"], [(10.0, 40.0, -0.5, 0.3)])
    _within(sig["min", "one block"], [(10.0, 30.0, -0.5, 0.2)], "v2")


def test_feedforward_and_smith_with_limits_events_on_the_lane_equal_python(caplog):
    ff = FEEDFORWARD + _cases(1.5, 2.0, -2.0, 0.2, 2.0) + (
        '[[controllers]]\nname = "ff"\n[controllers.main]\n'
        f"{_pid(0.8, 4.0, -2.0, 2.0, td=0.5)}"
        '[controllers.feedforward]\ntype = "LeadLag"\nk = -1.0\nt_lead = 2.0\nt_lag = 1.0\n'
    )  # fmt: skip
    sig = _same(ff, caplog, NO_NAN)
    _within(sig["ff", "steps"], [(10.0, 40.0, -2.0, 0.2)])
    smith = SMITH + _cases(1.0, 1.5, -5.0, 0.5, 5.0)
    for name, main in (("PI", _pid(1.0, 5.0, -5.0, 5.0)),
                       ("ADRC", _adrc(0.2, 0.8, 4.0, -5.0, 5.0, u_sf=0.1))):  # fmt: skip
        smith += f'[[controllers]]\nname = "{name}"\n[controllers.main]\n{main}'
        smith += '[controllers.model]\ntype = "FOPDT"\nk = 0.9\nt = 6.0\ndead_time = 3.0\n'
    sig = _same(smith, caplog, NO_NAN)
    for name in ("PI", "ADRC"):
        _within(sig[name, "steps"], [(10.0, 40.0, -5.0, 0.5)])


def test_limits_of_something_not_a_lane_controller_are_refused_with_the_reason():
    """A ``limits`` event naming the feed-forward lead-lag: refused where it is written.

    (The Python path used to stop in the run with an AttributeError; the lane
    refused it too.  The scenario parser now refuses it at the event's line.)
    """
    from ctrlblocks.sim import parse_scenario
    from ctrlblocks.sim.scenario import ScenarioError

    text = FEEDFORWARD + _case(
        "c", dict(t=5.0, do="limits", target="feedforward", u_min=-0.1, u_max=0.1), duration=10.0
    )
    text += (
        '[[controllers]]\nname = "ff"\n[controllers.main]\n'
        f"{_pid(0.8, 4.0, -2.0, 2.0)}"
        '[controllers.feedforward]\ntype = "LeadLag"\nk = -1.0\nt_lead = 2.0\nt_lag = 1.0\n'
    )
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, file="ff.toml")
    exc = info.value
    assert exc.key.endswith("events[0].target") and exc.line is not None
    assert "the LeadLag of controller 'ff' has no output limits" in str(exc)


# two limits events due in the same sample (t = 0 and t = 0.05, ts = 0.2), the second
# pair excluding the first's low limit: found by tests/sim/test_dispatch_campaign.py
TWO_IN_ONE_SAMPLE = """
[scenario]
name = "two_limits"
title = "two limits events in one sample"
source = "test"
structure = "{structure}"
ts = 0.2
duration = 0.4
[plant]
type = "PT2"
k = 2.0
t1 = 0.2
t2 = 0.5
{inner}
[initial]
u = -0.866
warmup = 0.2
[[controllers]]
name = "P"
{controller}
[[events]]
t = 0.0
do = "limits"
u_min = -0.393
u_max = 3.375
{target}
[[events]]
t = 0.05
do = "limits"
u_min = -1.88
u_max = 0.757
{target}
"""


@pytest.mark.parametrize(
    ("structure", "target"), [("single", ""), ("override", ""), ("cascade", 'target = "primary"')]
)
def test_two_limits_events_in_one_sample_limit_the_held_output_one_after_the_other(
    structure, target
):
    """The held output -0.866 is limited to -0.393 by the first pair and stays there
    (inside the second): the Python path's ``Block._relimit`` at each event.  Before,
    the lane limited it once, to the last pair in force (-0.866 stayed: u = -0.866 on
    the lane against -0.393)."""
    from .test_dispatch_campaign import check_case

    p = 'type = "PID"\nkp = 1.0\nu_min = -10.0\nu_max = 10.0\n'
    controller = {
        "single": p,
        "override": f"[[controllers.blocks]]\n{p}[[controllers.blocks]]\n{p}sp = 5.0\n",
        "cascade": f"[controllers.primary]\n{p}[controllers.secondary]\n{p}",
    }[structure]
    inner = "" if structure == "single" else '[inner_plant]\ntype = "PT1"\nk = 1.0\nt = 1.0\n'
    text = TWO_IN_ONE_SAMPLE.format(structure=structure, inner=inner, controller=controller,
                                    target=target)  # fmt: skip
    runs, lane, _lines = check_case(text)
    assert (runs, lane) == (1, 1)
    sig = run_scenario(parse_scenario(text)).runs[0].signals
    held = sig["sp2"] if structure == "cascade" else sig["u"]
    assert held[0] == -0.393
