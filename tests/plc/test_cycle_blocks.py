"""The exported FUNCTION_BLOCKs of the one-cycle blocks compute what the float32 blocks compute.

TwoPoint, ThreePoint, TransferFunction and SetpointProgram run one pure cycle
function (``ctrlblocks.blocks.cycleblock``); the export translates that
function.  Each test drives a ``precision="float32"`` block over a trace with
hostile samples (NaN, inf, values beyond REAL, a bad quality flag, resets),
exports the block's configuration, runs the ST in the interpreter with the
same inputs and requires every output bit-identical.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from ctrlblocks import SetpointProgram, ThreePoint, TransferFunction, TwoPoint, plc
from ctrlblocks.blocks.transfer import lowpass, notch

from .st_interpreter import Interpreter

pytest.importorskip("blark")
pytestmark = pytest.mark.slow  # blark's parser: the long campaign (pytest -m slow)


HOSTILE = (math.nan, math.inf, -math.inf, 4e38, -1e39)


def _values(n: int, seed: int, scale: float) -> list[float]:
    rng = np.random.default_rng(seed)
    xs = list(scale * rng.normal(size=n))
    for k in range(7, n, 23):
        xs[k] = HOSTILE[(k // 23) % len(HOSTILE)]
    return xs


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, bool) or isinstance(b, bool):
        return bool(a) == bool(b)
    x, y = np.float32(a), np.float32(b)
    return bool((np.isnan(x) and np.isnan(y)) or x.tobytes() == y.tobytes())


def _check(block: Any, fb_name: str, inputs: list[dict[str, Any]],
           call: Callable[[Any, dict[str, Any]], Any],
           outs: dict[str, Callable[[Any], Any]]) -> None:  # fmt: skip
    fb = Interpreter(plc.export(block, "codesys")).instance(fb_name)
    for k, inp in enumerate(inputs):
        call(block, inp)
        fb(**{n.upper(): v for n, v in inp.items() if n != "dt"})
        for name, get in outs.items():
            assert _same(fb[name], get(block)), f"sample {k}: {name} {fb[name]!r} vs {get(block)!r}"
        assert int(fb["ERROR_ID"]) == int(block.error_id), f"sample {k}: ERROR_ID"


def test_two_point_fb_equals_the_float32_block() -> None:
    b = TwoPoint(hysteresis=0.5, t_min_on=0.3, t_min_off=0.2, ts=0.1, precision="float32")
    pvs = _values(300, 1, 1.0)
    inputs = [{"sp": 0.1, "pv": pv, "pv_ok": k % 41 != 5, "enable": k % 97 > 3}
              for k, pv in enumerate(pvs)]  # fmt: skip
    _check(b, "CB_TWOPOINT", inputs,
           lambda blk, i: blk(i["sp"], i["pv"], pv_ok=i["pv_ok"], enable=i["enable"]),
           {"OUT": lambda blk: blk.out})  # fmt: skip


def test_three_point_fb_equals_the_float32_block() -> None:
    b = ThreePoint(deadband=0.5, hysteresis=0.3, t_min_off=0.2, ts=0.1, precision="float32")
    pvs = _values(300, 2, 1.0)
    inputs = [{"sp": 0.0, "pv": pv, "pv_ok": k % 37 != 5, "enable": True}
              for k, pv in enumerate(pvs)]  # fmt: skip
    _check(b, "CB_THREEPOINT", inputs,
           lambda blk, i: blk(i["sp"], i["pv"], pv_ok=i["pv_ok"]),
           {"OUT": lambda blk: blk.out, "RAISE_OUT": lambda blk: blk.raise_out,
            "LOWER_OUT": lambda blk: blk.lower_out})  # fmt: skip


def test_transfer_fb_equals_the_float32_block() -> None:
    sections = (*lowpass(2.0, 0.05, 3), notch(10.0, 3.0, 0.05, 0.05))
    b = TransferFunction(sections=sections, ts=0.05, out_min=-1.5, out_max=1.5, precision="float32")
    xs = _values(400, 3, 1.0)
    xs[200] = 3e38  # inside REAL, its memory is not: 16#8103
    inputs = [{"x": x, "init": k in (0, 150)} for k, x in enumerate(xs)]
    _check(b, "CB_TRANSFER", inputs, lambda blk, i: blk(i["x"], init=i["init"]),
           {"OUT": lambda blk: blk.out})  # fmt: skip


def test_setpoint_fb_equals_the_float32_block() -> None:
    b = SetpointProgram(segments=((50.0, 0.7, 3.0), (20.0, 0.0, 1.1), (80.0, 1.3, 0.0)),
                        start=10.0, repeat=True, holdback_ramp=4.0, holdback_soak=2.0, ts=0.1,
                        precision="float32")  # fmt: skip
    pvs = _values(600, 4, 3.0)
    inputs = []
    for k, pv in enumerate(pvs):
        # a PV that follows the setpoint with noise, so that the holdback acts sometimes
        inputs.append({"pv": pv, "pv_ok": k % 53 != 9, "run": k % 101 > 5, "reset": k == 400})
    state = {"sp": 10.0}

    def call(blk: Any, i: dict[str, Any]) -> None:
        pv = state["sp"] + i["pv"] if math.isfinite(i["pv"]) else i["pv"]
        i["pv"] = pv
        state["sp"] = blk(pv, pv_ok=i["pv_ok"], run=i["run"], reset=i["reset"])

    _check(b, "CB_SETPOINT", inputs, call,
           {"OUT": lambda blk: blk.out, "HELD": lambda blk: blk.held})  # fmt: skip


def test_heat_cool_stage_fb_equals_the_float32_block() -> None:
    """CB_HEATCOOL fed with the float32 PID's demand gives the float32 block's outputs."""
    from ctrlblocks import HeatCoolPID

    b = HeatCoolPID(kp=6.0, ti=20.0, cool_method="parameters", kp_cool=12.0, ti_cool=10.0,
                    deadzone=2.0, pwm_period=2.0, t_min_on=0.3, ts=0.1,
                    precision="float32")  # fmt: skip
    pvs = _values(800, 5, 4.0)
    inputs = []
    for k, pv in enumerate(pvs):
        inputs.append({"sp": 20.0 if (k // 200) % 2 else -20.0, "pv": pv})
    fb = Interpreter(plc.export(b, "codesys")).instance("CB_HEATCOOL")
    for k, i in enumerate(inputs):
        b(i["sp"], i["pv"])
        fb(V=b.demand)
        for name, ref in (("OUT", b.out), ("HEAT", b.heat), ("COOL", b.cool)):
            assert _same(fb[name], ref), f"sample {k}: {name} {fb[name]!r} vs {ref!r}"
        assert bool(fb["COOLING"]) == bool(b.snapshot()["_mem"]["cooling"]), k
