"""Loop structures, each described once, and the controller side that runs them.

A :class:`Structure` is everything ctrlblocks knows about one loop structure:
the roles of the blocks in a controller entry (:attr:`Structure.roles`) and
its other keys (:attr:`Structure.options`), how an entry is read
(:meth:`Structure.parse`), which measurements it reads
(:attr:`Structure.measurements`), which blocks write the MV
(:attr:`Structure.mv_roles`), which block an event acts on by default
(:attr:`Structure.event_target`), and the two phases of one sample
(:meth:`Structure.compute`, :meth:`Structure.update`).  :data:`STRUCTURES`
holds one object per structure; the simulator's and the runtime's tables are
derived from it, so adding a structure (split range, ratio, ...) is one new
:class:`Structure` subclass and its tests.

:class:`ControllerSide` holds the blocks of one controller entry (a
scenario's, or a runtime loop's) and runs them for the structure in Åström's
computational order (Åström 1987, section 6, Listing 6.3):

1. the caller reads the measurements (``y``; ``y2`` of a cascade's or an
   override's inner variable; ``dv``, the measured disturbance of a
   feed-forward structure) -- *Adin*;
2. :meth:`ControllerSide.compute` -- *ComputeOutput* of every block and
   *ShapeOutput* (the primary's output is the secondary's setpoint; the min
   or max selector of an override; while a cascade's inner loop is open
   its primary tracks ``y2`` or holds, :meth:`Cascade.follow_value`) -- returns
   the MV; no block state is committed;
3. the caller writes the MV -- *Daout*;
4. :meth:`ControllerSide.update` -- *UpdateState* of every block with the
   value actually applied (the secondary's ``awout`` goes to the primary's
   ``awin`` first: the AW handshake of Nowak et al. 2018, section 5, and
   Åström 1987, section 3; every override block tracks the selected MV,
   Åström 1987, Figs. 3.8/3.9; the Smith predictor's models advance with the
   MV, Nowak et al. 2018, section 3.1).

:meth:`ControllerSide.step` is 2 + 4 in one call, for a caller that applies
the MV as computed (the runtime).

Structures and what they read (``structure`` -> measurements):

=============  ==========================================================
``single``     ``y``
``cascade``    ``y`` (primary), ``y2`` (secondary)
``override``   ``y`` and/or ``y2``, as each block's ``measure`` says
``feedforward``  ``y``, ``dv`` (through the lead-lag into the PID's ``ff``)
``smith``      ``y`` (the controller sees ``y + y_model_fast - y_model``)
``split_range``  ``y``; one controller, two actuators (:mod:`.split`)
``ratio``      ``y`` (the controlled flow), ``w`` (the wild flow; the
               setpoint input is the ratio, :mod:`.ratio`)
``pulse_width``  ``y``; the controller output through a PWM (on/off MV)
``three_step``  ``y``, ``y2`` (the valve position: end switches, feedback);
               a step controller's OPEN/CLOSE commands are the MV
``scheduled``  ``y``; the controller's parameters follow the setpoint or ``y``
``heat_cool``  ``y``; a HeatCoolPID's heat and cool outputs on two actuators
``open_loop``  none (the block is driven by the setpoint)
=============  ==========================================================

Actuators: a structure writes one MV, except ``split_range`` and
``heat_cool``, which write two (:attr:`Structure.actuators`; :meth:`ControllerSide.actuator_values`
maps the controller output to them).

Quality flags (``y_ok``, ``y2_ok``, ``dv_ok``, ``w_ok``): a block is called
with the flag of what it measures (cascade: primary ``y_ok``, secondary
``y2_ok``; override: every block ``y_ok and y2_ok``); a bad ``dv`` freezes
the lead-lag (not called) and keeps its last output as ``ff``; a bad ``w``
makes the ratio station hold the last good setpoint.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import math
from typing import Any, ClassVar

from ..blocks.adrc import ADRC
from ..blocks.base import Mode, ParameterError
from ..blocks.heatcool import HeatCoolPID
from ..blocks.leadlag import LeadLag
from ..blocks.pid import PID
from ..blocks.protocols import Controller
from ..blocks.pwm import PulseWidth
from ..blocks.schedule import GainSchedule
from ..blocks.stepper import StepController
from .ratio import RatioConfig, RatioStation
from .spec import BlockSpec, ControllerSpec, SpecReader, TuneHook, build
from .split import SplitRange
from .toml import KeyPathError

__all__ = [
    "STRUCTURES",
    "ControllerSide",
    "Structure",
    "parse_controller",
    "read_controller",
    "set_manual",
]

_ENTRY_KEYS = ("name", "color", "style")  # keys of every controller entry
_CONTROLLERS = (PID, ADRC)  # the shipped two-phase controllers (blocks.protocols.Controller)


class _Controller:
    """Uniform two-phase access to a controller block.

    A :class:`~ctrlblocks.blocks.protocols.Controller` (PID, ADRC, a block of
    your own with that interface) runs in two phases with ``pv_ok`` and
    ``dt``; its ``ff`` input is wired when its ``compute_output`` has one (the
    feed-forward structure refuses a main block without it when the file is
    read).  Any other block is called once per sample as ``block(sp, y)``,
    with NaN for an invalid measurement.
    """

    def __init__(self, block: Any) -> None:
        self.block = block
        # PID and ADRC satisfy the protocol by construction; its runtime check (hasattr of
        # every member) costs ~0.1 ms, once per block of every simulated run
        self.two_phase = type(block) in _CONTROLLERS or isinstance(block, Controller)
        self.ok_name = "pv_ok" if self.two_phase else None
        self.takes_dt = self.two_phase
        self.takes_ff = _takes_ff(type(block)) if self.two_phase else _has_ff(block)

    def _inputs(self, y: float, ok: bool, dt: float | None) -> tuple[float, dict[str, Any]]:
        """``y`` and the keyword arguments for the quality flag and ``dt``."""
        kw: dict[str, Any] = {}
        if self.ok_name is not None:
            kw[self.ok_name] = ok
        elif not ok:
            y = math.nan  # a block without a quality flag sees an invalid value
        if dt is not None and self.takes_dt:
            kw["dt"] = dt
        return y, kw

    def output(
        self, sp: float, y: float, ok: bool, ff: float = 0.0, dt: float | None = None
    ) -> float:
        y, kw = self._inputs(y, ok, dt)
        if self.takes_ff:
            kw["ff"] = ff
        if self.two_phase:
            return float(self.block.compute_output(sp, y, **kw))
        return float(self.block(sp, y, **kw))

    def cycle(self, sp: float, y: float, ok: bool, dt: float | None = None) -> float:
        """The whole cycle in one call, ``block(sp, y, ...)``: compute, then update with ``v``.

        The blocks document it as identical to ``compute_output`` +
        ``update_state(v)`` (their fast lane; tests/fast checks it).
        """
        y, kw = self._inputs(y, ok, dt)
        return float(self.block(sp, y, **kw))

    def update(self, applied: float, measured: float | None = None) -> None:
        """UpdateState with the applied value.

        ``measured`` is the actuator's real output of this sample (after load,
        rate and range).  It is wired where the block is configured to use a
        measured MV: the PID's ``actuator_pos`` input (BACK_CALC_REAL,
        controltheplant 2024) and the ADRC's ``u_real`` (``u_real_on``,
        Nowak et al. 2018, section 5).
        """
        if not self.two_phase:
            return
        b = self.block
        if measured is not None:
            if hasattr(b, "actuator_pos"):
                b.actuator_pos = measured
            if getattr(getattr(b, "config", None), "u_real_on", False):
                applied = measured
        b.update_state(applied)


def _has_ff(fn: Any) -> bool:
    """Whether the callable ``fn`` takes a keyword ``ff``."""
    try:
        return "ff" in inspect.signature(fn).parameters
    except (TypeError, ValueError):  # pragma: no cover - builtins without signature
        return False


@functools.lru_cache(maxsize=256)
def _takes_ff(cls: type) -> bool:
    """Whether ``compute_output`` of the two-phase blocks of ``cls`` takes ``ff`` (read once)."""
    return _has_ff(cls.compute_output)


def _in_auto(block: Any) -> bool:
    """Whether ``block`` runs its own law (``mode`` AUTO; without a mode: not ``manual``)."""
    mode = getattr(block, "mode", None)
    if mode is not None:
        return mode == Mode.AUTO
    return not getattr(block, "manual", False)


def _follow(block: Any, value: float) -> tuple[str, Any, Any] | None:
    """Make ``block`` output ``value`` in the next compute; what :func:`_restore` puts back.

    A block with a track input (the PID: mode TRACK, ``track_value``, Åström
    1987, Fig. 4.4: the integrator is set so that ``P + I + D + FF`` is the
    output, and the first cycle back in AUTO continues from it) tracks;
    one with only a manual mode (the ADRC) runs that cycle in manual at
    ``value``, which solves x4 by (11) of Nowak et al. 2018 and re-solves it
    in its first cycle back in AUTO.  The mode inputs are the user's: they
    are put back right after the compute (the blocks commit the mode of the
    computed cycle, so the manual value still follows the output, In/Out).
    """
    if hasattr(block, "track"):
        saved = ("track", block.track, block.track_value)
        block.track, block.track_value = True, value
        return saved
    if hasattr(block, "manual") and hasattr(block, "manual_value"):
        saved = ("manual", block.manual, block.manual_value)
        block.manual, block.manual_value = True, value
        return saved
    return None  # a block with neither runs its own law


def _restore(block: Any, saved: tuple[str, Any, Any] | None) -> None:
    """Put back the mode inputs :func:`_follow` changed."""
    if saved is None:
        return
    name, on, value = saved
    if name == "track":
        block.track, block.track_value = on, value
    else:
        block.manual, block.manual_value = on, value


def set_manual(block: Any, on: bool, value: float | None = None) -> None:
    """Switch ``block`` to manual (``on``) or auto, with a new manual value when given."""
    if value is not None:
        if hasattr(block, "manual_value"):
            block.manual_value = value
        elif hasattr(block, "u_man"):
            block.u_man = value
    if hasattr(block, "manual"):
        block.manual = on


# ---------------------------------------------------------------------------
# The structures
# ---------------------------------------------------------------------------


class Structure:
    """One loop structure, described once (module docstring).

    Class attributes
    ----------------
    name : str
        The ``structure = "..."`` of a scenario or a runtime loop.
    roles : tuple of str
        The keys of a controller entry that hold its blocks (``override``:
        ``blocks``, an array of block tables).
    options : tuple of str
        The entry's other keys (``aw_handshake``, ``selector``).
    measurements : tuple of str
        What :meth:`compute` reads: ``y``, ``y2``, ``dv`` (an override reads
        what its blocks' ``measure`` keys name, :meth:`measurements_of`).
    mv_roles : tuple of str
        The roles of the blocks whose output is (or is selected as) the MV;
        mode, manual value and MV limits act on them (``blocks``: every
        override block).
    event_target : str
        The block an event with no ``target`` acts on.
    series_plant : bool
        The process has an inner plant (``u -> y2``) before the plant.
    runtime : bool
        The runtime runs it (a controller against process I/O).
    tuned_roles : tuple of str
        Roles whose table may hold a ``tune`` table (a bump test on the plant).
    actuators : int
        How many MVs the structure writes (``split_range``: 2).
    setpoint_signal : str or None
        The signal of :attr:`ControllerSide.values` that is the setpoint of
        ``y`` when the structure's setpoint input is something else (the
        ratio structure: ``sp_flow``); None: the setpoint input itself.
    closed_loop : bool
        The structure measures a plant and closes a loop around it (False:
        ``open_loop``, a block driven by the setpoint profile, no plant).
    margins_on_plant : bool
        The main block alone closes the loop around the plant, so its
        stability margins on a linear plant model are the loop's (the
        simulator's report analyses them).
    lone_block : bool
        The structure is one block and nothing else: a runtime loop gives it as
        its ``block`` table (not as a controller entry), and live tuning may
        retune it.
    array_roles : tuple of str
        Roles that hold an ARRAY of block tables (``override``: ``blocks``).
    optional_measurements : tuple of str
        Measurements of :attr:`measurements` a runtime loop may leave unbound
        (``three_step``: ``y2``, the valve position; without it the step
        controller runs on its own position estimate).
    output_tags : tuple of str
        Optional output tags a runtime loop may bind besides its MV, written
        with it (``three_step``: the ``open`` and ``close`` bits,
        :meth:`output_values`).
    scheduled : bool
        The structure sets some of the controller's parameters itself every
        sample (:meth:`scheduled_parameters`).
    """

    name: ClassVar[str]
    roles: ClassVar[tuple[str, ...]]
    options: ClassVar[tuple[str, ...]] = ()
    measurements: ClassVar[tuple[str, ...]] = ("y",)
    mv_roles: ClassVar[tuple[str, ...]] = ("main",)
    event_target: ClassVar[str] = "main"
    series_plant: ClassVar[bool] = False
    runtime: ClassVar[bool] = True
    tuned_roles: ClassVar[tuple[str, ...]] = ("main",)
    actuators: ClassVar[int] = 1
    setpoint_signal: ClassVar[str | None] = None
    compiled_lane: ClassVar[str | None] = None
    """The wiring of the simulator's compiled lane for this structure
    (``ctrlblocks.fast.simlane.WIRINGS``, run by ``ctrlblocks.sim.dispatch``); None: none."""
    closed_loop: ClassVar[bool] = True
    margins_on_plant: ClassVar[bool] = False
    lone_block: ClassVar[bool] = False
    array_roles: ClassVar[tuple[str, ...]] = ()
    optional_measurements: ClassVar[tuple[str, ...]] = ()
    output_tags: ClassVar[tuple[str, ...]] = ()

    def runtime_tables(self) -> tuple[str, ...]:
        """The keys of a runtime loop table that hold this structure's blocks and options."""
        return ("block",) if self.lone_block else (*self.roles, *self.options)

    def measurements_in(self, entry: Any) -> tuple[str, ...]:
        """What a controller entry (a raw table) makes the structure read, before parsing
        (an override: what its blocks' ``measure`` keys name, ``y`` by default)."""
        return self.measurements

    # -- reading a controller entry -------------------------------------------------

    def parse(
        self, r: SpecReader, e: dict[str, Any], key: str, ts: float, tune: TuneHook | None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """The blocks (role -> BlockSpec) and the options of the controller entry ``e``."""
        r.check_keys(e, {*_ENTRY_KEYS, *self.roles, *self.options}, key)
        blocks = {
            role: r.role(e, role, key, ts, tune if role in self.tuned_roles else None)
            for role in self.roles
        }
        return blocks, {}

    # -- the controller side ----------------------------------------------------------

    def setup(self, side: ControllerSide) -> None:
        """Build the side's blocks (role -> block) from its spec."""
        for role, s in side.spec.blocks.items():
            side.blocks[role] = side.make(s, "block")

    def controller_roles(self, side: ControllerSide) -> list[str]:
        """The roles of the blocks used as controllers (two-phase, quality flag)."""
        return [r for r in side.blocks if r != "feedforward"]

    def mv_roles_of(self, side: ControllerSide) -> list[str]:
        """The roles of :attr:`mv_roles` in this side (an override: every block)."""
        return list(self.mv_roles)

    def measurements_of(self, side: ControllerSide) -> tuple[str, ...]:
        """The measurements this side's :meth:`compute` reads."""
        return self.measurements

    def hold_for_warmup(self, side: ControllerSide, u0: float, y2: float) -> None:
        """Put the controllers in manual, each at its output in the steady state of ``u0``.

        The simulator's warm-up (``initial.warmup``): with the plant in the
        steady state of the initial MV ``u0`` (``y2``: the inner plant's
        output there, if there is one) the controllers' bumpless logic then
        initialises their states consistently.  Default: every controller
        holds ``u0``.
        """
        for ctrl in side.ctrls.values():
            set_manual(ctrl.block, True, u0)

    def step(
        self, side: ControllerSide, sp: float, y: float, y_ok: bool, dt: float | None,
        measurements: dict[str, Any],
    ) -> float:  # fmt: skip
        """One whole sample (:meth:`ControllerSide.step`): compute, then update with the MV."""
        u = side.compute(sp, y, y_ok=y_ok, dt=dt, **measurements)
        side.update(u)
        return u

    def compute(self, side: ControllerSide, sp: float, m: _Measured) -> tuple[float, dict]:
        """ComputeOutput and ShapeOutput: the MV and the structure's signals."""
        raise NotImplementedError

    def update(self, side: ControllerSide, u: float, measured: float | None) -> None:
        """UpdateState of every block with the applied MV ``u``."""
        raise NotImplementedError

    def reset_models(self, side: ControllerSide) -> None:
        """Put the structure's own models (if any) in the steady state of ``side.u0``."""

    def actuator_values(self, spec: ControllerSpec, u: float) -> tuple[float, ...]:
        """The :attr:`actuators` MVs written for the controller output ``u`` (one: ``u``)."""
        return (u,)

    def output_values(self, spec: ControllerSpec, u: float) -> dict[str, float]:
        """The values of the :attr:`output_tags` for the MV ``u`` (none by default)."""
        return {}

    def off_mv(self, spec: ControllerSpec) -> float | None:
        """The MV that switches the output stage off, or None (no stage).

        A structure whose MV is an output block's (a pulse-width output, a
        step controller's motor commands) has a fixed off state; a runtime
        loop writes it on stop and in place of a non-finite MV, not the
        controller's safe value (which is a controller output).
        """
        return None

    def scheduled_parameters(self, spec: ControllerSpec) -> tuple[str, ...]:
        """The controller parameters the structure sets itself every sample (none)."""
        return ()

    def compiled_blockers(self, side: ControllerSide) -> list[str]:
        """Why the simulator's compiled lane cannot run ``side`` (empty: it can).

        The one decision on the controller side: the structure needs a
        compiled loop (:attr:`compiled_lane`) and every controller block must
        be one the kernels cover, as the block itself says
        (``fast_path_blockers``, e.g. :meth:`ctrlblocks.PID.fast_path_blockers`).
        """
        if not self.compiled_lane:
            return [f"structure {self.name!r} has no compiled loop"]
        bad = []
        for role in self.lane_roles(side):
            block = side.blocks[role]
            check = getattr(block, "fast_path_blockers", None)
            if check is None:
                bad.append(f"{role}: {type(block).__name__} has no compiled kernel")
            else:
                bad += [f"{role}: {why}" for why in check(manual_ok=True)]
        return bad

    def lane_roles(self, side: ControllerSide) -> list[str]:
        """The roles of the compiled lane's controllers, in its wiring's order."""
        return self.controller_roles(side)

    def lane_options(self, side: ControllerSide) -> dict[str, Any]:
        """The wiring's inputs of the compiled lane besides the controllers
        (keyword arguments of ``ctrlblocks.fast.simlane.lane_loop``)."""
        return {}

    def lane_signals(self, side: ControllerSide) -> tuple[str, ...]:
        """The names of the lane's ``LaneResult.signals`` (:attr:`ControllerSide.values`)."""
        return ()


@dataclasses.dataclass(frozen=True)
class _Measured:
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


class Single(Structure):
    """One controller, one plant; the entry is the block table itself."""

    name = "single"
    roles = ("main",)
    compiled_lane = "single"
    margins_on_plant = True
    lone_block = True

    def parse(self, r, e, key, ts, tune):
        table = {k: v for k, v in e.items() if k not in _ENTRY_KEYS}
        spec = r.block_spec(table, key, ts, kind="block", tune=tune, table_keys=_ENTRY_KEYS)
        return {"main": spec}, {}

    def compute(self, side, sp, m):
        return side.ctrls["main"].output(sp, m.y, m.y_ok, 0.0, m.dt), {}

    def update(self, side, u, measured):
        side.ctrls["main"].update(u, measured=measured)

    def step(self, side, sp, y, y_ok, dt, measurements):
        # the block's one call: the same result as the two phases, on its fast lane
        u = side.u = side.ctrls["main"].cycle(sp, y, y_ok, dt)
        side.values = {"v": u}
        return u


class OpenLoop(Single):
    """A block driven by the setpoint profile (Åström 1987, Fig. 5.2: jump and rate)."""

    name = "open_loop"
    lone_block = False
    compiled_lane = None
    measurements = ()
    runtime = False
    tuned_roles = ()
    closed_loop = False
    margins_on_plant = False
    step = Structure.step

    def parse(self, r, e, key, ts, tune):
        return super().parse(r, e, key, ts, None)

    def controller_roles(self, side):
        return []

    def compute(self, side, sp, m):
        return float(side.blocks["main"](sp)), {}

    def update(self, side, u, measured):
        pass


class Cascade(Structure):
    """The primary's output is the secondary's setpoint; the AW handshake between them."""

    name = "cascade"
    roles = ("primary", "secondary")
    options = ("aw_handshake",)
    measurements = ("y", "y2")
    mv_roles = ("secondary",)
    event_target = "primary"
    series_plant = True
    tuned_roles = ()
    compiled_lane = "cascade"

    def lane_signals(self, side):
        return ("sp2",)

    def lane_options(self, side):
        return {"handshake": side.aw_handshake and hasattr(side.blocks["primary"], "awin")}

    def parse(self, r, e, key, ts, tune):
        r.check_keys(e, {*_ENTRY_KEYS, *self.roles, *self.options}, key)
        hs = e.get("aw_handshake", True)
        if not isinstance(hs, bool):
            raise r.fail(f"{key}.aw_handshake", f"must be true or false, got {hs!r}")
        return {role: r.role(e, role, key, ts) for role in self.roles}, {"aw_handshake": hs}

    def compute(self, side, sp, m):
        prim = side.blocks["primary"]
        follow = self.follow(side, m)
        if follow is None:
            side.tracking = {}
            v1 = side.ctrls["primary"].output(sp, m.y, m.y_ok, dt=m.dt)
        else:  # the cascade is open: the primary tracks (restored right after its compute)
            side.tracking = {"primary": follow[0]}
            saved = _follow(prim, follow[1])
            try:
                v1 = side.ctrls["primary"].output(sp, m.y, m.y_ok, dt=m.dt)
            finally:
                _restore(prim, saved)
        u = side.ctrls["secondary"].output(v1, m.y2, m.y2_ok, dt=m.dt)
        side.pending = (v1,)
        return u, {"sp2": v1}

    def follow_value(self, side: ControllerSide, m: _Measured) -> float | None:
        """What the primary tracks in this sample, or None: it runs in its own mode.

        While the inner loop is open the primary's output is a setpoint
        nobody follows, and a primary left in AUTO would integrate its error
        (windup).  The inner loop is open

        * while the secondary is not in AUTO (the operator's manual acts on
          it): the primary tracks the secondary's measurement ``y2``, the
          setpoint that makes the secondary's error zero (Åström 1987,
          section 3, "Cascade Control" and tracking; Åström & Hägglund 2006,
          cascade control), so that closing the cascade again is bumpless
          for both loops;
        * while ``y2`` is bad (quality flag false or not finite), whatever
          the secondary's mode (in AUTO it outputs its safe value or holds):
          the primary holds its last output, and the first good ``y2``
          continues from it.

        Only a primary in AUTO is made to track (a primary the user put in
        manual keeps its manual value).  :meth:`follow` also names the case.
        """
        follow = self.follow(side, m)
        return None if follow is None else follow[1]

    def follow(self, side: ControllerSide, m: _Measured) -> tuple[str, float] | None:
        """:meth:`follow_value` with what it is: ``("y2", y2)``, ``("hold", last output)``."""
        prim = side.blocks["primary"]
        if not _in_auto(prim):
            return None
        if not (m.y2_ok and math.isfinite(m.y2)):
            held = _num(getattr(prim, "out", math.nan))
            return ("hold", held) if math.isfinite(held) else None
        if _in_auto(side.blocks["secondary"]):
            return None
        return ("y2", float(m.y2))

    def hold_for_warmup(self, side, u0, y2):
        # the primary's output is the secondary's setpoint: y2 in the steady state
        set_manual(side.blocks["primary"], True, y2)
        set_manual(side.blocks["secondary"], True, u0)

    def update(self, side, u, measured):
        (v1,) = side.pending
        side.ctrls["secondary"].update(u)
        prim, sec = side.blocks["primary"], side.blocks["secondary"]
        if hasattr(prim, "awin") and side.aw_handshake:
            prim.awin = bool(getattr(sec, "awout", False))
        side.ctrls["primary"].update(v1)


class Override(Structure):
    """A min (or max) selector picks the MV of two or more controllers; all track it."""

    name = "override"
    roles = ("blocks",)
    options = ("selector",)
    measurements = ("y", "y2")
    mv_roles = ("blocks",)
    array_roles = ("blocks",)
    event_target = "blocks[0]"
    series_plant = True
    tuned_roles = ()
    compiled_lane = "override"

    def lane_signals(self, side):
        return tuple(f"v{i + 1}" for i in range(len(side.override)))

    def lane_options(self, side):
        return {
            "on_y2": [on_y2 for _, on_y2, _ in side.override],
            "sp_fixed": [math.nan if sp is None else sp for _, _, sp in side.override],
            "selector_max": side.selector == "max",
        }

    def measurements_in(self, entry):
        blocks = entry.get("blocks") if isinstance(entry, dict) else None
        used = set()
        if isinstance(blocks, list):
            used = {b.get("measure", "y") for b in blocks if isinstance(b, dict)}
        return tuple(m for m in ("y", "y2") if m in used) or ("y",)

    def parse(self, r, e, key, ts, tune):
        r.check_keys(e, {*_ENTRY_KEYS, "selector", "blocks"}, key)
        sel = r.string(e, "selector", f"{key}.selector", default="min")
        if sel not in ("min", "max"):
            raise r.fail(f"{key}.selector", f"must be 'min' or 'max', got {sel!r}")
        lst = e.get("blocks")
        if not isinstance(lst, list) or len(lst) < 2:
            raise r.fail(f"{key}.blocks", "must be an array of at least two controller tables")
        specs = []
        for j, b in enumerate(lst):
            bkey = f"{key}.blocks[{j}]"
            spec = r.block_spec(b, bkey, ts, kind="block", extra_keys=("measure", "sp"))
            meas = spec.extra.get("measure", "y")
            if meas not in ("y", "y2"):
                raise r.fail(f"{bkey}.measure", f"must be 'y' or 'y2', got {meas!r}")
            sp = spec.extra.get("sp", "sp")
            if sp != "sp" and (isinstance(sp, bool) or not isinstance(sp, (int, float))):
                raise r.fail(f"{bkey}.sp", f"must be 'sp' or a number, got {sp!r}")
            specs.append(spec)
        return {"blocks": specs}, {"selector": sel}

    def setup(self, side):
        side.override_specs = list(side.spec.blocks["blocks"])
        for i, s in enumerate(side.override_specs):
            side.blocks[f"blocks[{i}]"] = side.make(s, "block")
        # per block: its role, whether it measures y2, its fixed setpoint (None: sp)
        side.override = [
            (f"blocks[{i}]", s.extra.get("measure", "y") == "y2", _fixed_sp(s))
            for i, s in enumerate(side.override_specs)
        ]

    def mv_roles_of(self, side):
        return list(side.ctrls)

    def measurements_of(self, side):
        used = {"y2" if on_y2 else "y" for _, on_y2, _ in side.override}
        return tuple(m for m in ("y", "y2") if m in used)

    def compute(self, side, sp, m):
        ok = m.y_ok and m.y2_ok
        vs = [
            side.ctrls[role].output(
                sp if sp_i is None else sp_i, m.y2 if on_y2 else m.y, ok, dt=m.dt
            )
            for role, on_y2, sp_i in side.override
        ]
        u = min(vs) if side.selector == "min" else max(vs)
        return u, {f"v{i + 1}": vi for i, vi in enumerate(vs)}

    def update(self, side, u, measured):
        for role in side.ctrls:
            side.ctrls[role].update(u)


class FeedForward(Single):
    """The measured disturbance through a lead-lag into the controller's ``ff`` (before limits)."""

    name = "feedforward"
    lone_block = False
    compiled_lane = "feedforward"
    roles = ("main", "feedforward")
    measurements = ("y", "dv")
    margins_on_plant = False
    step = Structure.step

    def parse(self, r, e, key, ts, tune):
        blocks, opts = Structure.parse(self, r, e, key, ts, tune)
        main_block = r.build(blocks["main"], ts, kind="block")
        fn = getattr(main_block, "compute_output", main_block)
        if "ff" not in inspect.signature(fn).parameters:
            raise r.fail(
                f"{key}.main.type",
                f"{blocks['main'].type} has no feed-forward input 'ff'; "
                "the feedforward structure needs one (e.g. PID)",
            )
        return blocks, opts

    def compiled_blockers(self, side):
        bad = super().compiled_blockers(side)
        ll = side.blocks["feedforward"]
        if not isinstance(ll, LeadLag):
            bad.append(f"feedforward: {type(ll).__name__} has no compiled kernel (LeadLag has)")
        elif ll.config.precision != "float64":
            bad.append(f"feedforward: precision {ll.config.precision!r}")
        return bad

    def lane_signals(self, side):
        return ("ff",)

    def lane_options(self, side):
        return {"lead_lag": side.blocks["feedforward"]}

    def compute(self, side, sp, m):
        if m.dv_ok and math.isfinite(m.dv):
            side.ff = float(side.blocks["feedforward"](m.dv))
        ff = side.ff
        return side.ctrls["main"].output(sp, m.y, m.y_ok, ff, m.dt), {"ff": ff}


class Smith(Single):
    """Smith predictor (Nowak et al. 2018, section 3.1): ``y + y_model_fast - y_model``."""

    name = "smith"
    lone_block = False
    compiled_lane = "smith"
    roles = ("main", "model")
    margins_on_plant = False
    step = Structure.step

    def parse(self, r, e, key, ts, tune):
        r.check_keys(e, {*_ENTRY_KEYS, "main", "model"}, key)
        model = r.role(e, "model", key, ts, kind="plant")
        if "dead_time" not in model.params:
            raise r.fail(
                f"{key}.model.dead_time", "missing: the Smith predictor's model needs the dead time"
            )
        return {"main": r.role(e, "main", key, ts, tune), "model": model}, {}

    def setup(self, side):
        side.blocks["main"] = side.make(side.spec.blocks["main"], "block")
        model: BlockSpec = side.spec.blocks["model"]
        side.model = side.make(model, "plant")
        fast = dataclasses.replace(model, params={**model.params, "dead_time": 0.0})
        side.model_fast = side.make(fast, "plant")
        self.reset_models(side)

    def compute(self, side, sp, m):
        y_fb = m.y + side.model_fast.y - side.model.y
        return side.ctrls["main"].output(sp, y_fb, m.y_ok, 0.0, m.dt), {"y_pred": y_fb}

    def update(self, side, u, measured):
        side.ctrls["main"].update(u, measured=measured)
        side.model.step(u)
        side.model_fast.step(u)

    def lane_signals(self, side):
        return ("y_pred",)

    def lane_options(self, side):
        return {"models": (side.model, side.model_fast)}

    def reset_models(self, side):
        side.model.reset(side.u0)
        side.model_fast.reset(side.u0)


class SplitRangeStructure(Structure):
    """One controller, two actuators by a static split of its output (:mod:`.split`).

    The entry has the controller table ``main`` and the split table ``split``
    (``split``, ``gap``, ``a``, ``b`` of :class:`~.split.SplitRange`); the
    split's combined range is the controller's limits ``u_min..u_max`` (its
    anti-windup acts when both actuators are at their far ends).  The
    controller output ``v`` is continuous and the MVs ``u_a = a(v)``,
    ``u_b = b(v)`` are continuous functions of it: no bump when the active
    actuator changes.  Signals: ``u_a``, ``u_b`` and their limit status
    codes ``a_status``, ``b_status`` (0 active, 1 idle, 2 limit).
    """

    name = "split_range"
    roles = ("main",)
    options = ("split",)
    actuators = 2

    def parse(self, r, e, key, ts, tune):
        r.check_keys(e, {*_ENTRY_KEYS, "main", "split"}, key)
        main = r.role(e, "main", key, ts, tune)
        block = r.build(main, ts, kind="block")
        lo, hi = float(getattr(block, "u_min", math.nan)), float(getattr(block, "u_max", math.nan))
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise r.fail(
                f"{key}.main.u_min",
                "the split range needs the controller's finite limits u_min and u_max "
                "(they are the two actuators' combined range)",
            )
        table = r.table(e, "split", f"{key}.split", False)
        r.check_keys(table, {"split", "gap", "a", "b"}, f"{key}.split")
        try:
            split = SplitRange.from_table(table, lo, hi)
        except ParameterError as exc:
            raise r.fail(f"{key}.split.{exc.field}", exc.message) from None
        except TypeError as exc:  # pragma: no cover - keys are checked above
            raise r.fail(f"{key}.split", str(exc)) from None
        return {"main": main}, {"split": split}

    def compute(self, side, sp, m):
        u = side.ctrls["main"].output(sp, m.y, m.y_ok, 0.0, m.dt)
        split: SplitRange = side.spec.options["split"]
        a, b = split(u)
        sa, sb = split.status(u)
        return u, {"u_a": a, "u_b": b, "a_status": float(sa), "b_status": float(sb)}

    def update(self, side, u, measured):
        side.ctrls["main"].update(u)  # the controller tracks its own (continuous) output

    def actuator_values(self, spec, u):
        return spec.options["split"](u)


class RatioStructure(Structure):
    """Ratio control: the station's ``bias + r w`` is the flow loop's setpoint (:mod:`.ratio`).

    The structure's setpoint input is the requested *ratio*; ``w`` is the
    wild flow and ``y`` the controlled flow.  The entry has the flow
    controller ``main`` and the station table ``ratio`` (``r_min``,
    ``r_max``, ``bias``, ``rate`` of :class:`~.ratio.RatioConfig`).
    Signals: ``sp_flow`` (the flow setpoint), ``ratio`` (the working ratio),
    ``wild`` (the last good wild flow), ``wild_hold`` (1 while a bad wild
    flow holds the setpoint) and ``ratio_limited`` (1 while the request is
    outside the ratio limits).
    """

    name = "ratio"
    roles = ("main",)
    options = ("ratio",)
    measurements = ("y", "w")
    setpoint_signal = "sp_flow"

    def parse(self, r, e, key, ts, tune):
        r.check_keys(e, {*_ENTRY_KEYS, "main", "ratio"}, key)
        main = r.role(e, "main", key, ts, tune)
        table = r.table(e, "ratio", f"{key}.ratio", False)
        r.check_keys(table, {"r_min", "r_max", "bias", "rate"}, f"{key}.ratio")
        kw = {}
        for name in ("r_min", "r_max", "bias", "rate"):
            if name in table:
                kw[name] = r.number(table, name, f"{key}.ratio.{name}")
        try:
            cfg = RatioConfig(**kw, ts=ts)
        except ParameterError as exc:
            raise r.fail(f"{key}.ratio.{exc.field}", exc.message) from None
        return {"main": main}, {"ratio": cfg}

    def setup(self, side):
        super().setup(side)
        side.aux = RatioStation(side.spec.options["ratio"])

    def update(self, side, u, measured):
        side.ctrls["main"].update(u, measured=measured)

    def compute(self, side, sp, m):
        st: RatioStation = side.aux
        sp_flow = st(sp, m.w, m.w_ok, m.dt)
        u = side.ctrls["main"].output(sp_flow, m.y, m.y_ok, 0.0, m.dt)
        return u, {
            "sp_flow": sp_flow,
            "ratio": st.ratio,
            "wild": st.wild,
            "wild_hold": float(st.holding),
            "ratio_limited": float(st.limited),
        }


class _OutputStage(Structure):
    """A controller whose continuous output drives an output block that makes the MV.

    The controller tracks its own output (the output block realises it on
    average: a PWM duty, a motor's travel), so its anti-windup and modes are
    unchanged.  Subclasses name the output block's table (:attr:`stage_key`)
    and its class; without the table the controller output is the MV (the
    continuous reference in the same scenario).
    """

    roles = ("main",)
    stage_key: ClassVar[str]
    stage_block: ClassVar[type]
    stage_options: ClassVar[tuple[str, ...]] = ()

    def parse(self, r, e, key, ts, tune):
        r.check_keys(e, {*_ENTRY_KEYS, "main", self.stage_key}, key)
        main = r.role(e, "main", key, ts, tune)
        opts: dict[str, Any] = {}
        if self.stage_key in e:
            tkey = f"{key}.{self.stage_key}"
            table = r.table(e, self.stage_key, tkey, True)
            opts = {k: table[k] for k in self.stage_options if k in table}
            params = {k: v for k, v in table.items() if k not in self.stage_options}
            spec = r.block_spec(
                {"type": self.stage_block.__name__, **params},
                tkey,
                ts,
                kind="block",
                table_keys=self.stage_options,
            )
            opts[self.stage_key] = spec
        return {"main": main}, opts

    def setup(self, side):
        super().setup(side)
        spec = side.spec.options.get(self.stage_key)
        side.aux = None if spec is None else side.make(spec, "block")

    def controller_roles(self, side):
        return ["main"]

    def compute(self, side, sp, m):
        v = side.ctrls["main"].output(sp, m.y, m.y_ok, 0.0, m.dt)
        side.pending = (v,)
        if side.aux is None:
            return v, {"v_ctrl": v}
        return self.stage(side, v, m)

    def stage(self, side: ControllerSide, v: float, m: _Measured) -> tuple[float, dict]:
        """The output block's MV for the controller output ``v``, and its signals."""
        raise NotImplementedError

    def off_mv(self, spec):
        if self.stage_key not in spec.options:
            return None  # no output block: the controller output is the MV
        return self.stage_off(spec.options[self.stage_key])

    def stage_off(self, stage: BlockSpec) -> float:
        """The MV of the output block's off state (stop, a non-finite MV)."""
        raise NotImplementedError

    def update(self, side, u, measured):
        (v,) = side.pending
        side.ctrls["main"].update(v)


class PulseWidthStructure(_OutputStage):
    """A controller and a pulse-width output (:class:`~ctrlblocks.PulseWidth`): an on/off MV.

    ``[controllers.pwm]`` holds the PulseWidth parameters (``period``,
    ``t_min_on``, ``t_min_off``, ``in_lo``, ``in_hi``); the MV is ``in_hi``
    while the output is on and ``in_lo`` while it is off (a heater's full
    power or none).  Signals: ``v_ctrl`` (the controller output), ``duty``.
    """

    name = "pulse_width"
    options = ("pwm",)
    stage_key = "pwm"
    stage_block = PulseWidth

    def stage(self, side, v, m):
        pwm: PulseWidth = side.aux
        on = pwm(v, m.dt)
        c = pwm.config
        return c.in_lo + on * (c.in_hi - c.in_lo), {"v_ctrl": v, "duty": pwm.duty}

    def stage_off(self, stage):
        return float(stage.params.get("in_lo", PulseWidth.Config.in_lo))  # the output off


class ThreeStepStructure(_OutputStage):
    """A controller and a three-point step controller (:class:`~ctrlblocks.StepController`).

    The controller's output is the valve position it demands [%]; the step
    controller turns it into OPEN (+1) / CLOSE (-1) motor commands, the MV.
    The process is ``[inner_plant]`` = the motorised valve
    (:class:`~ctrlblocks.plants.MotorValve`, ``y2`` = its position) in series
    with ``[plant]``.  The valve's end switches are its position at 0 and at
    the span; ``feedback = true`` in ``[controllers.stepper]`` also wires the
    position as feedback.  Signals: ``demand``, ``position_est`` (the block's
    estimate), ``est_error`` (``|estimate - position|``), ``pulses`` (pulses
    started so far).
    """

    name = "three_step"
    options = ("stepper",)
    measurements = ("y", "y2")
    optional_measurements = ("y2",)
    output_tags = ("open", "close")
    series_plant = True
    tuned_roles = ()
    stage_key = "stepper"
    stage_block = StepController
    stage_options = ("feedback",)

    def parse(self, r, e, key, ts, tune):
        blocks, opts = super().parse(r, e, key, ts, tune)
        fb = opts.get("feedback", False)
        if not isinstance(fb, bool):
            raise r.fail(f"{key}.stepper.feedback", f"must be true or false, got {fb!r}")
        return blocks, opts

    def stage(self, side, v, m):
        sc: StepController = side.aux
        span = sc.config.span
        pos = m.y2
        known = m.y2_ok and math.isfinite(pos)
        cmd = sc(
            v,
            m.dt,
            open_limit=known and pos >= span,
            close_limit=known and pos <= 0.0,
            feedback=pos if side.spec.options.get("feedback") and known else None,
        )
        est_error = abs(sc.position - pos) if known else math.nan
        return float(cmd), {
            "demand": v,
            "position_est": sc.position,
            "est_error": est_error,
            "pulses": float(sc.pulses),
        }

    def stage_off(self, stage):
        return 0.0  # the motor stopped: the valve stays where it is

    def output_values(self, spec, u):
        # a three-point actuator's two relays: OPEN and CLOSE, never both
        return {"open": 1.0 if u > 0.0 else 0.0, "close": 1.0 if u < 0.0 else 0.0}


class ScheduledStructure(Structure):
    """Gain scheduling: the parameters follow the setpoint or the measurement (GainSchedule).

    ``[controllers.schedule]`` holds ``on`` (the scheduling variable: ``"sp"``,
    the setpoint, or ``"y"``, the measurement), ``breakpoints`` and, per
    parameter, its values at the breakpoints (``kp = [...]``, ``ti = [...]``).
    Every sample the schedule retunes the controller for ``w`` (through its
    ``configure``, bumplessly; only when the parameters change) before it
    computes.  The retune keeps the output continuous at the change and runs
    the new law from the same sample (the PID's integrator by
    ``pid.retune_states``, the ADRC's x4 by ``adrc.retune_x4``), so a
    schedule on the measurement, which retunes every sample, acts as the
    interpolated law.  Signals: ``w`` (the scheduling variable) and the
    scheduled parameters.
    """

    name = "scheduled"
    roles = ("main",)
    options = ("schedule",)

    def parse(self, r, e, key, ts, tune):
        r.check_keys(e, {*_ENTRY_KEYS, "main", "schedule"}, key)
        main = r.role(e, "main", key, ts, tune)
        skey = f"{key}.schedule"
        table = dict(r.table(e, "schedule", skey, True))
        on = table.pop("on", "sp")
        if on not in ("sp", "y"):
            raise r.fail(f"{skey}.on", f"must be 'sp' or 'y', got {on!r}")
        bps = table.pop("breakpoints", None)
        if not isinstance(bps, list) or not table:
            raise r.fail(skey, "needs breakpoints = [...] and at least one parameter = [...]")
        block = r.build(main, ts, kind="block")
        fields = {f.name for f in dataclasses.fields(block.config)} - {"precision"}
        r.check_keys(table, fields | {"on", "breakpoints"}, skey)  # a parameter of the block
        try:
            GainSchedule(block, breakpoints=bps, **table)
        except ParameterError as exc:
            raise r.fail(f"{skey}.{exc.field}", exc.message) from None
        except (TypeError, ValueError) as exc:
            raise r.fail(skey, str(exc)) from None
        return {"main": main}, {"schedule": {"on": on, "breakpoints": bps, **table}}

    def scheduled_parameters(self, spec):
        return tuple(k for k in spec.options["schedule"] if k not in ("on", "breakpoints"))

    def setup(self, side):
        super().setup(side)
        sched = dict(side.spec.options["schedule"])
        sched.pop("on")
        side.aux = GainSchedule(side.blocks["main"], **sched)

    def compute(self, side, sp, m):
        gs: GainSchedule = side.aux
        # retune the controller for w = sp or y (a bad w keeps the parameters in force)
        on_y = side.spec.options["schedule"]["on"] == "y"
        gs.schedule((m.y if m.y_ok else math.nan) if on_y else sp)
        u = side.ctrls["main"].output(sp, m.y, m.y_ok, 0.0, m.dt)
        return u, {"w": gs.w, **gs.parameters}

    def update(self, side, u, measured):
        side.ctrls["main"].update(u, measured=measured)


class HeatCoolStructure(Structure):
    """A heating/cooling controller (:class:`~ctrlblocks.HeatCoolPID`) on two actuators.

    The entry's ``main`` table is the HeatCoolPID; its output is ``heat -
    cool`` [%] (one of them is zero), which the structure writes as two MVs:
    actuator A the cooler (``max(0, -u)``), actuator B the heater
    (``max(0, u)``) -- the inputs ``u`` and ``u2`` of the shipped two-input
    plant :class:`~ctrlblocks.plants.HeatCool`.  With PWM outputs the MVs are
    0 or 100 %.  The block tracks its own demand (its PID's anti-windup acts
    at the demand's limits).  Signals: ``heat``, ``cool``, ``v_ctrl`` (the
    demand ``v``) and ``cooling`` (1 while the cooling parameter set is in force).
    """

    name = "heat_cool"
    roles = ("main",)
    actuators = 2
    tuned_roles = ()
    runtime = False  # the runtime's loops run PID or ADRC blocks (runtime/config.py)

    def parse(self, r, e, key, ts, tune):
        r.check_keys(e, {*_ENTRY_KEYS, "main"}, key)
        main = r.role(e, "main", key, ts)
        if not isinstance(r.build(main, ts, kind="block"), HeatCoolPID):
            raise r.fail(
                f"{key}.main.type",
                f"the heat_cool structure needs a HeatCoolPID, got {main.type}",
            )
        return {"main": main}, {}

    def hold_for_warmup(self, side, u0, y2):
        block: HeatCoolPID = side.blocks["main"]
        set_manual(block, True, block.demand_for(u0))  # the manual value is a demand

    def compute(self, side, sp, m):
        u = side.ctrls["main"].output(sp, m.y, m.y_ok, 0.0, m.dt)
        b: HeatCoolPID = side.blocks["main"]
        return u, {"heat": b.heat, "cool": b.cool, "v_ctrl": b.demand,
                   "cooling": float(b.cooling)}  # fmt: skip

    def update(self, side, u, measured):
        pass  # the block ran its whole sample in compute (it tracks its own demand)

    def actuator_values(self, spec, u):
        return (max(0.0, -u), max(0.0, u))

    def off_mv(self, spec):
        return 0.0  # both outputs off


STRUCTURES: dict[str, Structure] = {
    s.name: s
    for s in (
        Single(),
        Cascade(),
        Override(),
        FeedForward(),
        Smith(),
        SplitRangeStructure(),
        RatioStructure(),
        PulseWidthStructure(),
        ThreeStepStructure(),
        ScheduledStructure(),
        HeatCoolStructure(),
        OpenLoop(),
    )
}
"""Every loop structure, by name (one object each; the module docstring)."""


def parse_controller(
    entry: dict[str, Any],
    structure: str,
    ts: float,
    *,
    key: str,
    file: str = "<string>",
    error: type[KeyPathError] = KeyPathError,
    tune: TuneHook | None = None,
) -> ControllerSpec:
    """Check one controller entry of ``structure`` (its block tables and options).

    ``key`` is its key path in ``file``; a problem raises ``error`` with
    ``key.role.param``.  The simulator reads a scenario's ``[[controllers]]``
    entries with it and the runtime its loops' structures, so both accept the
    same tables.  ``tune`` reads a ``tune`` table of a role that allows one
    (:attr:`Structure.tuned_roles`; None: refused).
    """
    reader = SpecReader(file)
    reader.error = error
    s = STRUCTURES.get(structure)
    if s is None or not s.runtime:
        raise reader.fail(f"{key}.structure", f"no controller entry for {structure!r}")
    return read_controller(reader, entry, key, structure, ts, tune)


def read_controller(
    reader: SpecReader,
    entry: dict[str, Any],
    key: str,
    structure: str,
    ts: float,
    tune: TuneHook | None = None,
) -> ControllerSpec:
    """One controller entry of ``structure`` read with ``reader`` (errors name ``key``)."""
    name = reader.string(entry, "name", f"{key}.name")
    blocks, options = STRUCTURES[structure].parse(reader, entry, key, ts, tune)
    return ControllerSpec(
        name, blocks, {"color": entry.get("color"), "style": entry.get("style"), **options}
    )


class ControllerSide:
    """The blocks of one controller entry, wired for its structure (module docstring).

    Parameters
    ----------
    structure : str
        A name of :data:`STRUCTURES`: ``single``, ``cascade``, ``override``,
        ``feedforward``, ``smith`` or ``open_loop``.
    spec : ControllerSpec
        The controller entry (its blocks by role).
    ts : float
        Sample time [s].
    u0 : float
        The initial MV (the Smith predictor's models start in its steady state).
    file : str
        Names the file in error messages of :func:`~ctrlblocks.loops.spec.build`.
    error : type
        The :class:`~ctrlblocks.loops.toml.KeyPathError` subclass to raise.

    Attributes
    ----------
    kind : Structure
        The structure object.
    blocks : dict
        Role -> block (``main``, ``feedforward``; ``primary``, ``secondary``;
        ``blocks[0]``, ``blocks[1]``, ... of an override).
    mv_blocks : list
        The blocks whose output is (or is selected as) the MV: ``main``,
        the cascade's ``secondary``, every override block.  Mode, manual
        value and MV limits act on them.
    values : dict
        The structure's internal signals of the last :meth:`compute`:
        ``v`` (the MV), and ``sp2`` (the cascade's secondary setpoint),
        ``v1``, ``v2``, ... (override block outputs), ``ff`` (feed-forward),
        ``y_pred`` (the Smith predictor's feedback).
    tracking : dict
        Role -> what the block tracks in the last :meth:`compute` instead of
        running its own law, for a faceplate: the cascade's primary while
        the inner loop is open, ``"y2"`` (the secondary not in AUTO) or
        ``"hold"`` (``y2`` bad: its last output, :meth:`Cascade.follow_value`).
        Empty otherwise; the block's own mode stays the user's.
    """

    def __init__(
        self,
        structure: str,
        spec: ControllerSpec,
        ts: float,
        *,
        u0: float = 0.0,
        file: str = "<scenario>",
        error: type[KeyPathError] = KeyPathError,
    ) -> None:
        self.kind = STRUCTURES[structure]
        self.structure = structure
        self.spec = spec
        self.ts = ts
        self.file = file
        self.error = error
        self.u0 = u0
        self.blocks: dict[str, Any] = {}
        self.aux: Any = None  # the structure's own object: ratio station, gain schedule, ...
        self.kind.setup(self)
        self.ctrls = {r: _Controller(self.blocks[r]) for r in self.kind.controller_roles(self)}
        self.mv_blocks = [self.blocks[r] for r in self.kind.mv_roles_of(self)]
        self.aw_handshake = bool(spec.options.get("aw_handshake", True))
        self.selector = spec.options.get("selector", "min")
        self.ff = 0.0
        self.u = u0
        self.values: dict[str, float] = {}
        self.pending: tuple[float, ...] = ()
        self.tracking: dict[str, str] = {}

    def make(self, spec: BlockSpec, kind: str) -> Any:
        """Build the block (or plant) ``spec`` with this side's sample time."""
        return build(spec, self.ts, kind=kind, file=self.file, error=self.error)

    @property
    def main(self) -> Any:
        """The block that writes the MV (``main``, the cascade's ``secondary``, ``blocks[0]``)."""
        return self.mv_blocks[0]

    @property
    def measurements(self) -> tuple[str, ...]:
        """The measurements :meth:`compute` needs: ``y``, ``y2``, ``dv`` (module docstring)."""
        return self.kind.measurements_of(self)

    @property
    def event_target(self) -> str:
        """The role an event without a ``target`` acts on."""
        return self.kind.event_target

    def event_blocks(self, kind: str, target: str | None = None) -> list[Any]:
        """The blocks a controller-side event (``set``, ``mode``, ``manual_value``,
        ``limits``) acts on: the block ``target`` names; without one, ``set`` acts on
        :attr:`event_target`, the others on the MV blocks.  ``KeyError`` for a name that
        is not one of :attr:`blocks` (a plant is the caller's).
        """
        if target is not None:
            return [self.blocks[target]]
        return [self.blocks[self.event_target]] if kind == "set" else list(self.mv_blocks)

    def reset_models(self) -> None:
        """Put the Smith predictor's models in the steady state of ``u0``."""
        self.kind.reset_models(self)

    def actuator_values(self, u: float | None = None) -> tuple[float, ...]:
        """The MVs to write for the controller output ``u`` (default the last computed).

        One value for every structure but ``split_range``, which gives its
        two actuators' values ``(a(u), b(u))`` (:mod:`.split`).
        """
        return self.kind.actuator_values(self.spec, self.u if u is None else u)

    # -- the two phases ------------------------------------------------------------

    def compute(
        self,
        sp: float,
        y: float = math.nan,
        *,
        y_ok: bool = True,
        y2: float = math.nan,
        y2_ok: bool = True,
        dv: float = 0.0,
        dv_ok: bool = True,
        w: float = math.nan,
        w_ok: bool = True,
        dt: float | None = None,
    ) -> float:
        """ComputeOutput and ShapeOutput: the MV of this sample (no block state committed).

        Parameters
        ----------
        sp : float
            The setpoint (of the primary in a cascade) [PV units].
        y, y2, dv, w : float
            The measurements the structure reads (:attr:`measurements`;
            ``w``: the ratio structure's wild flow).
        y_ok, y2_ok, dv_ok, w_ok : bool
            Their quality flags (module docstring).
        dt : float, optional
            This sample's period [s] for the controllers (default ``ts``).

        Returns
        -------
        float
            The MV ``u`` (the controller output; a split range's two MVs are
            :meth:`actuator_values`); the structure's signals are in :attr:`values`.
        """
        m = _Measured(y, y_ok, y2, y2_ok, dv, dv_ok, dt, w, w_ok)
        u, vals = self.kind.compute(self, sp, m)
        vals["v"] = u
        self.u = u
        self.values = vals
        return u

    def update(self, applied: float | None = None, measured: float | None = None) -> None:
        """UpdateState of every block with the applied MV (default: the computed one).

        ``measured`` is the actuator's real output of the sample where it is
        known (the simulator's single-loop structures): it goes to a PID's
        ``actuator_pos`` and an ADRC with ``u_real_on``.
        """
        self.kind.update(self, self.u if applied is None else applied, measured)

    def step(
        self,
        sp: float,
        y: float = math.nan,
        *,
        y_ok: bool = True,
        dt: float | None = None,
        **measurements: Any,
    ) -> float:
        """:meth:`compute` then :meth:`update` with the computed MV; return the MV.

        A single loop calls its block once (``block(sp, y, ...)``, the same
        result as the two phases, on the block's fast lane; :meth:`Structure.step`).
        """
        return self.kind.step(self, sp, y, y_ok, dt, measurements)

    # -- mode, manual value, limits -------------------------------------------------

    @property
    def manual(self) -> bool:
        """True when the MV block is in manual."""
        return bool(getattr(self.main, "manual", False))

    def set_manual(self, on: bool, value: float | None = None) -> None:
        """Mode (and manual value) of the MV blocks (:attr:`mv_blocks`)."""
        for b in self.mv_blocks:
            set_manual(b, on, value)

    def set_limits(self, u_min: float, u_max: float) -> None:
        """MV limits of the MV blocks."""
        for b in self.mv_blocks:
            b.set_limits(u_min, u_max)

    def inner_states(self) -> dict[str, dict[str, Any]]:
        """What a faceplate shows of every block: role -> sp, pv, out, mode, error_id."""
        out: dict[str, dict[str, Any]] = {}
        for role, b in self.blocks.items():
            if role not in self.ctrls:
                continue
            sp = getattr(b, "sp_w", getattr(b, "sp", math.nan))
            pv = getattr(b, "pv_f", getattr(b, "y", math.nan))
            out[role] = {
                "sp": _num(sp),
                "pv": _num(pv),
                "out": _num(getattr(b, "out", math.nan)),
                "mode": "manual" if getattr(b, "manual", False) else "auto",
                "error_id": int(getattr(b, "error_id", 0)),
            }
        return out


def _fixed_sp(spec: BlockSpec) -> float | None:
    """An override block's own setpoint (``sp = NUMBER``), or None when it follows ``sp``."""
    sp = spec.extra.get("sp", "sp")
    return None if sp == "sp" else float(sp)


def _num(x: Any) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan
