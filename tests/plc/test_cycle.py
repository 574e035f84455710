"""The PLC cycle (blocks.plc_cycle) is the blocks' behaviour, and float32 is REAL arithmetic.

* run in float64, the cycle functions give the blocks' own outputs over the
  long traces (so the plumbing around the kernels -- modes, bad input,
  retuning, limits -- is the blocks' plumbing, not a second behaviour);
* ``precision="float32"`` stays within float32 rounding of float64 and really
  rounds every intermediate (Åström 1987, section 2: the increment
  ``K h e / Ti`` lost when added to a large integral);
* the option is refused where the cycle does not cover the configuration.
"""

from __future__ import annotations

import functools
import inspect
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ctrlblocks import ADRC, PID, LeadLag, MovingAverage, ParameterError, SteadyStateDetector
from ctrlblocks.blocks import adrc as adrc_mod
from ctrlblocks.blocks import plc_cycle as pc
from ctrlblocks.blocks.signals import steady_step

from .traces import (
    ADRC_OPTIONS,
    DB_OPTIONS,
    PID_MODES,
    PID_OPTIONS,
    REAL_SPIKE,
    adrc_trace,
    leadlag_trace,
    pid_trace,
)

ADRC_PROCESS = {"sp": 0.0, "y": 0.0, "y_ok": True, "manual": False, "u_man": 0.0,
                "awin": False, "u_real": math.nan, "ff": 0.0, "track": False,
                "track_value": 0.0, "hold": False, "rst": False}  # fmt: skip
PID_PROCESS = {"sp": 0.0, "pv": 0.0, "ff": 0.0, "dv": 0.0, "pv_ok": True, "manual": False,
               "man_value": 0.0, "rst": False, "track": False, "track_value": 0.0,
               "hold": False, "awin": False, "actuator_pos": math.nan}  # fmt: skip

FB_TO_PY = {
    "pid": {"SP": "sp", "PV": "pv", "FF": "ff", "PV_OK": "pv_ok", "MANUAL": "manual",
            "MAN_VALUE": "man_value", "RST": "rst", "K": "k", "TI": "ti", "U_MIN": "u_min",
            "U_MAX": "u_max", "DV": "dv", "TRACK": "track", "TRACK_VALUE": "track_value",
            "HOLD": "hold", "AWIN": "awin", "ACTUATOR_POS": "actuator_pos", "T_STAB": "t_stab",
            "TS": "ts"},
    "adrc": {"SP": "sp", "PV": "y", "PV_OK": "y_ok", "MANUAL": "manual", "MAN_VALUE": "u_man",
             "OMEGA_C": "omega_c", "OMEGA_O": "omega_o", "U_MIN": "u_min", "U_MAX": "u_max",
             "AWIN": "awin", "U_REAL": "u_real", "FF": "ff", "TRACK": "track",
             "TRACK_VALUE": "track_value", "HOLD": "hold", "RST": "rst", "PV_LO": "pv_lo",
             "PV_HI": "pv_hi", "TD_TIME": "td_time"},
    "leadlag": {"IN": "x", "ENABLE": "enable", "T_LEAD": "t_lead", "OUT_MIN": "out_min",
                "OUT_MAX": "out_max"},
}  # fmt: skip


def _run64(kind, block, trace):
    """The cycle function in float64, fed with the trace's inputs; per sample its output, its
    status and all its results by name."""
    fn, results, inputs, state, process = {
        "pid": (pc.pid_cycle, pc.PID_RESULTS, pc.pid_inputs, pc.pid_state, PID_PROCESS),
        "adrc": (pc.adrc_cycle, pc.ADRC_RESULTS, pc.adrc_inputs, pc.adrc_state,
                 ADRC_PROCESS),
        "leadlag": (pc.leadlag_cycle, pc.LEADLAG_RESULTS, pc.leadlag_inputs,
                    pc.leadlag_state, {"x": 0.0, "enable": True}),
    }[kind]  # fmt: skip
    args = {**process, **inputs(block.config), **state(block.config)}
    if "man_value" in args:
        args["man_value"] = args["out"]
    if "u_man" in args:
        args["u_man"] = args["out"]
    out = []
    for inp in trace.inputs:
        for k, v in inp.items():
            args[FB_TO_PY[kind][k]] = v
        res = dict(zip(results, fn(**args), strict=True))
        for k in args:
            if k in res:
                args[k] = res[k]
        if "man_value" in res:
            args["man_value"] = res["man_value"]
        mv = res.get("mv", res.get("out"))
        out.append((mv, res["error_id"], res))
    return out


