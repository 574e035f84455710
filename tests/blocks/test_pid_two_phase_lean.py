"""The PID's lean two-phase cycle equals its general one, bit for bit (issue 31).

``compute_output`` + ``update_state`` run one call of ``pid_law`` and a
pending cycle of a few floats (``PID._lean_cycle``, a C struct in the compiled
build) when nothing but the law is on; everything else takes the general
cycle (``PID._compute``, the sub-blocks, the ``_Cycle`` tuple).  A block whose
lean cycle is switched off (``_two_phase_lean = False``, for these tests only)
is the reference: a hypothesis state machine drives both through the same
sequence of both phases -- the applied value the output, another finite value
or not a number; ``compute_output`` twice, ``update_state`` alone --,
``__call__``, reconfiguration and retuning, limits, mode inputs, snapshots and
restores, ``reset``, ``start_at`` and ``load_kernel_state``, between the
phases too.  After every action the outputs, every state attribute and the
pending cycle must have the same bits; a snapshot compares the sub-blocks too.

The one difference the lean cycle makes is the sign of a zero: the general
cycle passes ``sp`` and ``pv`` through its filters, which are off (``0 y +
u``), and turns an input ``-0.0`` into ``+0.0`` after a positive filter
state; the lean cycle, like the per-call fast lane (``pid_step``), keeps
``-0.0``.  The state machine draws no ``-0.0`` for ``sp`` and ``pv``;
:func:`test_a_negative_zero_input_differs_in_the_sign_of_zeros_only` covers it.

``CTRLBLOCKS_COMPILED=require`` runs the same tests against the compiled build.
"""

from __future__ import annotations

import copy
import math
import struct
from enum import Enum

import numpy as np
import pytest
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import (
    RuleBasedStateMachine,
    initialize,
    invariant,
    precondition,
    rule,
    run_state_machine_as_test,
)

from ctrlblocks import PID, ParameterError

NAN, INF = math.nan, math.inf

BASES = {
    "pid_clamping": dict(kp=2.0, ti=10.0, td=0.5, ts=0.1, u_min=0.0, u_max=100.0),
    "pi_back_calc": dict(kp=3.0, ti=2.0, ts=0.1, u_min=-5.0, u_max=5.0,
                         anti_windup="back_calc_model", tt=0.3),
    "weights_reverse": dict(kp=1.5, ti=4.0, td=0.4, b=0.5, c=0.3, reverse=True, ts=0.1,
                            u_min=-20.0, u_max=30.0, derivative_method="tustin",
                            integral_method="forward"),
    "p_only_unlimited": dict(kp=0.8, ts=0.05, u_min=-INF, u_max=INF, reset_value=3.0),
    "narrow": dict(kp=20.0, ti=0.5, td=0.2, ts=0.1, u_min=0.0, u_max=1.0, safe_value=0.5,
                   integral_method="backward", derivative_method="forward", n=2.0),
}  # fmt: skip

# sp and pv: no -0.0 (the module docstring); the edges of the law too
PLAIN = st.floats(-150.0, 150.0).map(lambda x: x if x != 0.0 else 0.0)
SIGNALS = st.one_of(
    PLAIN,
    PLAIN,
    PLAIN,
    st.sampled_from((0.0, 1.0, 1e300, -1e300, 1e-300, NAN, INF, -INF)),
    st.integers(-1000, 1000),
)
FF = st.one_of(st.just(0.0), st.just(0.0), PLAIN, st.sampled_from((NAN, 1e308, -0.0)))
DV = st.one_of(st.just(0.0), st.just(0.0), st.just(0.0), st.sampled_from((1.0, NAN)))
DT = st.one_of(st.none(), st.none(), st.none(), st.sampled_from((0.1, 0.05, 0.0, NAN, 1e300)))
PV_OK = st.one_of(st.just(True), st.just(True), st.just(True),
                  st.sampled_from((False, 1, np.True_, None)))  # fmt: skip
