"""The ADRC option ``input_delay``: the ESO fed the delayed input (Zhao & Gao 2014)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ctrlblocks import ADRC, ErrorCode, ParameterError
from ctrlblocks.blocks.adrc import adrc_gains, adrc_switches, control_law, eso_euler
from ctrlblocks.plants import FOPDT

TS = 0.05
L = 3.0  # dead time of the test process [s], three times its lag T = 1 s


def load_iae(delay: float, wc: float, ratio: float, seconds: float = 200.0) -> float:
    """IAE of a unit load step at the process input, FOPDT 1 e^(-3 s)/(s + 1), loop at rest."""
    plant = FOPDT(1.0, 1.0, L, TS)
    adrc = ADRC(order=1, b0=1.0, omega_c=wc, omega_o=ratio * wc, ts=TS, u_min=-10.0,
                u_max=10.0, input_delay=delay)  # fmt: skip
    total = 0.0
    for k in range(int(seconds / TS)):
        y = plant.y
        u = adrc(0.0, y)
        plant.step(u + (1.0 if k * TS >= 10.0 else 0.0))
        total += abs(y) * TS
    return total


def test_delayed_observer_holds_a_tuning_the_plain_one_cannot_on_a_dead_time_process() -> None:
    # same tuning: omega_c = 0.6/T, omega_o = 3 omega_c; the plain ESO attributes the
    # dead time's lag to the disturbance and the loop oscillates into the limits
    plain, delayed = load_iae(0.0, 0.6, 3.0), load_iae(L, 0.6, 3.0)
    assert plain > 100.0
    assert delayed == pytest.approx(7.24, abs=0.05)
    # no controller does better than about L * d (the load is unseen for L seconds)
    assert delayed > L


def test_delayed_observer_beats_the_best_plain_tuning_on_a_dead_time_dominant_fopdt() -> None:
    best_plain = min(
        load_iae(0.0, wc, ratio) for wc in (0.2, 0.3, 0.35, 0.4, 0.45) for ratio in (3.0, 5.0)
    )
    assert best_plain == pytest.approx(6.51, abs=0.05)
    assert load_iae(L, 1.0, 5.0) == pytest.approx(3.59, abs=0.05)


def test_the_eso_is_fed_the_applied_u_of_d_samples_ago() -> None:
    # an independent wiring of (4a)/(4b) from the law functions with u_{i-1-d} in the ESO
    d, ts, b0, wc, wo = 4, 0.1, 0.5, 1.0, 4.0
    adrc = ADRC(order=2, b0=b0, omega_c=wc, omega_o=wo, ts=ts, input_delay=d * ts)
    l1, l2, l3, l4, kp, kd1, kd2 = adrc_gains(2, wc, wo)
    sw = adrc_switches(2)
    rng = np.random.default_rng(3)
    ys = np.cumsum(rng.normal(0.0, 0.1, 60))
    us = [0.0] * (d + 1)  # u applied before the start: u0 = 0
    x = (ys[0], 0.0, 0.0, 0.0)
    for y in ys:
        x = eso_euler(*x, us[-1 - d], y, 1.0, ts, b0, l1, l2, l3, l4, *sw)
        u = control_law(1.0, *x, b0, kp, kd1, kd2)
        assert adrc(1.0, y) == u
        us.append(u)
    assert adrc.x == x


def test_a_delay_below_half_a_sample_is_the_plain_block_bit_for_bit() -> None:
    a, b = ADRC(ts=0.1, input_delay=0.049), ADRC(ts=0.1)
    c, d = ADRC(ts=0.1, input_delay=0.26), ADRC(ts=0.1, input_delay=0.3)
    for k in range(300):
        y = math.sin(0.05 * k)
        assert a(1.0, y) == b(1.0, y)
        assert c(1.0, y) == d(1.0, y)  # rounded to 3 samples both


@pytest.mark.parametrize("bad", [-0.1, math.nan, math.inf, 1e9, "x", None])
def test_a_bad_input_delay_is_refused_and_the_old_configuration_stays(bad: object) -> None:
    adrc = ADRC(ts=0.1, input_delay=0.3)
    with pytest.raises((ParameterError, TypeError)) as exc:
        adrc.configure(input_delay=bad)
    if isinstance(exc.value, ParameterError):
        assert exc.value.code == ErrorCode.BAD_TIME_CONSTANT
    assert adrc.config.input_delay == 0.3
    with pytest.raises(ParameterError):
        ADRC(ts=0.1, input_delay=bad)


@settings(max_examples=30, deadline=None)
@given(d=st.integers(0, 12), split=st.integers(1, 80))
def test_snapshot_and_restore_carry_the_history_of_u(d: int, split: int) -> None:
    adrc = ADRC(order=1, b0=1.0, omega_c=0.5, omega_o=2.0, ts=0.1, input_delay=0.1 * d,
                u_min=-5.0, u_max=5.0)  # fmt: skip
    ys = [math.sin(0.1 * k) for k in range(split + 40)]
    for y in ys[:split]:
        adrc(1.0, y)
    snap = adrc.snapshot()
    first = [adrc(1.0, y) for y in ys[split:]]
    adrc.restore(snap)
    assert [adrc(1.0, y) for y in ys[split:]] == first


def test_a_snapshot_of_before_the_option_restores_with_the_history_at_rest() -> None:
    adrc = ADRC(ts=0.1, input_delay=0.3)
    for k in range(20):
        adrc(1.0, 0.1 * k)
    snap = adrc.snapshot()
    del snap["_u_hist"]
    adrc.restore(snap)
    assert adrc._u_hist == (adrc.out,) * 3


def test_a_longer_delay_pads_the_history_with_its_oldest_value_and_stays_bumpless() -> None:
    adrc = ADRC(ts=0.1, input_delay=0.2, omega_c=0.5, omega_o=2.0)
    for k in range(30):
        adrc(1.0, 0.02 * k)
    old = adrc._u_hist
    adrc.configure(input_delay=0.5)
    assert adrc._u_hist == (old[0],) * 3 + old
    adrc.configure(input_delay=0.1)
    assert adrc._u_hist == old[-1:]


def test_manual_to_auto_with_a_delay_continues_from_the_manual_value() -> None:
    plant = FOPDT(1.0, 1.0, 1.0, 0.1)
    adrc = ADRC(order=1, b0=1.0, omega_c=0.5, omega_o=2.0, ts=0.1, input_delay=1.0)
    adrc.manual, adrc.u_man = True, 0.4
    for _ in range(100):
        plant.step(adrc(0.4, plant.y))
    adrc.manual = False
    assert adrc(0.4, plant.y) == pytest.approx(0.4, abs=1e-12)


def test_the_compiled_kernels_name_the_option_they_lack() -> None:
    """The numba kernels carry a controller's state as a fixed tuple of floats: no delay
    line (docs/blocks/adrc.md); the block, its compiled build, the float32 cycle and the
    exported FB have it."""
    assert "input_delay" in ADRC(input_delay=0.2).fast_path_blockers()
    assert ADRC(input_delay=0.0).fast_path_blockers() == []


def _delay_run(precision: str, nd_shift: int = 0) -> list[float]:
    """A closed loop on a dead-time process whose delay is changed to shorter and longer."""
    adrc = ADRC(order=2, b0=0.5, omega_c=1.0, omega_o=5.0, ts=0.1, input_delay=0.5,
                u_min=-10.0, u_max=10.0, u0=2.0, precision=precision)  # fmt: skip
    line = [2.0] * 6
    y, v, out = 0.0, 0.0, []
    for k in range(400):
        if k == 150:
            adrc.configure(input_delay=0.2 + 0.1 * nd_shift)
        if k == 250:
            adrc.configure(input_delay=0.4 + 0.1 * nd_shift)
        u = adrc(1.0, y)
        out.append(u)
        line = [*line[1:], u]
        v += 0.1 * (-0.5 * v + 0.5 * line[0])
        y += 0.1 * v
    return out


def test_the_float32_cycle_has_the_delay_line_of_the_block() -> None:
    """The PLC cycle's delay line (plc_cycle.delay_line) feeds the ESO what the block's
    history does, through shorter and longer delays: the float32 block follows the
    float64 one within REAL's rounding -- and a line off by one sample would not."""
    ref, f32 = _delay_run("float64"), _delay_run("float32")
    worst = max(abs(a - b) for a, b in zip(ref, f32, strict=True))
    assert worst < 1e-4
    off = _delay_run("float64", nd_shift=1)
    assert max(abs(a - b) for a, b in zip(ref[150:], off[150:], strict=True)) > 100 * worst