@pytest.mark.parametrize(
    ("kind", "make"),
    [
        ("pid", lambda: pid_trace(1000, seed=7)),
        ("pid", lambda: pid_trace(400, seed=8, anti_windup="back_calc_model", reverse=True)),
        *(
            ("pid", functools.partial(pid_trace, 600, 20 + j, modes=True, **cfg))
            for j, cfg in enumerate(PID_OPTIONS)
        ),
        *(("pid", functools.partial(pid_trace, 1000, 60, **cfg)) for cfg in DB_OPTIONS),
        ("adrc", lambda: adrc_trace(1000, seed=9)),
        ("adrc", lambda: adrc_trace(400, seed=10, order=3, b0=0.01, omega_c=0.3, omega_o=1.2)),
        *(
            ("adrc", functools.partial(adrc_trace, 600, 40 + j, modes=True, **cfg))
            for j, cfg in enumerate(ADRC_OPTIONS)
        ),
        ("leadlag", lambda: leadlag_trace(400, seed=11)),
    ],
)
def test_cycle_in_float64_is_the_block(kind, make):
    start, trace = make()
    # the same inputs through the normal (float64) block
    cls = type(start)
    block = cls(**{**vars(start.config), "precision": "float64"})
    ref = []
    fig2 = []  # the ADRC's outputs of Nowak et al. 2018, Fig. 2: e, Y, Y_ref, the ESO state
    for inp in trace.inputs:
        if kind == "pid":
            for name, attr in PID_MODES.items():
                if name in inp:
                    setattr(block, attr, inp[name])
            if "K" in inp:
                block.configure(kp=inp["K"], ti=inp["TI"])
            if "U_MIN" in inp:
                block.configure(u_min=inp["U_MIN"], u_max=inp["U_MAX"])
            for name in ("T_STAB", "TS"):
                if name in inp:
                    block.configure(**{name.lower(): inp[name]})
            u = block(inp["SP"], inp["PV"], ff=inp["FF"], pv_ok=inp["PV_OK"], dv=inp.get("DV", 0.0))
            ref.append((u, int(block.error_id)))
        elif kind == "adrc":
            if "MANUAL" in inp:
                block.manual = inp["MANUAL"]
            if "MAN_VALUE" in inp:
                block.u_man = inp["MAN_VALUE"]
            if "AWIN" in inp:
                block.awin = inp["AWIN"]
            for name in ("TRACK", "TRACK_VALUE", "HOLD"):
                if name in inp:
                    setattr(block, name.lower(), inp[name])
            if "RST" in inp:
                block.reset_active = inp["RST"]
            if "PV_LO" in inp:
                block.configure(pv_range=(inp["PV_LO"], inp["PV_HI"]))
            if "TD_TIME" in inp:
                block.configure(td_time=inp["TD_TIME"])
            if "OMEGA_C" in inp:
                block.configure(omega_c=inp["OMEGA_C"], omega_o=inp["OMEGA_O"])
            if "U_MIN" in inp:
                block.set_limits(inp["U_MIN"], inp["U_MAX"])
            u = block(inp["SP"], inp["PV"], ff=inp.get("FF", 0.0), y_ok=inp["PV_OK"],
                      u_real=inp.get("U_REAL"))  # fmt: skip
            ref.append((u, int(block.error_id)))
            fig2.append((block.e, block.y, block.y_ref, *block.x, block.sp_td))
        else:
            if "T_LEAD" in inp:
                block.configure(t_lead=inp["T_LEAD"], out_min=inp["OUT_MIN"],
                                out_max=inp["OUT_MAX"])  # fmt: skip
            ref.append((block(inp["IN"], enable=inp["ENABLE"]), int(block.error_id)))
    got = _run64(kind, start, trace)
    # Up to the PV spikes: beyond the REAL range the cycle (written for REAL) sees a bad
    # input or an overflow where float64 computes on (test_overflow_... covers them).
    end = next((k for k, i in enumerate(trace.inputs) if i.get("PV") in SPIKES), len(ref))
    got, ref = got[:end], ref[:end]
    scale = max(abs(u) for u, _e in ref) + 1.0
    for k, ((u, e, _res), (v, f)) in enumerate(zip(got, ref, strict=True)):
        assert abs(u - v) <= 1e-12 * scale, f"sample {k}: cycle {u!r}, block {v!r}"
        assert e == f, f"sample {k}: cycle 16#{e:04X}, block 16#{f:04X}"
    if kind == "adrc":
        # the FB's outputs E, Y, Y_REF, X1..X3 and DISTURBANCE are the block's e, y, y_ref, x
        # and SP_TD the tracking differentiator's filtered setpoint (the working SP without)
        names = ("e_out", "y_out", "y_ref", "x1_out", "x2_out", "x3_out", "x4_out", "sp_td")
        moved = set()
        for k, ((_u, _e, res), want) in enumerate(zip(got, fig2[:end], strict=True)):
            for name, w in zip(names, want, strict=True):
                g = res[name]
                assert abs(g - w) <= 1e-12 * (abs(w) + scale), f"sample {k}: {name} {g!r}, {w!r}"
                if g != 0.0:
                    moved.add(name)
        n = start.config.order
        assert moved >= {"e_out", "y_out", "y_ref", "x1_out", "x4_out", "sp_td",
                         *(["x2_out"] if n >= 2 else []), *(["x3_out"] if n >= 3 else [])}


