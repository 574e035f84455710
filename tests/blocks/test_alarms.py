"""Alarm blocks: hysteresis, delays, ISA-18.2 states, shelving, suppression, no chattering."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ctrlblocks import Alarm, ErrorCode, LoopAlarms, ParameterError
from ctrlblocks.blocks import alarms as al


def _transitions(active: list[bool]) -> int:
    return sum(a != b for a, b in itertools.pairwise(active))


def test_high_alarm_sets_at_the_limit_and_clears_below_limit_minus_deadband() -> None:
    a = Alarm(limit=80.0, deadband=2.0, ts=1.0)
    seq = [79.9, 80.0, 78.5, 78.01, 77.99, 79.0]
    assert [a(x) for x in seq] == [False, True, True, True, False, False]


def test_low_alarm_mirrors_the_high_one() -> None:
    a = Alarm(limit=20.0, kind="low", deadband=1.0, ts=1.0)
    assert [a(x) for x in (20.1, 20.0, 20.9, 21.01)] == [False, True, True, False]


def test_on_delay_of_three_samples_needs_three_samples_beyond_the_limit() -> None:
    a = Alarm(limit=1.0, on_delay=3.0, off_delay=2.0, ts=1.0)
    seq = [2, 2, 0, 2, 2, 2, 0, 0, 2, 0, 0]
    got = [a(float(x)) for x in seq]
    #        2      2      0      2      2      2     0     0      2     0      0
    assert got == [False, False, False, False, False, True, True, False, False, False, False]


def test_isa_states_unack_acked_returned_and_rtn_unack() -> None:
    a = Alarm(limit=1.0, ts=1.0)
    a(2.0)
    assert a.state == al.UNACK
    assert a.acknowledge() and a.state == al.ACKED
    a(0.0)
    assert a.state == al.NORMAL  # acknowledged and returned
    a(2.0)
    a(0.0)
    assert a.state == al.RTN_UNACK  # returned before acknowledgement: still listed
    a(2.0)
    assert a.state == al.UNACK  # active again
    a(0.0)
    a.acknowledge()
    assert a.state == al.NORMAL
    assert not a.acknowledge()  # nothing to acknowledge


def test_shelving_hides_the_alarm_for_its_time_then_annunciates_it_again() -> None:
    a = Alarm(limit=1.0, ts=1.0)
    a(2.0)
    a.shelve(3.0)
    states = [(a(2.0), a.state) for _ in range(4)]
    assert [s for _, s in states] == [al.SHELVED, al.SHELVED, al.SHELVED, al.UNACK]
    assert all(active for active, _ in states)  # evaluated while shelved
    a.shelve(100.0)
    a.unshelve()
    assert a.state == al.UNACK


@pytest.mark.parametrize("seconds", [0.0, -1.0, math.nan, 86400.1, "10"])
def test_shelving_needs_a_time_limit(seconds: object) -> None:
    a = Alarm(limit=1.0)
    with pytest.raises(ParameterError):
        a.shelve(seconds)  # type: ignore[arg-type]
    assert a.state == al.NORMAL


def test_deviation_alarm_is_suppressed_in_manual_and_annunciated_after() -> None:
    la = LoopAlarms(dev=5.0, h=90.0, ts=1.0)
    la(50.0, 60.0, manual=True)
    assert la.state_of("DEV") == al.SUPPRESSED and la.status()[1].active
    la(50.0, 60.0, manual=False)
    assert la.state_of("DEV") == al.UNACK


def test_pv_alarm_is_not_suppressed_in_manual_by_default() -> None:
    la = LoopAlarms(h=90.0, ts=1.0)
    la(50.0, 95.0, manual=True)
    assert la.state_of("H") == al.UNACK


def test_rate_of_change_over_a_period_is_the_held_difference_quotient() -> None:
    la = LoopAlarms(roc=0.8, roc_period=4.0, ts=1.0)
    pv = [0.0, 1.0, 2.0, 3.0, 4.0, 4.0, 4.0, 4.0, 4.0]
    rates = []
    for x in pv:
        la(0.0, x)
        rates.append(la.rate)
    # mark at t=0; at t=4: (4-0)/4 = 1; at t=8: (4-4)/4 = 0
    assert rates == [0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 0.0]
    assert la.state_of("ROC") == al.RTN_UNACK


def test_bad_pv_raises_bad_and_holds_the_other_alarms() -> None:
    la = LoopAlarms(h=10.0, ts=1.0)
    la(0.0, 11.0)
    la(0.0, math.nan)
    assert la.error_id == ErrorCode.BAD_INPUT
    assert la.state_of("BAD") == al.UNACK and la.state_of("H") == al.UNACK
    la(0.0, 5.0, pv_ok=False)
    assert la.error_id == ErrorCode.BAD_MEASUREMENT
    assert la.status()[0].active  # H held while the PV is bad
    la(0.0, 5.0)
    assert la.error_id == ErrorCode.NO_ERROR
    assert la.state_of("BAD") == al.RTN_UNACK and la.state_of("H") == al.RTN_UNACK


def test_transitions_name_each_state_change_with_its_value() -> None:
    la = LoopAlarms(h=80.0, hh=90.0, ts=1.0)
    la(50.0, 95.0)
    assert la.transitions == (("HH", al.NORMAL, al.UNACK, 95.0), ("H", al.NORMAL, al.UNACK, 95.0))
    assert la.acknowledge("HH") == ["HH"]
    assert la.out == 2.0 and la.unacknowledged == 1 and la.worst == 1


def test_limits_out_of_order_are_refused_and_the_old_configuration_stays() -> None:
    la = LoopAlarms(h=80.0, hh=90.0)
    with pytest.raises(ParameterError) as e:
        la.configure(hh=70.0)
    assert e.value.code == ErrorCode.BAD_LIMITS
    assert la.config.hh == 90.0
    with pytest.raises(ParameterError):
        LoopAlarms(suppress_in_manual=("XX",))


def test_switching_an_alarm_off_at_run_time_takes_it_out_of_service() -> None:
    la = LoopAlarms(h=80.0, ts=1.0)
    la(0.0, 85.0)
    la.configure(h=None)
    assert la.state_of("H") == al.OUT_OF_SERVICE
    la.configure(h=80.0)
    la(0.0, 85.0)
    assert la.state_of("H") == al.UNACK


def _noisy_at_limit(n: int, seed: int) -> np.ndarray:
    """A PV whose mean sits on the limit 50.0, white noise sigma 1, plus a slow wander."""
    rng = np.random.default_rng(seed)
    return 50.0 + rng.normal(0.0, 1.0, n) + 0.5 * np.sin(np.arange(n) * 2 * np.pi / 600.0)


def _max_transitions_per_minute(active: list[bool], ts: float) -> int:
    changes = np.flatnonzero(np.diff(np.array(active, dtype=int)))
    w = round(60.0 / ts)
    return int(max((np.sum((changes >= k) & (changes < k + w)) for k in changes), default=0))


@pytest.mark.parametrize("seed", range(5))
def test_no_chattering_on_a_noisy_pv_at_the_limit(seed: int) -> None:
    pv = _noisy_at_limit(7200, seed)
    bare = Alarm(limit=50.0, ts=1.0)
    tuned = Alarm(limit=50.0, deadband=2.0, on_delay=5.0, off_delay=5.0, ts=1.0)
    a_bare = [bare(x) for x in pv]
    a_tuned = [tuned(x) for x in pv]
    # without deadband and delays the alarm chatters: thousands of transitions in 2 h
    assert _transitions(a_bare) > 2000
    assert _max_transitions_per_minute(a_bare, 1.0) >= 20
    # with them: on (5 samples above 50: p = 1/32) and off (5 samples below 48: p ~ 1e-8)
    # a transition per minute at most (ISA 2016's chattering: repeated transitions in a short time)
    assert _transitions(a_tuned) <= 4
    assert _max_transitions_per_minute(a_tuned, 1.0) <= 1


# ---------------------------------------------------------------------------
# the state machine against an independent table of ISA-18.2 transitions
# ---------------------------------------------------------------------------

_TABLE = {  # (state, active) -> next state, without operator action
    (al.NORMAL, False): al.NORMAL, (al.NORMAL, True): al.UNACK,
    (al.UNACK, False): al.RTN_UNACK, (al.UNACK, True): al.UNACK,
    (al.ACKED, False): al.NORMAL, (al.ACKED, True): al.ACKED,
    (al.RTN_UNACK, False): al.RTN_UNACK, (al.RTN_UNACK, True): al.UNACK,
}  # fmt: skip
_ACK = {al.UNACK: al.ACKED, al.RTN_UNACK: al.NORMAL}


@given(st.lists(st.tuples(st.booleans(), st.booleans(), st.booleans(), st.booleans()),
                max_size=60))  # fmt: skip
@settings(max_examples=300, deadline=None)
def test_alarm_state_follows_the_isa_transition_table(steps: list) -> None:
    state = al.NORMAL
    for active, ack, suppressed, enabled in steps:
        got = al.alarm_state(state, active, ack, False, suppressed, enabled)
        if not enabled:
            want = al.OUT_OF_SERVICE
        elif suppressed:
            want = al.SUPPRESSED
        else:
            base = al.NORMAL if state >= al.SHELVED else state
            want = _TABLE[(base, active)]
            if ack:
                want = _ACK.get(want, want)
        assert got == want
        state = got


# ---------------------------------------------------------------------------
# PLC: the translator accepts the alarm functions; the ST runs like the Python
# ---------------------------------------------------------------------------


def _st_source(fn) -> tuple[str, str, dict[str, str]]:
    """The ST of ``fn`` as a FUNCTION_BLOCK with its functions, its name, and the ST name of
    each Python parameter (a keyword such as ``limit`` is escaped)."""
    import importlib

    from ctrlblocks.plc.translate import Program

    ex = importlib.import_module("ctrlblocks.plc.export")  # the module, not the function
    st = ex.DIALECTS["codesys"]

    prog = Program()
    sig = prog.fb_type(fn)
    lines: list[str] = []
    for p in prog.ordered():
        lines += st.function_text(p)
    lines += st.fb_text(ex._small_block(prog.fbs[sig.pou]))
    return "\n".join(lines) + "\n", sig.pou, sig.st


def test_alarm_cycle_translates_to_st_that_runs_like_the_python() -> None:
    pytest.importorskip("blark")
    from tests.plc.st_interpreter import Interpreter

    src, pou, names = _st_source(al.alarm_cycle)
    fb = Interpreter(src).instance(pou)
    rng = np.random.default_rng(4)
    state, active, timer, left = al.NORMAL, False, 0.0, 0.0
    for k in range(400):
        inp = dict(x=float(np.float32(50.0 + rng.normal(0, 2))), x_ok=bool(rng.random() > 0.05),
                   limit=50.0, deadband=1.0, high=True, on_delay=2.0, off_delay=3.0, h=1.0,
                   enabled=k % 97 != 5, ack=bool(rng.random() < 0.1),
                   shelve=k % 53 == 7, shelve_time=4.0, unshelve=k % 71 == 9,
                   suppress=k % 41 < 3)  # fmt: skip
        state, active, timer, left = al.alarm_cycle(**inp, state=state, active=active,
                                                    timer=timer, shelve_left=left)
        fb(**{names[n]: v for n, v in inp.items()})
        assert (int(fb.output("STATE")), bool(fb.output("ACTIVE"))) == (state, active), k
        assert float(fb.output("SHELVE_LEFT")) == pytest.approx(left)


def test_rate_cycle_translates_to_st() -> None:
    from ctrlblocks.plc.translate import Program

    prog = Program()
    sig = prog.fb_type(al.rate_cycle)
    assert sig.pou == "CB_ROC"


@given(st.lists(st.tuples(st.floats(-20, 120), st.floats(30, 70), st.booleans(), st.booleans()),
                min_size=1, max_size=80),
       st.sampled_from([0.0, 0.5, 2.0]), st.sampled_from([0.0, 1.0, 3.0]))  # fmt: skip
@settings(max_examples=200, deadline=None)
def test_loop_alarms_equal_alarm_cycle_called_for_every_alarm(steps, db, delay) -> None:
    """The block's cycle (which skips alarms at rest) against alarm_cycle on every alarm."""
    cfg = dict(hh=95.0, h=80.0, l=20.0, ll=5.0, dev=10.0, roc=3.0, roc_period=2.0,
               deadband=db, roc_deadband=0.5, on_delay=delay, off_delay=delay, ts=1.0)  # fmt: skip
    la = LoopAlarms(**cfg)
    limits = (95.0, 80.0, 20.0, 5.0, 10.0, 3.0, 0.5)
    dbs = (db, db, db, db, db, 0.5, 0.0)
    high = (True, True, False, False, True, True, True)
    sup = (False, False, False, False, True, True, False)
    mem = [[al.NORMAL, False, 0.0, 0.0] for _ in range(7)]
    roc = (0.0, 0.0, 0.0, False)
    for pv, sp, manual, ok in steps:
        la(sp, pv, pv_ok=ok, manual=manual)
        roc = al.rate_cycle(pv, ok, 2.0, 1.0, *roc)
        vals = (pv, pv, pv, pv, abs(sp - pv), abs(roc[0]), 0.0 if ok else 1.0)
        oks = (ok,) * 6 + (True,)
        for i in range(7):
            mem[i] = list(al.alarm_cycle(vals[i], oks[i], limits[i], dbs[i], high[i], delay,
                                         delay, 1.0, True, False, False, 0.0, False,
                                         manual and sup[i], *mem[i]))  # fmt: skip
        assert [s.state for s in la.status()] == [m[0] for m in mem]
        assert [s.active for s in la.status()] == [m[1] for m in mem]
