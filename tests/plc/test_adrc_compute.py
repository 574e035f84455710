"""The ADRC's process data of a cycle is one function, ``adrc.adrc_compute``, for every executor.

The block (``ADRC.compute_output``, float64) and the PLC cycle (``plc_cycle.adrc_cycle``: the
exported FB ``CB_ADRC`` and the block's ``precision="float32"`` lane) both call it:

* a mutation of the one function moves the outputs of both (neither keeps a copy);
* hypothesis drives both in float64 with random options, modes and hostile process
  values, retunes left out (the block gets them through ``configure``, the FB detects them
  in its cycle: ``test_cycle.py`` and ``test_cycle_hostile.py`` compare those): every
  output bit for bit;
* what the sharing changed: the FB's output ramp now acts in a cycle whose observer
  overflowed behind a held output, as the block's always did.
"""

from __future__ import annotations

import math
import sys

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ctrlblocks import ADRC, ErrorCode, compiled
from ctrlblocks.blocks import adrc as adrc_mod
from ctrlblocks.blocks import plc_cycle as pc

PROCESS = {"sp": 0.0, "y": 0.0, "ff": 0.0, "y_ok": True, "manual": False, "u_man": 0.0,
           "track": False, "track_value": 0.0, "hold": False, "rst": False, "awin": False,
           "u_real": math.nan}  # fmt: skip
FIG2 = ("e_out", "y_out", "y_ref", "x1_out", "x2_out", "x3_out", "x4_out", "sp_td")


class _Fb:
    """``adrc_cycle`` in float64 with its state carried from call to call."""

    def __init__(self, block: ADRC) -> None:
        cfg = block.config
        self.args = {**PROCESS, **pc.adrc_inputs(cfg), **pc.adrc_state(cfg)}
        self.args["u_man"] = self.args["out"]

    def __call__(self, **inputs: object) -> dict[str, object]:
        self.args.update(inputs)
        res = dict(zip(pc.ADRC_RESULTS, pc.adrc_cycle(**self.args), strict=True))
        for k in self.args:
            if k in res:
                self.args[k] = res[k]
        return res


def _same(a: float, b: float) -> bool:
    return a == b or (a != a and b != b)


def _step(block: ADRC, fb: _Fb, sp: float, y: float, **kw: object) -> tuple[float, float]:
    for name in ("manual", "track", "hold", "awin", "track_value"):
        if name in kw:
            setattr(block, name, kw[name])
    if "rst" in kw:
        block.reset_active = kw["rst"]
    if "u_man" in kw:
        block.u_man = kw["u_man"]
    u = block(sp, y, ff=kw.get("ff", 0.0), y_ok=kw.get("y_ok", True), u_real=kw.get("u_real"))
    fbin = {k: v for k, v in kw.items() if k in PROCESS}
    fbin.update(ff=kw.get("ff", 0.0), y_ok=kw.get("y_ok", True))
    if fbin.get("u_real") is None:
        fbin["u_real"] = math.nan
    res = fb(sp=sp, y=y, **fbin)
    return u, res


def test_a_mutation_of_the_one_function_moves_the_block_and_the_fb_alike(monkeypatch):
    """Both executors run ``adrc_compute``: shifting its output shifts both, by the same."""
    original = adrc_mod.adrc_compute

    def mutant(*args):
        res = original(*args)
        return (res[0] + 0.125, *res[1:])

    cfg = {"order": 2, "b0": 0.5, "omega_c": 1.0, "omega_o": 5.0, "u_min": -10.0,
           "u_max": 10.0, "sp_filter": 0.3, "td_time": 0.5}  # fmt: skip
    plain_block = ADRC(**cfg)
    plain = [_step(plain_block, _Fb(plain_block), 1.0, 0.1 * k)[0] for k in range(5)]
    monkeypatch.setattr(adrc_mod, "adrc_compute", mutant)
    monkeypatch.setattr(pc, "adrc_compute", mutant)
    block = ADRC(**cfg)
    fb = _Fb(block)
    for k in range(5):
        u, res = _step(block, fb, 1.0, 0.1 * k)
        assert u == res["mv"] != plain[k], k  # both moved, alike (the shift feeds back)
        if k == 0:
            assert u == plain[0] + 0.125


def test_the_block_and_the_cycle_call_the_function_and_no_part_of_it():
    """The process data is nowhere else: neither caller calls what ``adrc_compute`` calls."""
    import ast
    import inspect
    import textwrap

    # (the FB scales the sensor's saturation, a configuration value, itself)
    inner = {"adrc_law", "input_stage", "mode_output", "tracking_differentiator", "pid_output"}
    # the source (the compiled build's cdef method has none to read: its .py is this one)
    for fn in (compiled.interpreted("adrc").ADRC._compute_output, pc.adrc_cycle):
        src = textwrap.dedent(inspect.getsource(fn))
        called = {n.func.id for n in ast.walk(ast.parse(src))
                  if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)}  # fmt: skip
        assert "adrc_compute" in called, fn
        assert not called & inner, (fn, called & inner)


VALUES = st.one_of(
    st.floats(-200.0, 200.0, allow_nan=False),
    st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -0.0, 1e30, -1e30, 1e-30, 5e-324]),
)
STEP = st.fixed_dictionaries(
    {"sp": VALUES, "y": VALUES},
    optional={"ff": VALUES, "y_ok": st.booleans(), "manual": st.booleans(), "u_man": VALUES,
              "track": st.booleans(), "track_value": VALUES, "hold": st.booleans(),
              "rst": st.booleans(), "awin": st.booleans(), "u_real": VALUES},
)  # fmt: skip