SPIKES = (REAL_SPIKE, 1.7e308)


@pytest.mark.parametrize(
    "make",
    [
        lambda p: PID(kp=1.5, ti=4.0, td=0.5, u_min=0.0, u_max=100.0, precision=p),
        lambda p: PID(kp=1.5, ti=4.0, algorithm="velocity", out_rate=20.0, precision=p),
        lambda p: ADRC(order=2, b0=0.05, omega_c=0.5, omega_o=2.5, precision=p),
        lambda p: ADRC(order=3, b0=0.05, discretisation="exact", precision=p),
    ],
)
def test_overflow_of_the_law_holds_the_output_and_recovers_as_the_block_does(make):
    """A PV in range whose law overflows: the output is held (16#8103), never NaN, and the
    next good cycles continue from it without a bump -- in REAL (the FB's cycle, PV 3e38)
    as the float64 block does (its output guard, PV 1.7e308)."""
    for precision, spike in (("float32", REAL_SPIKE), ("float64", 1.7e308)):
        blk = make(precision)
        for _ in range(50):
            held = blk(30.0, 29.0)
        assert blk(30.0, spike) == held
        assert blk.error_id == 0x8103
        after = [blk(30.0, 29.0) for _ in range(3)]
        assert all(math.isfinite(u) for u in after)
        assert abs(after[0] - held) < 0.05 * (abs(held) + 1.0), (precision, held, after)
        assert blk.error_id in (0, 0x8301)


@pytest.mark.parametrize("n", [1, 2, 3])
@pytest.mark.parametrize("a", [1e-9, 1e-4, 0.05, 0.0999, 0.1, 0.3, 1.0, 3.0, 40.0])
def test_exact_coefficients_spelled_out_equal_the_blocks_ackermann_ones(n, a):
    """exact_coefficients (the one design: PLC arithmetic, no expm1, no matrices) against
    an independent closed form (numpy, expm1, tests/blocks/exact_oracle.py) for every
    order, omega ts from 1e-9 to 40."""
    from tests.blocks.exact_oracle import exact_coefficients as oracle

    b0, h = 0.7, 0.05
    wc, wo = 0.4 * a / h, a / h
    got = pc.exact_coefficients(n, b0, wc, wo, h)
    coef, gains = oracle(n, b0, wc, wo, h)
    assert got == pytest.approx((*coef, *gains), rel=1e-13, abs=0.0)


