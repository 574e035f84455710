"""Default engineering ranges derived from the loop: absurd tunings refused without configuration.

The issue: a PID without ``tuning_ranges`` accepted ``ti = 1e-300`` and
``kp = 1e6`` from an engineer and became an on/off controller with no error.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ctrlblocks.blocks.adrc import ADRC, euler_pole_polynomial
from ctrlblocks.blocks.base import ErrorCode
from ctrlblocks.blocks.pid import PID
from ctrlblocks.runtime import CommandError, MemoryBus
from ctrlblocks.runtime.bounds import derived_tuning_range, stability_limit, ultimate_gain

from .conftest import bounded, loop_toml, make, run


def pid_loop():
    rt, clock, _ = make(loop_toml(block='{ type = "PID", kp = 2.0, ti = 8.0, u_min = 0.0, '
                                  'u_max = 100.0 }'), {"io": MemoryBus()})  # fmt: skip
    return rt, clock


@pytest.mark.parametrize(
    ("tunings", "field"),
    [
        ({"ti": 1e-300}, "tunings.ti"),
        ({"kp": 1e6}, "tunings.kp"),
        ({"td": 1e9}, "tunings.td"),
        ({"n": 1e5}, "tunings.n"),
        ({"kp": 1e-9}, "tunings.kp"),
    ],
)
def test_a_pid_without_tuning_ranges_refuses_absurd_tunings(tunings, field):
    rt, clock = pid_loop()

    async def main():
        await run(rt, clock, 0.25)
        with pytest.raises(CommandError) as err:
            rt.command("loop", user="eng", tunings=tunings)
        st = rt.state("loop")
        await rt.stop()
        return err.value, st

    exc, st = bounded(main())
    assert (exc.field, exc.code) == (field, ErrorCode.BAD_PARAMETER)
    assert "outside the engineering range" in exc.message
    assert (st["tunings"]["kp"], st["tunings"]["ti"]) == (2.0, 8.0)  # the old ones in force


def test_reasonable_retunings_are_accepted_and_zero_switches_a_term_off():
    rt, clock = pid_loop()

    async def main():
        await run(rt, clock, 0.25)
        for t in ({"kp": 5.0, "ti": 2.0}, {"ti": 0.0}, {"td": 0.5, "n": 8.0}, {"kp": 0.05}):
            rt.command("loop", user="eng", tunings=t)
        st = rt.state("loop")
        await rt.stop()
        return st

    st = bounded(main())
    assert (st["tunings"]["kp"], st["tunings"]["ti"], st["tunings"]["td"]) == (0.05, 0.0, 0.5)


def test_the_derived_ranges_are_those_of_the_table():
    """Hand-evaluated: ts 0.1 s, kp 2, ti 8 s; ADRC n = 2 b0 0.05, omega_c 0.35, omega_o 1.75."""
    pid = PID(kp=2.0, ti=8.0, ts=0.1, u_min=0.0, u_max=100.0).config
    kp = derived_tuning_range(pid, "kp", 0.1)
    assert (kp.lo, kp.hi) == pytest.approx((0.02, 200.0))
    ti = derived_tuning_range(pid, "ti", 0.1)
    assert (ti.lo, ti.hi, ti.zero_ok, ti.unit) == (pytest.approx(0.01), 1000.0, True, "s")
    adrc = ADRC(order=2, b0=0.05, omega_c=0.35, omega_o=1.75, ts=0.1).config
    oo = derived_tuning_range(adrc, "omega_o", 0.1)  # observer m = 3: (2^(4/3) - 2)/ts
    assert oo.lo == pytest.approx(0.0175) and oo.hi == pytest.approx(5.1984, rel=1e-4)
    oc = derived_tuning_range(adrc, "omega_c", 0.1)  # controller m = 2: (2^(3/2) - 2)/ts
    assert oc.hi == pytest.approx(8.2843, rel=1e-4)
    order = derived_tuning_range(adrc, "order", 0.1)
    assert (order.lo, order.hi, order.integer) == (1.0, 3.0, True)
    assert order.refuses(2.5) and order.refuses(4) and order.refuses(2) is None


@pytest.mark.parametrize("m", [1, 2, 3, 4])
def test_the_bandwidth_limit_is_where_the_euler_image_reaches_the_unit_circle(m):
    """Independent check: the roots of the Euler image P_m (Nowak et al. 2018, (4a);
    blocks.adrc) are inside the unit circle just below the limit, outside just above."""
    ts = 0.1
    n, chain = (m - 1, "observer") if m > 1 else (1, "controller")
    a = stability_limit(n, chain, "euler", ts) * ts
    inside = np.max(np.abs(np.roots(euler_pole_polynomial(m, a * 0.999))))
    outside = np.max(np.abs(np.roots(euler_pole_polynomial(m, a * 1.001))))
    assert inside < 1.0 < outside


@pytest.mark.parametrize(("k", "t", "dl"), [(1.0, 1.0, 0.1), (2.5, 30.0, 4.0), (0.3, 5.0, 5.0)])
def test_the_ultimate_gain_equals_python_controls_gain_margin(k, t, dl):
    """Against python-control: the gain margin of the FOPDT with a 12th-order Pade delay."""
    control = pytest.importorskip("control")
    num, den = control.pade(dl, 12)
    g = control.tf([k], [t, 1.0]) * control.tf(num, den)
    gm, _pm, _wg, _wp = control.margin(g)
    assert ultimate_gain(k, t, dl) == pytest.approx(gm, rel=1e-3)


def test_with_an_identified_model_kp_stops_at_twice_the_ultimate_gain():
    pid = PID(kp=2.0, ti=8.0, ts=0.1).config
    model = {"kind": "FOPDT", "gain": 2.5, "time_constant": 30.0, "dead_time": 4.0}
    ku = ultimate_gain(2.5, 30.0, 4.0)
    kp = derived_tuning_range(pid, "kp", 0.1, model)
    assert kp.hi == pytest.approx(2.0 * ku) and "ultimate gain" in kp.why
    assert kp.refuses(2.1 * ku) and kp.refuses(1.9 * ku) is None


@pytest.mark.parametrize(
    "block",
    [
        PID(kp=2.0, ti=8.0, td=0.5, ts=0.1, u_min=0.0, u_max=100.0),
        PID(kp=1.0, ti=0.0, ts=0.1),  # ti, td, ff_k 0: no magnitude to scale from
        ADRC(order=2, b0=0.05, omega_c=0.35, omega_o=1.75, ts=0.1),
        ADRC(order=1, b0=2.0, omega_c=1.0, omega_o=5.0, ts=0.1, discretisation="exact"),
    ],
    ids=["pid", "pid-zeros", "adrc", "adrc-exact"],
)
def test_every_numeric_tuning_has_a_range_that_refuses_absurd_values(block):
    """The issue: 'default engineering ranges for every tuning parameter'. Whatever
    the block's fields are now or later, each number gets a range, and 1e300 (or its
    negative) is outside it -- the block itself would accept most of them."""
    from ctrlblocks.runtime.bounds import LoopBounds

    class Loop:  # what LoopBounds reads of a runtime's loop
        config = type("Cfg", (), {"ts": 0.1})()

    Loop.block = block
    ranges = LoopBounds(Loop()).tunings
    numeric = [
        f.name
        for f in dataclasses.fields(block.config)
        if isinstance(getattr(block.config, f.name), (int, float))
        and not isinstance(getattr(block.config, f.name), bool)
        and f.name not in ("ts", "u_min", "u_max", "safe_value", "u_sf")
    ]
    assert numeric and set(numeric) <= set(ranges), set(numeric) - set(ranges)
    for name in numeric:
        assert ranges[name].refuses(1e300) and ranges[name].refuses(-1e300), name
        assert ranges[name].refuses(getattr(block.config, name)) is None, name  # in force: in
