"""One control loop of the runtime: a block, its I/O bindings, its cycle and its commands.

Each cycle (called by the scan, :mod:`ctrlblocks.runtime.scan`, at an
absolute deadline, with the inputs it read):

1. the :class:`~ctrlblocks.blocks.monitor.CycleMonitor` records the measured
   period of the cycle; a period above the warning limit is an *overrun*
   (``overrun`` in the state, an alarm);
2. inputs late (the read was not back within the connection's deadline):
   the loop holds -- the block does not run, nothing is written -- or, with
   ``on_late = "last_good"``, runs on its last good inputs, flagged ``late``;
3. apply mode / manual value / limits from I/O (a bound value that cannot
   be read leaves the one in force);
4. run the block: ``block(sp, pv, y_ok=/pv_ok=quality, dt=...)`` with
   **the dt the blocks can take**: ``ts`` while the time since the block's
   last step is within the warning limit (jitter), that time when it is
   longer (a *stretched period*, an alarm), and never more than ``max_dt``
   (default 10 ts): beyond it the loop re-initialises its blocks from the MV
   and the present PV, as after a restart.  A PV that failed, timed out, was
   stale, NaN or of bad quality sets the quality flag false *in this cycle*:
   ADRC goes to its safe value ``u_sf``, PID to its ``safe_value`` or holds
   (``on_bad_pv``); both recover without a bump when the PV returns;
5. write the MV; a failed write is retried ``write_retries`` times at once,
   then reported (``write_ok`` false, ``write_error``) and the next cycle
   writes again.

**Bumpless on every transition.** At a cold start, after a reconnection of
one of its connections and after a restart, the loop reads the MV back from
the device (with the cycle's inputs) and starts from it as a PLC block
leaves MAN for AUTO: for one cycle its MV blocks are in manual at that MV,
so they track it (the ADRC solves its handover offset, docs/blocks/adrc.md),
then they go back to their mode; a loop in MAN takes it as its manual
value.  Block states older than ``max_dt`` (a restart's retained snapshot,
an observer frozen through an outage) are replaced first: the blocks start
at rest at that MV on the present PV (``Block.start_at``: an ADRC's
observer with x4 = -b0 u, the plant held by the device's MV); the two steps after a start use
``ts`` as their dt (a start-up period is no process time).  Without a
read-back: the retained MV, else ``initial_mv``, else the blocks' own start.

Structures with more I/O: a ``split_range`` loop writes two MVs (``mv``:
actuator A, ``mv2``: actuator B, both the split of the controller output
:attr:`ControlLoop.mv`, :meth:`ControlLoop.writes`); a ``ratio`` loop reads
the wild flow (``wild``): a bad wild flow does not make the loop's
measurement bad -- the ratio station holds the last good flow setpoint
(``signals.wild_hold``) and the flow controller goes on.

What the operator sees at a glance is :attr:`ControlLoop.conditions`
(:mod:`ctrlblocks.runtime.status`): bad PV, on safe value, holding, late
I/O, stretched period, overrun, oscillating MV, MV at a limit, ...

A loop never raises out of its cycle; faults only change its status.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from ..blocks.base import ErrorCode, ParameterError, is_finite, require_limits
from ..blocks.monitor import CycleMonitor
from ..loops.structures import ControllerSide
from .bounds import LoopBounds
from .config import MEASUREMENTS, MODES, Binding, LoopConfig
from .io import Connection, Reading
from .status import OFF_DELAY, Conditions, SwingDetector

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
        self.holding = False
        self.late = False  # this cycle's inputs were late
        self.has_inputs = False  # a cycle has had inputs (the first samples wait for them)
        self.late_cycles = 0
        self.stretched = 0  # steps with a stretched period (dt > ts)
        self.initialisations = 0  # bumpless (re)starts: start, reconnect, restart, held
        self.last_start = ""  # how the last one went
        self.conditions = Conditions()  # what the faceplate shows at a glance (.status)
        self._swing = SwingDetector()
        self._stretched_now = False
        self._held_long = False
        self._fault_since: float | None = None
        self._last_good_mv: float | None = None
        self._t = 0.0
        self._t_step: float | None = None  # cycle time of the last block step
        self._t_good: float | None = None  # ... of the last step on a good PV
        self._settle = 0  # steps after a start that use ts as dt
        # a pending bumpless start: why ("start", "reconnect", "restart", "held"), the MV
        # to start from (read back, retained, initial) and the age of the blocks' state [s]
        self._init: str | None = "start" if config.start == "read_back" else None
        self._init_mv: float | None = None
        self._init_age = math.inf
        self._retained_mv: float | None = None  # set by restore_retained
        self.tuning: Any = None  # a live tuning (ctrlblocks.runtime.autotune.LoopTuning)
        # the values of the bound alarm outputs, in the order of config.alarm_outputs (the
        # runtime's HealthMonitor.output_values); None: no alarm outputs are written
        self.alarm_values: Callable[[], Sequence[float]] | None = None
        self.alarm_output_error = ""
        # the engineering ranges every command is checked against (runtime.bounds)
        self.bounds = LoopBounds(self)
        self._limits_in = (math.nan, math.nan)
        # signal -> binding of the inputs read each cycle
        written = set(config.written())
        self._inputs = {n: b for n, b in config.bindings().items() if b.is_io and n not in written}
        # an output stage (PWM, step controller) has a fixed off state (Structure.off_mv)
        self._off_mv = self.side.kind.off_mv(self.side.spec)
        self._want_readback = self._init is not None and self._readback_possible()
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

    def cycle(
        self, t: float, period: float, inputs: Mapping[str, Reading] | None, *, late: bool = False
    ) -> float | None:
        """Steps 1-4 of the module docstring at cycle time ``t`` [s]: the MV to write.

        ``inputs`` are this cycle's readings (None: they are late and the loop
        holds; ``late`` with readings: the last good ones, ``on_late =
        "last_good"``).  The MV is checked before it goes out: a non-finite
        value (a block defect) becomes the loop's ``safe_value``, with
        ``mv_alarm`` set in the state and the ``safe_value`` condition (the
        runtime audits it).  None when nothing is to be written: the
        loop held, or the cycle failed with an exception.
        """
        first = self.cycle_count == 0
        self.overrun = not first and bool(self.monitor(period))
        self._t = t
        self.dt = self.ts
        self.late = late
        if late:
            self.late_cycles += 1
        if inputs is None:
            self.dt = 0.0  # the block did not run
            self._status(t)
            return None
        self.has_inputs = True
        try:
            self._apply_inputs(inputs)
            ok, meas = self._measurements(inputs)
            u = self._run(t, ok, meas)
            if u is None:  # a start waits for the MV read back (bounded by the read's timeout)
                self.dt = 0.0
                self._status(t)
                return None
            u = self._guard(u)
            self.mv = u
            self._status(t)
            return u
        except Exception as exc:  # a loop never stops the runtime
            log.exception("loop %s: cycle failed", self.name)
            self.last_exception = f"{type(exc).__name__}: {exc}"
            return None

    def _run(self, t: float, ok: bool, meas: Mapping[str, float]) -> float | None:
        """This cycle's MV: a bumpless start, a live test's step or the structure's step.

        A start (pending in ``_init``) waits for a good PV -- until then the
        blocks' fault rule runs and the MV is read back every cycle, so the
        start takes the device's MV of the cycle the PV returns -- and for the
        MV read back (None: hold this cycle).  A good PV after more than
        ``max_dt`` without a step on a good PV (a long hold, an outage) starts
        again from the MV last written (module docstring).
        """
        bound = self.config.dt_bound
        if self._init is None and ok and self._t_good is not None and t - self._t_good > bound:
            held = self._t_step is None or t - self._t_step > bound
            self._begin("held" if held else "pv back", t - self._t_good)
            self._init_mv = self.mv if self.write_ok and is_finite(self.mv) else None
            self._want_readback = self._init_mv is None and self._readback_possible()
        if self._init is not None:
            if not ok:  # the fault rule now; the start when the PV is back
                self._want_readback = self._readback_possible()
                u = self._step(t, ok, meas, None)
                self._stepped(t, ok)
                return u
            if self._want_readback:
                return None
            return self._initialise(t, ok, meas)
        dt = self._dt(t)
        if self.tuning is not None and self.tuning.active:
            u = self.tuning.cycle(ok, meas, dt)
        else:
            u = self._step(t, ok, meas, dt)
        self._stepped(t, ok)
        return u

    def compute(self, t: float, period: float, inputs: Mapping[str, Reading]) -> float | None:
        """:meth:`cycle` with inputs that are on time (the MV to write, or None)."""
        return self.cycle(t, period, inputs)

    def _measurements(self, inputs: Mapping[str, Reading]) -> tuple[bool, dict[str, float]]:
        """The structure's measurements and whether all of them are good (``pv_ok``).

        Every measurement the structure needs must be good, else the MV blocks
        see a bad measurement in this cycle (their safe value).
        """
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
        return ok, meas

    def _dt(self, t: float) -> float | None:
        """The dt of this step (module docstring, step 4): None (ts) or the stretched period.

        Beyond ``max_dt`` only a step on a bad PV comes here (a good one starts
        again, :meth:`_run`): its blocks run their fault rule, dt None.
        """
        if self._t_step is None or self._settle > 0:
            self._settle = max(0, self._settle - 1)
            return None
        gap = t - self._t_step
        if gap <= self.monitor.warn_limit + 1e-9 or gap > self.config.dt_bound + 1e-9:
            return None
        self.stretched += 1
        self._stretched_now = True
        self.conditions.set(
            "stretched", True, f"the block ran on a period of {gap:.3g} s ({gap / self.ts:.2g} ts)",
            t, off_delay=OFF_DELAY,
        )  # fmt: skip
        self.dt = gap
        return gap

    def _stepped(self, t: float, ok: bool) -> None:
        self._t_step = t
        if ok:
            self._t_good = t

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

    def _status(self, t: float) -> None:
        """Update :attr:`conditions` after this cycle (:mod:`~ctrlblocks.runtime.status`)."""
        c, blk, cfg = self.conditions, self.block, self.config
        manual = self.side.manual
        c.set("late_io", self.late, "inputs not back within the deadline" + (
            ": the MV is held" if self.dt == 0.0 else ": running on the last good inputs"
        ), t, off_delay=OFF_DELAY)  # fmt: skip
        c.set("overrun", self.overrun,
              f"cycle period {self.monitor.out:.3g} s, ts {self.ts:g} s", t,
              off_delay=OFF_DELAY)  # fmt: skip
        c.set("stretched", self._stretched_now, t=t, off_delay=OFF_DELAY)
        c.set("held_long", self._held_long, t=t,
              off_delay=OFF_DELAY + math.ceil(cfg.dt_bound / self.ts))  # fmt: skip
        self._held_long = False
        self._stretched_now = False
        bad = self.cycle_count > 0 or self.dt != 0.0
        bad = bad and not self.pv_ok and self.pv_reason != "no cycle yet"
        c.set("bad_pv", bad, f"PV bad: {self.pv_reason}", t)
        fault_safe = bad and not self.holding and not manual and (
            cfg.block_type == "ADRC" or cfg.on_bad_pv == "safe")
        safe = fault_safe or bool(self.mv_alarm)
        c.set("safe_value", safe, self.mv_alarm or
              f"PV bad: the safe value {cfg.safe_value:g} is written", t)  # fmt: skip
        held = self.holding or (self.dt == 0.0 and self._t_step is not None)
        c.set("holding", held, "the last good MV is held" if self.holding
              else "inputs late: the MV is held", t)  # fmt: skip
        errs = self.input_errors
        c.set("input_error", bool(errs), "; ".join(f"{k}: {v}" for k, v in errs.items()), t)
        code = int(blk.error_id)
        block_err = code != 0 and not bad and self.dt != 0.0
        c.set("block_error", block_err, f"16#{code:04X} {blk.error_name}", t,
              severity="alarm" if blk.error else "info")  # fmt: skip
        lo, hi = float(blk.u_min), float(blk.u_max)
        mv = self.mv
        at = not manual and not safe and not held and is_finite(mv) and (
            (math.isfinite(hi) and mv >= hi - 1e-9 * max(1.0, abs(hi)))
            or (math.isfinite(lo) and mv <= lo + 1e-9 * max(1.0, abs(lo))))  # fmt: skip
        c.set("mv_limit", at, f"MV {mv:.6g} at its {'upper' if mv >= hi else 'lower'} limit", t)
        if manual or self.dt == 0.0:
            swinging = False
            if manual:
                self._swing.reset()
        else:
            span = hi - lo
            if not math.isfinite(span) and self.bounds.mv is not None:
                span = self.bounds.mv.hi - self.bounds.mv.lo
            swinging = self._swing.update(mv, span)
        c.set("oscillating", swinging,
              "the MV swings: it reversed by more than 10 % of its range "
              f"{self._swing.recent} times in {self._swing.window} cycles", t)  # fmt: skip
        testing = self.tuning is not None and self.tuning.active
        c.set("tuning", testing, "a live tuning test runs", t)
        down = sorted(n for n in cfg.connections() if not self.connections[n].connected)
        c.set("connection_down", bool(down), "; ".join(
            f"{n}: {self.connections[n].last_error}" for n in down), t)  # fmt: skip

    def _guard(self, u: float) -> float:
        """A non-finite MV never leaves the loop: the safe value, an alarm and an audit entry."""
        if isinstance(u, (int, float)) and math.isfinite(u):
            self.mv_alarm = ""
            return float(u)
        safe = self.config.safe_value if self._off_mv is None else self._off_mv
        msg = f"the block gave a non-finite MV ({u!r}): the safe value {safe!r} is written"
        if self.mv_alarm != msg:  # once per episode (the safe_value condition is audited)
            log.error("loop %s: %s", self.name, msg)
        self.mv_alarm = msg
        return safe

    def writes(self, u: float) -> list[tuple[str, float]]:
        """The ``(address, value)`` items that write the MV ``u`` (one; a split range's two).

        The structure's bound output tags go with it (a step controller's
        ``open``/``close`` bits, ``Structure.output_values``), and the bound
        alarm outputs (``alarm_values``: the alarms' states as the last
        recorded sample and any acknowledgement since left them).
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
        if c.alarm_outputs and self.alarm_values is not None:
            try:
                states = self.alarm_values()
            except Exception as exc:  # a defect: the MV still goes out, the alarm outputs not
                if not self.alarm_output_error:
                    log.exception("loop %s: alarm outputs not written", self.name)
                self.alarm_output_error = f"{type(exc).__name__}: {exc}"
            else:
                self.alarm_output_error = ""
                items += [
                    (b.address, v) for b, v in zip(c.alarm_outputs.values(), states, strict=True)
                ]
        return items

    def written(self, err: str | None) -> None:
        """Record the outcome of this cycle's MV write (None: accepted; else the failure)."""
        self.write_ok = err is None
        self.conditions.set("write_failed", err is not None, f"MV write: {err}", self._t)
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
            "t_wall": time.time(),  # the snapshots' age at a restart
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
        self._retained_mv = finite_or_none(st.get("mv")) if self._off_mv is None else None
        saved = finite_or_none(st.get("t_wall"))
        self._begin("restart", math.inf if saved is None else max(0.0, time.time() - saved))
        self._init_mv = None
        self._want_readback = self._readback_possible()
        log.info("loop %s: retained state restored", self.name)

    # -- bumpless starts (module docstring) -------------------------------------------

    def _readback_possible(self) -> bool:
        """The MV can be read back: one actuator that holds a controller output.

        A split range's two actuators do not give the controller output back
        (in the gap every output maps to the same values), nor does an output
        stage's MV (on/off, motor commands).
        """
        return self.config.mv2 is None and self._off_mv is None and self.config.mv.is_io

    def _begin(self, reason: str, age: float) -> None:
        """Start a bumpless (re)start at the next cycle with inputs (module docstring)."""
        self._init = reason
        self._init_age = age

    def resync(self, reason: str) -> None:
        """Start again bumplessly from the device's MV (a reconnection: ``reason``).

        The next read of the MV's connection reads the MV back; the blocks'
        state is reset when the last good step is older than ``max_dt``.
        """
        age = math.inf if self._t_good is None else self._t - self._t_good
        self._begin(reason, age)
        self._init_mv = None
        self._want_readback = self._readback_possible()

    def readback_address(self) -> str | None:
        """The MV's address while a read-back is wanted (the scan reads it with the inputs)."""
        return self.config.mv.address if self._want_readback else None

    def read_back(self, reading: Reading | None) -> None:
        """The MV read back from the device (bad or None: the retained or initial MV)."""
        self._want_readback = False
        if reading is not None and reading.ok:
            self._init_mv = reading.value
        else:
            self._init_mv = None
            if reading is not None:
                log.debug("loop %s: the MV could not be read back (%s)", self.name, reading.reason)

    def restart_from(self, reading: Reading | None) -> None:
        """The MV read back from the device before the first cycle (see :meth:`read_back`)."""
        self.read_back(reading)

    def _initialise(self, t: float, ok: bool, meas: Mapping[str, float]) -> float:
        """The bumpless start (module docstring): the MV blocks track the start MV for a step."""
        reason = self._init or "start"
        u0 = self._init_mv
        source = "the device's MV" if reason != "held" else "the MV last written"
        if u0 is None and reason == "restart":
            u0, source = self._retained_mv, "the retained MV"
        if u0 is None and self.config.initial_mv is not None:
            u0, source = self.config.initial_mv, "initial_mv"
        if u0 is not None:
            u0 = min(max(float(u0), float(self.block.u_min)), float(self.block.u_max))
            u0 = u0 if is_finite(u0) else None
        self._init, self._init_mv = None, None
        if u0 is not None and self._init_age > self.config.dt_bound:
            self._reset_blocks(u0)  # stale: at rest at u0 on the present PV, then track u0
        self._swing.reset()
        self._settle = 1  # this step and the next one use ts
        self._fault_since = None
        if u0 is None:  # nothing to start from: the blocks' own start
            u = self._step(t, ok, meas, None)
            what = "the blocks' own start (no MV read back, no initial_mv)"
        else:
            manual, mval = self.side.manual, float(self.block.manual_value)
            if manual and not self.is_bound("manual_value"):
                mval = u0  # MAN: the manual value is what the device has
            self.side.set_manual(True, u0)
            u = self._step(t, ok, meas, None)
            self.side.set_manual(manual, mval if manual else None)
            if not manual:
                self._set_manual_value(mval)
            what = f"{source} {u0:.6g}"
        self._stepped(t, ok)
        self.initialisations += 1
        age = "" if math.isinf(self._init_age) else f", block state {self._init_age:.3g} s old"
        self.last_start = f"{reason}: bumpless from {what}{age}"
        log.debug("loop %s: %s", self.name, self.last_start)
        if reason == "held":  # a warning (audited once per episode), kept over the next holds
            span = OFF_DELAY + math.ceil(self.config.dt_bound / self.ts)
            self.conditions.set("held_long", True, f"no step on good inputs for more than "
                                f"max_dt = {self.config.dt_bound:g} s: {self.last_start}",
                                t, off_delay=span)  # fmt: skip
            self._held_long = True
        self._init_age = math.inf
        return u

    def _reset_blocks(self, u0: float) -> None:
        """Start the controllers again at rest at the MV ``u0`` (their state is stale).

        ``Block.start_at``: an ADRC's observer starts on the present PV with
        x4 = -b0 u0 -- the plant at rest on the MV the device holds -- not on
        the initial u0 of its configuration (whose x4 the observer would then
        correct, moving the MV away from the set point first). Mode, manual
        value and limits stay.
        """
        for role in self.side.ctrls:
            b = self.side.blocks[role]
            manual = getattr(b, "manual", None)
            mval = getattr(b, "manual_value", None)
            b.start_at(u0)
            if manual is not None:
                b.manual = manual
            if mval is not None:
                b.manual_value = mval

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
            "late": self.late,
            "late_cycles": self.late_cycles,
            "on_late": self.config.on_late,
            "max_dt": self.config.dt_bound,
            "stretched": self.stretched,
            "initialisations": self.initialisations,
            "last_start": self.last_start,
            # what an operator sees at a glance (runtime.status): codes, and each with its text
            "status": self.conditions.codes(),
            "conditions": self.conditions.as_json(),
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