@pytest.mark.parametrize("a", [1e-12, 1e-6, 0.01, 0.0999, 0.1, 0.5, 2.0, 50.0])
def test_pole_distance_equals_expm1(a):
    d, q = pc.pole_distance(a / 0.1, 0.1)
    assert d == pytest.approx(-math.expm1(-a), rel=3e-14)
    assert q == pytest.approx(-math.expm1(-a) / 0.1, rel=3e-14)


@pytest.mark.parametrize("n", [1, 2, 3])
@pytest.mark.parametrize("disc", ["euler", "exact"])
def test_discretisation_ok_is_the_blocks_trusted_range(n, disc):
    for a in np.linspace(0.05, 2.0, 40):
        for ratio in (0.2, 1.0):
            args = (n, ratio * a / 0.1, a / 0.1, 0.1)
            assert pc.discretisation_ok(*args, disc == "exact") == (
                adrc_mod.discretisation_trusted(*args, disc)
            )


def test_float32_block_stays_within_single_precision_of_float64():
    _start, trace = pid_trace(1000, seed=12)
    ref = PID(kp=1.5, ti=4.0, td=0.5, ts=0.1, u_min=0.0, u_max=100.0)
    f32 = [u for u, _e, _f in trace.outputs]
    # replay the float32 block's inputs through the float64 block (same events)
    worst = 0.0
    for inp, u32 in zip(trace.inputs, f32, strict=True):
        if "MANUAL" in inp:
            ref.manual = inp["MANUAL"]
        if "MAN_VALUE" in inp:
            ref.manual_value = inp["MAN_VALUE"]
        if "RST" in inp:
            ref.reset_active = inp["RST"]
        if "K" in inp:
            ref.configure(kp=inp["K"], ti=inp["TI"])
        if "U_MIN" in inp:
            ref.configure(u_min=inp["U_MIN"], u_max=inp["U_MAX"])
        u64 = ref(inp["SP"], inp["PV"], ff=inp["FF"], pv_ok=inp["PV_OK"])
        assert np.float32(u32) == u32  # a REAL value
        worst = max(worst, abs(u32 - u64))
    assert 0.0 < worst < 1e-3  # rounding differs, but only at single precision (% of range)


def test_float32_loses_the_integral_increment_as_astrom_warns():
    """Åström 1987, (2.8) and section 2: ``K h e/Ti`` is rounded off when added to I."""
    kw = {"kp": 1.0, "ti": 1000.0, "ts": 0.01, "u_min": 0.0, "u_max": 100.0,
          "reset_value": 50.0, "integral_method": "forward"}  # fmt: skip
    f32 = PID(**kw, precision="float32")
    f64 = PID(**kw)
    for blk in (f32, f64):
        blk.manual, blk.manual_value = True, 50.0
        blk(50.0, 50.0)  # integrator set to 50 % bumplessly
        blk.manual = False
    e = 0.01  # a 0.01 % control error: increment K h e / Ti = 1e-7 per sample
    for _ in range(2000):
        u32 = f32(50.0 + e, 50.0)
        u64 = f64(50.0 + e, 50.0)
    # the switch to AUTO continues at 50 %; then float64 integrates 1999 * 1e-7 = 2e-4,
    # while in float32 ulp(50) = 3.8e-6 > 2 * 1e-7 rounds every increment away
    assert u64 - 50.0 == pytest.approx(1999 * 1e-7, rel=1e-6)
    assert abs(u32 - 50.0) <= float(np.spacing(np.float32(50.0)))
    assert np.spacing(np.float32(50.0)) > 2 * 1e-7


