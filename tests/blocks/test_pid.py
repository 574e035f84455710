"""PID block: algorithm variants, two-phase use, limits, NaN handling, forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ctrlblocks import (
    PID,
    ErrorCode,
    ParameterError,
    isa_to_series,
    parallel_to_series,
    series_to_isa,
    series_to_parallel,
)


def _pv(k: int) -> float:
    return 0.3 * math.sin(0.21 * k) + 0.1 * math.cos(1.3 * k) if k else 0.0


# --- forms ------------------------------------------------------------------


def test_series_to_parallel_is_equation_2_5() -> None:
    # K = K'(Ti'+Td')/Ti' = 2*5/4, Ti = 5, Td = 4*1/5
    assert series_to_parallel(2.0, 4.0, 1.0) == pytest.approx((2.5, 5.0, 0.8), abs=1e-15)


def test_parallel_to_series_is_equation_2_6_and_inverts_2_5() -> None:
    k, ti, td = 3.0, 10.0, 2.0  # 1 - 4 Td/Ti = 0.2
    r = math.sqrt(0.2)
    want = (1.5 * (1 + r), 5.0 * (1 + r), 5.0 * (1 - r))
    got = parallel_to_series(k, ti, td)
    assert got == pytest.approx(want, abs=1e-12)
    assert series_to_isa(*got) == pytest.approx((k, ti, td), abs=1e-12)


def test_parallel_to_series_refuses_ti_below_4_td() -> None:
    with pytest.raises(ParameterError) as info:
        isa_to_series(1.0, 3.9, 1.0)
    assert info.value.code == ErrorCode.BAD_FORM
    assert isa_to_series(1.0, 4.0, 1.0) == pytest.approx((0.5, 2.0, 2.0), abs=1e-15)


# --- velocity algorithm ---------------------------------------------------------


@pytest.mark.parametrize("imeth", ["forward", "backward", "tustin"])
@pytest.mark.parametrize(("ti", "td"), [(2.0, 0.0), (2.0, 0.4), (0.0, 0.0), (0.0, 0.4)])
def test_velocity_equals_positional_without_limits(imeth: str, ti: float, td: float) -> None:
    kw = dict(
        kp=1.5, ti=ti, td=td, b=0.6, c=0.2, ts=0.1, u_min=-1e6, u_max=1e6, integral_method=imeth
    )
    pos, vel = PID(**kw), PID(**kw, algorithm="velocity")
    a = [pos(1.0 if k > 3 else 0.0, _pv(k), ff=0.1 * math.sin(k)) for k in range(300)]
    b = [vel(1.0 if k > 3 else 0.0, _pv(k), ff=0.1 * math.sin(k)) for k in range(300)]
    assert max(abs(x) for x in a) > 0.5
    np.testing.assert_allclose(b, a, rtol=0, atol=1e-9)


@pytest.mark.parametrize("td", [0.0, 0.5])
def test_p_and_pd_in_velocity_form_hold_the_proper_steady_state_after_a_limit(td: float) -> None:
    # Åström 1987, Fig. 2.3/2.4: without the reset feedback the output would keep
    # the offset it got while limited; with it, u -> kp (r - y) + bias.
    pid = PID(kp=2.0, td=td, ts=0.1, u_min=-1.0, u_max=1.0, algorithm="velocity", tt=0.3)
    for _ in range(20):
        pid(0.2, 0.0)  # u = 0.4, inside the limits
    assert pid.out == pytest.approx(0.4, abs=1e-12)
    for _ in range(20):
        pid(3.0, 0.0)  # wants 6: limited at 1
    assert pid.out == 1.0 and pid.limits_active
    for _ in range(200):
        pid(0.2, 0.0)
    assert pid.out == pytest.approx(0.4, abs=1e-9)
    assert not pid.limits_active


# --- two-phase ---------------------------------------------------------------------


def test_compute_output_is_idempotent_within_a_cycle() -> None:
    pid = PID(
        kp=1.0,
        ti=1.0,
        td=0.2,
        ts=0.1,
        u_min=-10,
        u_max=10,
        sp_filter=0.5,
        pv_filter=0.3,
        sp_rate=2.0,
        out_rate=5.0,
    )
    for k in range(10):
        pid(1.0, _pv(k))
    v1 = pid.compute_output(2.0, 0.4)
    v2 = pid.compute_output(2.0, 0.4)
    assert v1 == v2
    pid.update_state(v1)
    ref = PID(pid.config)
    for k in range(10):
        ref(1.0, _pv(k))
    assert ref(2.0, 0.4) == v1
    assert pid.snapshot() == ref.snapshot()


def test_compute_output_commits_nothing_until_update_state() -> None:
    # the two-phase contract of blocks.base: one pending value, the committed state
    # (filters and ramps included) untouched until update_state, no scratch attributes
    pid = PID(kp=1.0, ti=1.0, td=0.2, ts=0.1, u_min=-10, u_max=10, sp_filter=0.5,
              pv_filter=0.3, sp_rate=2.0, out_rate=5.0, ff_k=0.5, ff_t_lead=1.0)  # fmt: skip
    for k in range(10):
        pid(1.0, _pv(k), dv=0.1 * k)
    before = pid.snapshot()
    names = set(vars(pid))
    v1 = pid.compute_output(2.0, 0.4, dv=1.0)
    pid.compute_output(-3.0, 5.0, dv=-2.0)  # another candidate first ...
    after = pid.snapshot()
    private = [n for n in PID._state_fields if n.startswith("_")]  # not the readable outputs
    assert [after[n] for n in private] == [before[n] for n in private]
    assert after["_subs"] == before["_subs"]
    assert set(vars(pid)) == names
    assert pid.compute_output(2.0, 0.4, dv=1.0) == v1  # ... then the real one
    pid.update_state(v1)
    assert pid.snapshot()["_subs"] != before["_subs"]
    ref = PID(pid.config)
    for k in range(10):
        ref(1.0, _pv(k), dv=0.1 * k)
    assert ref(2.0, 0.4, dv=1.0) == v1
    assert pid.snapshot() == ref.snapshot()
    snap = pid.snapshot()
    pid.update_state(0.0)  # no pending cycle: nothing happens
    assert pid.snapshot() == snap


def test_call_is_compute_then_update_with_its_own_output() -> None:
    a = PID(kp=1.0, ti=0.5, ts=0.1, u_min=-1, u_max=1)
    b = PID(a.config)
    for k in range(50):
        u = a(1.0, _pv(k))
        v = b.compute_output(1.0, _pv(k))
        b.update_state(v)
        assert u == v


# --- limits ------------------------------------------------------------------------


def test_clamping_stops_the_integrator_at_the_limit() -> None:
    pid = PID(kp=1.0, ti=1.0, ts=0.1, u_min=0.0, u_max=2.0, anti_windup="clamping")
    for _ in range(100):
        pid(5.0, 0.0)  # P alone = 5 > 2
    assert pid.out == 2.0 and pid.limits_active and pid.awout
    assert pid.i == pytest.approx(0.0, abs=1e-12)  # never integrated


def test_set_limits_reversed_pair_keeps_the_old_limits_and_sets_8201() -> None:
    pid = PID(kp=1.0, ti=1.0, ts=0.1, u_min=0.0, u_max=10.0)
    pid(1.0, 0.0)
    pid.set_limits(5.0, 1.0)
    assert pid.error_id == ErrorCode.BAD_LIMITS and pid.error
    assert (pid.u_min, pid.u_max) == (0.0, 10.0)
    pid(100.0, 0.0)
    assert pid.out == 10.0 and pid.error_id == ErrorCode.BAD_LIMITS
    pid.set_limits(math.nan, 3.0)
    assert pid.error_id == ErrorCode.BAD_LIMITS
    pid.set_limits(-1.0, 3.0)
    assert pid(100.0, 0.0) == 3.0 and pid.error_id == 0


# --- process data ---------------------------------------------------------------


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("where", ["sp", "pv", "ff"])
def test_bad_input_holds_the_output_and_recovers_without_a_bump(bad: float, where: str) -> None:
    pid = PID(kp=2.0, ti=1.0, td=0.3, ts=0.1, u_min=-10, u_max=10)
    for k in range(30):
        pid(1.0, _pv(k))
    held = pid.out
    args = {"sp": 1.0, "pv": 0.5, "ff": 0.0}
    args[where] = bad
    for _ in range(5):
        u = pid(args["sp"], args["pv"], ff=args["ff"])
        assert u == held
        assert pid.error_id == ErrorCode.BAD_INPUT and pid.error
    u = pid(1.0, 0.5)  # PV moved from ~0.1 to 0.5 meanwhile: no bump on recovery
    assert u == pytest.approx(held, abs=1e-12)
    assert pid.error_id == 0


def test_bad_input_with_safe_value_goes_to_the_safe_value() -> None:
    pid = PID(kp=2.0, ti=1.0, ts=0.1, safe_value=7.0)
    pid(50.0, 40.0)
    assert pid(50.0, math.nan) == 7.0
    assert pid.error_id == ErrorCode.BAD_INPUT


@pytest.mark.parametrize("dt", [0.0, -0.1, math.nan, math.inf])
def test_bad_dt_holds_the_output_with_no_cycle(dt: float) -> None:
    pid = PID(kp=2.0, ti=1.0, ts=0.1, u_min=-10, u_max=10)
    u = pid(1.0, 0.0)
    snap = pid.snapshot()
    assert pid(1.0, 0.0, dt=dt) == u
    assert pid.error_id == ErrorCode.NO_CYCLE
    snap.pop("error_id")
    now = pid.snapshot()
    now.pop("error_id")
    assert now == snap
    assert pid(1.0, 0.0) != u and pid.error_id == 0


def test_numpy_inputs_give_plain_float_outputs_and_states() -> None:
    pid = PID(kp=1.0, ti=1.0, td=0.2, ts=0.1)
    pid.manual, pid.manual_value = True, np.float64(3.0)
    pid(np.float64(1.0), np.float64(0.5), ff=np.float64(0.1))
    pid.manual = False
    u = pid(np.float64(1.0), np.float64(0.5), ff=np.float64(0.1), dv=np.float64(0.0))
    assert type(u) is float
    for name in ("out", "p", "i", "d", "ff", "e", "manual_value", "_i", "_d", "_w_prev"):
        assert type(getattr(pid, name)) is float, name


def test_compute_output_again_with_other_inputs_replaces_the_first_attempt() -> None:
    kw = dict(kp=1.0, ti=1.0, td=0.2, ts=0.1, u_min=-10, u_max=10, sp_filter=0.5, sp_rate=2.0)
    a, b = PID(**kw), PID(**kw)
    for k in range(10):
        a(1.0, _pv(k))
        b(1.0, _pv(k))
    a.compute_output(5.0, 3.0, ff=1.0)  # a first attempt, then the real inputs
    v = a.compute_output(2.0, 0.4)
    a.update_state(v)
    assert v == b(2.0, 0.4)
    assert a.snapshot() == b.snapshot()


def test_per_call_dt_is_the_integration_step() -> None:
    pid = PID(kp=2.0, ti=4.0, ts=0.1, u_min=-100, u_max=100, integral_method="backward")
    pid(1.0, 0.0)
    pid(1.0, 0.0, dt=0.5)  # backward Euler: + K dt/Ti e = 2 * 0.5/4 * 1
    assert pid.i == pytest.approx(0.25, abs=1e-12)
    pid(1.0, 0.0)  # back to ts
    assert pid.i == pytest.approx(0.30, abs=1e-12)


def test_clamping_also_stops_the_integrator_while_the_output_ramp_limits() -> None:
    pid = PID(kp=1.0, ti=1.0, ts=0.1, u_min=-100, u_max=100, out_rate=1.0)  # 0.1 per cycle
    pid(0.0, 0.0)
    for k in range(1, 30):
        u = pid(10.0, 0.0)  # wants 10 + I: the ramp holds it back
        assert u == pytest.approx(0.1 * k, abs=1e-12) and pid.limits_active
        assert pid.i == 0.0
    free = PID(
        kp=1.0,
        ti=1.0,
        ts=0.1,
        u_min=-100,
        u_max=100,
        out_rate=1.0,
        anti_windup="back_calc_model",
        tt=1e9,
    )
    free(0.0, 0.0)
    for _ in range(29):
        free(10.0, 0.0)
    # trapezoid: 0.1 (0 + 10)/2 in the step cycle, then 0.1 * 10 per cycle: winds up
    assert free.i == pytest.approx(0.5 + 28 * 1.0, rel=1e-8)


# --- retuning (tuning fields only: the short path of configure) ------------------------


def _retune_pair(**cfg: object) -> tuple[PID, PID]:
    a, b = PID(**cfg), PID(**cfg)
    for k in range(15):
        a(1.0, _pv(k), dv=0.1 * k)
        b(1.0, _pv(k), dv=0.1 * k)
    return a, b


@pytest.mark.parametrize(
    "cfg",
    [
        {"kp": 1.5, "ti": 2.0, "td": 0.3, "ts": 0.1, "u_min": -10, "u_max": 10},
        {"kp": 1.5, "ti": 2.0, "td": 0.3, "ts": 0.1, "sp_filter": 0.5, "out_rate": 4.0,
         "ff_k": 0.5, "anti_windup": "back_calc_model", "tt": 0.7},
        {"kp": 0.8, "ti": 0.0, "td": 0.2, "ts": 0.1, "algorithm": "velocity", "form": "series"},
    ],
)  # fmt: skip
def test_a_tuning_change_gives_the_state_of_the_full_configure(cfg: dict) -> None:
    a, b = _retune_pair(**cfg)
    changes = {"kp": 2.5, "ti": 3.0, "td": 0.1, "b": 0.7, "c": 0.2, "n": 8.0}
    a.configure(**changes)  # tuning fields only: the short path
    b.configure(**changes, u_min=b.config.u_min)  # with another field: the full path
    assert a.config == b.config
    assert a.snapshot() == b.snapshot()
    for k in range(20):  # the same bumpless continuation, bit for bit
        assert a(2.0, _pv(k), dv=0.2) == b(2.0, _pv(k), dv=0.2)
    assert a.snapshot() == b.snapshot()


def test_a_refused_tuning_change_keeps_configuration_and_state() -> None:
    pid = PID(kp=1.0, ti=2.0, td=0.0, n=10.0, ts=0.1, derivative_method="forward")
    for k in range(10):
        pid(1.0, _pv(k))
    cfg, snap = pid.config, pid.snapshot()
    for changes, code in (
        ({"td": 0.4}, ErrorCode.BAD_PID_COEFFS),  # Td/N = 0.04 <= ts/2: unstable (2.10)
        ({"kp": -1.0}, ErrorCode.BAD_PID_COEFFS),
        ({"tt": 0.0}, ErrorCode.BACK_CALC_T),
        ({"kp": 1e308, "ti": 1e-300}, ErrorCode.BAD_PID_COEFFS),  # K/Ti overflows
    ):
        with pytest.raises(ParameterError) as exc:
            pid.configure(**changes)
        assert exc.value.code == code
        assert pid.config is cfg and pid.snapshot() == snap
    twin = PID(cfg)  # never asked to retune
    for k in range(10):
        twin(1.0, _pv(k))
    assert pid(1.0, 0.5) == twin(1.0, 0.5)
