"""The ADRC as a drop-in for the PID (issue 34, point 1): feed-forward, output ramp, TRACK, HOLD.

``ff`` is added to the law's output before the limits, as in the PID; the ESO
is fed the applied u *less* the ff of its cycle, so the feed-forward's effect
is part of the total disturbance x4 estimates.  What follows from it, and is
checked here on a first-order process ``y' = -a y + k u + d`` simulated
exactly (zero-order hold):

* offset-free whatever the feed-forward (a wrong or unrelated ff is one more
  disturbance the observer removes);
* a measured load fed forward exactly (``ff = -d/k`` at the instant of the
  step) leaves the loop where it was: the ESO sees no change at all;
* bumpless: MAN -> AUTO with ff in force continues from the held output, and a
  NaN ff holds the output (``BAD_INPUT``) and resumes without a bump;
* ff = 0 is the block as before (the trace hashes and the kernels' lanes are
  unchanged, tests/sim/test_trace_hashes.py and tests/fast).

The output ramp ``out_rate`` is the PID's (``pid_output``): at most ``out_rate h``
a cycle in every mode, the ESO fed the ramped u, offset-free.  The float32
cycle and the exported FB of both are checked against the block by the PLC
tests (``tests/plc/traces.py``: ``FF``, TRACK and HOLD in the mode traces,
``out_rate`` among the options, hostile FF values and the modes in the seeded
sequences).  TRACK and HOLD are MAN with another value: priority TRACK > HOLD >
MANUAL, bumpless back to AUTO.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ctrlblocks import ADRC
from ctrlblocks.blocks.base import ErrorCode, Mode, ParameterError

A, K, TS = 0.5, 2.0, 0.1
E = math.exp(-A * TS)


def plant(y: float, u: float, d: float) -> float:
    """One exact ZOH step of ``y' = -a y + k u + d``."""
    return E * y + (1.0 - E) * (K * u + d) / A


def adrc(**kw) -> ADRC:
    return ADRC(**{"order": 1, "b0": K, "omega_c": 1.0, "omega_o": 5.0, "ts": TS,
                   "u_min": -10.0, "u_max": 10.0, **kw})  # fmt: skip


def run(block: ADRC, n: int, sp: float, y: float, d, ff) -> tuple[list[float], list[float], float]:
    ys, us = [], []
    for k in range(n):
        u = block(sp, y, ff=ff(k))
        us.append(u)
        y = plant(y, u, d(k))
        ys.append(y)
    return ys, us, y


@settings(max_examples=30, deadline=None)
@given(ff=st.floats(-3.0, 3.0), d=st.floats(-1.0, 1.0),
       discretisation=st.sampled_from(["euler", "exact"]))  # fmt: skip
def test_offset_free_whatever_the_feed_forward(ff, d, discretisation):
    block = adrc(discretisation=discretisation, omega_c=0.8, omega_o=6.0)
    _ys, us, y = run(block, 1500, 1.0, 0.0, lambda k: d, lambda k: ff)
    assert y == pytest.approx(1.0, abs=1e-6)
    # the law's part takes up what the feed-forward and the load leave: u = (a - d)/k
    assert us[-1] == pytest.approx((A * 1.0 - d) / K, abs=1e-5)
    assert block.ff == ff


def test_a_measured_load_fed_forward_leaves_the_loop_where_it_was():
    d_step, k_step = 0.8, 300
    exact, _, _ = run(adrc(), 900, 1.0, 0.0, lambda k: d_step if k >= k_step else 0.0,
                      lambda k: -d_step / K if k >= k_step else 0.0)  # fmt: skip
    blind, _, _ = run(adrc(), 900, 1.0, 0.0, lambda k: d_step if k >= k_step else 0.0,
                      lambda k: 0.0)  # fmt: skip
    at_rest = exact[k_step - 1]
    assert abs(at_rest - 1.0) < 1e-6
    dev_ff = max(abs(v - 1.0) for v in exact[k_step - 1:])
    dev_blind = max(abs(v - 1.0) for v in blind[k_step - 1:])
    assert dev_ff < 1e-6 < 0.05 < dev_blind  # the observer never had to find the load


