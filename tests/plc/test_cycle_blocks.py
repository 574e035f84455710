"""The exported FUNCTION_BLOCKs of the one-cycle blocks compute what the float32 blocks compute.

TwoPoint, ThreePoint, TransferFunction and SetpointProgram run one pure cycle
function (``ctrlblocks.blocks.cycleblock``); the export translates that
function.  Each test drives a ``precision="float32"`` block over a trace with
hostile samples (NaN, inf, values beyond REAL, a bad quality flag, resets),
exports the block's configuration, runs the ST with the same inputs -- in the
project's interpreter and compiled strictly by MATIEC and gcc (:mod:`.matiec`,
skipped with a message where MATIEC is not built) -- and requires every output
bit-identical.  The heat/cool stage and the regulator's stations run beside the
PID: their FBs are driven as a PLC wires them to CB_PID.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from ctrlblocks import (
    ErrorCode,
    Regulator,
    SetpointProgram,
    ThreePoint,
    TransferFunction,
    TwoPoint,
    plc,
)
from ctrlblocks.blocks.transfer import lowpass, notch

from . import matiec

pytestmark = pytest.mark.slow  # blark's parser, gcc: the long campaign (pytest -m slow)


@pytest.fixture(params=["interpreter", "matiec"])
def compiled(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
             ) -> Callable[[Any, str], Any]:  # fmt: skip
    """``compiled(block, fb_name)``: a fresh instance of the block's exported FB, run by the
    project's ST interpreter or compiled by MATIEC (strict) and gcc.  ``block`` may be a list
    of blocks exported into one project and ``fb_name`` a tuple of FB names: a tuple of
    instances (one parse, one build)."""
    if request.param == "interpreter":
        pytest.importorskip("blark")
        from .st_interpreter import Interpreter

        def interpreted(block: Any, fb: str | tuple[str, ...]) -> Any:
            st = Interpreter(plc.export(block, "codesys"))
            return tuple(st.instance(f) for f in fb) if isinstance(fb, tuple) else st.instance(fb)

        return interpreted
    matiec.require_matiec()
    cache = tmp_path_factory.mktemp("matiec")

    def built(block: Any, fb: str | tuple[str, ...]) -> Any:
        names = list(fb) if isinstance(fb, tuple) else [fb]
        lib = matiec.build(plc.export(block, "codesys"), cache, names)
        return tuple(lib.instance(f) for f in names) if isinstance(fb, tuple) else lib.instance(fb)

    return built


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


def _check(compiled: Callable[[Any, str], Any], block: Any, fb_name: str,
           inputs: list[dict[str, Any]], call: Callable[[Any, dict[str, Any]], Any],
           outs: dict[str, Callable[[Any], Any]]) -> None:  # fmt: skip
    fb = compiled(block, fb_name)
    for k, inp in enumerate(inputs):
        call(block, inp)
        fb(**{n.upper(): v for n, v in inp.items() if n != "dt"})
        for name, get in outs.items():
            assert _same(fb[name], get(block)), f"sample {k}: {name} {fb[name]!r} vs {get(block)!r}"
        assert int(fb["ERROR_ID"]) == int(block.error_id), f"sample {k}: ERROR_ID"


def test_two_point_fb_equals_the_float32_block(compiled) -> None:
    b = TwoPoint(hysteresis=0.5, t_min_on=0.3, t_min_off=0.2, ts=0.1, precision="float32")
    pvs = _values(300, 1, 1.0)
    inputs = [{"sp": 0.1, "pv": pv, "pv_ok": k % 41 != 5, "enable": k % 97 > 3}
              for k, pv in enumerate(pvs)]  # fmt: skip
    _check(compiled, b, "CB_TWOPOINT", inputs,
           lambda blk, i: blk(i["sp"], i["pv"], pv_ok=i["pv_ok"], enable=i["enable"]),
           {"OUT": lambda blk: blk.out})  # fmt: skip


def test_three_point_fb_equals_the_float32_block(compiled) -> None:
    b = ThreePoint(deadband=0.5, hysteresis=0.3, t_min_off=0.2, ts=0.1, precision="float32")
    pvs = _values(300, 2, 1.0)
    inputs = [{"sp": 0.0, "pv": pv, "pv_ok": k % 37 != 5, "enable": True}
              for k, pv in enumerate(pvs)]  # fmt: skip
    _check(compiled, b, "CB_THREEPOINT", inputs,
           lambda blk, i: blk(i["sp"], i["pv"], pv_ok=i["pv_ok"]),
           {"OUT": lambda blk: blk.out, "RAISE_OUT": lambda blk: blk.raise_out,
            "LOWER_OUT": lambda blk: blk.lower_out})  # fmt: skip


def test_transfer_fb_equals_the_float32_block(compiled) -> None:
    sections = (*lowpass(2.0, 0.05, 3), notch(10.0, 3.0, 0.05, 0.05))
    b = TransferFunction(sections=sections, ts=0.05, out_min=-1.5, out_max=1.5, precision="float32")
    xs = _values(400, 3, 1.0)
    xs[200] = 3e38  # inside REAL, its memory is not: 16#8103
    inputs = [{"x": x, "init": k in (0, 150)} for k, x in enumerate(xs)]
    _check(compiled, b, "CB_TRANSFER", inputs, lambda blk, i: blk(i["x"], init=i["init"]),
           {"OUT": lambda blk: blk.out})  # fmt: skip


def test_setpoint_fb_equals_the_float32_block(compiled) -> None:
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

    _check(compiled, b, "CB_SETPOINT", inputs, call,
           {"OUT": lambda blk: blk.out, "HELD": lambda blk: blk.held})  # fmt: skip


def test_heat_cool_stage_fb_equals_the_float32_block(compiled) -> None:
    """CB_HEATCOOL fed with the float32 PID's demand gives the float32 block's outputs."""
    from ctrlblocks import HeatCoolPID

    b = HeatCoolPID(kp=6.0, ti=20.0, cool_method="parameters", kp_cool=12.0, ti_cool=10.0,
                    deadzone=2.0, pwm_period=2.0, t_min_on=0.3, ts=0.1,
                    precision="float32")  # fmt: skip
    pvs = _values(800, 5, 4.0)
    inputs = []
    for k, pv in enumerate(pvs):
        inputs.append({"sp": 20.0 if (k // 200) % 2 else -20.0, "pv": pv})
    fb = compiled(b, "CB_HEATCOOL")
    for k, i in enumerate(inputs):
        b(i["sp"], i["pv"])
        fb(V=b.demand)
        for name, ref in (("OUT", b.out), ("HEAT", b.heat), ("COOL", b.cool)):
            assert _same(fb[name], ref), f"sample {k}: {name} {fb[name]!r} vs {ref!r}"
        assert bool(fb["COOLING"]) == bool(b.snapshot()["_mem"]["cooling"]), k


def test_regulator_fb_wired_to_the_pid_fb_equals_the_float32_regulator(compiled) -> None:
    """CB_REGULATOR called before CB_PID (its SP, MANUAL, MAN_VALUE written to CB_PID, CB_PID.MV
    to its PID_MV), as docs/plc.md wires them, is the float32 Regulator (Åström 1987,
    Fig. 4.6) bit for bit: both switches both ways, held and accelerating raise/lower buttons,
    remote setpoints that are NaN, inf or beyond REAL, bad and beyond-REAL measurements, PV_OK
    false, Tr > 0, and U_MAX, TM_OUT and TR retuned mid-run."""
    reg = Regulator(kp=3.0, ti=8.0, td=0.6, u_min=-5.0, u_max=90.0, sp_min=0.0, sp_max=120.0,
                    tm_sp=20.0, tm_out=10.0, t_accel=1.0, accel_max=4.0, tr=0.3, sp0=40.0,
                    u0=15.0, sp_rate=5.0, ts=0.1, precision="float32")  # fmt: skip
    fb_reg, fb_pid = compiled([reg, reg.pid], ("CB_REGULATOR", "CB_PID"))
    rng = np.random.default_rng(7)
    spr = _values(1200, 8, 10.0)
    pvs = _values(1200, 9, 0.5)
    y = 20.0
    switched = {"auto": 0, "remote": 0}
    codes = set()
    for k in range(1200):
        if k % 97 == 40 or k % 211 == 5:
            reg.auto = not reg.auto
            switched["auto"] += 1
        if k % 131 == 60:
            reg.remote = not reg.remote
            switched["remote"] += 1
        b = {n: bool(rng.random() < 0.35) for n in ("sp_inc", "sp_dec", "out_inc", "out_dec")}
        if k // 50 % 3 == 0:  # held for 50 samples: the rate accelerates
            b = {"sp_inc": True, "sp_dec": False, "out_inc": k % 2 == 0, "out_dec": False}
        retune: dict[str, float] = {}
        if k == 500:
            retune = {"u_max": 70.0, "tm_out": 5.0, "tr": 0.0}
        if k == 900:
            retune = {"u_max": 100.0, "tr": 1.5}
        if retune:
            reg.configure(**retune)
        sp_remote = 60.0 + spr[k]
        pv = y + pvs[k] if math.isfinite(pvs[k]) else pvs[k]
        pv_ok = k % 67 != 30
        u = reg(pv, sp_remote, pv_ok=pv_ok, **b)
        writes = {n.upper(): v for n, v in (*b.items(), *retune.items())}
        fb_reg(PID_MV=fb_pid["MV"], SP_REMOTE=sp_remote, AUTO=reg.auto, REMOTE=reg.remote,
               **writes)  # fmt: skip
        pid_retune = {n.upper(): v for n, v in retune.items() if n == "u_max"}
        fb_pid(SP=fb_reg["SP"], PV=pv, PV_OK=pv_ok, MANUAL=fb_reg["MANUAL"],
               MAN_VALUE=fb_reg["MAN_VALUE"], **pid_retune)  # fmt: skip
        assert _same(fb_pid["MV"], u), f"sample {k}: MV {fb_pid['MV']!r} vs {u!r}"
        assert _same(fb_reg["SP"], reg.sp), f"sample {k}: SP {fb_reg['SP']!r} vs {reg.sp!r}"
        err = int(fb_reg["ERROR_ID"]) or int(fb_pid["ERROR_ID"])
        assert err == int(reg.error_id), f"sample {k}: ERROR_ID {err:#x} vs {reg.error_id!r}"
        codes.add(err)
        y = 0.97 * y + 0.03 * 0.8 * u
    assert switched["auto"] >= 10 and switched["remote"] >= 8
    assert {ErrorCode.BAD_INPUT, ErrorCode.BAD_MEASUREMENT} <= codes  # the bad data came