def test_velocity_form_needs_precision_only_where_the_increments_are_added():
    """Åström 1987, section 2 (incremental form): increments are fine in short words."""
    k, h, ti, e = 1.0, 0.01, 1000.0, 0.01
    inc32 = np.float32(k) * np.float32(h) / np.float32(ti) * np.float32(e)
    assert abs(float(inc32) - 1e-7) < 1e-7 * 1e-6  # the increment itself is accurate in REAL
    acc32, acc64 = np.float32(50.0), 50.0
    for _ in range(2000):
        acc32 = acc32 + inc32  # a REAL output integrator loses it
        acc64 = acc64 + float(inc32)  # an LREAL one keeps it
    assert acc32 == np.float32(50.0)
    assert acc64 - 50.0 == pytest.approx(2e-4, rel=1e-5)


@pytest.mark.parametrize(
    ("cls", "kw", "field"),
    [
        (PID, {"deadband": 1.0, "t_stab": 20000.0}, "t_stab"),  # a 2e5-sample ARRAY
    ],
)
def test_float32_is_refused_where_the_plc_cycle_does_not_cover_the_options(cls, kw, field):
    with pytest.raises(ParameterError, match=field) as exc:
        cls(**kw, precision="float32")
    assert exc.value.code == 0x8210


def test_unknown_precision_is_refused_and_the_old_configuration_stays():
    ll = LeadLag(k=2.0)
    with pytest.raises(ParameterError, match="precision"):
        ll.configure(precision="float16")
    assert ll.config.precision == "float64" and ll.config.k == 2.0


def test_reset_restarts_the_float32_cycle():
    pid = PID(kp=1.0, ti=1.0, u_min=-math.inf, u_max=math.inf, precision="float32")
    first = [pid(1.0, 0.0) for _ in range(5)]
    pid.reset()
    assert [pid(1.0, 0.0) for _ in range(5)] == first


@pytest.mark.parametrize(
    "block",
    [
        PID(kp=2.0, ti=3.0, td=0.5, n=8.0, b=0.6, c=0.2, ts=0.05, reverse=True,
            integral_method="forward", derivative_method="tustin"),
        PID(kp=1.5, ti=0.0, td=1.0, anti_windup="back_calc_model", tt=2.0, u_min=-5.0),
        ADRC(order=1, b0=0.5, omega_c=2.0, omega_o=9.0, ts=0.02, t_ref=0.5),
        ADRC(order=3, b0=0.01, omega_c=0.3, omega_o=1.2, anti_windup="freeze", u_max=9.0),
    ],
)  # fmt: skip
def test_cycle_passes_the_kernel_the_blocks_own_kernel_params(block, monkeypatch):
    """The coefficients the cycle computes from its inputs are the block's kernel_params()."""
    kind = "pid" if isinstance(block, PID) else "adrc"
    seen = []
    # each block's one law, through its one process-data function (pid_compute, adrc_compute)
    name = "pid_compute" if kind == "pid" else "adrc_compute"
    kernel = getattr(pc, name)

    def spy(*args):
        bound = inspect.signature(kernel).bind(*args).arguments
        seen.append(bound["prm"])
        return kernel(*args)

    monkeypatch.setattr(pc, name, spy)
    inputs = getattr(pc, f"{kind}_inputs")(block.config)
    state = getattr(pc, f"{kind}_state")(block.config)
    process = ({**PID_PROCESS, "sp": 1.0} if kind == "pid"
               else {**ADRC_PROCESS, "sp": 1.0})  # fmt: skip
    getattr(pc, f"{kind}_cycle")(**process, **inputs, **state)
    assert tuple(seen[0]) == pytest.approx(tuple(block.kernel_params()), rel=1e-15, abs=1e-300)