@st.composite
def configs(draw):
    cfg = {"order": draw(st.sampled_from([1, 2, 3])), "b0": draw(st.sampled_from([0.05, 1.0])),
           "omega_c": draw(st.sampled_from([0.3, 1.0, 4.0])), "ts": 0.1,
           "discretisation": draw(st.sampled_from(["euler", "exact"])),
           "u_min": draw(st.sampled_from([-math.inf, -5.0])),
           "u_max": draw(st.sampled_from([math.inf, 20.0])),
           "u_sf": draw(st.sampled_from([0.0, 2.5])), "u0": draw(st.sampled_from([0.0, 1.0])),
           "anti_windup": draw(st.sampled_from(["directional", "freeze", "off"])),
           "reverse": draw(st.booleans()), "out_rate": draw(st.sampled_from([0.0, 5.0])),
           "u_real_on": draw(st.booleans()),
           "input_delay": draw(st.sampled_from([0.0, 0.3])),
           "pv_range": draw(st.sampled_from([None, (-50.0, 150.0)])),
           "sp_filter": draw(st.sampled_from([0.0, 0.4])),
           "sp_rate": draw(st.sampled_from([0.0, 20.0]))}  # fmt: skip
    cfg["omega_o"] = cfg["omega_c"] * draw(st.sampled_from([3.0, 5.0, 10.0]))
    if draw(st.booleans()):
        cfg.update(anti_backoff=True, y_sat=draw(st.sampled_from([50.0, 120.0])), y_sat_lo=-40.0)
    else:
        cfg["pv_filter"] = draw(st.sampled_from([0.0, 0.4]))
    reference = draw(st.sampled_from(["none", "t_ref", "td"]))
    if reference == "t_ref":
        cfg["t_ref"] = 0.5
    elif reference == "td":
        cfg["td_time"] = 0.6
    return cfg


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cfg=configs(), steps=st.lists(STEP, min_size=5, max_size=60))
def test_the_block_is_the_cycle_bit_for_bit_in_float64(cfg, steps):
    """Random options, modes and process values: the float64 block and the float64 cycle give
    the same MV, status and outputs of Fig. 2 bit for bit in every cycle (no retunes)."""
    block = ADRC(**cfg)
    fb = _Fb(block)
    for k, step in enumerate(steps):
        u, res = _step(block, fb, **step)
        assert _same(u, res["mv"]), (k, u, res["mv"])
        assert int(block.error_id) == int(res["error_id"]), (k, block.error_id, res["error_id"])
        want = (block.e, block.y, block.y_ref, *block.x, block.sp_td)
        for name, w in zip(FIG2, want, strict=True):
            assert _same(res[name], w), (k, name, res[name], w)


@pytest.mark.parametrize(("precision", "spike"), [("float64", 1e308), ("float32", 3e38)])
def test_the_output_ramp_acts_in_a_cycle_whose_observer_overflowed(precision, spike):
    """An ESO that overflows behind a held output (MAN) restarts (16#8103) and the output of
    the cycle stands -- ramped, as in every mode but RESET.  Before the FB and the block
    shared their process data, the FB (and so the float32 block) skipped the ramp in that
    cycle and jumped to the manual value."""
    a = ADRC(order=2, b0=1.0, omega_c=1.0, omega_o=4.0, ts=0.1, out_rate=1.0,
             precision=precision)  # fmt: skip
    a.manual, a.u_man = True, 0.0
    a(0.0, 0.0)
    a.u_man = 5.0
    assert a(0.0, spike) == pytest.approx(0.1, rel=1e-6)  # out_rate ts, not 5.0
    assert a.error_id == ErrorCode.BAD_RESULT
    assert a(0.0, 0.5) == pytest.approx(0.2, rel=1e-6) and a.error_id == ErrorCode.NO_ERROR


@pytest.mark.parametrize("delay", [0.0, 0.3])
@pytest.mark.parametrize("t_ref", [0.0, 0.5])
def test_after_a_law_that_overflowed_the_block_and_the_fb_continue_alike(delay, t_ref, monkeypatch):
    """A PV whose law overflows (1.7e308) in the cycle where the feed-forward changes: the
    output is held (16#8103) and the ESO restarts (``adrc_compute``; the block's delay
    history by ``ADRC._resume``, the FB's delay line in its cycle).  Both keep the
    feed-forward the held output was made with (the last one: the ESO restarts on the held
    u less it) and this cycle's reference, so every later cycle is the same bit for bit.
    Before, the FB kept this cycle's FF and the last reference: the restarted ESO started
    from another u and the outputs parted.  The FB runs in float64 with the double's range
    as its REAL's (its ``REAL_MAX`` the largest double), so that the same PV overflows both
    laws."""
    monkeypatch.setattr(pc, "REAL_MAX", sys.float_info.max)
    cfg = {"order": 2, "b0": 0.5, "omega_c": 1.0, "omega_o": 5.0, "ts": 0.1, "u_min": -50.0,
           "u_max": 50.0, "input_delay": delay, "t_ref": t_ref}  # fmt: skip
    block = ADRC(**cfg)
    fb = _Fb(block)
    for k in range(40):
        u, res = _step(block, fb, 1.0, 0.02 * k, ff=0.5)
        assert _same(u, res["mv"]), k
    u, res = _step(block, fb, 1.0, 1.7e308, ff=3.0)
    assert int(block.error_id) == int(res["error_id"]) == ErrorCode.BAD_RESULT
    assert _same(u, res["mv"])
    for k in range(40):
        u, res = _step(block, fb, 1.0, 0.8 + 0.005 * k, ff=3.0)
        assert _same(u, res["mv"]), (k, u, res["mv"])
        assert int(block.error_id) == int(res["error_id"]), k
        want = (block.e, block.y, block.y_ref, *block.x, block.sp_td)
        for name, w in zip(FIG2, want, strict=True):
            assert _same(res[name], w), (k, name, res[name], w)
