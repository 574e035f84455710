"""The same process in other units gets the same tuning and the same margins.

A process gain ``k`` [PV unit / MV unit] changes by powers of ten with the
units (bar or Pa, a fraction or per cent, ppm); the loop does not: a rule's
``kp`` scales with ``1/k``, the ADRC's ``b0`` with ``k``, and the margins,
the poles and the searched bandwidths stay.  Before the closed-loop poles
were computed in units scaled to the process (``Loop.poles``), a gain of
``1e30`` put a pole of ``|z| = 0.999999`` at ``1.00001``: ``tune adrc``
refused every order-2 and -3 tuning as "dead time too long", and ``tune
pid`` called an AMIGO loop on a gain of ``1e300`` unstable.

Seeded: the scales are drawn over 10^-150 .. 10^150 (the range
:mod:`ctrlblocks.tuning.identify` accepts in data) and the fixed ones below.
"""

from __future__ import annotations

import math
import random

import numpy as np
import pytest

from ctrlblocks import ADRC, PID
from ctrlblocks.blocks.base import ParameterError
from ctrlblocks.tuning.adrc import adrc_tuning
from ctrlblocks.tuning.identify import FOPDT, SOPDT, Integrating
from ctrlblocks.tuning.margins import Loop
from ctrlblocks.tuning.pid_rules import amigo, lambda_tuning, simc

_rng = random.Random(20261202)
# the fixed extremes in the default run, six random scales with the long campaigns (-m slow)
SCALES = [1e25, 1e30, -1e30, 1e-30, 1e100, 1e-100, 1e150, 1e-150] + [
    pytest.param(_rng.choice((1.0, -1.0)) * 10.0 ** _rng.uniform(-150.0, 150.0),
                 marks=pytest.mark.slow)
    for _ in range(6)
]  # fmt: skip


def _same(a: float, b: float, rel: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or math.isclose(a, b, rel_tol=rel, abs_tol=0.0)


def _loop_numbers(lp: Loop) -> tuple[float, ...]:
    mg = lp.margins()
    return (mg.ms, mg.gm, mg.pm, mg.wc_crossover, float(mg.stable), mg.radius)


@pytest.mark.parametrize("order", [1, 2, 3])
@pytest.mark.parametrize("scale", SCALES, ids=lambda s: f"{s:.3g}")
def test_adrc_tuning_is_the_same_in_any_units(order: int, scale: float) -> None:
    ref = adrc_tuning(1.0, 10.0, 2.0, order)
    got = adrc_tuning(scale, 10.0, 2.0, order)
    # a negative gain: the block with reverse = True and b0 > 0, the same loop
    assert got.reverse is (scale < 0.0) and got.config().get("reverse", False) is (scale < 0.0)
    scale = abs(scale) if got.reverse else scale
    assert got.ts == ref.ts
    assert _same(got.omega_c, ref.omega_c, 1e-9), (got.omega_c, ref.omega_c)
    assert _same(got.omega_o, ref.omega_o, 1e-9)
    assert _same(got.b0 / scale, ref.b0, 1e-12)
    assert got.margins.stable and ref.margins.stable
    assert _same(got.margins.ms, ref.margins.ms, 1e-6)
    assert _same(got.margins.pm, ref.margins.pm, 1e-6)
    assert _same(got.integral_gain * (-scale if got.reverse else scale), ref.integral_gain, 1e-6)


@pytest.mark.parametrize("rule", [simc, amigo, lambda_tuning], ids=lambda r: r.__name__)
@pytest.mark.parametrize("scale", SCALES, ids=lambda s: f"{s:.3g}")
def test_pid_margins_are_the_same_in_any_units(rule, scale: float) -> None:
    ref_t, got_t = rule(1.0, 10.0, 2.0), rule(scale, 10.0, 2.0)
    assert _same(got_t.kp * scale, ref_t.kp, 1e-12)
    ref = Loop(FOPDT(1.0, 10.0, 2.0), PID(**ref_t.as_kwargs(), ts=0.2))
    got = Loop(FOPDT(scale, 10.0, 2.0), PID(**got_t.as_kwargs(), ts=0.2))
    for a, b in zip(_loop_numbers(got), _loop_numbers(ref), strict=True):
        assert _same(a, b, 1e-6), (_loop_numbers(got), _loop_numbers(ref))


@pytest.mark.parametrize("scale", SCALES, ids=lambda s: f"{s:.3g}")
@pytest.mark.parametrize(
    "model",
    [lambda k: SOPDT(k, 10.0, 2.0, 3.0), lambda k: Integrating(k, 2.0)],
    ids=["sopdt", "integrating"],
)
@pytest.mark.parametrize("block", ["pid", "adrc"])
def test_poles_are_the_same_in_any_units(scale: float, model, block: str) -> None:
    """The poles themselves: the slowest, near |z| = 1, is the one that decides stability.

    The SOPDT's gain sits in its input matrix: up to 1e100 and beyond its
    ZOH lost Phi's accuracy (``plants.linear._zoh``), the integrating
    model's sits in its output matrix.
    """


    def make(k: float) -> PID | ADRC:
        if block == "pid":
            return PID(kp=0.3 / abs(k), ti=12.0, td=1.0, ts=0.1, reverse=k < 0)
        return ADRC(order=2, b0=0.05 * abs(k), omega_c=0.05, omega_o=0.25, ts=0.1, reverse=k < 0)

    ref = Loop(model(1.0 if scale > 0 else -1.0), make(1.0 if scale > 0 else -1.0))
    got = Loop(model(scale), make(scale))
    r_ref = np.sort(np.abs(ref.poles()))[::-1]
    r_got = np.sort(np.abs(got.poles()))[::-1]
    assert abs(r_got[0] - r_ref[0]) <= 1e-9, (r_got[0], r_ref[0])
    assert got.stable() == ref.stable()
    assert _same(got.integral_gain() * scale, ref.integral_gain() * (-1.0 if scale < 0 else 1.0),
                 1e-6)  # fmt: skip


def test_a_gain_whose_rule_underflows_names_the_rule() -> None:
    """simc on a gain of 1e308 gives kp = 0.0 by underflow: refused as the rule's, not as kp > 0."""
    with pytest.raises(ParameterError, match=r"simc rule gives 0\.0"):
        simc(1e308, 10.0, 2.0)