def test_man_to_auto_with_feed_forward_is_bumpless_and_moves_toward_the_setpoint():
    block = adrc()
    y = 0.0
    block.manual, block.u_man = True, 1.5
    for _ in range(200):
        u = block(2.0, y, ff=0.7)
        y = plant(y, u, 0.0)
    assert u == 1.5
    block.manual = False
    first = block(2.0, y, ff=0.7)
    assert first == pytest.approx(1.5, abs=1e-12)  # no bump at the switch
    y = plant(y, first, 0.0)
    second = block(2.0, y, ff=0.7)
    assert second < first  # the process rests at k u / a = 6 above the set point 2: down
    block2 = adrc()
    y = 0.0
    block2.manual, block2.u_man = True, 0.1
    for _ in range(300):
        y = plant(y, block2(2.0, y, ff=0.7), 0.0)
    assert y == pytest.approx(K * 0.1 / A, rel=1e-3)  # 0.4, below the set point 2
    block2.manual = False
    u0 = block2(2.0, y, ff=0.7)
    y = plant(y, u0, 0.0)
    u1 = block2(2.0, y, ff=0.7)
    assert u0 == pytest.approx(0.1, abs=1e-12) and u1 > u0  # up, toward the set point


def test_a_bad_feed_forward_holds_the_output_and_resumes_without_a_bump():
    block = adrc()
    _ys, us, y = run(block, 300, 1.0, 0.0, lambda k: 0.0, lambda k: 0.2)
    held = us[-1]
    for bad in (math.nan, math.inf, -math.inf):
        u = block(1.0, y, ff=bad)
        assert u == pytest.approx(held, abs=1e-12) and block.error_id == ErrorCode.BAD_INPUT
        assert block.ff == 0.2  # the last good one stays
    u = block(1.0, y, ff=0.2)
    assert block.error_id == ErrorCode.NO_ERROR
    assert abs(u - held) < 1e-3  # resumes from the held output


def test_two_phase_with_feed_forward_is_the_call():
    a, b = adrc(order=2, b0=1.0), adrc(order=2, b0=1.0)
    y = 0.0
    for k in range(400):
        ff = 0.3 * math.sin(0.05 * k)
        ua = a(1.0, y, ff=ff)
        ub = b.compute_output(1.0, y, ff=ff)
        b.update_state(ub)
        assert ua == ub
        y = plant(y, ua, 0.1)


@pytest.mark.parametrize("config", [{}, {"discretisation": "exact"}, {"input_delay": 0.3},
                                    {"reverse": True}, {"precision": "float32"}])
def test_feed_forward_with_every_option_stays_offset_free(config):
    sgn = -1.0 if config.get("reverse") else 1.0
    block = adrc(**config)
    y = 0.0
    for k in range(2000):
        u = block(1.0, y, ff=0.4 if k > 500 else 0.0)
        y = E * y + (1.0 - E) * (sgn * K * u + 0.2) / A
    assert y == pytest.approx(1.0, abs=1e-4)


def test_snapshot_keeps_the_feed_forward_and_an_old_snapshot_restores():
    block = adrc()
    run(block, 50, 1.0, 0.0, lambda k: 0.0, lambda k: 0.25)
    snap = block.snapshot()
    assert snap["_ff_prev"] == 0.25
    other = adrc()
    other.restore(snap)
    assert other.ff == 0.25
    old = {k: v for k, v in snap.items() if k not in ("_ff_prev", "ff")}
    other.restore(old)  # a retain file written before the feed-forward input
    assert other.ff == 0.0


# -- the output ramp (out_rate) ---------------------------------------------------------


