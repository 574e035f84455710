"""Live auto-tuning of a running loop: start, safety, abort, result, accept or reject, audit.

:class:`LiveTuning` (``runtime.tuning``) runs a
:class:`~ctrlblocks.tuning.live.LiveTuner` experiment -- PID_Compact's
*pretuning* (``method="step"``, a step of the MV) or *fine tuning*
(``method="relay"``, a relay oscillation) -- on one loop of the running
runtime, one sample per cycle, and keeps its result until an engineer accepts
or rejects it.  The faceplate (``/api/loops/NAME/tune``) and the command
``ctrlblocks tune-live`` drive it; docs/autotuning.md shows both.

What it guarantees:

* **Bounds.** Every MV the experiment applies lies inside ``mv_min..mv_max``
  (default the loop's output limits; narrower bounds are allowed, wider ones
  refused) -- checked before the start, nothing moves otherwise.  A PV
  outside ``pv_min..pv_max``, a bad PV or a test longer than ``max_time``
  ends the experiment at once.
* **The loop stays in its mode.** During the test the experiment's MV goes
  to the process and the loop's blocks *track* it (their
  ``update_state`` with the applied MV, as when the loop holds its MV on a
  fault), so when the test ends -- done, aborted or failed -- the MV returns
  to ``u0``, the value before the test, and the loop continues from there in
  the mode it was in: a manual loop at its manual value, an auto loop
  bumplessly from ``u0``.
* **The operator wins.** A command to the loop (mode, setpoint, manual
  value, any other) aborts a running test first ("operator command ..."),
  with the MV back at ``u0``, then the command applies as usual; a mode or a
  setpoint that changes through I/O aborts it at the next cycle.
* **Nothing applied without acceptance.** A finished test keeps the
  identified model and the proposed tunings (with the robustness margins Ms,
  GM, PM of each proposal on the identified model where there is one,
  :func:`~ctrlblocks.tuning.margins.margins`); :meth:`LiveTuning.accept`
  applies one through :meth:`Runtime.command <ctrlblocks.runtime.Runtime.command>`
  (validated by the block, bumpless by the block's own retuning rules) and
  writes the retain file at once, so the tuning survives a restart.
* **Audited.** ``tune-start`` (who, method, bounds), ``tune-abort`` (who or
  what, and why), ``tune-result`` (the model and the proposals, or why it
  failed), ``tune-accept`` / ``tune-reject`` (who, which proposal) go to the
  historian's audit table next to the commands.

Only loops of the ``single`` structure can be tuned live (the experiment
identifies the path from the loop's MV to its PV).
"""

from __future__ import annotations

import asyncio
import dataclasses
import logging
import math
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

from ..blocks.base import ErrorCode, ParameterError
from ..loops.structures import STRUCTURES
from .loop import CommandError, ControlLoop

if TYPE_CHECKING:  # pragma: no cover
    from ..tuning.live import LiveTuner
    from .runtime import Runtime

# ctrlblocks.tuning (scipy) is imported when a test starts, not with the runtime: its
# import takes seconds, and a runtime that is never tuned should not start slower

__all__ = ["METHODS", "LiveTuning", "LoopTuning"]

log = logging.getLogger(__name__)

METHODS = ("step", "relay")
"""Experiments: PID_Compact's pretuning (``step``) and fine tuning (``relay``)."""

_OPTIONS = ("amplitude", "mv_min", "mv_max", "pv_min", "pv_max", "max_time", "hysteresis",
            "pre_time")  # fmt: skip