APPLIED = st.one_of(
    st.tuples(st.just("out"), st.sampled_from((1.0, 1.0, 0.5, -1.0, 1.0001))),  # out * scale
    PLAIN,
    st.sampled_from((NAN, INF, -INF, -0.0, 1e300, "x", None, 7, np.float64(2.5), np.nan)),
)
CHANGES = {
    "kp": st.sampled_from((0.5, 2.0, 8.0)),
    "ti": st.sampled_from((0.0, 1.0, 10.0)),
    "td": st.sampled_from((0.0, 0.3)),
    "n": st.sampled_from((5.0, 10.0)),
    "b": st.sampled_from((0.5, 1.0)),
    "c": st.sampled_from((0.0, 0.5)),
    "tt": st.sampled_from((None, 0.5)),
    "sp_filter": st.sampled_from((0.0, 1.0)),
    "pv_filter": st.sampled_from((0.0, 0.4)),
    "sp_rate": st.sampled_from((0.0, 20.0)),
    "out_rate": st.sampled_from((0.0, 30.0)),
    "anti_windup": st.sampled_from(("clamping", "back_calc_model", "back_calc_real")),
    "algorithm": st.sampled_from(("positional", "velocity")),
    "deadband": st.sampled_from((0.0, 0.5)),
    "bumpless": st.sampled_from(("integrator", "suppress_p_action", "track_setpoint")),
    "i_band": st.sampled_from((0.0, 2.0)),
    "ff_k": st.sampled_from((0.0, 0.5)),
    "reverse": st.booleans(),
    "pv_range": st.sampled_from((None, (0.0, 200.0))),
    "safe_value": st.sampled_from((None, 5.0)),
    "ts": st.sampled_from((0.1, 0.2)),
    "u_min": st.sampled_from((-10.0, 0.0, -INF, 50.0)),
    "u_max": st.sampled_from((10.0, 100.0, INF, 0.0)),
}
LEAN_AGAIN = dict(sp_filter=0.0, pv_filter=0.0, sp_rate=0.0, out_rate=0.0, algorithm="positional",
                  deadband=0.0, bumpless="integrator", i_band=0.0, ff_k=0.0, pv_range=None,
                  anti_windup="clamping")  # fmt: skip
MODES = ("manual", "track", "hold", "reset_active", "awin")
MODE_VALUES = ("manual_value", "track_value", "actuator_pos")


def _norm(x):
    """``x`` for an exact comparison: a float as its bits, containers element by element."""
    if type(x) is float:
        return ("float", struct.pack("<d", x))
    if isinstance(x, Enum):
        return (type(x).__name__, x.value)
    if isinstance(x, np.ndarray):
        return ("array", x.dtype.str, x.shape, x.tobytes())
    if isinstance(x, dict):
        return ("dict", tuple((k, _norm(v)) for k, v in sorted(x.items())))
    if isinstance(x, tuple | list):
        return (type(x).__name__, tuple(_norm(v) for v in x))
    if isinstance(x, np.generic):
        return (type(x).__name__, x.tobytes())
    if x is None or isinstance(x, bool | int | str):
        return (type(x).__name__, x)
    return (type(x).__name__, _norm(vars(x)))  # a deque's holder, a sub-state object


def _pending(block: PID):
    """The pending cycle as the general path's tuple (the lean one turned into it on a copy)."""
    if block._pending is True:
        return copy.deepcopy(block)._full_cycle()
    return block._pending


def _attributes(block: PID):
    """The outputs and every state attribute, read as they are (nothing brought up to date)."""
    names = (*block._state_fields, "error_id", "mode", "_lo", "_hi", "_h", "_prm")
    return {name: getattr(block, name) for name in names}


def _same(a, b, what: str) -> None:
    na, nb = _norm(a), _norm(b)
    if na != nb:
        if isinstance(a, dict):
            diff = {k: (a[k], b.get(k)) for k in a if _norm(a[k]) != _norm(b.get(k))}
            raise AssertionError(f"{what} differ: {diff}")
        raise AssertionError(f"{what} differ: {a!r} != {b!r}")


