"""Alarms and the live assessment of the runtime's loops.

A loop of the runtime's configuration may carry two tables::

    [[loops]]
    name = "level"
    ...
    alarms = { h = 90.0, hh = 95.0, l = 10.0, dev = 5.0, deadband = 1.0, on_delay = 5.0 }
    assess = { window = 3600.0, every = 900.0, pv_span = 100.0, ti = 40.0 }

``alarms`` takes the fields of :class:`ctrlblocks.blocks.alarms.LoopAlarmsConfig`
(the loop's ``ts`` is the alarms' sample time); ``assess`` the live assessment's
window and period [s] and the :class:`ctrlblocks.health.AssessOptions` fields
``u_min``, ``u_max``, ``pv_span``, ``ti``, ``tu`` and ``dead_time``.

A third table, ``alarm_outputs``, binds the alarms' states to device
variables (a PLC or SCADA reads them as variables of the loop)::

    alarm_outputs = { h_state = "plc:ns=2;s=level.H", h_unack = "plc:ns=2;s=level.H_unack" }

Its keys are :data:`ALARM_OUTPUT_KEYS`: per configured alarm ``NAME_state``
(the ISA-18.2 state number, :data:`~ctrlblocks.blocks.alarms.STATE_NAMES`),
``NAME_active`` (1/0: the condition after deadband and delays) and
``NAME_unack`` (1/0: waiting for an acknowledgement, UNACK or RTN_UNACK), and
for the loop ``unacknowledged`` (how many wait) and ``worst`` (the highest
priority annunciated, 1..3; 0: none).  The loop writes them with its MV in
the cycle's batched write (:meth:`HealthMonitor.output_values`).

:class:`HealthMonitor` sees every sample the runtime records (``observe``): it
runs the loop's :class:`~ctrlblocks.LoopAlarms` (MAN from the sample's mode,
the PV's quality from ``pv_ok``) and its
:class:`~ctrlblocks.health.live.LiveAssessor`.  Every alarm state change is
written to the historian's audit table through its own API
(``Historian.audit``) as action ``alarm NAME``: time, loop, alarm, old and new
state, the value in the message, and ``who`` -- ``alarm`` for the process,
the user for an acknowledgement or a shelving.  :func:`alarm_events` reads them
back.  The loops' first assessments are spread over the period, so that 200
loops do not all assess in the same cycle.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from ..blocks.alarms import ALARM_NAMES, RTN_UNACK, STATE_NAMES, UNACK, LoopAlarms, LoopAlarmsConfig
from ..blocks.base import ParameterError

__all__ = [
    "ALARM_KEYS",
    "ALARM_OUTPUT_KEYS",
    "ASSESS_KEYS",
    "HealthMonitor",
    "alarm_events",
    "alarm_output_problem",
    "check_health_tables",
]

ALARM_KEYS = tuple(f for f in LoopAlarmsConfig.__dataclass_fields__ if f != "ts")
"""The keys of a loop's ``alarms`` table."""
ASSESS_KEYS = ("window", "every", "u_min", "u_max", "pv_span", "ti", "tu", "dead_time")
"""The keys of a loop's ``assess`` table."""

_ALARM_FIELDS = ("state", "active", "unack")
ALARM_OUTPUT_KEYS = (
    *(f"{n.lower()}_{f}" for n in ALARM_NAMES for f in _ALARM_FIELDS),
    "unacknowledged",
    "worst",
)
"""The keys of a loop's ``alarm_outputs`` table (the module docstring)."""

Fail = Callable[[str, str], Exception]


def alarm_output_problem(key: str, health: Mapping[str, Any]) -> str | None:
    """Why ``key`` cannot be an alarm output of a loop with ``health``; None: it can.

    ``health`` is the loop's :func:`check_health_tables` result.
    """
    if key not in ALARM_OUTPUT_KEYS:
        return (
            "unknown key; the alarm outputs are NAME_state, NAME_active, NAME_unack "
            f"(NAME: {', '.join(n.lower() for n in ALARM_NAMES)}), unacknowledged, worst"
        )
    alarms = health.get("alarms")
    if alarms is None:
        return "the loop has no alarms table: there is no alarm state to write"
    name = key.rpartition("_")[0].upper()
    if name and LoopAlarmsConfig(**alarms).limit(name) is None:
        how = "bad_pv = true" if name == "BAD" else f"alarms.{name.lower()}"
        return f"alarm {name} is not configured (it needs {how})"
    return None