class LoopTuning:
    """One live tuning of one loop: the experiment, then its result until a decision.

    ``state``: ``running``, then ``done`` (a result to accept or reject),
    ``aborted`` or ``failed`` (with ``reason``); after a decision ``accepted``
    or ``rejected``.
    """

    def __init__(self, loop: ControlLoop, tuner: LiveTuner, user: str, options: dict[str, Any]):
        self.loop = loop
        self.tuner = tuner
        self.user = user
        self.options = options
        self.method = tuner.method
        self.mode0 = loop.mode
        self.sp0 = loop.sp
        self.manual0 = float(loop.block.manual_value)
        self.u0 = tuner.u0
        self.decision = ""  # "accepted" / "rejected"
        self.decided_by = ""
        self.accepted = ""  # the name of the accepted proposal
        self.margins: dict[str, dict[str, Any]] = {}
        self.mv = tuner.u0  # the MV of the last cycle [MV unit]
        self._status: dict[str, Any] | None = None
        self.ended = False  # the cycle that ended the test has run
        self.restore = (self.mode0, self.manual0)  # mode and manual value after the test
        self.aborted_by = "runtime"
        self.on_end: Callable[[LoopTuning], None] | None = None
        self.margins_ready = False

    @property
    def running(self) -> bool:
        """True while the experiment drives the MV."""
        return self.tuner.running

    @property
    def state(self) -> str:
        return self.decision or self.tuner.state.value

    @property
    def active(self) -> bool:
        """True until the cycle that ends the test (and restores the mode) has run."""
        return not self.ended

    def operator_action(self) -> str:
        """Why the test must stop for the operator ("" when nothing changed).

        Commands go through :meth:`LiveTuning.command`; this catches a mode or
        setpoint that comes from I/O.
        """
        lp = self.loop
        if lp.is_bound("mode") and lp.mode != self.mode0:
            return f"the mode input changed to {lp.mode}"
        if not (lp.sp == self.sp0 or (math.isnan(lp.sp) and math.isnan(self.sp0))):
            return f"the setpoint changed to {lp.sp:g}"
        return ""

    def cycle(self, ok: bool, meas: Mapping[str, float], dt: float | None) -> float:
        """This cycle of the test: the experiment's MV (module docstring).

        The MV blocks are in manual at the experiment's MV, so they track it
        exactly; in the cycle the test ends the MV is ``u0`` and the loop goes
        back to its mode (manual at its manual value, or auto from ``u0``).
        """
        lp = self.loop
        if self.tuner.running:
            why = self.operator_action()
            if why:
                self.tuner.abort(why)
        y = meas.get("y", math.nan)
        try:
            u = self.tuner.step(y if ok else math.nan)
        except Exception as exc:  # a defect of the experiment never stops the loop
            log.exception("loop %s: live test failed", lp.name)
            self.tuner.abort(f"the test failed: {type(exc).__name__}: {exc}")
            u = self.u0
        lp.side.set_manual(True, u)
        lp.side.compute(lp.sp, y, y_ok=ok, dt=dt)
        lp.side.update(u)
        lp.side.values["v"] = u
        self.mv = u
        if not self.tuner.running:
            mode, mval = self.restore
            lp.side.set_manual(mode == "manual", mval if mode == "manual" else None)
            self.ended = True
            if self.on_end is not None:
                self.on_end(self)
        self.changed()
        return u

    def retained(self, state: dict[str, Any]) -> dict[str, Any]:
        """A loop's retained state as it will be after the test (a stop during a test)."""
        mode, mval = self.restore
        out = {**state, "mv": self.u0}
        if state.get("mode") is not None:  # not bound to I/O
            out["mode"] = mode
        if state.get("manual_value") is not None:
            out["manual_value"] = mval
        return out

    def changed(self) -> None:
        """Forget the cached :meth:`status` (something in it changed)."""
        self._status = None

    def status(self) -> dict[str, Any]:
        """Plain values for a faceplate, the CLI or the audit (cached between cycles)."""
        if self._status is None:
            st = self.tuner.status()
            st.update(
                state=self.state,
                user=self.user,
                options=dict(self.options),
                u0=self.u0,
                mv=self.mv,
                mode=self.mode0,
                decided_by=self.decided_by,
                accepted=self.accepted,
                margins=self.margins,
                margins_ready=self.margins_ready,
            )
            self._status = st
        return self._status


class LiveTuning:
    """The live tunings of a runtime's loops (``runtime.tuning``; module docstring).

    Call its methods on the runtime's event loop (as :meth:`Runtime.command`).
    Refusals raise :class:`~ctrlblocks.runtime.loop.CommandError`.
    """

    def __init__(self, runtime: Runtime) -> None:
        self.runtime = runtime
        self.tunings: dict[str, LoopTuning] = {}
        self._tasks: set[asyncio.Task[None]] = set()

    def _loop(self, name: str) -> ControlLoop:
        try:
            return self.runtime.loops[name]
        except KeyError:
            raise CommandError("loop", f"unknown loop {name!r}") from None

    # -- queries ---------------------------------------------------------------------

    def status(self, loop: str) -> dict[str, Any] | None:
        """The tuning of ``loop`` (running or the last one), None when there was none."""
        self._loop(loop)
        tu = self.tunings.get(loop)
        return None if tu is None else tu.status()

    # -- the experiment ----------------------------------------------------------------

    def start(
        self,
        loop: str,
        *,
        user: str,
        method: str,
        amplitude: float,
        mv_min: float | None = None,
        mv_max: float | None = None,
        pv_min: float | None = None,
        pv_max: float | None = None,
        max_time: float = 3600.0,
        hysteresis: float = 0.0,
        pre_time: float = 1.0,
    ) -> dict[str, Any]:
        """Start a ``method`` test on ``loop`` as ``user``; its status.

        Parameters
        ----------
        method : {"step", "relay"}
        amplitude : float
            Step ``du`` (signed) or relay amplitude ``d`` (> 0) [MV unit].
        mv_min, mv_max : float, optional
            Bounds of every experiment MV; default the loop's output limits
            (bounds outside them are refused).
        pv_min, pv_max : float, optional
            PV bounds; leaving them aborts the test (default: none).
        max_time : float
            Longest test [s].
        hysteresis : float
            Relay hysteresis [PV unit] (just above the noise band).
        pre_time : float
            Step: time held at the present MV before the step [s].

        The relay switches around the setpoint when the loop is in auto, around
        the present PV in manual.  Refused (``CommandError``, audited) when a
        test runs on the loop, when a result waits for a decision, when the loop
        has no good PV or MV yet, or for a bad option.
        """
        lp = self._loop(loop)
        options = {
            "method": method, "amplitude": amplitude, "mv_min": mv_min, "mv_max": mv_max,
            "pv_min": pv_min, "pv_max": pv_max, "max_time": max_time,
            "hysteresis": hysteresis, "pre_time": pre_time,
        }  # fmt: skip
        try:
            tu = self._new(lp, user, options)
        except CommandError as exc:
            self.runtime.audit(user, "tune-start", loop=loop, new=_plain(options), ok=False,
                               message=str(exc))  # fmt: skip
            raise
        self.tunings[loop] = tu
        self.runtime.audit(user, "tune-start", loop=loop, old={"mode": tu.mode0, "mv": tu.u0},
                           new=_plain(tu.options))  # fmt: skip
        log.info("loop %s: live %s test started by %s", loop, method, user)
        return tu.status()

    def _new(self, lp: ControlLoop, user: str, options: dict[str, Any]) -> LoopTuning:
        old = self.tunings.get(lp.name)
        if old is not None and old.active:
            raise CommandError("tune", f"a {old.method} test is running (started by {old.user})")
        if old is not None and old.state == "done":
            raise CommandError(
                "tune", "the result of the last test waits for a decision: accept or reject it"
            )
        if not STRUCTURES[lp.config.structure].lone_block:
            raise CommandError(
                "tune", f"live tuning needs a single loop, this one is {lp.config.structure!r}"
            )
        if options["method"] not in METHODS:
            raise CommandError("method", f"must be one of {METHODS}, got {options['method']!r}")
        if lp.cycle_count == 0 or not lp.pv_ok or not math.isfinite(lp.mv):
            raise CommandError("tune", "the loop has no good PV and MV yet: wait for its cycles")
        lo, hi = float(lp.block.u_min), float(lp.block.u_max)
        opts = dict(options)
        for k, default in (("mv_min", lo), ("mv_max", hi), ("pv_min", -math.inf),
                           ("pv_max", math.inf)):  # fmt: skip
            v = opts[k]
            opts[k] = default if v is None else v
        for k in _OPTIONS:
            v = opts[k]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or math.isnan(v):
                raise CommandError(k, f"must be a number, got {v!r}")
            opts[k] = float(v)
        if opts["mv_min"] < lo or opts["mv_max"] > hi:
            raise CommandError(
                "mv_min" if opts["mv_min"] < lo else "mv_max",
                f"the MV bounds {opts['mv_min']:g}..{opts['mv_max']:g} must lie inside the "
                f"loop's limits {lo:g}..{hi:g}",
                ErrorCode.BAD_LIMITS,
            )
        if not opts["pv_min"] <= lp.pv <= opts["pv_max"]:
            raise CommandError(
                "pv_min",
                f"the PV {lp.pv:g} is outside the bounds {opts['pv_min']:g}..{opts['pv_max']:g}",
                ErrorCode.BAD_LIMITS,
            )
        from ..tuning.live import LiveTuner

        reverse = bool(getattr(lp.block.config, "reverse", False))
        try:
            tuner = LiveTuner(
                opts["method"],
                ts=lp.ts,
                u0=lp.mv,
                amplitude=opts["amplitude"],
                setpoint=lp.sp if lp.mode == "auto" and math.isfinite(lp.sp) else None,
                mv_min=opts["mv_min"],
                mv_max=opts["mv_max"],
                pv_min=opts["pv_min"],
                pv_max=opts["pv_max"],
                max_time=opts["max_time"],
                hysteresis=opts["hysteresis"],
                gain_sign=-1 if reverse else 1,
                pre_time=opts["pre_time"],
            )
        except ParameterError as exc:
            raise CommandError(exc.field, exc.message, exc.code) from None
        tu = LoopTuning(lp, tuner, user, opts)
        tu.on_end = self.ended
        lp.tuning = tu
        return tu

    def abort(self, loop: str, *, user: str, reason: str = "") -> dict[str, Any]:
        """Abort the running test of ``loop``: at the next cycle the MV returns to ``u0``."""
        tu = self._running(loop, user, "tune-abort")
        tu.tuner.abort(f"aborted by {user}" + (f": {reason}" if reason else ""))
        tu.aborted_by = user
        tu.changed()
        return tu.status()

    def command(self, lp: ControlLoop, user: str, changes: Mapping[str, Any]) -> dict[str, Any]:
        """An operator command to ``lp`` (:meth:`Runtime.command`): it ends a running test.

        The command is validated and applied to the loop as it was before the
        test (its mode, its manual value, the MV ``u0``); when it is accepted the
        test is aborted and the mode and manual value the command leaves are the
        ones the loop goes to after the end cycle (the next one, which outputs
        ``u0``).  A refused command changes nothing and the test goes on.
        """
        tu = self.tunings.get(lp.name)
        if tu is None or not tu.active:
            return lp.command(**changes)
        mode, mval = tu.restore
        lp.side.set_manual(mode == "manual", mval if mode == "manual" else tu.u0)
        lp.mv = tu.u0
        try:
            old = lp.command(**changes)
        except CommandError:
            lp.side.set_manual(True, tu.mv)
            lp.mv = tu.mv
            raise
        tu.restore = (lp.mode, float(lp.block.manual_value))
        lp.side.set_manual(True, tu.mv)
        lp.mv = tu.mv
        if tu.running:
            tu.tuner.abort(f"operator command {','.join(sorted(changes))} by {user}")
            tu.aborted_by = user
            tu.changed()
        return old

    def ended(self, tu: LoopTuning) -> None:
        """Audit the end of a test: the result (margins computed off the cycle), or why not."""
        from ..tuning.live import TunerState

        lp, state = tu.loop, tu.tuner.state
        if state is not TunerState.DONE:
            action = "tune-abort" if state is TunerState.ABORTED else "tune-result"
            who = tu.aborted_by if action == "tune-abort" else "runtime"
            new = {"mv": tu.u0, "elapsed": tu.tuner.status()["elapsed"]}
            self.runtime.audit(who, action, loop=lp.name, ok=False, message=tu.tuner.reason,
                               new=new)  # fmt: skip
            log.warning("loop %s: live %s test %s: %s", lp.name, tu.method, state.value,
                        tu.tuner.reason)  # fmt: skip
            return
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:  # called outside the runtime (a test): at once
            self._result(tu, proposal_margins(lp, tu.tuner))
            return
        task = loop.create_task(self._margins_then_result(tu))
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def _margins_then_result(self, tu: LoopTuning) -> None:
        try:
            mg = await asyncio.to_thread(proposal_margins, tu.loop, tu.tuner)
        except Exception as exc:  # pragma: no cover - proposal_margins reports its own errors
            mg = {"error": {"error": str(exc)}}
        self._result(tu, mg)

    def _result(self, tu: LoopTuning, mg: dict[str, dict[str, Any]]) -> None:
        tu.margins = mg
        tu.margins_ready = True
        tu.changed()
        st = tu.status()
        self.runtime.audit(
            "runtime", "tune-result", loop=tu.loop.name, ok=True,
            new=_plain({k: st.get(k) for k in ("method", "model", "proposals", "margins",
                                               "warnings")}),
            message=f"{tu.method} test done after {st['elapsed']:g} s",
        )  # fmt: skip
        log.info("loop %s: live %s test done: %s", tu.loop.name, tu.method, st.get("model"))

    # -- the decision -----------------------------------------------------------------

    def accept(
        self, loop: str, *, user: str, proposal: str, force: bool = False
    ) -> dict[str, Any]:
        """Apply ``proposal`` of the finished test to ``loop`` (bumpless); the old tunings.

        Goes through :meth:`Runtime.command` (validated by the block; audited as a
        command), then writes the retain file.  A proposal whose margins on the
        identified model say the loop would be unstable or fragile
        (``Ms > MS_FRAGILE``, :data:`~ctrlblocks.tuning.margins.MS_FRAGILE`) is
        refused unless ``force``.
        """
        tu = self._done(loop, user, "tune-accept")
        proposals = tu.tuner.result.proposals if tu.tuner.result else {}
        msg = ""
        if proposal not in proposals:
            msg = f"unknown proposal {proposal!r}; proposals: {sorted(proposals)}"
        elif not force and (why := fragile(tu.margins.get(proposal))):
            msg = f"{proposal} {why} on the identified model: accept it with force"
        if msg:
            self.runtime.audit(user, "tune-accept", loop=loop, ok=False, message=msg,
                               new={"proposal": proposal})  # fmt: skip
            raise CommandError("proposal", msg)
        try:
            tunings = block_tunings(tu.loop, proposals[proposal])
            old = self.runtime.command(loop, user=user, tunings=tunings)
        except CommandError as exc:
            self.runtime.audit(user, "tune-accept", loop=loop, ok=False,
                               new={"proposal": proposal}, message=str(exc))  # fmt: skip
            raise
        tu.decision, tu.decided_by, tu.accepted = "accepted", user, proposal
        tu.changed()
        self.runtime.audit(user, "tune-accept", loop=loop, old=_plain(old.get("tunings")),
                           new=_plain({"proposal": proposal, "tunings": tunings}))  # fmt: skip
        self._retain_now()
        return old

    def reject(self, loop: str, *, user: str) -> dict[str, Any]:
        """Reject the result of the finished test of ``loop`` (nothing changes); its status."""
        tu = self._done(loop, user, "tune-reject")
        tu.decision, tu.decided_by = "rejected", user
        tu.changed()
        self.runtime.audit(user, "tune-reject", loop=loop, new={"method": tu.method})
        return tu.status()

    def _running(self, loop: str, user: str, action: str) -> LoopTuning:
        self._loop(loop)
        tu = self.tunings.get(loop)
        if tu is None or not tu.running:
            msg = "no test is running on this loop"
            self.runtime.audit(user, action, loop=loop, ok=False, message=msg)
            raise CommandError("tune", msg)
        return tu

    def _done(self, loop: str, user: str, action: str) -> LoopTuning:
        self._loop(loop)
        tu = self.tunings.get(loop)
        if tu is None or tu.state != "done":
            msg = (
                "the test is still running"
                if tu is not None and tu.active
                else "no test result waits for a decision"
            )
            self.runtime.audit(user, action, loop=loop, ok=False, message=msg)
            raise CommandError("tune", msg)
        return tu

    def _retain_now(self) -> None:
        if self.runtime.retain is None:
            return
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:  # no event loop here: the next periodic save retains it
            return
        task = loop.create_task(self.runtime.save_retained())
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)