class TwoPhase(RuleBasedStateMachine):
    """A lean block and the reference (lean cycle off) driven alike."""

    lean_cycles = 0  # compute_output calls that took the lean cycle, over the whole run
    lean_commits = 0  # update_state calls that committed one, with a value other than out

    @initialize(base=st.sampled_from(sorted(BASES)))
    def make(self, base):
        self.lean, self.ref = PID(**BASES[base]), PID(**BASES[base])
        self.ref._two_phase_lean = False
        self.snaps = []

    def _both(self, action):
        """``action(block)`` on both; the same result or the same exception."""
        results = []
        for block in (self.lean, self.ref):
            try:
                results.append(("ok", action(block)))
            except (ParameterError, TypeError, ValueError) as exc:
                results.append((type(exc).__name__, str(exc)))
        _same(results[0], results[1], "results")
        return results[0]

    @rule(sp=SIGNALS, pv=SIGNALS, ff=FF, dv=DV, dt=DT, pv_ok=PV_OK)
    def compute(self, sp, pv, ff, dv, dt, pv_ok):
        self._both(lambda b: b.compute_output(sp, pv, ff=ff, dv=dv, dt=dt, pv_ok=pv_ok))
        TwoPhase.lean_cycles += self.lean._pending is True
        assert self.ref._pending is not True

    @rule(sp=PLAIN, pv=PLAIN)
    def compute_plain(self, sp, pv):  # the lean cycle's own case, drawn more often
        self.compute(sp, pv, 0.0, 0.0, None, True)

    @rule(cycles=st.lists(st.tuples(PLAIN, PLAIN, APPLIED), min_size=1, max_size=8))
    def cycle(self, cycles):  # both phases, the applied value drawn
        for sp, pv, applied in cycles:
            self.compute(sp, pv, 0.0, 0.0, None, True)
            self.the_same()
            self.update(applied)
            self.the_same()

    @rule(applied=APPLIED)
    def update(self, applied):
        lean = self.lean._pending is True
        if isinstance(applied, tuple):  # the output times a factor
            self._both(lambda b: b.update_state(b.out * applied[1]))
        else:
            self._both(lambda b: b.update_state(applied))
        TwoPhase.lean_commits += lean and not (isinstance(applied, tuple) and applied[1] == 1.0)

    @rule(sp=SIGNALS, pv=SIGNALS, ff=FF, dt=DT)
    def call(self, sp, pv, ff, dt):
        self._both(lambda b: b(sp, pv, ff=ff, dt=dt))

    @rule(data=st.data())
    def configure(self, data):
        names = data.draw(st.lists(st.sampled_from(sorted(CHANGES)), min_size=1, max_size=3))
        changes = {n: data.draw(CHANGES[n]) for n in names}
        self._both(lambda b: b.configure(**changes))

    @rule(lo=st.sampled_from((-10.0, 0.0, 0.5, 2.0, NAN, -INF)),
          hi=st.sampled_from((1.0, 3.0, 100.0, 0.0, INF, NAN)))  # fmt: skip
    def limits(self, lo, hi):
        self._both(lambda b: b.set_limits(lo, hi))

    @rule(name=st.sampled_from(MODES), on=st.sampled_from((True, False, False, 1, np.False_)))
    def mode(self, name, on):
        self._both(lambda b: setattr(b, name, on))

    @rule()
    def auto(self):
        for name in MODES:
            self._both(lambda b, name=name: setattr(b, name, False))

    @rule()
    def lean_again(self):  # the options of the lean cycle off again
        self._both(lambda b: b.configure(**LEAN_AGAIN))

    @rule(name=st.sampled_from(MODE_VALUES), value=st.one_of(PLAIN, st.just(NAN)))
    def mode_value(self, name, value):
        self._both(lambda b: setattr(b, name, value))

    @rule()
    def snapshot(self):
        sa, sb = self.lean.snapshot(), self.ref.snapshot()
        _same(sa, sb, "snapshots")
        self.snaps.append((sa, sb))

    @precondition(lambda self: self.snaps)
    @rule(data=st.data())
    def restore(self, data):
        sa, sb = data.draw(st.sampled_from(self.snaps))
        self.lean.restore(sa)
        self.ref.restore(sb)

    @rule(out=st.sampled_from((None, 0.7, 50.0, NAN)))
    def restart(self, out):
        self._both(lambda b: b.reset() if out is None else b.start_at(out))

    @rule()
    def kernel_state(self):
        self._both(lambda b: b.load_kernel_state(b.kernel_state()))

    @invariant()
    def the_same(self):
        if not hasattr(self, "lean"):
            return
        _same(_attributes(self.lean), _attributes(self.ref), "attributes")
        _same(_pending(self.lean), _pending(self.ref), "pending cycles")
        # the sub-blocks too, on copies (a snapshot brings them up to date)
        _same(copy.deepcopy(self.lean).snapshot(), copy.deepcopy(self.ref).snapshot(), "states")

    def teardown(self):
        if hasattr(self, "lean"):
            _same(self.lean.snapshot(), self.ref.snapshot(), "snapshots")


