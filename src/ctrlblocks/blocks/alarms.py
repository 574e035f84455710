"""Process alarms: PV limits HH/H/L/LL, deviation, rate of change and bad PV, in ISA-18.2 states.

What a PLC's PID block offers as alarms (Rockwell PIDE: PV high/low, deviation and
rate-of-change alarms with a deadband), with the alarm life cycle of
ANSI/ISA-18.2-2016 (ISA 2016, the alarm state transition diagram): an alarm
is annunciated when it becomes active, stays until it is acknowledged *and* has
returned, and can be shelved by the operator (for a limited time) or suppressed by
design (here: while the loop is in MAN, for the alarms configured so).

One alarm, one sample (:func:`alarm_cycle`)
-------------------------------------------
1. **Condition with hysteresis** (:func:`limit_condition`).  A high alarm on
   value ``x`` with limit ``L`` and deadband ``db`` (ISA 2016's deadband: the
   change needed to clear an alarm) becomes true at ``x >= L`` and false again
   only at ``x < L - db``; a low alarm true at ``x <= L`` and false at
   ``x > L + db``.
2. **On and off delays** (:func:`delay_step`).  ``active`` follows the
   condition only after the condition has differed from it for ``on_delay``
   seconds (to become active) or ``off_delay`` seconds (to return); a shorter
   excursion restarts the delay.  Deadband and delays together keep a noisy PV
   at the limit from chattering (ISA 2016: a chattering alarm "repeatedly
   transitions between the active state and the not active state in a short
   period of time").
3. **State** (:func:`alarm_state`), ISA 2016's states::

      NORMAL (A) --active--> UNACK (B) --ack--> ACKED (C) --returns--> NORMAL
                             UNACK (B) --returns--> RTN_UNACK (D) --ack--> NORMAL
                                                    RTN_UNACK (D) --active--> UNACK
      any --shelve--> SHELVED (F);  any --suppress--> SUPPRESSED (G);
      any --not enabled--> OUT_OF_SERVICE (H)

   Leaving SHELVED, SUPPRESSED or OUT_OF_SERVICE starts again at NORMAL in the
   same sample, so a condition still active is annunciated anew (UNACK).  While
   shelved or suppressed the condition is still evaluated (``active`` is
   readable), only not annunciated; out of service it is not evaluated.
   ISA 2016's latched state (E) is not offered.
4. **Shelving** is for ``shelve_time`` seconds (ISA 2016 asks for a time limit);
   ``unshelve`` ends it early.

A value that is not valid (``x_ok`` false: a bad PV, a NaN) leaves the
condition and its delay as they were; the bad-PV alarm reports it.

The functions are pure and written in the subset of Python that the PLC
translator (:mod:`ctrlblocks.plc`) turns into IEC 61131-3 Structured Text:
:func:`alarm_cycle` is the ``CB_ALARM`` FUNCTION_BLOCK and :func:`rate_cycle`
``CB_ROC``; the blocks :class:`Alarm` and :class:`LoopAlarms` call them.

Rate of change (:func:`rate_cycle`): the PV's change over ``period`` seconds,
``r = (PV[now] - PV[mark]) / elapsed``, recomputed whenever ``elapsed >=
period`` (a sample-and-hold over the period, as PIDE's ``PVROCPeriod``); 0
gives the change of every sample.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from typing import Any, NamedTuple

from .base import (
    Block,
    BlockConfig,
    ErrorCode,
    ParameterError,
    as_flag,
    as_input,
    require_bool,
    require_choice,
    require_finite,
    require_nonnegative,
    require_positive,
)
from .plc_cycle import plc_block

__all__ = [
    "ACKED",
    "ALARM_NAMES",
    "NORMAL",
    "OUT_OF_SERVICE",
    "RTN_UNACK",
    "SHELVED",
    "STATE_NAMES",
    "SUPPRESSED",
    "UNACK",
    "Alarm",
    "AlarmConfig",
    "AlarmStatus",
    "LoopAlarms",
    "LoopAlarmsConfig",
    "alarm_cycle",
    "alarm_state",
    "delay_step",
    "limit_condition",
    "rate_cycle",
]

# ISA-18.2 alarm states (ISA 2016, the state transition diagram; the letter in brackets)
NORMAL = 0
"""(A) normal: not active, acknowledged."""
UNACK = 1
"""(B) active, unacknowledged."""
ACKED = 2
"""(C) active, acknowledged."""
RTN_UNACK = 3
"""(D) returned to normal, unacknowledged."""
SHELVED = 4
"""(F) shelved by the operator (for a limited time)."""
SUPPRESSED = 5
"""(G) suppressed by design (here: the loop is in MAN)."""
OUT_OF_SERVICE = 6
"""(H) out of service (the alarm is not enabled)."""

STATE_NAMES = ("NORMAL", "UNACK", "ACKED", "RTN_UNACK", "SHELVED", "SUPPRESSED", "OUT_OF_SERVICE")
"""The state names by number."""

SHELVE_MAX = 86400.0
"""The longest shelving [s]: one day (ISA 2016 asks for shelving with a time limit)."""


# ---------------------------------------------------------------------------
# The pure functions (the PLC translator's subset)
# ---------------------------------------------------------------------------


def limit_condition(x: float, limit: float, deadband: float, high: bool, was: bool) -> bool:
    """The alarm condition of ``x`` against ``limit`` with hysteresis ``deadband``.

    High: true from ``x >= limit``, false again only below ``limit - deadband``;
    low: true from ``x <= limit``, false again only above ``limit + deadband``.
    ``was`` is the condition (the alarm's ``active``) of the last sample.
    """
    if high:
        if was:
            return x >= limit - deadband
        return x >= limit
    if was:
        return x <= limit + deadband
    return x <= limit


def delay_step(
    cond: bool, active: bool, timer: float, on_delay: float, off_delay: float, h: float
) -> tuple[bool, float]:
    """On/off delay: ``active`` takes the value of ``cond`` once they have differed for the delay.

    ``timer`` [s] counts how long they have differed (reset when they agree);
    the delay is ``on_delay`` to become active, ``off_delay`` to return.  A
    small slack makes a delay of ``k h`` switch after exactly ``k`` samples.
    Returns ``(active, timer)``.
    """
    if cond == active:
        return active, 0.0
    timer = timer + h
    delay = off_delay
    if cond:
        delay = on_delay
    if timer >= delay - 1e-9 * h:
        return cond, 0.0
    return active, timer


def alarm_state(
    state: int, active: bool, ack: bool, shelved: bool, suppressed: bool, enabled: bool
) -> int:
    """The next ISA-18.2 state (see the module docstring) of an alarm in ``state``."""
    if not enabled:
        return OUT_OF_SERVICE
    if shelved:
        return SHELVED
    if suppressed:
        return SUPPRESSED
    if state >= SHELVED:  # released: start again, an active condition is annunciated anew
        state = NORMAL
    if state == NORMAL:
        if active:
            state = UNACK
    elif state == UNACK:
        if not active:
            state = RTN_UNACK
    elif state == ACKED:
        if not active:
            state = NORMAL
    elif state == RTN_UNACK and active:
        state = UNACK
    if ack:
        if state == UNACK:
            state = ACKED
        elif state == RTN_UNACK:
            state = NORMAL
    return state


@plc_block("ALARM", ("state", "active", "timer", "shelve_left"), hidden=("timer",))
def alarm_cycle(
    x: float,
    x_ok: bool,
    limit: float,
    deadband: float,
    high: bool,
    on_delay: float,
    off_delay: float,
    h: float,
    enabled: bool,
    ack: bool,
    shelve: bool,
    shelve_time: float,
    unshelve: bool,
    suppress: bool,
    state: int,
    active: bool,
    timer: float,
    shelve_left: float,
) -> tuple[int, bool, float, float]:
    """One sample of one alarm: condition, delays, shelving, ISA-18.2 state.

    ``shelve`` starts a shelving of ``shelve_time`` seconds, ``unshelve`` ends
    it; ``ack`` acknowledges.  Returns ``(state, active, timer, shelve_left)``.
    """
    if not enabled:
        active = False
        timer = 0.0
    elif x_ok:
        cond = limit_condition(x, limit, deadband, high, active)
        active, timer = delay_step(cond, active, timer, on_delay, off_delay, h)
    if shelve:
        shelve_left = shelve_time
    if unshelve:
        shelve_left = 0.0
    shelved = shelve_left > 0.0
    if shelved:
        shelve_left = shelve_left - h
        if shelve_left < 0.0:
            shelve_left = 0.0
    state = alarm_state(state, active, ack, shelved, suppress, enabled)
    return state, active, timer, shelve_left


@plc_block("ROC", ("rate", "mark", "elapsed", "started"), hidden=("mark", "elapsed", "started"))
def rate_cycle(
    x: float, x_ok: bool, period: float, h: float, rate: float, mark: float, elapsed: float,
    started: bool,
) -> tuple[float, float, float, bool]:  # fmt: skip
    """Rate of change of ``x`` [units/s] over ``period`` seconds (sample-and-hold).

    The first valid sample sets the mark; afterwards, whenever ``elapsed >=
    period``, ``rate = (x - mark) / elapsed`` and the mark moves to ``x``.  An
    invalid sample holds everything.  Returns ``(rate, mark, elapsed, started)``.
    """
    if x_ok:
        if not started:
            mark = x
            elapsed = 0.0
            rate = 0.0
            started = True
        else:
            elapsed = elapsed + h
            if elapsed >= period - 1e-9 * h:
                rate = (x - mark) / elapsed
                mark = x
                elapsed = 0.0
    return rate, mark, elapsed, started


# ---------------------------------------------------------------------------
# The blocks
# ---------------------------------------------------------------------------


def _require_delays(c: Any) -> None:
    require_nonnegative("deadband", c.deadband, ErrorCode.BAD_LIMITS)
    require_nonnegative("on_delay", c.on_delay, ErrorCode.BAD_TIME_CONSTANT)
    require_nonnegative("off_delay", c.off_delay, ErrorCode.BAD_TIME_CONSTANT)
    require_positive("ts", c.ts, ErrorCode.NO_CYCLE)


class AlarmStatus(NamedTuple):
    """What a faceplate shows of one alarm."""

    name: str
    state: int
    active: bool
    priority: int
    limit: float
    value: float

    @property
    def state_name(self) -> str:
        """The ISA-18.2 state's name (``"UNACK"``, ...)."""
        return STATE_NAMES[self.state]

    @property
    def annunciated(self) -> bool:
        """True in UNACK, ACKED and RTN_UNACK: the alarm is on the operator's list."""
        return UNACK <= self.state <= RTN_UNACK


@dataclasses.dataclass(frozen=True)
class AlarmConfig(BlockConfig):
    """Configuration of :class:`Alarm`.

    Attributes
    ----------
    limit : float
        Alarm limit [units of the value].
    kind : {"high", "low"}
        A high alarm is active at ``x >= limit``, a low one at ``x <= limit``.
    deadband : float
        Hysteresis [units of the value] >= 0: the change back across the limit
        needed to return.
    on_delay, off_delay : float
        Delays [s] >= 0 before the alarm becomes active / returns.
    ts : float
        Sample time [s] > 0.
    enabled : bool
        False: out of service (ISA-18.2 state H).
    priority : int
        1 (high) .. 3 (low), shown on the faceplate.
    """

    limit: float = 0.0
    kind: str = "high"
    deadband: float = 0.0
    on_delay: float = 0.0
    off_delay: float = 0.0
    ts: float = 1.0
    enabled: bool = True
    priority: int = 2

    def validate(self) -> None:
        require_finite("limit", self.limit, ErrorCode.BAD_LIMITS)
        require_choice("kind", self.kind, ("high", "low"))
        _require_delays(self)
        require_bool("enabled", self.enabled)
        _require_priority("priority", self.priority)


def _require_priority(field: str, p: Any) -> None:
    if type(p) is not int or not 1 <= p <= 3:
        raise ParameterError(ErrorCode.BAD_PARAMETER, field, f"must be 1, 2 or 3, got {p!r}")


class Alarm(Block):
    """One limit alarm on any value, with deadband, delays and ISA-18.2 states.

    ``alarm(x)`` evaluates one sample and returns ``active``; ``state`` is the
    ISA-18.2 state (:data:`NORMAL` ... :data:`OUT_OF_SERVICE`), ``out`` is
    ``active`` as 1.0/0.0.  :meth:`acknowledge`, :meth:`shelve` and
    :meth:`unshelve` act at once (and the next sample continues from there).

    A NaN/inf ``x`` or ``ok=False`` holds the condition (``BAD_INPUT`` /
    ``BAD_MEASUREMENT``).

    Examples
    --------
    >>> a = Alarm(limit=80.0, deadband=2.0, ts=1.0)
    >>> [a(x) for x in (79.0, 80.5, 79.0, 77.5)]
    [False, True, True, False]
    >>> a.state_name        # returned, not yet acknowledged
    'RTN_UNACK'
    >>> a.acknowledge(); a.state_name
    'NORMAL'
    """

    Config = AlarmConfig
    _state_fields = ("out", "state", "active", "_timer", "_shelve_left", "value")
    config: AlarmConfig
    _config: AlarmConfig

    def _reset_state(self) -> None:
        self.out = 0.0
        self.state = NORMAL if self._config.enabled else OUT_OF_SERVICE
        self.active = False
        self._timer = 0.0
        self._shelve_left = 0.0
        self.value = math.nan

    @property
    def state_name(self) -> str:
        """The ISA-18.2 state's name."""
        return STATE_NAMES[self.state]

    @property
    def shelve_left(self) -> float:
        """Seconds of shelving left (0: not shelved)."""
        return self._shelve_left

    def status(self, name: str = "") -> AlarmStatus:
        """The alarm as a faceplate shows it."""
        c = self._config
        return AlarmStatus(name, self.state, self.active, c.priority, c.limit, self.value)

    def __call__(
        self, x: float, *, ok: Any = True, suppress: Any = False, dt: float | None = None
    ) -> bool:
        """Evaluate one sample of ``x``; ``suppress`` (e.g. the loop is in MAN) suppresses it."""
        c = self._config
        h = self._cycle_time(dt, c.ts)
        if h is None:
            return self.active
        v = as_input(x)
        good = as_flag(ok, False)
        self.error_id = ErrorCode.NO_ERROR
        if not good:
            self.error_id = ErrorCode.BAD_MEASUREMENT
        elif not math.isfinite(v):
            self.error_id = ErrorCode.BAD_INPUT
            good = False
        else:
            self.value = v
        self.state, self.active, self._timer, self._shelve_left = alarm_cycle(
            v, good, c.limit, c.deadband, c.kind == "high", c.on_delay, c.off_delay, h,
            c.enabled, False, False, 0.0, False, as_flag(suppress, False),
            self.state, self.active, self._timer, self._shelve_left,
        )  # fmt: skip
        self.out = 1.0 if self.active else 0.0
        return self.active

    def acknowledge(self) -> bool:
        """Acknowledge (UNACK -> ACKED, RTN_UNACK -> NORMAL); True if the state changed."""
        old = self.state
        self.state = alarm_state(self.state, self.active, True, False, False, True)
        if old >= SHELVED:
            self.state = old  # nothing to acknowledge while shelved, suppressed or out of service
        return self.state != old

    def shelve(self, seconds: float) -> None:
        """Shelve for ``seconds`` (0 < seconds <= :data:`SHELVE_MAX`); refused otherwise."""
        self._shelve_left = _shelve_seconds(seconds)
        if self.state != OUT_OF_SERVICE:
            self.state = SHELVED

    def unshelve(self) -> None:
        """End a shelving now; a condition still active is annunciated anew."""
        if self.state == SHELVED:
            self._shelve_left = 0.0
            self.state = alarm_state(NORMAL, self.active, False, False, False, True)


def _shelve_seconds(seconds: Any) -> float:
    s = require_positive("seconds", seconds, ErrorCode.BAD_TIME_CONSTANT)
    if s > SHELVE_MAX:
        raise ParameterError(
            ErrorCode.BAD_TIME_CONSTANT, "seconds", f"shelving is limited to {SHELVE_MAX:g} s"
        )
    return s


ALARM_NAMES = ("HH", "H", "L", "LL", "DEV", "ROC", "BAD")
"""The alarms of a loop: PV high-high, high, low, low-low, deviation ``|SP - PV|``,
rate of change ``|dPV/dt|`` and bad PV."""

_PRIORITY = {"HH": 1, "H": 2, "L": 2, "LL": 1, "DEV": 3, "ROC": 3, "BAD": 1}
_HIGH = {"HH": True, "H": True, "L": False, "LL": False, "DEV": True, "ROC": True, "BAD": True}
_HIGH_BY_INDEX = tuple(_HIGH[n] for n in ALARM_NAMES)


@dataclasses.dataclass(frozen=True)
class LoopAlarmsConfig(BlockConfig):
    """Configuration of :class:`LoopAlarms`.  A limit of None switches its alarm off.

    Attributes
    ----------
    hh, h, l, ll : float or None
        PV limits [PV units], ``ll <= l <= h <= hh`` among those given.
    dev : float or None
        Deviation limit [PV units] > 0: alarm at ``|SP - PV| >= dev``.
    roc : float or None
        Rate-of-change limit [PV units/s] > 0: alarm at ``|rate| >= roc``.
    roc_period : float
        Period [s] >= 0 of the rate (:func:`rate_cycle`); 0: every sample.
    deadband : float
        Hysteresis [PV units] >= 0 of the PV and deviation alarms.
    roc_deadband : float
        Hysteresis [PV units/s] >= 0 of the rate alarm.
    on_delay, off_delay : float
        Delays [s] >= 0 of every alarm.
    bad_pv : bool
        Alarm BAD while the PV is invalid (NaN, inf, quality flag false).
    suppress_in_manual : tuple of str
        The alarms suppressed while the loop is in MAN (default DEV and ROC:
        in MAN the setpoint does not act, and the operator moves the PV).
    ts : float
        Sample time [s] > 0.
    """

    hh: float | None = None
    h: float | None = None
    l: float | None = None  # noqa: E741  (the engineer's name of the low limit)
    ll: float | None = None
    dev: float | None = None
    roc: float | None = None
    roc_period: float = 0.0
    deadband: float = 0.0
    roc_deadband: float = 0.0
    on_delay: float = 0.0
    off_delay: float = 0.0
    bad_pv: bool = True
    suppress_in_manual: tuple[str, ...] = ("DEV", "ROC")
    ts: float = 1.0

    def validate(self) -> None:
        given = []
        for name in ("ll", "l", "h", "hh"):
            v = getattr(self, name)
            if v is not None:
                given.append((name, require_finite(name, v, ErrorCode.BAD_LIMITS)))
        for (n1, v1), (n2, v2) in itertools.pairwise(given):
            if v1 > v2:
                raise ParameterError(
                    ErrorCode.BAD_LIMITS, f"{n1}/{n2}", f"{n1} = {v1!r} is above {n2} = {v2!r}"
                )
        for name in ("dev", "roc"):
            if getattr(self, name) is not None:
                require_positive(name, getattr(self, name), ErrorCode.BAD_LIMITS)
        require_nonnegative("roc_period", self.roc_period, ErrorCode.BAD_TIME_CONSTANT)
        require_nonnegative("roc_deadband", self.roc_deadband, ErrorCode.BAD_LIMITS)
        _require_delays(self)
        require_bool("bad_pv", self.bad_pv)
        s = self.suppress_in_manual
        if not isinstance(s, tuple) or any(n not in ALARM_NAMES for n in s):
            raise ParameterError(
                ErrorCode.BAD_PARAMETER,
                "suppress_in_manual",
                f"must be a tuple of alarm names ({', '.join(ALARM_NAMES)}), got {s!r}",
            )

    def limit(self, name: str) -> float | None:
        """The limit of alarm ``name`` (None: not configured; BAD has none)."""
        if name == "BAD":
            return 0.5 if self.bad_pv else None
        return getattr(self, name.lower())  # type: ignore[no-any-return]


class LoopAlarms(Block):
    """The alarms of one loop: HH, H, L, LL, DEV, ROC and BAD, each an :func:`alarm_cycle`.

    ``alarms(sp, pv, pv_ok=True, manual=False)`` evaluates one sample.
    ``status()`` lists every configured alarm (:class:`AlarmStatus`);
    ``transitions`` are the state changes of the last call (or of the last
    acknowledge/shelve), as ``(name, old_state, new_state, value)``;
    ``out`` is the number of annunciated alarms (UNACK, ACKED or RTN_UNACK),
    ``unacknowledged`` those still to acknowledge, ``worst`` the highest
    priority among the annunciated (0: none).

    A NaN/inf or invalid PV (``BAD_MEASUREMENT`` / ``BAD_INPUT``) holds the
    PV, deviation and rate alarms and raises BAD; a NaN setpoint holds DEV.

    Examples
    --------
    >>> al = LoopAlarms(h=80.0, hh=90.0, deadband=1.0, ts=1.0)
    >>> for pv in (70.0, 85.0, 92.0):
    ...     n = al(75.0, pv)
    >>> [(s.name, s.state_name) for s in al.status() if s.annunciated]
    [('HH', 'UNACK'), ('H', 'UNACK')]
    >>> sorted(al.acknowledge())
    ['H', 'HH']
    """

    Config = LoopAlarmsConfig
    _state_fields = (
        "out", "_state", "_active", "_timer", "_shelve_left", "_value", "rate", "_mark",
        "_elapsed", "_started", "transitions",
    )  # fmt: skip
    config: LoopAlarmsConfig
    _config: LoopAlarmsConfig
    _state: list[int]

    def _apply_config(self, old: BlockConfig | None) -> None:
        c = self._config
        self._on = tuple(c.limit(n) is not None for n in ALARM_NAMES)
        self._limits = tuple(
            float(c.limit(n) or 0.0) for n in ALARM_NAMES
        )  # off alarms: any finite number
        db = (c.deadband,) * 6
        self._deadbands = (*db[:5], c.roc_deadband, 0.0)
        self._suppress = tuple(n in c.suppress_in_manual for n in ALARM_NAMES)
        self._configured = tuple(i for i, on in enumerate(self._on) if on)
        if old is not None:  # an alarm switched off goes out of service; switched on: NORMAL
            self._state = [
                s if on else OUT_OF_SERVICE for s, on in zip(self._state, self._on, strict=True)
            ]
            self._state = [
                NORMAL if on and s == OUT_OF_SERVICE else s
                for s, on in zip(self._state, self._on, strict=True)
            ]

    def _reset_state(self) -> None:
        n = len(ALARM_NAMES)
        self.out = 0.0
        self._state = [NORMAL if on else OUT_OF_SERVICE for on in self._on]
        self._active = [False] * n
        self._timer = [0.0] * n
        self._shelve_left = [0.0] * n
        self._value = [math.nan] * n
        self.rate = 0.0
        self._mark = 0.0
        self._elapsed = 0.0
        self._started = False
        self.transitions: tuple[tuple[str, int, int, float], ...] = ()

    # -- reading -----------------------------------------------------------------

    def status(self, *, configured_only: bool = True) -> list[AlarmStatus]:
        """Every (configured) alarm as a faceplate shows it."""
        out = []
        for i, name in enumerate(ALARM_NAMES):
            if configured_only and not self._on[i]:
                continue
            limit = self._limits[i] if self._on[i] else math.nan
            out.append(
                AlarmStatus(
                    name, self._state[i], self._active[i], _PRIORITY[name], limit, self._value[i]
                )
            )
        return out

    def state_of(self, name: str) -> int:
        """The ISA-18.2 state of alarm ``name``."""
        return self._state[_index(name)]

    def active_of(self, name: str) -> bool:
        """True while alarm ``name``'s condition holds (after deadband and delays)."""
        return self._active[_index(name)]

    @property
    def unacknowledged(self) -> int:
        """Number of alarms waiting for acknowledgement (UNACK, RTN_UNACK)."""
        return sum(s in (UNACK, RTN_UNACK) for s in self._state)

    @property
    def worst(self) -> int:
        """Highest priority (1 highest) among the annunciated alarms; 0 when none."""
        ps = [_PRIORITY[n] for n, s in zip(ALARM_NAMES, self._state, strict=True)
              if UNACK <= s <= RTN_UNACK]  # fmt: skip
        return min(ps) if ps else 0

    # -- the cycle -----------------------------------------------------------------

    def __call__(
        self, sp: float, pv: float, *, pv_ok: Any = True, manual: Any = False,
        dt: float | None = None,
    ) -> int:  # fmt: skip
        """Evaluate one sample; return the number of annunciated alarms."""
        c = self._config
        h = self._cycle_time(dt, c.ts)
        if h is None:
            self.transitions = ()
            return int(self.out)
        y, r = as_input(pv), as_input(sp)
        good = as_flag(pv_ok, False)
        man = as_flag(manual, False)
        self.error_id = ErrorCode.NO_ERROR
        if not good:
            self.error_id = ErrorCode.BAD_MEASUREMENT
        elif not math.isfinite(y) or not math.isfinite(r):
            self.error_id = ErrorCode.BAD_INPUT
        y_ok = good and math.isfinite(y)
        self.rate, self._mark, self._elapsed, self._started = rate_cycle(
            y, y_ok, c.roc_period, h, self.rate, self._mark, self._elapsed, self._started
        )
        dev = abs(r - y) if math.isfinite(r) else math.nan
        values = (y, y, y, y, dev, abs(self.rate), 0.0 if y_ok else 1.0)
        oks = (y_ok,) * 4 + (y_ok and math.isfinite(dev), y_ok, True)
        old = list(self._state)
        st, act, tim, shl = self._state, self._active, self._timer, self._shelve_left
        for i in self._configured:  # operator actions act at once, not as inputs here
            sup = man and self._suppress[i]
            if st[i] == NORMAL and not act[i] and tim[i] == 0.0 and shl[i] == 0.0 and not sup:
                # at rest: alarm_cycle would change nothing unless the condition is true
                if not oks[i]:
                    continue
                if not limit_condition(values[i], self._limits[i], self._deadbands[i],
                                       _HIGH_BY_INDEX[i], False):  # fmt: skip
                    self._value[i] = values[i]
                    continue
            st[i], act[i], tim[i], shl[i] = alarm_cycle(
                values[i], oks[i], self._limits[i], self._deadbands[i], _HIGH_BY_INDEX[i],
                c.on_delay, c.off_delay, h, True, False, False, 0.0, False, sup, st[i], act[i],
                tim[i], shl[i],
            )  # fmt: skip
            if oks[i]:
                self._value[i] = values[i]
        self._finish(old)
        return int(self.out)

    def _finish(self, old: list[int]) -> None:
        if old == self._state:  # the common cycle: nothing changed
            if self.transitions:
                self.transitions = ()
            return
        self.transitions = tuple(
            (n, o, s, self._value[i])
            for i, (n, o, s) in enumerate(zip(ALARM_NAMES, old, self._state, strict=True))
            if o != s
        )
        self.out = float(sum(UNACK <= s <= RTN_UNACK for s in self._state))

    # -- operator actions (at once; the next sample continues from there) -----------

    def acknowledge(self, name: str | None = None) -> list[str]:
        """Acknowledge alarm ``name`` (all when None); return the names whose state changed."""
        old = list(self._state)
        for i in _indices(name):
            s = self._state[i]
            if s < SHELVED:
                self._state[i] = alarm_state(s, self._active[i], True, False, False, True)
        self._finish(old)
        return [t[0] for t in self.transitions]

    def shelve(self, name: str, seconds: float) -> None:
        """Shelve alarm ``name`` for ``seconds`` (<= :data:`SHELVE_MAX`)."""
        i = _index(name)
        s = _shelve_seconds(seconds)
        old = list(self._state)
        if self._on[i]:
            self._shelve_left[i] = s
            self._state[i] = SHELVED
        self._finish(old)

    def unshelve(self, name: str) -> None:
        """End the shelving of alarm ``name``; a condition still active is annunciated anew."""
        i = _index(name)
        old = list(self._state)
        if self._state[i] == SHELVED:
            self._shelve_left[i] = 0.0
            self._state[i] = alarm_state(NORMAL, self._active[i], False, False, False, True)
        self._finish(old)


def _index(name: str) -> int:
    try:
        return ALARM_NAMES.index(name)
    except ValueError:
        raise KeyError(f"no alarm {name!r}; alarms: {', '.join(ALARM_NAMES)}") from None


def _indices(name: str | None) -> range | tuple[int]:
    return range(len(ALARM_NAMES)) if name is None else (_index(name),)
