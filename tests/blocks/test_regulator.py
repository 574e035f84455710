"""The complete regulator of Åström 1987, Fig. 4.6: two switches, both bumpless."""

from __future__ import annotations

import inspect
import math

import numpy as np
import pytest

from ctrlblocks import PID, ErrorCode, ManualStation, ParameterError, Regulator


def _plant(u: float, y: float) -> float:
    return 0.9 * y + 0.1 * 0.8 * u  # a first-order process, gain 0.8


def test_auto_to_manual_and_back_are_bumpless_at_any_error() -> None:
    reg = Regulator(kp=3.0, ti=8.0, td=1.0, sp0=40.0, u0=10.0, ts=0.5)
    y, outs, switches = 0.0, [], []
    for k in range(400):
        if k in (60, 140, 230, 310):
            reg.auto = not reg.auto
            switches.append(k)
        u = reg(y, out_inc=(k % 40 < 10), out_dec=(k % 50 > 45))
        outs.append(u)
        y = _plant(u, y)
    for k in switches:
        assert outs[k] == pytest.approx(outs[k - 1], abs=1e-9), k


def test_manual_buttons_move_the_output_at_the_station_rate() -> None:
    # range 0..100 % in tm_out = 20 s: 5 %/s without acceleration (accel_max = 1)
    reg = Regulator(u0=10.0, tm_out=20.0, accel_max=1.0, ts=0.1)
    reg.auto = False
    for _ in range(10):
        u = reg(0.0, out_inc=True)
    assert u == pytest.approx(15.0, abs=1e-9)


def test_remote_to_local_keeps_the_setpoint_and_local_buttons_move_it() -> None:
    reg = Regulator(kp=1.0, ti=5.0, sp0=20.0, sp_min=0.0, sp_max=100.0, tm_sp=100.0,
                    accel_max=1.0, ts=1.0)  # fmt: skip
    reg.remote = True
    for _ in range(5):
        reg(10.0, 63.5)
    assert reg.sp == 63.5
    reg.remote = False
    reg(10.0)
    assert reg.sp == 63.5  # the local setpoint tracked the remote one
    reg(10.0, sp_inc=True)
    assert reg.sp == pytest.approx(64.5)  # 100 units in 100 s: 1 a second


def test_a_bad_remote_setpoint_holds_the_setpoint() -> None:
    reg = Regulator(kp=1.0, ti=5.0, ts=1.0)
    reg.remote = True
    reg(10.0, 30.0)
    reg(10.0, math.nan)
    assert reg.sp == 30.0 and reg.error_id == ErrorCode.BAD_INPUT
    reg(10.0, 31.0)
    assert reg.sp == 31.0 and reg.error_id == ErrorCode.NO_ERROR


def test_anti_windup_in_automatic_is_the_pids() -> None:
    reg = Regulator(kp=2.0, ti=5.0, u_max=50.0, sp0=100.0, ts=1.0)
    y = 0.0
    for _ in range(200):
        y = _plant(reg(y), y)
    assert reg.out == 50.0
    assert reg.pid.i <= 50.0 + 1e-9  # the integrator did not wind up beyond the limit


def test_snapshot_restore_replays_the_same_outputs() -> None:
    reg = Regulator(kp=2.0, ti=5.0, sp0=30.0, ts=1.0)
    y = 0.0
    for _ in range(20):
        y = _plant(reg(y), y)
    snap, y0 = reg.snapshot(), y
    a = []
    for _ in range(20):
        a.append(reg(y))
        y = _plant(a[-1], y)
    reg.restore(snap)
    y, b = y0, []
    for _ in range(20):
        b.append(reg(y))
        y = _plant(b[-1], y)
    np.testing.assert_array_equal(a, b)


def test_bad_configuration_is_refused_with_the_old_one_kept() -> None:
    reg = Regulator(kp=1.0)
    with pytest.raises(ParameterError) as e:
        reg.configure(u_min=10.0, u_max=0.0)
    assert e.value.code == ErrorCode.BAD_LIMITS
    with pytest.raises(ParameterError) as e:
        reg.configure(tr=-1.0)
    assert e.value.code == ErrorCode.BACK_CALC_T
    assert reg.config == Regulator(kp=1.0).config


