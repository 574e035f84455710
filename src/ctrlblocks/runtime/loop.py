"""One control loop of the runtime: a block, its I/O bindings, its cycle and its commands.

Each cycle (called by the scheduler at an absolute deadline):

1. the :class:`~ctrlblocks.blocks.monitor.CycleMonitor` records the measured
   period; a period above the warning limit is an *overrun*: the loop's
   ``overrun`` status is set and this cycle's block call uses the measured
   period as ``dt`` (otherwise the configured ``ts``);
2. read the bound inputs (PV, and SP, mode, manual value, limits where they
   are bound to I/O), one request per connection, concurrently;
3. apply mode / manual value / limits from I/O (a bound value that cannot
   be read leaves the one in force);
4. run the block: ``block(sp, pv, y_ok=/pv_ok=quality, dt=...)``.  A PV that
   failed, timed out, was stale, NaN or of bad quality sets the quality flag
   false *in this cycle*: ADRC goes to its safe value ``u_sf``, PID to its
   ``safe_value`` or holds (``on_bad_pv``); both recover without a bump when
   the PV returns (the blocks' own rules);
5. write the MV; a failed write is retried ``write_retries`` times at once,
   then reported (``write_ok`` false, ``write_error``) and the next cycle
   writes again.

Structures with more I/O: a ``split_range`` loop writes two MVs (``mv``:
actuator A, ``mv2``: actuator B, both the split of the controller output
:attr:`ControlLoop.mv`, :meth:`ControlLoop.writes`); a ``ratio`` loop reads
the wild flow (``wild``): a bad wild flow does not make the loop's
measurement bad -- the ratio station holds the last good flow setpoint
(``signals.wild_hold``) and the flow controller goes on.

A loop never raises out of its cycle; faults only change its status.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Mapping
from typing import Any

from ..blocks.base import ErrorCode, ParameterError, is_finite, require_limits
from ..blocks.monitor import CycleMonitor
from ..loops.structures import ControllerSide
from .bounds import LoopBounds
from .config import MEASUREMENTS, MODES, Binding, LoopConfig
from .io import Connection, Reading

__all__ = ["CommandError", "ControlLoop", "Sample"]

log = logging.getLogger(__name__)

_LOOP_LEVEL = ("ts", "safe_value", "u_sf", "u_min", "u_max")


class CommandError(ValueError):
    """A command refused by a loop (bad value, signal bound to I/O, unknown key).

    ``code`` is an :class:`~ctrlblocks.blocks.base.ErrorCode` (``BAD_PARAMETER``
    unless the block gave its own), ``field`` the refused key.
    """

    def __init__(self, field: str, message: str, code: int = ErrorCode.BAD_PARAMETER) -> None:
        self.field, self.message, self.code = field, message, ErrorCode(code)
        super().__init__(f"{field}: {message}")


@dataclasses.dataclass(frozen=True)
class Sample:
    """What the historian records for one loop and one cycle."""

    loop: str
    cycle: int
    t_wall: float
    t: float
    dt: float
    sp: float
    pv: float
    mv: float
    mode: str
    error_id: int
    pv_ok: bool
    write_ok: bool
    overrun: bool


class ControlLoop:
    """A block running against process I/O (see the module docstring).

    Parameters
    ----------
    config : LoopConfig
        The loop's configuration.
    side : ControllerSide
        The structure's blocks (:func:`~ctrlblocks.runtime.config.build_side`).
    connections : mapping
        Connection name -> :class:`~ctrlblocks.runtime.io.Connection`.

    Attributes
    ----------
    block : PID or ADRC
        The block that writes the MV (``side.main``): its status, limits
        and tunings are the faceplate's.
    """

    def __init__(
        self, config: LoopConfig, side: ControllerSide, connections: Mapping[str, Connection]
    ) -> None:
        self.config = config
        self.name = config.name
        self.side = side
        self.block = side.main
        self.connections = connections
        self.ts = config.ts
        self.monitor = CycleMonitor(
            ts=config.ts, warn_limit=config.warn_limit, alarm_limit=config.alarm_limit
        )
        # status for the faceplate
        self.cycle_count = 0
        self.pv = math.nan
        self.pv_ok = False
        self.pv_reason = "no cycle yet"
        self.measurements: dict[str, float] = {}
        self.mv = math.nan
        self.write_ok = True
        self.write_error = ""
        self.write_failures = 0
        self.overrun = False
        self.dt = config.ts
        self.input_errors: dict[str, str] = {}
        self.last_exception = ""
        self.mv_alarm = ""
        self.alarms: list[str] = []  # new alarm messages; the runtime audits and clears them
        self.holding = False
        self._fault_since: float | None = None
        self._last_good_mv: float | None = None
        self._t = 0.0
        self._restart_mv: float | None = None  # set by restore_retained
        self.tuning: Any = None  # a live tuning (ctrlblocks.runtime.autotune.LoopTuning)
        # the engineering ranges every command is checked against (runtime.bounds)
        self.bounds = LoopBounds(self)
        self._limits_in = (math.nan, math.nan)
        # signal -> binding of the inputs read each cycle
        written = {"mv", "mv2", *config.outputs}
        self._inputs = {n: b for n, b in config.bindings().items() if b.is_io and n not in written}
        # an output stage (PWM, step controller) has a fixed off state (Structure.off_mv)
        self._off_mv = self.side.kind.off_mv(self.side.spec)
        self.sp = float(config.sp.value) if not config.sp.is_io else math.nan
        mode = config.mode.value if not config.mode.is_io else "auto"
        self._set_mode(mode)
        if config.manual_value is not None and not config.manual_value.is_io:
            self._set_manual_value(float(config.manual_value.value))

    # -- helpers ---------------------------------------------------------------

    @property
    def mode(self) -> str:
        """``"auto"`` or ``"manual"``."""
        return "manual" if self.block.manual else "auto"

    def _set_mode(self, mode: str, *, preset: bool = True) -> None:
        manual = mode == "manual"
        value = None
        if manual and not self.side.manual and preset and not self.is_bound("manual_value"):
            # auto -> manual without a new manual value: continue from the output
            value = next((float(x) for x in (self.mv, self.block.out) if is_finite(x)), None)
        self.side.set_manual(manual, value)

    def _set_manual_value(self, value: float) -> None:
        for b in self.side.mv_blocks:
            b.manual_value = value

    def is_bound(self, signal: str) -> bool:
        """True when ``signal`` comes from process I/O (commands cannot change it)."""
        b = self.config.bindings().get(signal)
        return b is not None and b.is_io

    def _apply_inputs(self, inputs: Mapping[str, Reading]) -> None:
        errors: dict[str, str] = {}
        for sig, r in inputs.items():
            if sig not in MEASUREMENTS and not r.ok:
                errors[sig] = r.reason
        if "sp" in inputs and inputs["sp"].ok:
            self.sp = inputs["sp"].value  # a bad SP read keeps the last good SP
        if "manual_value" in inputs and inputs["manual_value"].ok:
            self._set_manual_value(inputs["manual_value"].value)
        if "mode" in inputs and inputs["mode"].ok:
            m = inputs["mode"].value
            if m in (0.0, 1.0):
                self._set_mode(MODES[int(m)])
            else:
                errors["mode"] = f"mode input {m!r} is not 0 (auto) or 1 (manual)"
        if "u_min" in inputs:
            lo, hi = inputs["u_min"], inputs["u_max"]
            if lo.ok and hi.ok and (lo.value, hi.value) != self._limits_in:
                self._limits_in = (lo.value, hi.value)
                self.side.set_limits(lo.value, hi.value)
        self.input_errors = errors

    # -- the cycle ----------------------------------------------------------------
    #
    # The runtime's scan (:class:`~ctrlblocks.runtime.scan.Scan`) runs the
    # cycle of many loops on one I/O image: it reads the :meth:`inputs` of
    # every due loop in one batched request per connection, calls
    # :meth:`compute` of each, writes every MV in one batched request per
    # connection, reports each write with :meth:`written` and records
    # :meth:`sample` (``Scan([loop], connections).run(t, period)`` for one loop alone).

    def inputs(self) -> Mapping[str, Binding]:
        """The I/O inputs read each cycle: signal -> binding (PV, and SP, mode, ... if bound)."""
        return self._inputs

    def compute(self, t: float, period: float, inputs: Mapping[str, Reading]) -> float | None:
        """Steps 1, 3 and 4 of the module docstring on this cycle's ``inputs``: the MV to write.

        The MV is checked before it goes out: a non-finite value (a block
        defect) becomes the loop's ``safe_value``, with ``mv_alarm`` set in the
        state and an entry in :attr:`alarms` (the runtime audits and logs it).
        None when the cycle failed with an exception (nothing is written).
        """
        first = self.cycle_count == 0
        dt: float | None = None
        overrun = False
        if not first:
            overrun = bool(self.monitor(period))
            if overrun:
                dt = period
        self.overrun = overrun
        self.dt = self.ts if dt is None else dt
        self._t = t
        try:
            self._apply_inputs(inputs)
            # every measurement the structure needs must be good, else the MV
            # blocks see a bad measurement in this cycle (their safe value)
            ok = True
            reasons = []
            meas: dict[str, float] = {}
            for sig, name in MEASUREMENTS.items():
                if sig in inputs:
                    r = inputs[sig]
                    meas[name] = r.value if r.ok else math.nan
                    self.measurements[sig] = r.value
                    if sig == "wild":  # the ratio station's own fault rule (module docstring)
                        meas["w_ok"] = float(r.ok)
                    elif not r.ok:
                        ok = False
                        reasons.append(r.reason if sig == "pv" else f"{sig}: {r.reason}")
            pv = inputs["pv"] if "pv" in inputs else inputs["pv2"]
            self.pv, self.pv_ok, self.pv_reason = pv.value, ok, "; ".join(reasons)
            if self._restart_mv is not None:
                u = self._bumpless_restart(t, ok, meas, dt)
            elif self.tuning is not None and self.tuning.active:
                u = self.tuning.cycle(ok, meas, dt)
            else:
                u = self._step(t, ok, meas, dt)
            u = self._guard(u)
            self.mv = u
            return u
        except Exception as exc:  # a loop never stops the runtime
            log.exception("loop %s: cycle failed", self.name)
            self.last_exception = f"{type(exc).__name__}: {exc}"
            return None

    def _step(self, t: float, ok: bool, meas: Mapping[str, float], dt: float | None) -> float:
        """The structure's step; with ``on_fault = "hold"`` the last good MV while it may hold."""
        args = dict(
            y_ok=ok,
            y2=meas.get("y2", math.nan),
            y2_ok=ok,
            dv=meas.get("dv", 0.0),
            dv_ok=ok,
            w=meas.get("w", math.nan),
            w_ok=bool(meas.get("w_ok", 1.0)),
            dt=dt,
        )
        y = meas.get("y", math.nan)
        if ok:
            self._fault_since = None
            u = self.side.step(self.sp, y, **args)
            self._last_good_mv = u
            self.holding = False
            return u
        if self._fault_since is None:
            self._fault_since = t
        held = self._last_good_mv
        hold = (
            self.config.on_fault == "hold"
            and held is not None
            and t - self._fault_since < self.config.hold_time - 1e-9
            and not self.side.manual
        )
        self.holding = hold
        if not hold:
            return self.side.step(self.sp, y, **args)
        # hold the last good MV: the blocks run their fault rule, then track the held MV
        # (the applied value), so the recovery is bumpless from it
        self.side.compute(self.sp, y, **args)
        self.side.update(held)
        self.side.values["v"] = held
        return held

    def _guard(self, u: float) -> float:
        """A non-finite MV never leaves the loop: the safe value, an alarm and an audit entry."""
        if isinstance(u, (int, float)) and math.isfinite(u):
            self.mv_alarm = ""
            return float(u)
        safe = self.config.safe_value if self._off_mv is None else self._off_mv
        msg = f"the block gave a non-finite MV ({u!r}): the safe value {safe!r} is written"
        if self.mv_alarm != msg:  # once per episode
            log.error("loop %s: %s", self.name, msg)
            self.alarms.append(msg)
        self.mv_alarm = msg
        return safe

    def writes(self, u: float) -> list[tuple[str, float]]:
        """The ``(address, value)`` items that write the MV ``u`` (one; a split range's two).

        The structure's bound output tags go with it (a step controller's
        ``open``/``close`` bits, ``Structure.output_values``).
        """
        c = self.config
        if c.mv2 is None:
            items = [(c.mv.address, u)]
        else:
            a, b = self.side.actuator_values(u)
            items = [(c.mv.address, a), (c.mv2.address, b)]
        if c.outputs:
            values = self.side.kind.output_values(self.side.spec, u)
            items += [(b.address, values[tag]) for tag, b in c.outputs.items()]
        return items

    def written(self, err: str | None) -> None:
        """Record the outcome of this cycle's MV write (None: accepted; else the failure)."""
        self.write_ok = err is None
        if err is not None:
            self.write_failures += 1
            if self.write_error != err:
                log.warning("loop %s: MV write failed: %s", self.name, err)
            self.write_error = err
        else:
            self.write_error = ""

    def sample(self, t: float) -> Sample:
        """The historian's row of the cycle just run (and count the cycle)."""
        self.cycle_count += 1
        return Sample(
            loop=self.name,
            cycle=self.cycle_count - 1,
            t_wall=time.time(),
            t=t,
            dt=self.dt,
            sp=self.sp,
            pv=self.pv,
            mv=self.mv,
            mode=self.mode,
            error_id=int(self.block.error_id),
            pv_ok=self.pv_ok,
            write_ok=self.write_ok,
            overrun=self.overrun,
        )

    @property
    def stop_value(self) -> float:
        """The MV written on a graceful stop (``stop_value``, else ``safe_value``).

        An output stage (pulse width, step controller) stops at its off state.
        """
        c = self.config
        if self._off_mv is not None:
            return self._off_mv
        return c.stop_value if c.stop_value is not None else c.safe_value

    # -- retentive state (ctrlblocks.runtime.retain) ----------------------------------

    def retained(self) -> dict[str, Any]:
        """What survives a restart (module docstring of :mod:`~ctrlblocks.runtime.retain`)."""
        blk = self.block
        st = {
            "sp": None if self.is_bound("sp") else self.sp,
            "mode": None if self.is_bound("mode") else self.mode,
            "manual_value": None if self.is_bound("manual_value") else float(blk.manual_value),
            "limits": None if self.is_bound("u_min") else [float(blk.u_min), float(blk.u_max)],
            "tunings": self.state_tunings(),
            "file_tunings": dict(self.config.block_params),
            "mv": self.mv,
            "snapshots": {role: b.snapshot() for role, b in self.side.blocks.items()},
        }
        if self.tuning is not None and self.tuning.active:  # a stop during a live test
            st = self.tuning.retained(st)
        return st

    def state_tunings(self) -> dict[str, Any]:
        """The MV block's tunings (its configuration without the loop-level keys)."""
        cfg = self.block.config
        return {
            f.name: getattr(cfg, f.name)
            for f in dataclasses.fields(cfg)
            if f.name not in _LOOP_LEVEL
        }

    def restore_retained(self, st: Mapping[str, Any]) -> None:
        """Restore a :meth:`retained` state; the next cycle starts from :meth:`restart_from`.

        Tunings: a retained value is used unless the configuration file's value
        of that key changed since it was retained (then the file wins, logged).
        """
        from .retain import finite_or_none

        tunings = dict(st.get("tunings") or {})
        before = st.get("file_tunings") or {}
        now = self.config.block_params
        for k in list(tunings):
            if k in now and before.get(k) != now[k]:
                log.info(
                    "loop %s: %s = %r from the configuration file replaces the retained %r "
                    "(the file changed)",
                    self.name,
                    k,
                    now[k],
                    tunings[k],
                )
                del tunings[k]
        current = self.state_tunings()
        changed = {
            k: v
            for k, v in tunings.items()
            if k in current and v != current[k] and not isinstance(current[k], (dict, list))
        }
        snaps = st.get("snapshots") or {}
        try:
            for role, snap in snaps.items():
                if role in self.side.blocks:
                    self.side.blocks[role].restore(snap)
        except Exception as exc:  # a snapshot of another block version: start its state fresh
            log.warning("loop %s: retained block state not restored (%s)", self.name, exc)
            for b in self.side.blocks.values():
                b.reset()
        if changed:
            try:
                self.block.configure(**changed)
            except (ParameterError, TypeError) as exc:
                log.warning("loop %s: retained tunings %s refused (%s)", self.name, changed, exc)
        limits = st.get("limits")
        if limits and all(finite_or_none(x) is not None for x in limits):
            self.side.set_limits(float(limits[0]), float(limits[1]))
        if (sp := finite_or_none(st.get("sp"))) is not None and not self.is_bound("sp"):
            self.sp = sp
        mv = finite_or_none(st.get("manual_value"))
        if mv is not None and not self.is_bound("manual_value"):
            self._set_manual_value(mv)
        if st.get("mode") in MODES and not self.is_bound("mode"):
            self._set_mode(st["mode"], preset=False)
        # the bumpless restart sets the controller's output; an output stage's MV (on/off,
        # motor commands) is not one: the restored snapshot continues the controller
        self._restart_mv = finite_or_none(st.get("mv")) if self._off_mv is None else None
        log.info("loop %s: retained state restored", self.name)

    def restart_from(self, reading: Reading | None) -> None:
        """The MV read back from the device before the first cycle (bad or None: the retained).

        A split-range loop restarts from its retained controller output: one
        actuator's value does not give it back (in the gap every output maps
        to the same values).
        """
        # an output stage's MV (on/off, motor commands) is not the controller's output either
        ok = reading is not None and reading.ok
        if ok and self.config.mv2 is None and self._off_mv is None:
            self._restart_mv = reading.value  # type: ignore[union-attr]

    def _bumpless_restart(self, t: float, ok: bool, meas: Mapping[str, float], dt: float | None):
        """The first cycle after a restart: output the read-back MV, the blocks track it."""
        u0 = self._restart_mv
        self._restart_mv = None
        manual, mval = self.side.manual, float(self.block.manual_value)
        self.side.set_manual(True, u0)
        u = self._step(t, ok, meas, dt)
        self.side.set_manual(manual, mval if manual else None)
        if not manual:
            self._set_manual_value(mval)
        return u

    # -- state and commands ---------------------------------------------------------

    def state(self) -> dict[str, Any]:
        """Everything a faceplate shows, as plain values."""
        blk = self.block
        m = self.monitor
        return {
            "name": self.name,
            "block": self.config.block_type,
            "structure": self.config.structure,
            "ts": self.ts,
            "cycle": self.cycle_count,
            "sp": self.sp,
            "pv": self.pv,
            "mv": self.mv,
            "mode": self.mode,
            "manual_value": float(blk.manual_value),
            "error": bool(blk.error),
            "error_id": int(blk.error_id),
            "error_name": blk.error_name,
            "pv_ok": self.pv_ok,
            "pv_reason": self.pv_reason,
            "write_ok": self.write_ok,
            "write_error": self.write_error,
            "write_failures": self.write_failures,
            "input_errors": dict(self.input_errors),
            "last_exception": self.last_exception,
            "mv_alarm": self.mv_alarm,
            "on_fault": self.config.on_fault,
            "holding": self.holding,
            "u_min": float(blk.u_min),
            "u_max": float(blk.u_max),
            "safe_value": self.config.safe_value,
            "on_bad_pv": self.config.on_bad_pv,
            "tunings": self.state_tunings(),
            "tuning": None if self.tuning is None else self.tuning.status(),
            "bound": {s: str(b) for s, b in self.config.bindings().items() if b.is_io},
            "overrun": self.overrun,
            "dt": self.dt,
            "measurements": dict(self.measurements),
            "signals": dict(self.side.values),
            "blocks": self.side.inner_states(),
            "tracking": dict(self.side.tracking),
            "period": {
                "last": m.out,
                "mean": m.mean,
                "min": m.min,
                "max": m.max,
                "jitter_std": m.jitter_std,
                "overruns": m.overruns,
                "alarms": m.alarms,
            },
        }

    def command(self, **changes: Any) -> dict[str, Any]:
        """Apply an operator command; all-or-nothing; return the old values of what changed.

        Keys: ``mode`` (``"auto"``/``"manual"``), ``manual_value``, ``sp``,
        ``u_min`` and ``u_max`` (together), ``tunings`` (a dict for the
        block's ``configure``, which validates it and keeps the old
        configuration on refusal; its bumpless rules apply).  A signal bound
        to I/O cannot be commanded, and a setpoint, manual value, limit or
        tuning outside the loop's engineering ranges (:attr:`bounds`,
        ``sp_range``, ``mv_range``, ``tuning_ranges``) is refused.  Raises
        :class:`CommandError`; nothing changes then.
        """
        allowed = {"mode", "manual_value", "sp", "u_min", "u_max", "tunings"}
        unknown = sorted(set(changes) - allowed)
        if unknown:
            raise CommandError(unknown[0], f"unknown command; expected one of {sorted(allowed)}")
        for sig in ("mode", "manual_value", "sp", "u_min", "u_max"):
            if sig in changes and self.is_bound(sig):
                raise CommandError(sig, f"is bound to I/O ({self.config.bindings()[sig]})")
        old: dict[str, Any] = {}
        if "mode" in changes and changes["mode"] not in MODES:
            raise CommandError("mode", f"must be one of {MODES}, got {changes['mode']!r}")
        for sig in ("manual_value", "sp"):
            if sig in changes and not (
                not isinstance(changes[sig], bool) and is_finite(changes[sig])
            ):
                raise CommandError(sig, f"must be a finite number, got {changes[sig]!r}")
        limits = None
        if "u_min" in changes or "u_max" in changes:
            if not ("u_min" in changes and "u_max" in changes):
                raise CommandError("u_min", "give u_min and u_max together")
            try:
                limits = require_limits("u_min", changes["u_min"], "u_max", changes["u_max"])
            except ParameterError as exc:
                raise CommandError(exc.field, exc.message, exc.code) from None
        outside = self.bounds.check(changes)  # the engineering ranges (runtime.bounds)
        if outside is not None:
            raise CommandError(*outside)
        tunings = changes.get("tunings")
        if tunings is not None:
            if not isinstance(tunings, Mapping) or not tunings:
                raise CommandError("tunings", "must be a non-empty table of block parameters")
            scheduled = self.side.kind.scheduled_parameters(self.side.spec)
            for k in tunings:
                if k in _LOOP_LEVEL:
                    raise CommandError(f"tunings.{k}", "is not a tuning (use its own command)")
                if k in scheduled:
                    raise CommandError(
                        f"tunings.{k}", "is set by the loop's gain schedule every cycle"
                    )
            cfg = self.block.config
            try:
                before = {k: getattr(cfg, k) for k in tunings}
            except AttributeError as exc:
                raise CommandError("tunings", f"unknown parameter: {exc}") from None
            try:
                self.block.configure(**dict(tunings))
            except ParameterError as exc:
                raise CommandError(f"tunings.{exc.field}", exc.message, exc.code) from None
            except TypeError as exc:
                raise CommandError("tunings", str(exc)) from None
            old["tunings"] = before
        if limits is not None:
            old["u_min"], old["u_max"] = float(self.block.u_min), float(self.block.u_max)
            self.side.set_limits(*limits)
        if "sp" in changes:
            old["sp"] = self.sp
            self.sp = float(changes["sp"])
        if "manual_value" in changes:
            old["manual_value"] = float(self.block.manual_value)
            self._set_manual_value(float(changes["manual_value"]))
        if "mode" in changes:
            old["mode"] = self.mode
            self._set_mode(changes["mode"], preset="manual_value" not in changes)
        return old