def test_moving_average_kernel_is_the_moving_average_block_with_window_changes():
    """plc_cycle.moving_average (the block's one cycle on a ring in a fixed array, with the
    PLC's resum threshold) against MovingAverage (its list resized by configure) over 3000
    samples with the window changed to shorter and longer lengths (the newest values kept,
    as the block keeps them): the same means to 1e-12, in float64."""
    rng = np.random.default_rng(70)
    cap = 40
    names = ("mean", "buf", "idx", "count", "since", "total", "spread", "mag", "n_prev")
    state = {"mean": 0.0, "buf": [0.0] * cap, "idx": 0, "count": 0, "since": 0, "total": 0.0,
             "spread": 0.0, "mag": 0.0, "n_prev": 0}  # fmt: skip
    ma = MovingAverage(n=25)
    n = 25
    for k in range(3000):
        if k in (400, 900, 1500, 2200):
            n = {400: 7, 900: 40, 1500: 1, 2200: 13}[k]
            ma.configure(n=n)
        u = 50.0 + 10.0 * math.sin(k / 50.0) + rng.standard_normal()
        ref = ma(u)
        res = pc.moving_average(u, n, pc.SUM_LOSS_REAL, *(state[k] for k in names))
        state = dict(zip(names, res, strict=True))
        assert abs(state["mean"] - ref) <= 1e-12 * 60.0, (k, state["mean"], ref)


def test_steady_detector_kernel_is_the_steady_state_detector_block():
    """signals.steady_step (the PID's dead band, pid.pid_update) against SteadyStateDetector
    over a signal that settles, jumps and settles again, with restarts (the block's reset)."""
    rng = np.random.default_rng(71)
    det = SteadyStateDetector(tolerance=0.5, t_stab=1.0, ts=0.1)
    anchor, elapsed, started = 0.0, 0.0, False
    seen = 0
    for k in range(600):
        u = (0.0 if k < 200 else 5.0) + (0.3 if k % 97 == 0 else 0.05) * rng.standard_normal()
        restart = k % 150 == 149
        if restart:
            det.reset()
            ref = False
        else:
            ref = det(u)
        steady, anchor, elapsed, started = steady_step(
            u, 0.5, 1.0, 0.1, restart, anchor, elapsed, started
        )
        assert steady == ref, k
        seen += steady
    assert 100 < seen < 550  # it was steady, and not always


def test_float32_adrc_with_a_measured_cycle_time_every_cycle_keeps_controlling():
    """A PLC that writes the measured cycle time to TS changes TS every cycle: a retune.

    Before the ADRC's retune acted from the same cycle, each TS change held the MV for
    the cycle and re-solved x4 by (11) in the next, so the REAL cycle (and the FB
    exported from it) froze at its first output (4.9 here, for ever); the Euler law's
    gains do not depend on TS, so the retune moves nothing and the loop runs as with
    the float64 block.
    """
    from ctrlblocks.plants import PTn

    runs = {}
    for prec in ("float64", "float32"):
        a = ADRC(order=2, b0=0.05, omega_c=0.35, omega_o=1.75, ts=0.1, u_min=0.0, u_max=5.0,
                 precision=prec)  # fmt: skip
        plant = PTn(k=0.73, t=[7.3, 2.2, 1.4], ts=0.1)
        outs = []
        for k in range(600):
            u = a(2.0, plant.y, dt=0.1 if k % 2 else 0.11)
            plant.step(u)
            outs.append(u)
        runs[prec] = np.array(outs)
    assert len(set(runs["float32"][:50])) == 50  # it moves every cycle
    np.testing.assert_allclose(runs["float32"], runs["float64"], rtol=0, atol=1e-4)
    assert runs["float32"][-1] == pytest.approx(2.0 / 0.73, abs=1e-4)  # offset-free