def check_health_tables(raw: Mapping[str, Any], key: str, ts: float, fail: Fail) -> dict[str, Any]:
    """Check a loop's ``alarms`` and ``assess`` tables; ``{"alarms": {...}, "assess": {...}}``.

    ``fail(key_path, message)`` makes the configuration error (the runtime's
    :class:`~ctrlblocks.runtime.config.RuntimeConfigError`, naming the file and line).
    """
    out: dict[str, Any] = {}
    alarms = raw.get("alarms")
    if alarms is not None:
        if not isinstance(alarms, Mapping):
            raise fail(f"{key}.alarms", "must be a table")
        unknown = sorted(set(alarms) - set(ALARM_KEYS))
        if unknown:
            raise fail(f"{key}.alarms.{unknown[0]}",
                       f"unknown key; the alarms take {', '.join(ALARM_KEYS)}")  # fmt: skip
        params = dict(alarms)
        if "suppress_in_manual" in params and isinstance(params["suppress_in_manual"], list):
            params["suppress_in_manual"] = tuple(params["suppress_in_manual"])
        try:
            LoopAlarms(**params, ts=ts)
        except ParameterError as exc:
            raise fail(f"{key}.alarms.{exc.field.split('/')[0]}", exc.message) from None
        out["alarms"] = params
    assess = raw.get("assess")
    if assess is not None:
        if not isinstance(assess, Mapping):
            raise fail(f"{key}.assess", "must be a table")
        for k, v in assess.items():
            if k not in ASSESS_KEYS:
                keys = ", ".join(ASSESS_KEYS)
                raise fail(f"{key}.assess.{k}", f"unknown key; assess takes {keys}")
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise fail(f"{key}.assess.{k}", f"must be a finite number, got {v!r}")
            if k in ("window", "every", "pv_span", "ti", "tu") and v <= 0:
                raise fail(f"{key}.assess.{k}", f"must be > 0, got {v!r}")
        window = float(assess.get("window", 3600.0))
        if window < 10 * ts:
            raise fail(f"{key}.assess.window", f"must hold at least 10 samples ({10 * ts:g} s)")
        out["assess"] = dict(assess)
    return out


@dataclass
class _Loop:
    alarms: LoopAlarms | None
    live: Any
    findings: list[dict[str, Any]] = field(default_factory=list)
    assessed_at: float = math.nan