def test_the_delay_line_gives_the_value_pushed_n_calls_before_hand_checked() -> None:
    from ctrlblocks.blocks.plc_cycle import delay_line

    buf, idx, n_prev = [0.0] * 4, 0, 0
    got = []
    for k, n in enumerate((2, 2, 2, 2, 1, 3, 3, 3, 5)):
        u, buf, idx, n_prev, ok = delay_line(float(k + 1), n, False, buf, idx, n_prev)
        got.append((u, ok))
    # n = 2 from the start: the line is filled with the first value (as reset with u0)
    assert got[:4] == [(1.0, True), (1.0, True), (1.0, True), (2.0, True)]
    assert got[4] == (4.0, True)  # shorter: the newest values kept (5 pushed, 4 one before)
    # longer (1 -> 3) when 6 is pushed: the line held (5,) before 6, padded with its
    # oldest value to (5, 5, 5), as adrc._resize_history; then 5 is 3 pushes before 8
    assert got[5:8] == [(5.0, True), (5.0, True), (5.0, True)]
    assert got[8] == (6.0, False)  # 5 > the ring (4 values: at most 3): the 3 stays


def test_the_delay_line_is_the_blocks_history_through_any_delay_changes() -> None:
    """Against the block's own history (a tuple of the nd values before u_prev, resized
    by adrc._resize_history): any sequence of pushes and delays within the ring."""
    from hypothesis import given
    from hypothesis import strategies as st

    from ctrlblocks.blocks.adrc import _resize_history
    from ctrlblocks.blocks.plc_cycle import delay_line

    @given(st.integers(1, 8), st.lists(st.tuples(st.floats(-1e3, 1e3), st.integers(0, 9))))
    def check(cap: int, steps: list[tuple[float, int]]) -> None:
        buf, idx, n_prev = [0.0] * cap, 0, 0
        hist: tuple[float, ...] = ()
        u_prev, nd = 0.0, 0
        for k, (push, n) in enumerate(steps):
            u, buf, idx, n_prev, ok = delay_line(push, n, False, buf, idx, n_prev)
            # the block: u_prev moves into the history, then a new delay resizes it
            hist = (*hist[1:], u_prev) if (k and nd) else hist
            u_prev = push
            assert ok == (n == nd or 0 <= n < cap)
            if n != nd and ok:
                hist, nd = _resize_history(hist, n, u_prev), n
            assert n_prev == nd
            assert u == (hist[0] if nd else u_prev)

    check()