def test_the_pid_block_and_its_fb_run_one_process_data_function(monkeypatch):
    """The block's general cycle and the FB's cycle (pid_cycle: the float32 lane, the export)
    both run pid.pid_compute and pid.pid_update, the one implementation of the process data
    around the law (the mode's target, the judgement of the inputs, the bad-input output, the
    input stage, the transfer, the law's failure; the commit, the dead band's detector):
    replacing those functions changes both."""
    from ctrlblocks.blocks import pid as pid_mod
    from ctrlblocks.compiled import interpreted

    seen = []
    for name in ("pid_compute", "pid_update"):
        assert getattr(pc, name) is getattr(interpreted("pid"), name)
        for mod, who in ((pid_mod, "block"), (pc, "fb")):
            real = getattr(mod, name)

            def spy(*args, _real=real, _who=who, _name=name):
                seen.append((_who, _name))
                return _real(*args)

            monkeypatch.setattr(mod, name, spy)
    block = PID(kp=2.0, ti=3.0, pv_filter=1.0)  # a filter: the general cycle
    block.update_state(block.compute_output(1.0, 0.0))
    pc.pid_cycle(**{**PID_PROCESS, "sp": 1.0}, **pc.pid_inputs(block.config),
                 **pc.pid_state(block.config))  # fmt: skip
    assert seen == [("block", "pid_compute"), ("block", "pid_update"), ("fb", "pid_compute"),
                    ("fb", "pid_update")]  # fmt: skip


_MODE_ATTR = {"manual": "manual", "track": "track", "hold": "hold", "rst": "reset_active"}


@settings(max_examples=100, deadline=None)
@given(
    options=st.fixed_dictionaries({
        "pv_range": st.sampled_from([None, (-20.0, 180.0)]),
        "sp_filter": st.sampled_from([0.0, 0.7]), "pv_filter": st.sampled_from([0.0, 0.3]),
        "sp_rate": st.sampled_from([0.0, 4.0]), "out_rate": st.sampled_from([0.0, 30.0]),
        "ff_k": st.sampled_from([0.0, 1.5]), "algorithm": st.sampled_from(["positional",
                                                                         "velocity"]),
        "bumpless": st.sampled_from(["integrator", "suppress_p_action"]),
        "deadband": st.sampled_from([0.0, 2.0]), "safe_value": st.sampled_from([None, 5.0]),
        "td": st.sampled_from([0.0, 0.4]), "reverse": st.booleans(),
    }),
    steps=st.lists(st.tuples(
        st.one_of(st.floats(-50.0, 150.0), st.just(math.nan)),
        st.one_of(st.floats(-50.0, 150.0), st.just(math.inf)),
        st.floats(-5.0, 5.0), st.floats(-5.0, 5.0), st.booleans(),
        st.sampled_from([None, None, None, "manual", "track", "hold", "rst"]),
        st.floats(-120.0, 120.0),
    ), min_size=1, max_size=40),
)  # fmt: skip
def test_pid_block_and_its_fb_in_float64_agree_on_random_options_modes_and_bad_inputs(
    options, steps
):
    """Hypothesis: the block and pid_cycle run in float64 give the same output and status on
    every sample, over the input-stage options, the modes and bad inputs (the
    process data of both is pid.pid_compute; the FB's commit is its own)."""
    cfg = {**options, "ff_t_lag": 2.0, "dev_tol": 1.0}
    block = PID(kp=1.2, ti=2.0, ts=0.1, u_min=-100.0, u_max=100.0, t_stab=0.5, **cfg)
    args = {**PID_PROCESS, **pc.pid_inputs(block.config), **pc.pid_state(block.config)}
    args["man_value"] = args["out"]
    for k, (sp, pv, ff, dv, pv_ok, mode, value) in enumerate(steps):
        for name, attr in _MODE_ATTR.items():
            on = mode == name
            setattr(block, attr, on)
            args[name] = on
        if mode == "manual":
            block.manual_value = args["man_value"] = value
        block.track_value = args["track_value"] = value
        u = block(sp, pv, ff=ff, dv=dv, pv_ok=pv_ok)
        args.update(sp=sp, pv=pv, ff=ff, dv=dv, pv_ok=pv_ok)
        res = dict(zip(pc.PID_RESULTS, pc.pid_cycle(**args), strict=True))
        args.update({n: res[n] for n in args if n in res})
        args["man_value"] = res["man_value"]
        assert abs(res["mv"] - u) <= 1e-9 * (1.0 + abs(u)), f"sample {k}: {res['mv']!r}, {u!r}"
        assert res["error_id"] == int(block.error_id), f"sample {k}"