class _Assembled:
    """Fig. 4.6 assembled from the blocks themselves: a PID and two ManualStations, each idle
    integrator tracking the active one right after it ran (the Regulator before its cycle)."""

    def __init__(self, **cfg: float) -> None:
        c = Regulator(**cfg).config
        self.pid = PID(**c.pid_params())
        self.sp_st = ManualStation(**c.station_params("sp"))
        self.out_st = ManualStation(**c.station_params("out"))
        self.sp, self.auto, self.remote = self.sp_st.out, True, False

    def __call__(self, pv: float, sp_remote: float, dt: float | None, **b: bool) -> float:
        h = dt if dt is not None else self.pid.config.ts
        if self.remote:
            if math.isfinite(sp_remote):
                self.sp = sp_remote
                self.sp_st(track=sp_remote, dt=h)
        else:
            self.sp = self.sp_st(b["sp_inc"], b["sp_dec"], dt=h)
        if self.auto:
            self.pid.manual = False
            u = self.pid(self.sp, pv, dt=h)
            self.out_st(track=u, dt=h)
            return u
        u = self.out_st(b["out_inc"], b["out_dec"], dt=h)
        self.pid.manual, self.pid.manual_value = True, u
        self.pid(self.sp, pv, dt=h)
        return u


@pytest.mark.parametrize("seed", range(6))
def test_the_cycle_is_the_pid_and_two_manual_stations_bit_for_bit(seed: int) -> None:
    """regulator_cycle defers the output station's tracking to the next cycle (a PLC reads the
    PID's MV before calling it): the same operations on the same values as tracking at once,
    with per-call dt, both switches, accelerating buttons, NaN remote setpoints and Tr > 0."""
    rng = np.random.default_rng(seed)
    cfg = {"kp": 2.0, "ti": 6.0, "td": 0.5 * (seed % 2), "u_min": -10.0, "u_max": 120.0,
           "tm_sp": 30.0, "tm_out": 15.0, "tr": (0.0, 0.4, 2.0)[seed % 3], "sp0": 40.0,
           "u0": 25.0, "ts": 0.2, "sp_rate": 2.0 * (seed % 2)}  # fmt: skip
    reg, ref = Regulator(**cfg), _Assembled(**cfg)
    y = 30.0
    for k in range(1500):
        if rng.random() < 0.02:
            reg.auto = ref.auto = not reg.auto
        if rng.random() < 0.02:
            reg.remote = ref.remote = not reg.remote
        b = {n: bool(rng.random() < 0.3) for n in ("sp_inc", "sp_dec", "out_inc", "out_dec")}
        spr = float(rng.choice([55.0, math.nan, 70.0 + rng.normal()]))
        dt = None if rng.random() < 0.7 else float(rng.uniform(0.05, 1.0))
        u = reg(y, spr, dt=dt, **b)
        assert u == ref(y, spr, dt, **b) and reg.sp == ref.sp, k
        y = 0.95 * y + 0.05 * 0.8 * u


def test_limits_and_manual_times_written_at_run_time_keep_the_ones_in_force() -> None:
    """The cycle (the PLC's CB_REGULATOR) refuses reversed limits and a Tm <= 0 written as
    inputs, with BAD_LIMITS / BAD_PARAMETER, and computes on with the set in force."""
    from ctrlblocks.blocks.regulator import REGULATOR_RESULTS, regulator_cycle

    reg = Regulator(sp0=50.0, tm_sp=100.0, accel_max=1.0, ts=1.0)
    vals = reg.plc_values()
    args = {k: vals[k] for k in inspect.signature(regulator_cycle).parameters}
    for bad, code in (({"sp_min": 100.0, "sp_max": 0.0}, ErrorCode.BAD_LIMITS),
                      ({"tm_sp": 0.0}, ErrorCode.BAD_PARAMETER),
                      ({"u_max": math.nan}, ErrorCode.BAD_LIMITS)):  # fmt: skip
        res = dict(zip(REGULATOR_RESULTS, regulator_cycle(**{**args, **bad, "sp_inc": True}),
                       strict=True))  # fmt: skip
        assert res["error_id"] == code
        assert res["sp_out"] == 51.0  # 100 units in 100 s from 50: the set in force moved it
        assert (res["sp_lo"], res["sp_hi"], res["tm_sp_f"]) == (0.0, 100.0, 100.0)


def test_a_float32_regulator_refuses_an_int_beyond_any_float_with_a_parameter_error() -> None:
    """The fuzz campaign's find (seed 0): the REAL-range check of precision="float32" ran before
    the PID's own check and raised OverflowError on 10**400."""
    reg = Regulator(kp=1.0, ti=5.0, precision="float32")
    with pytest.raises(ParameterError):
        reg.configure(sp_rate=10**400)
    with pytest.raises(ParameterError) as e:
        reg.configure(u_max=1e31)
    assert e.value.code == ErrorCode.BAD_LIMITS
    assert reg.config == Regulator(kp=1.0, ti=5.0, precision="float32").config
