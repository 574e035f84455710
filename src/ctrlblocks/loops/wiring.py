"""A loop structure's signal flow, described once as data, and its run in Åström's order.

A :class:`Wiring` says what a structure does in one sample, and nothing is
written beside it: the Python path (:class:`~.side.ControllerSide`) runs it
here, and the simulator's compiled lane (``ctrlblocks.fast.simlane``) runs
the same description on arrays (through :mod:`.lane`).  It holds

* the :class:`Stage` objects that compute signals from the measurements
  before any controller (the lead-lag feed-forward ``ff`` of Bonde et al.
  2021, Fig. 10; the Smith predictor's ``y_pred``, Nowak et al. 2018,
  section 3.1; a ratio station's flow setpoint; a gain schedule);
* the :class:`Loop` of every controller, in the order they compute: where
  its setpoint comes from (the setpoint input, a number of its own, another
  loop's output -- a cascade --, or a stage's signal), what it measures
  (``y``, ``y2`` or a stage's signal), which quality flags it runs on, its
  feed-forward input, which loop's anti-windup output is its ``awin`` (the
  AW handshake of Nowak et al. 2018, section 5, and Åström 1987, section 3),
  and which loop's opening makes it track (a cascade's primary,
  :meth:`Wiring.follow`);
* the MV: one loop's output, or a min or max selector over all of them
  (Åström 1987, Figs. 3.8/3.9: every loop then commits with the selected
  value);
* an :class:`OutputStage` that turns the MV into what is written (a
  pulse-width output, a step controller's motor commands) or adds signals
  (a split range's two actuators).

One sample (Åström 1987, section 6, Listing 6.3): :meth:`Wiring.compute`
(*ComputeOutput* of every loop in order, then *ShapeOutput*: the selector
and the output stage), the caller writes the MV, :meth:`Wiring.update`
(*UpdateState* of every loop in reverse order -- an inner loop before the
outer one that reads its ``awout`` -- with the value it applied: the MV for
the loops that make it, its own output for the others; then the stages,
e.g. the Smith predictor's models advance with the MV).
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any, ClassVar

from .controller import set_manual

if TYPE_CHECKING:  # pragma: no cover
    from .side import ControllerSide

__all__ = ["MEASUREMENTS", "SELECTORS", "Loop", "Measured", "OutputStage", "Stage", "Wiring"]

MEASUREMENTS = ("y", "y2", "dv", "w")
"""What a structure may measure: the controlled variable ``y``, the inner
variable ``y2`` (a cascade's or an override's), the measured disturbance
``dv`` (feed-forward) and the wild flow ``w`` (ratio)."""

SELECTORS = ("min", "max")
"""The MV selectors of :attr:`Wiring.mv` (the first of equal values wins)."""


@dataclasses.dataclass(frozen=True)
class Measured:
    """The measurements of one sample, with their quality flags, and ``dt``."""

    y: float
    y_ok: bool
    y2: float
    y2_ok: bool
    dv: float
    dv_ok: bool
    dt: float | None
    w: float = math.nan
    w_ok: bool = True

    def value(self, name: str) -> float:
        """The measurement ``name`` (``y`` or ``y2``)."""
        return self.y2 if name == "y2" else self.y

    def good(self, flags: tuple[str, ...]) -> bool:
        """Whether every quality flag of ``flags`` (``y``, ``y2``) is good."""
        return all(self.y2_ok if f == "y2" else self.y_ok for f in flags)


@dataclasses.dataclass(frozen=True)
class Loop:
    """One controller of a structure and what it is wired to (module docstring).

    Parameters
    ----------
    role : str
        The controller's role (``main``, ``primary``, ``blocks[0]``, ...).
    sp : str or float
        Its setpoint: ``"sp"`` (the setpoint input), a number (its own,
        fixed), the role of an earlier loop (its output) or a stage's signal.
    pv : str
        Its measurement: ``"y"``, ``"y2"`` or a stage's signal (``"y_pred"``).
    ok : tuple of str
        The measurements whose quality flags it runs on (bad: its
        bad-measurement cycle).
    ff : str, optional
        The stage signal into its feed-forward input ``ff``.
    awin : str, optional
        The loop whose anti-windup output ``awout`` is its ``awin``, read
        after that loop's update (for the next sample).
    follows : str, optional
        The loop whose opening makes this one track (:meth:`Wiring.follow`).
    signal : str, optional
        Its output's name among the structure's signals (``sp2``, ``v1``).
    """

    role: str
    sp: str | float = "sp"
    pv: str = "y"
    ok: tuple[str, ...] = ("y",)
    ff: str | None = None
    awin: str | None = None
    follows: str | None = None
    signal: str | None = None


class Stage:
    """A part of a structure that is not a controller; it runs before the loops.

    ``signals`` names what :meth:`compute` adds to the sample's signals (that
    the loops may read), ``measurements`` what it reads; ``roles`` the
    entry's roles it owns (not built as controllers).  Its objects live in
    ``side.parts[name]``.
    """

    name: ClassVar[str]
    signals: ClassVar[tuple[str, ...]] = ()
    measurements: ClassVar[tuple[str, ...]] = ()
    roles: ClassVar[tuple[str, ...]] = ()

    def setup(self, side: ControllerSide) -> None:
        """Build the stage's objects for ``side``."""

    def compute(
        self, side: ControllerSide, sp: float, m: Measured, signals: dict[str, float]
    ) -> None:
        """Add this sample's signals to ``signals``."""

    def update(self, side: ControllerSide, u: float) -> None:
        """After the loops' UpdateState, with the applied MV ``u``."""

    def reset(self, side: ControllerSide) -> None:
        """Back to the steady state of ``side.u0`` (the simulator's warm-up)."""