def fragile(margins: Mapping[str, Any] | None) -> str:
    """Why a proposal's margins make it unsafe to apply ("" when they do not, or are unknown)."""
    from ..tuning.margins import MS_FRAGILE

    if not margins or "stable" not in margins:
        return ""
    if not margins["stable"]:
        return "makes the loop unstable"
    ms = margins.get("ms")
    if isinstance(ms, (int, float)) and ms > MS_FRAGILE:
        return f"is fragile (Ms {ms:.2f} > {MS_FRAGILE:g})"
    return ""


def block_tunings(lp: ControlLoop, proposal: Mapping[str, Any]) -> dict[str, Any]:
    """The ``tunings`` command of ``proposal`` for the loop's block (refused if it does not fit)."""
    kind = str(proposal.get("type", ""))
    block = lp.config.block_type
    if kind != block:
        raise CommandError("proposal", f"a {kind} proposal does not fit this loop's {block} block")
    tunings = {k: v for k, v in proposal.items() if k != "type"}
    cfg = lp.block.config
    if kind == "PID" and (getattr(cfg, "form", "isa") != "isa" or getattr(cfg, "pv_range", None)):
        raise CommandError(
            "proposal",
            "the proposals are ISA-form gains in engineering units; this PID has "
            f"form={cfg.form!r}, pv_range={cfg.pv_range!r}: convert them by hand",
        )
    if kind == "ADRC" and tunings.get("order") == getattr(cfg, "order", None):
        tunings.pop("order")  # unchanged: do not send it
    return tunings