def _run(examples: int, steps: int, derandomize: bool) -> None:
    TwoPhase.lean_cycles = TwoPhase.lean_commits = 0
    run_state_machine_as_test(
        TwoPhase,
        settings=settings(
            max_examples=examples,
            stateful_step_count=steps,
            deadline=None,
            derandomize=derandomize,
            suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
        ),
    )
    # the lean cycle did run, and committed values other than its output
    assert TwoPhase.lean_cycles > examples
    assert TwoPhase.lean_commits > examples // 4


def test_the_lean_two_phase_cycle_equals_the_general_one():
    _run(40, 50, derandomize=True)  # the CI run: the same examples every time


@pytest.mark.slow
@pytest.mark.timeout(1800)
def test_the_lean_two_phase_cycle_equals_the_general_one_long():
    _run(600, 80, derandomize=False)


def _pair(**config):
    lean, ref = PID(**config), PID(**config)
    ref._two_phase_lean = False
    return lean, ref


@pytest.mark.parametrize("base", sorted(BASES))
def test_a_closed_loop_with_a_shaped_output(base):
    # the runtime's and the structures' use: the output shaped (here a slower actuator
    # that saturates inside the limits, and a dropped sample) before update_state
    lean, ref = _pair(**BASES[base])
    y = 0.0
    lean_cycles = 0
    for k in range(600):
        sp = 1.0 + (k >= 300)
        pv = y + 0.01 * math.sin(k)
        v = lean.compute_output(sp, pv)
        lean_cycles += lean._pending is True
        assert v == ref.compute_output(sp, pv)
        u = min(v, 0.8 * lean.u_max) if k % 50 else NAN  # applied: saturated, once lost
        lean.update_state(u)
        ref.update_state(u)
        _same(_attributes(lean), _attributes(ref), "attributes")
        y += 0.05 * ((u if u == u else v) - y)
    _same(lean.snapshot(), ref.snapshot(), "snapshots")
    assert lean_cycles > 550


def test_the_lean_cycle_tracks_the_applied_value_by_hand():
    # clamping, PI: the integrator tracks u - out with g = h/(Tt + h) (Åström 1987, Fig. 3.6)
    pid = PID(kp=2.0, ti=1.0, ts=0.1, u_min=-10.0, u_max=10.0, tt=0.4)
    pid.update_state(pid.compute_output(1.0, 0.0))  # cold: P = 2, no integral
    v = pid.compute_output(1.0, 0.0)
    assert pid._pending is True  # the lean cycle
    i_k = 2.0 * 0.1 / 1.0 * 0.5 * (1.0 + 1.0)  # Tustin: K h/Ti (e + e_prev)/2
    assert v == pytest.approx(2.0 + i_k, abs=1e-15) and pid.i == pytest.approx(i_k, abs=1e-15)
    pid.update_state(1.0)  # applied below the output: the integrator tracks it
    g = 0.1 / (0.4 + 0.1)
    assert pid._i == pytest.approx(i_k + g * (1.0 - v), abs=1e-15)
    assert pid.manual_value == 1.0 and pid._pending is None
    pid.update_state(5.0)  # nothing pending: ignored
    assert pid._i == pytest.approx(i_k + g * (1.0 - v), abs=1e-15)


def test_compute_output_twice_and_update_state_alone():
    lean, ref = _pair(**BASES["pid_clamping"])
    for b in (lean, ref):
        for _ in range(5):
            b.update_state(b.compute_output(1.0, 0.4))
    first = lean.compute_output(3.0, 0.4)
    assert lean._pending is True
    again = lean.compute_output(1.0, 0.4)  # from the committed state again
    assert again == ref.compute_output(1.0, 0.4) and first == lean.compute_output(3.0, 0.4)
    ref.compute_output(3.0, 0.4)
    for b in (lean, ref):
        b.update_state(2.0)
        b.update_state(2.0)  # nothing pending: ignored
    _same(lean.snapshot(), ref.snapshot(), "snapshots")