class OutputStage:
    """What follows the MV: an output block that makes the written value, or more signals.

    ``realises``: the output block realises the controller output on average
    (a PWM's duty, a motor's travel), so the MV loops commit their own output
    (their anti-windup and modes are unchanged) instead of the written value.
    """

    name: ClassVar[str] = "output"
    realises: ClassVar[bool] = False
    roles: ClassVar[tuple[str, ...]] = ()
    measurements: tuple[str, ...] = ()

    def setup(self, side: ControllerSide) -> None:
        """Build the stage's objects for ``side``."""

    def shape(self, side: ControllerSide, v: float, m: Measured) -> tuple[float, dict[str, float]]:
        """The MV written for the controllers' MV ``v``, and the stage's signals."""
        raise NotImplementedError


@dataclasses.dataclass(frozen=True)
class Wiring:
    """A structure's signal flow (module docstring).

    Parameters
    ----------
    loops : tuple of Loop
        The controllers, in the order they compute.
    mv : str
        The role whose output is the MV, or a selector of :data:`SELECTORS`.
    stages : tuple of Stage
        Run before the loops, in order.
    output : OutputStage, optional
        Run after the selection.
    measured_mv : bool
        The MV loops are given the actuator's measured output in their
        UpdateState when the caller knows it (one plant, one actuator).
    """

    loops: tuple[Loop, ...]
    mv: str = "main"
    stages: tuple[Stage, ...] = ()
    output: OutputStage | None = None
    measured_mv: bool = False

    # -- derived facts ---------------------------------------------------------------

    @property
    def roles(self) -> tuple[str, ...]:
        """The loops' roles, in their order."""
        return tuple(lp.role for lp in self.loops)

    @property
    def mv_roles(self) -> tuple[str, ...]:
        """The roles whose output is (or is selected as) the MV."""
        return self.roles if self.mv in SELECTORS else (self.mv,)

    @property
    def measurements(self) -> tuple[str, ...]:
        """What a sample reads: the loops' measurements and the stages' inputs."""
        used = {lp.pv for lp in self.loops}
        for part in (*self.stages, *((self.output,) if self.output is not None else ())):
            used.update(part.measurements)
        return tuple(m for m in MEASUREMENTS if m in used)

    @property
    def signals(self) -> tuple[str, ...]:
        """The names of the structure's signals of a sample (besides ``v``), in order:
        the stages', the loops', the output stage's are the stage's own."""
        out: list[str] = [s for st in self.stages for s in st.signals]
        out += [lp.signal for lp in self.loops if lp.signal is not None]
        return tuple(out)

    @property
    def one_call(self) -> bool:
        """One loop on the setpoint and ``y`` and nothing else: a whole sample is the
        block's one call (``block(sp, y, ...)``, its fast lane; :meth:`step`)."""
        if len(self.loops) != 1 or self.stages or self.output is not None:
            return False
        lp = self.loops[0]
        return lp == Loop(lp.role)

    # -- the two phases --------------------------------------------------------------

    def compute(self, side: ControllerSide, sp: float, m: Measured) -> tuple[float, dict]:
        """ComputeOutput of every loop and ShapeOutput: the MV and the structure's signals."""
        signals: dict[str, float] = {}
        for st in self.stages:
            st.compute(side, sp, m, signals)
        outs: dict[str, float] = {}
        tracking: dict[str, str] = {}
        for lp in self.loops:
            w = side.ctrls[lp.role]
            if isinstance(lp.sp, str):
                r = sp if lp.sp == "sp" else outs[lp.sp] if lp.sp in outs else signals[lp.sp]
            else:
                r = lp.sp
            pv = signals[lp.pv] if lp.pv in signals else m.value(lp.pv)
            ok = m.good(lp.ok)
            ff = 0.0 if lp.ff is None else signals[lp.ff]
            follow = None if lp.follows is None else self.follow(side, lp, m)
            if follow is None:
                v = w.output(r, pv, ok, ff, m.dt)
            else:  # the loop above is open: this one tracks (restored right after its compute)
                tracking[lp.role] = follow[0]
                saved = w.follow(follow[1])
                try:
                    v = w.output(r, pv, ok, ff, m.dt)
                finally:
                    w.restore(saved)
            outs[lp.role] = v
        side.tracking = tracking
        if self.mv in SELECTORS:
            vs = [outs[lp.role] for lp in self.loops]
            u = min(vs) if self.mv == "min" else max(vs)
        else:
            u = outs[self.mv]
        side.pending = (u, outs)
        for lp in self.loops:
            if lp.signal is not None:
                signals[lp.signal] = outs[lp.role]
        if self.output is not None:
            u, extra = self.output.shape(side, u, m)
            signals.update(extra)
        return u, signals

    def update(self, side: ControllerSide, applied: float, measured: float | None) -> None:
        """UpdateState of every loop (reverse order), then of the stages (module docstring)."""
        u_sel, outs = side.pending
        mv = applied if self.output is None or not self.output.realises else u_sel
        mv_roles = self.mv_roles
        for lp in reversed(self.loops):
            w = side.ctrls[lp.role]
            if lp.awin is not None:
                w.set_awin(side.ctrls[lp.awin].awout)
            if lp.role in mv_roles:
                w.update(mv, measured if self.measured_mv else None)
            else:
                w.update(outs[lp.role])
        for st in self.stages:
            st.update(side, applied)

    def step(
        self, side: ControllerSide, sp: float, y: float, y_ok: bool, dt: float | None,
        measurements: dict[str, Any],
    ) -> float:  # fmt: skip
        """One whole sample: compute, then update with the MV (:attr:`one_call`: one call)."""
        if self.one_call:
            u = side.u = side.ctrls[self.loops[0].role].cycle(sp, y, y_ok, dt)
            side.values = {"v": u}
            return u
        u = side.compute(sp, y, y_ok=y_ok, dt=dt, **measurements)
        side.update(u)
        return u

    # -- tracking and the warm-up ---------------------------------------------------------

    def follow(self, side: ControllerSide, lp: Loop, m: Measured) -> tuple[str, float] | None:
        """What loop ``lp`` tracks in this sample, or None: it runs in its own mode.

        ``lp`` follows the loop ``lp.follows`` names (a cascade's primary its
        secondary).  While that loop is open, ``lp``'s output is a setpoint
        nobody follows, and a loop left in AUTO would integrate its error
        (windup).  That loop is open

        * while it is not in AUTO (the operator's manual acts on it): ``lp``
          tracks its measurement (a cascade's ``y2``), the setpoint that makes
          its error zero (Åström 1987, section 3, "Cascade Control" and
          tracking; Åström & Hägglund 2006, cascade control), so that closing
          the cascade again is bumpless for both loops;
        * while its measurement is bad (quality flag false or not finite),
          whatever its mode (in AUTO it outputs its safe value or holds):
          ``lp`` holds its last output, and the first good measurement
          continues from it.

        Only a loop in AUTO is made to track (one the user put in manual keeps
        its manual value).  Returns ``("y2", y2)`` or ``("hold", last output)``.
        """
        w = side.ctrls[lp.role]
        if not w.auto:
            return None
        leader = next(x for x in self.loops if x.role == lp.follows)
        value = m.value(leader.pv)
        if not (m.good(leader.ok) and math.isfinite(value)):
            held = w.out
            return ("hold", held) if math.isfinite(held) else None
        if side.ctrls[leader.role].auto:
            return None
        return (leader.pv, float(value))

    def hold_for_warmup(self, side: ControllerSide, u0: float, y2: float) -> None:
        """Every loop in manual at its output in the steady state of the MV ``u0``.

        An MV loop holds ``u0``; a loop whose output is the setpoint of a loop
        on ``y2`` (a cascade's primary) holds ``y2``, the inner measurement in
        that steady state.
        """
        for lp in self.loops:
            feeds_y2 = any(x.sp == lp.role and x.pv == "y2" for x in self.loops)
            set_manual(side.ctrls[lp.role].block, True, y2 if feeds_y2 else u0)

