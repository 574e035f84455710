"""PID and ADRC satisfy the one controller interface, with the engineer's names."""

from __future__ import annotations

import math

import pytest

from ctrlblocks import ADRC, PID, compiled
from ctrlblocks.blocks.protocols import Controller
from ctrlblocks.loops import ControllerSide, parse_controller


def _adrc():
    return ADRC(order=1, b0=1.0, omega_c=1.0, omega_o=5.0, ts=0.1, u_min=-5.0, u_max=5.0)


@pytest.mark.parametrize("make", [lambda: PID(kp=1.0, ti=2.0), _adrc])
def test_pid_and_adrc_are_controllers_with_pv_ok_and_manual_value(make):
    block = make()
    assert isinstance(block, Controller)
    for sig in (compiled.signature(type(block), "compute_output"), compiled.signature(type(block))):
        assert {"pv_ok", "dt"} <= set(sig.parameters)
    block.manual_value = 1.5
    block.manual = True
    assert block(0.0, 0.0) == 1.5


def test_adrc_pv_ok_and_its_alias_y_ok_give_the_same_cycle():
    a, b, c = _adrc(), _adrc(), _adrc()
    for k in range(6):
        ok = k not in (2, 3)
        ua = a(1.0, 0.1 * k, pv_ok=ok)
        ub = b(1.0, 0.1 * k, y_ok=ok)
        uc = c.compute_output(1.0, 0.1 * k, pv_ok=ok)
        c.update_state(uc)
        assert ua == ub == uc and a.error_id == b.error_id == c.error_id
    assert a.u_man == a.manual_value  # the alias of the manual value


def test_a_plain_callable_block_sees_nan_for_a_bad_measurement():
    seen = []

    class Echo:
        def __init__(self, ts: float = 1.0) -> None:
            self.ts = ts

        def __call__(self, sp: float, y: float) -> float:
            seen.append(y)
            return 0.0

    from ctrlblocks.loops import BLOCK_TYPES, register

    register("block", Echo)
    try:
        side = ControllerSide("single", parse_controller({"name": "e", "type": "Echo"},
                                                         "single", 0.1, key="c"), 0.1)  # fmt: skip
        assert not isinstance(side.main, Controller)
        side.step(1.0, 2.0, y_ok=False)
        side.step(1.0, 2.0)
        assert math.isnan(seen[0]) and seen[1] == 2.0
    finally:
        del BLOCK_TYPES["Echo"]