@pytest.mark.parametrize(
    "between",
    [
        lambda b: b.configure(sp_filter=2.0),
        lambda b: b.configure(kp=3.0),
        lambda b: b.configure(algorithm="velocity"),
        lambda b: b.set_limits(0.0, 0.5),
        lambda b: b.set_limits(2.0, 1.0),
        lambda b: setattr(b, "manual", True),
        lambda b: b.snapshot(),
        lambda b: b.load_kernel_state(b.kernel_state()),
    ],
    ids=["filter_on", "retune", "velocity", "narrow_limits", "bad_limits", "manual",
         "snapshot", "kernel_state"],
)  # fmt: skip
def test_between_the_phases(between):
    lean, ref = _pair(**BASES["pid_clamping"])
    for b in (lean, ref):
        for k in range(5):
            b(1.0, 0.3 + 0.01 * k)  # the fast lane: the sub-blocks are left behind
        b.compute_output(1.5, 0.35)
    assert lean._pending is True
    results = []
    for b in (lean, ref):
        try:
            results.append(between(b))
        except ParameterError as exc:
            results.append(exc.code)
    _same(results[0], results[1], "results")
    _same(_pending(lean), _pending(ref), "pending cycles")
    _same(_attributes(lean), _attributes(ref), "attributes")
    for b in (lean, ref):
        b.update_state(b.out * 0.9)
        for _ in range(20):
            b.update_state(b.compute_output(1.5, 0.4))
    _same(lean.snapshot(), ref.snapshot(), "snapshots")


def test_p_suppressed_after_a_change_of_the_bumpless_method():
    # P suppressed (SUPPRESS_P_ACTION) when the method changes to "integrator": the
    # configuration is the lean cycle's, the state is not -- P stays off until |e| <= dev_tol
    config = dict(kp=2.0, ti=1.0, ts=0.1, u_min=-100.0, u_max=100.0,
                  bumpless="suppress_p_action", dev_tol=1.0)  # fmt: skip
    lean, ref = _pair(**config)
    for b in (lean, ref):
        b.manual, b.manual_value = True, 3.0
        for _ in range(2):
            b.update_state(b.compute_output(5.0, 0.0))
        b.manual = False
        b.update_state(b.compute_output(5.0, 0.0))
        b.configure(bumpless="integrator")
        assert b.p_suppressed and b._lean
    for pv in (0.0, 0.0, 4.5, 4.5):
        assert lean.compute_output(5.0, pv) == ref.compute_output(5.0, pv)
        for b in (lean, ref):
            b.update_state(b.out)
        _same(_attributes(lean), _attributes(ref), "attributes")
    assert not lean.p_suppressed  # back when |e| <= dev_tol
    assert lean.compute_output(5.0, 4.5) == ref.compute_output(5.0, 4.5)
    assert lean._pending is True


def test_a_negative_zero_input_differs_in_the_sign_of_zeros_only():
    config = dict(kp=1.0, ts=0.1, u_min=-1.0, u_max=1.0)
    lean, ref = _pair(**config)
    fast = PID(**config)  # the per-call fast lane, pid_step
    for b in (lean, ref):
        b.update_state(b.compute_output(1.0, 1.0))  # the filters' state positive
    fast(1.0, 1.0)
    for sp, pv in ((-0.0, 0.0), (0.0, -0.0), (-0.0, -0.0), (1.0, -0.0)):
        assert lean.compute_output(sp, pv) == ref.compute_output(sp, pv) == fast(sp, pv)
        assert lean._pending is True and fast._lean_ran
        # the general cycle's filters made the -0.0 a +0.0; the lean cycle keeps it, as
        # the fast lane does
        assert _norm((lean.sp_w, lean.pv_f)) == _norm((fast.sp_w, fast.pv_f))
        for b in (lean, ref):
            b.update_state(b.out)
        assert lean.snapshot() == ref.snapshot()  # equal as numbers: -0.0 == 0.0
    assert math.copysign(1.0, ref.pv_f) == 1.0 and math.copysign(1.0, lean.pv_f) == -1.0


def test_an_overflow_takes_the_general_cycle():
    # a law that overflows behind the limits: the general cycle's failed cycle
    lean, ref = _pair(kp=1e300, ti=1.0, ts=1.0, u_min=0.0, u_max=1.0)
    for b in (lean, ref):
        b.update_state(b.compute_output(1.0, 0.0))
    for sp in (1e300, -1e300, 1.0):
        va, vb = lean.compute_output(sp, -1e300), ref.compute_output(sp, -1e300)
        assert lean._pending is not True
        _same((va, _attributes(lean)), (vb, _attributes(ref)), "attributes")
        for b in (lean, ref):
            b.update_state(b.out)
    _same(lean.snapshot(), ref.snapshot(), "snapshots")