class HealthMonitor:
    """The alarms and the live assessment of the runtime's loops (see the module docstring).

    Parameters
    ----------
    loops : iterable of (name, ts, health tables)
        Each loop's name, sample time and :func:`check_health_tables` result.
    audit : callable, optional
        ``audit(who, loop, action, old, new, ok, message)``: the historian's audit
        (the runtime's ``audit``); None records nothing.
    """

    def __init__(
        self, loops: Iterable[tuple[str, float, Mapping[str, Any]]],
        audit: Callable[..., None] | None = None,
    ) -> None:  # fmt: skip
        self._audit = audit
        self._loops: dict[str, _Loop] = {}
        todo = [(n, ts, h) for n, ts, h in loops if h]
        for i, (name, ts, h) in enumerate(todo):
            al = LoopAlarms(**h["alarms"], ts=ts) if "alarms" in h else None
            live = None
            if "assess" in h:
                live = _live(name, ts, h["assess"], i / max(len(todo), 1))
            self._loops[name] = _Loop(al, live)

    def __bool__(self) -> bool:
        return bool(self._loops)

    @property
    def loops(self) -> list[str]:
        """The loops with alarms or an assessment."""
        return list(self._loops)

    def observe(self, s: Any) -> None:
        """One recorded sample (:class:`~ctrlblocks.runtime.loop.Sample`) of a loop."""
        lh = self._loops.get(s.loop)
        if lh is None:
            return
        manual = s.mode != "auto"
        if lh.alarms is not None:
            dt = s.dt if isinstance(s.dt, float) and s.dt > 0 and math.isfinite(s.dt) else None
            lh.alarms(s.sp, s.pv, pv_ok=s.pv_ok, manual=manual, dt=dt)
            self._log(s.loop, "alarm", lh.alarms.transitions)
        if lh.live is not None:
            lh.live.append(s.t, s.sp, s.pv, s.mv, not manual, bool(s.pv_ok))
            if lh.live.due(s.t):
                try:
                    a = lh.live.assess(s.t)
                except ValueError:  # a window the assessment cannot use (time reset)
                    a = None
                if a is not None:
                    lh.findings = [f.as_dict() for f in a.findings]
                    lh.assessed_at = s.t_wall

    def _log(self, loop: str, who: str, transitions: Iterable[tuple[str, int, int, float]]) -> None:
        if self._audit is None:
            return
        for name, old, new, value in transitions:
            self._audit(who, loop, f"alarm {name}", STATE_NAMES[old], STATE_NAMES[new], True,
                        f"value {value:.6g}" if math.isfinite(value) else "")  # fmt: skip

    def _alarms(self, loop: str) -> LoopAlarms:
        lh = self._loops.get(loop)
        if lh is None or lh.alarms is None:
            raise KeyError(f"loop {loop!r} has no alarms")
        return lh.alarms

    def acknowledge(self, loop: str, alarm: str | None, user: str) -> list[str]:
        """Acknowledge ``alarm`` (all: None) of ``loop`` as ``user``; the alarms that changed."""
        al = self._alarms(loop)
        changed = al.acknowledge(alarm)
        self._log(loop, user, al.transitions)
        return changed

    def shelve(self, loop: str, alarm: str, seconds: float, user: str) -> None:
        """Shelve ``alarm`` of ``loop`` for ``seconds`` as ``user`` (refused: ParameterError)."""
        al = self._alarms(loop)
        al.shelve(alarm, seconds)
        self._log(loop, user, al.transitions)

    def unshelve(self, loop: str, alarm: str, user: str) -> None:
        """End the shelving of ``alarm`` of ``loop`` as ``user``."""
        al = self._alarms(loop)
        al.unshelve(alarm)
        self._log(loop, user, al.transitions)

    def output_values(self, loop: str, keys: Iterable[str]) -> list[float]:
        """The values of the alarm outputs ``keys`` (:data:`ALARM_OUTPUT_KEYS`) of ``loop``.

        States as their numbers, flags as 1.0 / 0.0 -- exact in any numeric
        variable (a FLOAT32 register pair, a UInt16, a Boolean node).
        """
        al = self._alarms(loop)
        out = []
        for key in keys:
            if key == "unacknowledged":
                out.append(float(al.unacknowledged))
                continue
            if key == "worst":
                out.append(float(al.worst))
                continue
            name, _, what = key.rpartition("_")
            st = al.state_of(name.upper())
            if what == "state":
                out.append(float(st))
            elif what == "unack":
                out.append(1.0 if st in (UNACK, RTN_UNACK) else 0.0)
            else:
                out.append(1.0 if al.active_of(name.upper()) else 0.0)
        return out

    def status(self, loop: str) -> dict[str, Any]:
        """The loop's alarm state at a glance, its alarm list and the last findings."""
        lh = self._loops.get(loop)
        if lh is None:
            return {"alarms": [], "unacknowledged": 0, "worst": 0, "findings": []}
        al = lh.alarms
        rows = [] if al is None else [
            {"name": a.name, "state": a.state_name, "active": a.active, "priority": a.priority,
             "limit": a.limit, "value": a.value if math.isfinite(a.value) else None}
            for a in al.status()
        ]  # fmt: skip
        return {
            "alarms": rows,
            "unacknowledged": 0 if al is None else al.unacknowledged,
            "worst": 0 if al is None else al.worst,
            "findings": list(lh.findings),
            "assessed_at": lh.assessed_at if math.isfinite(lh.assessed_at) else None,
        }


def _live(name: str, ts: float, table: Mapping[str, Any], phase: float) -> Any:
    from ..health.assess import AssessOptions
    from ..health.live import LiveAssessor

    opts = AssessOptions(**{k: float(v) for k, v in table.items() if k not in ("window", "every")})
    every = float(table.get("every", 900.0))
    live = LiveAssessor(name, ts, window=float(table.get("window", 3600.0)), every=every,
                        options=opts)  # fmt: skip
    live.delay_first(phase * every)
    return live


def alarm_events(historian: Any, loop: str | None = None) -> list[dict[str, Any]]:
    """The alarm journal from the historian: time, loop, alarm, old and new state, value, who."""
    out = []
    for r in historian.audit_rows(loop):
        action = str(r.get("action") or "")
        if not action.startswith("alarm "):
            continue
        out.append({"t_wall": r["t_wall"], "loop": r["loop"], "alarm": action[6:],
                    "old": _json(r["old"]), "new": _json(r["new"]), "who": r["who"],
                    "message": r["message"]})  # fmt: skip
    return out


def _json(text: Any) -> Any:
    try:
        return json.loads(text)
    except (TypeError, ValueError):
        return text
