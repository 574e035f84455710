"""Every one-cycle block exports to every target (the translator accepts its cycle)."""

from __future__ import annotations

import pytest

from ctrlblocks import (
    HeatCoolPID,
    Regulator,
    SetpointProgram,
    ThreePoint,
    TransferFunction,
    TwoPoint,
    plc,
)
from ctrlblocks.blocks.transfer import lowpass

BLOCKS = {
    "CB_TWOPOINT": lambda: TwoPoint(),
    "CB_THREEPOINT": lambda: ThreePoint(),
    "CB_TRANSFER": lambda: TransferFunction(sections=lowpass(1.0, 0.1, 3), ts=0.1),
    "CB_SETPOINT": lambda: SetpointProgram(segments=((1.0, 1.0, 1.0), (0.0, 0.0, 0.0))),
    "CB_HEATCOOL": lambda: HeatCoolPID(kp=2.0, ti=30.0, pwm_period=4.0),
    "CB_REGULATOR": lambda: Regulator(kp=2.0, ti=10.0, sp0=50.0, u0=40.0, tr=0.5, ts=0.1),
}


@pytest.mark.parametrize("target", plc.TARGETS)
@pytest.mark.parametrize("fb", sorted(BLOCKS))
def test_cycle_block_exports_to_every_target(fb: str, target: str) -> None:
    text = plc.export(BLOCKS[fb](), target)
    assert fb in text


def test_array_inputs_carry_the_configured_coefficients() -> None:
    text = plc.export(TransferFunction(sections=lowpass(1.0, 0.1, 3), ts=0.1), "codesys")
    assert "B0 : ARRAY[0..1] OF REAL := [0.04765687684249756, 0.0023791576428724326];" in text
    xml = plc.export(TransferFunction(sections=lowpass(1.0, 0.1, 3), ts=0.1), "plcopen")
    assert '<arrayValue><value><simpleValue value="0.04765687684249756" /></value>' in xml
