"""The blocks' per-call fast lanes equal their two-phase path, sample by sample and state by state.

``PID.__call__`` (and ``ADRC.__call__``) run one pure kernel function in plain
auto operation.  Here a block called normally and a twin driven through
``compute_output`` + ``update_state`` (which never takes the fast lane) see
the same inputs -- including manual mode, limits written at run time, NaN
measurements, irregular ``dt`` and reconfiguration -- and must agree exactly:
same output, same snapshot (every state field and sub-block) after every cycle.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, rule

from ctrlblocks import ADRC, PID, ParameterError


def _two_phase(block, *args, **kw):
    v = block.compute_output(*args, **kw)
    block.update_state(v)
    return block.out


def _same(a, b):
    sa, sb = a.snapshot(), b.snapshot()
    assert sa.keys() == sb.keys()
    for k in sa:
        x, y = sa[k], sb[k]
        if isinstance(x, float) and math.isnan(x):
            assert isinstance(y, float) and math.isnan(y), k
        else:
            assert x == y, k


def _script(n=400, seed=1):
    rng = np.random.default_rng(seed)
    steps = []
    for k in range(n):
        ev = {}
        if 100 <= k < 130:
            ev["manual"] = True
        if k == 160:
            ev["limits"] = (0.0, 1.2)
        if k == 220:
            ev["limits"] = (0.0, 3.0)
        if k in (250, 251):
            ev["pv"] = math.nan
        if k == 270:
            ev["dt"] = 0.05
        if k == 300:
            ev["configure"] = {"ti": 4.0}
        steps.append((float(np.sin(k / 40.0) + 1.2), float(rng.normal(0.8, 0.3)), ev))
    return steps


PIDS = {
    "clamping": dict(kp=3.0, ti=6.0, td=1.0, ts=0.1, u_min=0.0, u_max=3.0),
    "back_calc": dict(kp=3.0, ti=6.0, td=1.0, ts=0.1, u_min=0.0, u_max=3.0,
                      anti_windup="back_calc_model"),
    "weights": dict(kp=2.0, ti=5.0, td=0.5, b=0.5, c=0.2, reverse=True, ts=0.1, u_min=-2.0,
                    u_max=3.0, derivative_method="tustin"),
}  # fmt: skip


@pytest.mark.parametrize("name", list(PIDS))
def test_pid_fast_lane_equals_the_two_phase_cycle(name):
    fast, slow = PID(**PIDS[name]), PID(**PIDS[name])
    lanes = 0
    for sp, pv, ev in _script():
        for b in (fast, slow):
            b.manual = ev.get("manual", False)
            b.manual_value = 0.7
            if "limits" in ev:
                b.set_limits(*ev["limits"])
            if "configure" in ev:
                b.configure(**ev["configure"])
        pv = ev.get("pv", pv)
        kw = {"dt": ev["dt"]} if "dt" in ev else {}
        u_fast = fast(sp, pv, **kw)
        lanes += fast._lean_ran
        u_slow = _two_phase(slow, sp, pv, **kw)
        assert u_fast == u_slow
        _same(fast, slow)
    assert lanes > 300  # the fast lane did run


def test_pid_filter_switched_on_after_fast_cycles_starts_where_the_two_phase_one_does():
    fast, slow = PID(kp=2.0, ti=5.0, ts=0.1), PID(kp=2.0, ti=5.0, ts=0.1)
    for k in range(50):
        assert fast(1.0 + 0.01 * k, 0.5) == _two_phase(slow, 1.0 + 0.01 * k, 0.5)
    fast.configure(sp_filter=2.0, out_rate=5.0)
    slow.configure(sp_filter=2.0, out_rate=5.0)
    for _ in range(50):
        assert fast(2.0, 0.6) == _two_phase(slow, 2.0, 0.6)
    _same(fast, slow)


def test_pid_fast_lane_result_by_hand():
    # P + I (Tustin) + no D, first cycle after the cold start and the next one:
    # cycle 1: e = 1 - 0.5, u = K e + I0 = 2 * 0.5 + 0 = 1.0 (cold: no integration)
    # cycle 2: I = K h/Ti (e + e)/2 = 2 * 0.1/4 * 0.5 = 0.025, u = 1.0 + 0.025
    pid = PID(kp=2.0, ti=4.0, ts=0.1, u_min=-10.0, u_max=10.0)
    assert pid(1.0, 0.5) == 1.0
    assert pid(1.0, 0.5) == pytest.approx(1.025, abs=1e-15)
    assert pid._lean_ran


ADRCS = {
    "n2": dict(order=2, b0=0.5, omega_c=1.0, omega_o=4.0),
    "n3_freeze": dict(order=3, b0=0.5, omega_c=1.0, omega_o=3.0, anti_windup="freeze"),
    "n1_tref": dict(order=1, b0=2.0, omega_c=2.0, omega_o=6.0, t_ref=0.5),
}


@pytest.mark.parametrize("name", list(ADRCS))
def test_adrc_fast_lane_equals_the_two_phase_cycle(name):
    make = lambda: ADRC(**ADRCS[name], ts=0.1, u_min=0.0, u_max=3.0)  # noqa: E731
    fast, slow = make(), make()
    lanes = 0
    y = 0.0
    for sp, noise, ev in _script(seed=4):
        for b in (fast, slow):
            b.manual = ev.get("manual", False)
            b.u_man = 0.7 if b.manual else b.u_man
            if "limits" in ev:
                b.set_limits(*ev["limits"])
            if "configure" in ev:
                b.configure(omega_c=1.5)
        yv = ev.get("pv", y + 0.05 * noise)
        kw = {"dt": ev["dt"]} if "dt" in ev else {}
        u_fast = fast(sp, yv, **kw)
        lanes += fast._prm is not None
        u_slow = _two_phase(slow, sp, yv, **kw)
        assert u_fast == u_slow and math.isfinite(u_fast)
        _same(fast, slow)
        assert fast.error_id == slow.error_id and fast.u_man == slow.u_man
        y += 0.1 * (0.8 * u_fast - y)  # a first-order plant closes the loop
    assert lanes > 300


def test_pid_inputs_whose_sum_overflows_take_the_general_path_with_the_same_result():
    # the lane tests the inputs' finiteness on their sum: finite inputs whose sum
    # overflows run the two-phase cycle instead, which must give the lane's result
    for sp, pv, ff in ((1e308, 1e308, 0.0), (-1e308, 0.5, -1e308), (1e308, -1e308, 1e308)):
        fast, slow = PID(**PIDS["clamping"]), PID(**PIDS["clamping"])
        for k in range(6):
            args = (sp, pv) if k % 2 else (1.0, 0.8)
            kw = {"ff": ff} if k % 2 else {}
            assert fast(*args, **kw) == _two_phase(slow, *args, **kw)
            _same(fast, slow)


def test_p_suppressed_after_a_switch_keeps_the_pid_off_the_fast_lane() -> None:
    # bumpless="suppress_p_action": after MAN -> AUTO the P action is off until
    # |e| <= dev_tol, also after a reconfiguration to another bumpless method (the
    # law's suppressed flag is state, not configuration). The fast lane once passed
    # the law "not suppressed" there: a bump of kp e (here 2 x 2 = 4) on the call path
    # that the two phases did not make.
    fast, slow = (PID(kp=2.0, ti=5.0, ts=0.1, u_min=0.0, u_max=100.0,
                      bumpless="suppress_p_action") for _ in range(2))  # fmt: skip
    slow._two_phase_lean = False
    for block, step in ((fast, lambda b: b(5.0, 3.0)), (slow, lambda b: _two_phase(b, 5.0, 3.0))):
        block.manual, block.manual_value = True, 10.0
        for _ in range(3):
            step(block)
        block.manual = False
        for _ in range(3):
            step(block)
        assert block.p_suppressed
        block.configure(bumpless="integrator")
    for _ in range(5):
        assert fast(5.0, 3.0) == _two_phase(slow, 5.0, 3.0) < 11.0  # no P kick of 4
        _same(fast, slow)


class PIDLaneAdmission(RuleBasedStateMachine):
    """The PID's fast lane admits exactly the cycles the two-phase path runs as it would.

    A block called normally and a twin driven through the general cycle of
    ``compute_output`` + ``update_state`` get the same writes of the mode
    inputs, reconfigurations (options that switch the lane off and on, the
    sample time, tuning, refused values, the bumpless method: P suppressed
    after a switch outlives a change to another method, and the lane once
    missed it), limits (refused ones too), cycles at other ``dt`` and the
    kernel parameters' read (which sets ``h`` back to ``ts``): same output and
    state after every cycle.  (A cached admission flag, tried and not kept,
    must pass this; a stale one failed it.)
    """

    def __init__(self) -> None:
        super().__init__()
        self.fast, self.slow = PID(**PIDS["back_calc"]), PID(**PIDS["back_calc"])
        self.slow._two_phase_lean = False  # the twin runs the general cycle, always

    def _both(self, fn):
        for b in (self.fast, self.slow):
            fn(b)

    @rule(name=st.sampled_from(["manual", "track", "hold", "reset_active", "awin"]),
          value=st.booleans())  # fmt: skip
    def mode_input(self, name, value):
        self._both(lambda b: setattr(b, name, value))

    @rule(changes=st.sampled_from([
        {"ti": 4.0}, {"kp": 2.5, "td": 0.5}, {"ts": 0.2}, {"ts": 0.1}, {"sp_filter": 1.0},
        {"sp_filter": 0.0}, {"out_rate": 5.0}, {"out_rate": 0.0}, {"deadband": 0.05},
        {"deadband": 0.0}, {"algorithm": "velocity"}, {"algorithm": "positional"},
        {"anti_windup": "clamping"}, {"anti_windup": "back_calc_model"}, {"kp": math.nan},
        {"ts": -1.0}, {"bumpless": "suppress_p_action"}, {"bumpless": "integrator"},
    ]))  # fmt: skip
    def configure(self, changes):
        refused = []
        for b in (self.fast, self.slow):
            try:
                b.configure(**changes)
            except ParameterError:
                refused.append(b)
        assert len(refused) in (0, 2)

    @rule(lo=st.sampled_from([0.0, -1.0, 0.5, math.nan]), hi=st.sampled_from([3.0, 1.2, -2.0]))
    def set_limits(self, lo, hi):
        self._both(lambda b: b.set_limits(lo, hi))

    @rule()
    def kernel_params(self):
        self._both(lambda b: b.kernel_params())

    @rule(sp=st.floats(-2.0, 3.0), pv=st.floats(-2.0, 3.0),
          dt=st.sampled_from([None, None, None, 0.1, 0.05, 0.3]))  # fmt: skip
    def cycle(self, sp, pv, dt):
        kw = {} if dt is None else {"dt": dt}
        u_fast = self.fast(sp, pv, **kw)
        u_slow = _two_phase(self.slow, sp, pv, **kw)
        assert u_fast == u_slow
        _same(self.fast, self.slow)


TestPIDLaneAdmission = PIDLaneAdmission.TestCase
TestPIDLaneAdmission.settings = settings(max_examples=60, stateful_step_count=40, deadline=None)


def test_a_pid_with_p_suppressed_is_not_handed_to_the_kernels() -> None:
    pid = PID(kp=2.0, ti=5.0, ts=0.1, u_min=0.0, u_max=100.0, bumpless="suppress_p_action")
    pid.manual, pid.manual_value = True, 10.0
    pid(5.0, 3.0)
    pid.manual = False
    pid(5.0, 3.0)
    pid.configure(bumpless="integrator")
    assert pid.p_suppressed
    assert not pid.fast_path_supported()
    assert any("suppressed" in why for why in pid.fast_path_blockers())
    for _ in range(3):  # |e| <= dev_tol ends it; then the kernels may take it
        pid(5.0, 5.0)
    assert not pid.p_suppressed and pid.fast_path_supported()