def test_a_delay_beyond_the_exported_line_is_refused_by_the_float32_block() -> None:
    adrc = ADRC(order=1, b0=1.0, omega_c=1.0, omega_o=4.0, ts=0.1, input_delay=0.2,
                precision="float32")  # fmt: skip
    adrc(1.0, 0.0)
    adrc.configure(input_delay=0.5)  # the float32 cycle's line holds 2 samples
    adrc(1.0, 0.0)
    assert adrc.error_id == ErrorCode.BAD_TIME_CONSTANT
    adrc.reset()  # a reset sizes the line anew from the configuration
    adrc(1.0, 0.0)
    assert adrc.error_id != ErrorCode.BAD_TIME_CONSTANT


@pytest.mark.slow
def test_the_exported_fb_with_a_delay_equals_the_float32_block() -> None:
    """Bit for bit over a closed-loop day (tests/plc/traces.py), the FB's DELAY input."""
    pytest.importorskip("blark")
    from ctrlblocks import plc
    from tests.plc.st_interpreter import Interpreter
    from tests.plc.traces import adrc_trace, replay, ulps

    block, trace = adrc_trace(3000, 5, input_delay=1.0)
    fb = Interpreter(plc.export(block, "codesys")).instance("CB_ADRC")
    got = replay(fb, trace, "MV", "AWOUT", None)
    assert max(ulps(g[0], ref[0]) for g, ref in zip(got, trace.outputs, strict=True)) == 0


def test_the_float32_cycle_follows_the_block_through_delays_switched_off_and_on() -> None:
    """Without a delay in force the PLC cycle leaves its line alone; one switched on again
    is filled with the output in force, as the block's history is (float32 ~ float64)."""
    delays = {60: 0.0, 100: 0.2, 180: 0.0, 220: 0.3}

    def run(precision: str) -> list[float]:
        adrc = ADRC(order=1, b0=1.0, omega_c=1.0, omega_o=4.0, ts=0.1, input_delay=0.3,
                    u_min=-5.0, u_max=5.0, precision=precision)  # fmt: skip
        y, out = 0.0, []
        for k in range(300):
            if k in delays:
                adrc.configure(input_delay=delays[k])
            u = adrc(1.0 if k < 150 else -1.0, y)
            assert adrc.error_id == ErrorCode.NO_ERROR
            out.append(u)
            y += 0.1 * (-y + u)
        return out

    ref, f32 = run("float64"), run("float32")
    assert max(abs(a - b) for a, b in zip(ref, f32, strict=True)) < 1e-4