@settings(max_examples=25, deadline=None)
@given(rate=st.floats(0.05, 20.0), sp=st.floats(-3.0, 3.0), seed=st.integers(0, 1000))
def test_the_output_moves_at_most_out_rate_h_in_every_mode(rate, sp, seed):
    """The PID's output ramp on the ADRC (controltheplant 2024, section 2.3.8): in AUTO, MAN
    and on a bad measurement (the safe value) the output changes by at most out_rate h."""
    import random

    r = random.Random(seed)
    block = adrc(out_rate=rate, u_sf=-8.0)
    y, prev = 0.0, block.out
    for k in range(400):
        if k % 50 == 0:
            block.manual = r.random() < 0.3
            block.u_man = r.uniform(-10.0, 10.0)
        ok = r.random() > 0.05
        u = block(sp, y, ff=r.choice((0.0, 0.0, 2.0)), pv_ok=ok)
        assert abs(u - prev) <= rate * TS * (1 + 1e-12) + 1e-12, (k, u, prev)
        prev = u
        y = plant(y, u, 0.3)


def test_a_ramped_adrc_is_offset_free_and_its_observer_knows_the_ramp():
    fast, slow = adrc(), adrc(out_rate=0.5)
    y1 = y2 = 0.0
    for _ in range(3000):
        y1 = plant(y1, fast(1.0, y1), 0.4)
        y2 = plant(y2, slow(1.0, y2), 0.4)
    assert y1 == pytest.approx(1.0, abs=1e-6) and y2 == pytest.approx(1.0, abs=1e-6)
    assert slow.u_raw == pytest.approx(slow.out, abs=1e-6)  # at rest the ramp is idle


def test_out_rate_is_refused_when_negative_and_the_old_configuration_stays():
    block = adrc(out_rate=1.0)
    with pytest.raises(ParameterError) as info:
        block.configure(out_rate=-1.0)
    assert info.value.code == ErrorCode.BAD_RATE and block.config.out_rate == 1.0
    assert "out_rate" in adrc(out_rate=1.0).fast_path_blockers()


# -- TRACK and HOLD ---------------------------------------------------------------------


def _at_rest(block: ADRC, u_man: float) -> float:
    """The loop at rest in MAN on ``u_man``; returns y."""
    y = 0.0
    block.manual, block.u_man = True, u_man
    for _ in range(300):
        y = plant(y, block(1.0, y), 0.0)
    block.manual = False
    return y


@pytest.mark.parametrize("mode", ["track", "hold"])
def test_track_and_hold_give_their_output_and_return_to_auto_without_a_bump(mode):
    block = adrc(u_min=-5.0, u_max=5.0)
    y = _at_rest(block, 0.1)  # y = k 0.1 / a = 0.4, below the set point 1
    for _ in range(5):
        y = plant(y, block(1.0, y), 0.0)  # AUTO: the MV rises toward the set point
    last = block.out
    setattr(block, mode, True)
    block.track_value = 9.0  # limited to 5
    assert block.mode == (Mode.TRACK if mode == "track" else Mode.HOLD)
    for _ in range(50):
        u = block(1.0, y, ff=0.3)
        y = plant(y, u, 0.0)
    assert u == (5.0 if mode == "track" else last)
    assert block.u_man == u  # the manual value follows (In/Out), as in the PID's TRACK
    setattr(block, mode, False)
    first = block(1.0, y, ff=0.3)
    assert first == pytest.approx(u, abs=1e-12)  # no bump at the return


def test_the_priority_is_track_hold_manual_and_a_bad_tracking_value_holds():
    block = adrc(u_min=-5.0, u_max=5.0)
    y = _at_rest(block, 1.0)
    block.manual, block.u_man = True, -2.0
    block.hold = True
    block.track, block.track_value = True, 3.0
    assert block.mode == Mode.TRACK and block(1.0, y) == 3.0
    block.track = False
    assert block.mode == Mode.HOLD and block(1.0, y) == 3.0  # the last u, held
    block.hold = False
    assert block.mode == Mode.MANUAL and block(1.0, y) == -2.0
    block.track, block.track_value = True, math.nan
    assert block(1.0, y) == -2.0 and block.error_id == ErrorCode.BAD_INPUT
    block.mode = Mode.AUTO
    assert not (block.track or block.hold or block.manual)
    block.mode = Mode.RESET  # above them all: u0 (0 here) at once
    assert block.reset_active and block(1.0, y) == 0.0 and block.mode == Mode.RESET
    with pytest.raises(ParameterError):
        block.mode = 7
