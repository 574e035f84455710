"""The ADRC on a reverse-acting process (``reverse = True``): the block on ``-y`` and ``-sp``.

A process with a negative gain (cooling, an outlet valve) needs ``b0 < 0`` in
the model ``Y^(n) = h + b0 u`` of Nowak et al. 2018, section 2, which the block
refuses; ``reverse`` makes the block work on the mirrored measurement and set
point instead.  The oracle is exact: negation is exact in floating point, so a
reversed block fed ``(sp, y)`` must give bit for bit the u, the status and the
(negated) readings of the plain block fed ``(-sp, -y)`` with the sensor
saturation mirrored -- through bad data, MAN, anti-windup, anti-backoff and
both discretisations, per call and in the two-phase form, in float64 and in the
PLC cycle's REAL (``precision="float32"``, what the exported FB computes).
"""

from __future__ import annotations

import math
import random

import pytest

from ctrlblocks import ADRC
from ctrlblocks.blocks.base import ErrorCode, ParameterError


def _same(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


def _pair(r: random.Random, precision: str = "float64") -> tuple[ADRC, ADRC]:
    kw = dict(
        precision=precision,
        order=r.choice((1, 2, 3)), b0=10 ** r.uniform(-2, 2), omega_c=0.3, omega_o=1.5, ts=0.1,
        u_min=-5.0, u_max=5.0, t_ref=r.choice((0.0, 1.0)), u_sf=r.uniform(-1, 1),
        anti_windup=r.choice(("directional", "freeze", "off")), anti_backoff=r.random() < 0.4,
        y_sat=r.uniform(0.5, 3.0), y_sat_lo=r.uniform(-3.0, -0.5),
        discretisation=r.choice(("euler", "exact")),
    )  # fmt: skip
    mirrored = {**kw, "y_sat": -kw["y_sat_lo"], "y_sat_lo": -kw["y_sat"]}
    return ADRC(**kw, reverse=True), ADRC(**mirrored)


@pytest.mark.parametrize("precision", ["float64", "float32"])
@pytest.mark.parametrize("two_phase", [False, True], ids=["per-call", "two-phase"])
@pytest.mark.parametrize("seed", range(12))
def test_reverse_is_the_plain_block_on_the_mirrored_signals(
    seed: int, two_phase: bool, precision: str
) -> None:
    r = random.Random(seed)
    rev, plain = _pair(r, precision)
    y = 0.0
    for k in range(400):
        sp = (1.0 if k > 10 else 0.0) if r.random() > 0.03 else math.nan  # a bad set point too
        yv = y + r.gauss(0.0, 0.01) if r.random() > 0.03 else math.nan
        ok = r.random() > 0.02
        if r.random() < 0.02:
            rev.manual = plain.manual = not rev.manual
        if two_phase:
            ua = rev.compute_output(sp, yv, pv_ok=ok)
            ub = plain.compute_output(-sp, -yv, pv_ok=ok)
            applied = max(-4.0, min(4.0, ua))  # an outer limit: the ESO takes what was applied
            rev.update_state(applied)
            plain.update_state(applied)
        else:
            ua, ub = rev(sp, yv, pv_ok=ok), plain(-sp, -yv, pv_ok=ok)
        assert _same(ua, ub), (k, ua, ub)
        assert rev.error_id == plain.error_id
        assert _same(rev.y, -plain.y) and _same(rev.e, -plain.e) and rev.y_ref == -plain.y_ref
        assert rev.x == tuple(v for v in plain.x)  # the ESO runs in the mirrored units
        y += 0.1 * (-0.5 * ua - 0.2 * y)  # the reverse-acting process


def test_a_reverse_acting_loop_settles_on_the_set_point() -> None:
    """Closed loop on ``-0.5/(5 s + 1)``: the reversed ADRC (b0 > 0) brings y to the set point."""
    adrc = ADRC(order=1, b0=0.1, omega_c=0.5, omega_o=2.5, ts=0.1, reverse=True)
    y = 0.0
    for _ in range(600):
        u = adrc(2.0, y)
        y += 0.1 / 5.0 * (-0.5 * u - y)
    assert y == pytest.approx(2.0, abs=1e-6)
    assert u == pytest.approx(-4.0, rel=1e-5)  # u = y/k, k = -0.5


@pytest.mark.parametrize(("precision", "tol"), [("float64", 1e-9), ("float32", 1e-5)])
def test_switching_reverse_in_operation_is_bumpless(precision: str, tol: float) -> None:
    adrc = ADRC(order=2, b0=0.2, omega_c=0.4, omega_o=2.0, ts=0.1, u_min=-10.0, u_max=10.0,
                precision=precision)  # fmt: skip
    y = 0.0
    for _ in range(100):
        u = adrc(1.0, y)
        y += 0.02 * (0.5 * u - y)
    assert abs(u) > 0.1
    adrc.configure(reverse=True)
    assert adrc.config.reverse is True
    u_next = adrc(1.0, y)
    assert u_next == pytest.approx(u, abs=tol * max(1.0, abs(u))), (u, u_next)
    # and back: the states change sign again
    adrc.configure(reverse=False)
    assert adrc(1.0, y) == pytest.approx(u, abs=tol * max(1.0, abs(u)))


def test_reverse_is_not_on_the_compiled_paths_but_in_the_plc_cycle() -> None:
    adrc = ADRC(order=2, b0=0.2, omega_c=0.4, omega_o=2.0, reverse=True)
    assert "reverse" in adrc.fast_path_blockers()
    f32 = ADRC(order=2, b0=0.2, omega_c=0.4, omega_o=2.0, reverse=True, precision="float32")
    assert f32.config.reverse is True
    with pytest.raises(ParameterError) as exc:
        ADRC(order=2, b0=0.2, omega_c=0.4, omega_o=2.0, reverse="yes")
    assert exc.value.code == ErrorCode.BAD_PARAMETER and exc.value.field == "reverse"
    plain = ADRC(order=2, b0=0.2, omega_c=0.4, omega_o=2.0, precision="float32")
    plain.configure(reverse=True)
    assert plain.config.reverse is True


SCENARIO = """
[scenario]
name = "cooling"
title = "a reverse-acting process"
source = "test"
ts = 0.1
duration = 150.0
[plant]
type = "FOPDT"
k = -1.5
t = 20.0
dead_time = 2.0
[actuator]
u_min = -100.0
u_max = 100.0
[initial]
y = 0.0
[[controllers]]
name = "ADRC"
type = "ADRC"
order = 1
b0 = 0.075
omega_c = 0.15
omega_o = 0.75
reverse = true
[[events]]
t = 5.0
do = "setpoint"
value = -10.0
"""


def test_a_scenario_runs_the_reversed_adrc_on_the_python_path(caplog) -> None:
    import logging

    from ctrlblocks.sim import parse_scenario, run_scenario

    with caplog.at_level(logging.DEBUG, logger="ctrlblocks.sim.dispatch"):
        (run,) = run_scenario(parse_scenario(SCENARIO)).runs
    assert "reverse" in caplog.text  # the reason the compiled lane does not take it
    y, u = run.signals["y"], run.signals["u"]
    assert y[-1] == pytest.approx(-10.0, abs=0.05)  # settled on the set point
    assert u[-1] == pytest.approx(-10.0 / -1.5, rel=0.01)  # u = y/k: a positive MV