def proposal_margins(lp: ControlLoop, tuner: LiveTuner) -> dict[str, dict[str, Any]]:
    """Ms, GM, PM of every proposal on the identified FOPDT (step tests; none for a relay).

    Each proposal is configured into a copy of the loop's block (its other
    settings as they are), or a fresh block of the proposal's type.
    """
    res = tuner.result
    if res is None or res.model.get("kind") != "FOPDT":
        return {}
    from ..blocks.registry import block_class
    from ..tuning.identify import FOPDT
    from ..tuning.margins import margins

    m = res.model
    model = FOPDT(m["gain"], m["time_constant"], m["dead_time"])
    out: dict[str, dict[str, Any]] = {}
    for name, prop in res.proposals.items():
        kw = {k: v for k, v in prop.items() if k != "type"}
        try:
            cls = block_class(prop.get("type", type(lp.block).__name__))
            if isinstance(lp.block, cls):
                cfg = lp.block.config
                base = {f.name: getattr(cfg, f.name) for f in dataclasses.fields(cfg)}
                block = cls(**{**base, **kw})
            else:
                block = cls(ts=lp.ts, **kw)
            mg = margins(model, block)
            out[name] = {**mg.as_dict(), "summary": mg.summary()}
        except Exception as exc:  # a margin that cannot be computed is reported, not raised
            out[name] = {"error": f"{type(exc).__name__}: {exc}"}
    return out


def _plain(x: Any) -> Any:
    """JSON-friendly copy (non-finite floats as strings) for the audit table."""
    if isinstance(x, Mapping):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return str(x)
    return x
