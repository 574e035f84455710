"""The :class:`Structure` object: everything ctrlblocks knows about one loop structure.

A structure is described once: how a controller entry is read
(:meth:`Structure.parse`), what the simulator and the runtime need to know
of it (its class attributes), and what it does in a sample -- its
:class:`~.wiring.Wiring` (:meth:`Structure.wiring_of`), which both the
Python path (:class:`~.side.ControllerSide`) and the simulator's compiled
lane run.  Adding a structure is one subclass (docs/architecture.md,
"Adding a loop structure").
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar

from .spec import ControllerSpec, SpecReader, TuneHook
from .wiring import Measured, Wiring

if TYPE_CHECKING:  # pragma: no cover
    from .side import ControllerSide

__all__ = ["ENTRY_KEYS", "Structure"]

ENTRY_KEYS = ("name", "color", "style")
"""Keys of every controller entry besides its structure's roles and options."""


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
    wiring : Wiring or None
        What the structure does in a sample (:mod:`.wiring`); a structure
        whose wiring depends on the entry gives it in :meth:`wiring_of`.
        None: no controller (``open_loop``, :meth:`compute` of its own).
    measurements : tuple of str
        What the structure may read: ``y``, ``y2``, ``dv``, ``w``, declared
        before any entry is read (a runtime configuration binds them); a
        controller side reads its wiring's (:meth:`measurements_of`).
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
    """

    name: ClassVar[str]
    roles: ClassVar[tuple[str, ...]]
    options: ClassVar[tuple[str, ...]] = ()
    wiring: ClassVar[Wiring | None] = None
    measurements: ClassVar[tuple[str, ...]] = ("y",)
    mv_roles: ClassVar[tuple[str, ...]] = ("main",)
    event_target: ClassVar[str] = "main"
    series_plant: ClassVar[bool] = False
    runtime: ClassVar[bool] = True
    tuned_roles: ClassVar[tuple[str, ...]] = ("main",)
    actuators: ClassVar[int] = 1
    setpoint_signal: ClassVar[str | None] = None
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
        r.check_keys(e, {*ENTRY_KEYS, *self.roles, *self.options}, key)
        blocks = {
            role: r.role(e, role, key, ts, tune if role in self.tuned_roles else None)
            for role in self.roles
        }
        return blocks, {}

    # -- the controller side ----------------------------------------------------------

    def wiring_of(self, side: ControllerSide) -> Wiring | None:
        """The wiring of ``side`` (read from its entry; default :attr:`wiring`)."""
        return self.wiring

    def setup(self, side: ControllerSide) -> None:
        """Build the side's blocks (role -> block) from its spec, then its stages' objects.

        A role a stage owns (the Smith predictor's plant ``model``) is built by
        the stage.
        """
        w = side.wiring
        parts = () if w is None else (*w.stages, *((w.output,) if w.output else ()))
        owned = {r for p in parts for r in p.roles}
        for role, s in side.spec.blocks.items():
            if role not in owned:
                side.blocks[role] = side.make(s, "block")
        for p in parts:
            p.setup(side)

    def controller_roles(self, side: ControllerSide) -> tuple[str, ...]:
        """The roles of the blocks used as controllers: the wiring's loops."""
        return () if side.wiring is None else side.wiring.roles

    def mv_roles_of(self, side: ControllerSide) -> tuple[str, ...]:
        """The roles whose output is (or is selected as) the MV in this side."""
        return self.mv_roles if side.wiring is None else side.wiring.mv_roles

    def measurements_of(self, side: ControllerSide) -> tuple[str, ...]:
        """The measurements this side's :meth:`compute` reads."""
        return self.measurements if side.wiring is None else side.wiring.measurements

    def hold_for_warmup(self, side: ControllerSide, u0: float, y2: float) -> None:
        """Put the controllers in manual, each at its output in the steady state of ``u0``.

        The simulator's warm-up (``initial.warmup``): with the plant in the
        steady state of the initial MV ``u0`` (``y2``: the inner plant's
        output there, if there is one) the controllers' bumpless logic then
        initialises their states consistently (:meth:`.Wiring.hold_for_warmup`).
        """
        if side.wiring is not None:
            side.wiring.hold_for_warmup(side, u0, y2)

    def step(
        self, side: ControllerSide, sp: float, y: float, y_ok: bool, dt: float | None,
        measurements: dict[str, Any],
    ) -> float:  # fmt: skip
        """One whole sample (:meth:`ControllerSide.step`): compute, then update with the MV."""
        if side.wiring is not None:
            return side.wiring.step(side, sp, y, y_ok, dt, measurements)
        u = side.compute(sp, y, y_ok=y_ok, dt=dt, **measurements)
        side.update(u)
        return u

    def compute(self, side: ControllerSide, sp: float, m: Measured) -> tuple[float, dict]:
        """ComputeOutput and ShapeOutput: the MV and the structure's signals."""
        assert side.wiring is not None  # a structure without one has its own compute
        return side.wiring.compute(side, sp, m)

    def update(self, side: ControllerSide, u: float, measured: float | None) -> None:
        """UpdateState of every block with the applied MV ``u``."""
        assert side.wiring is not None
        side.wiring.update(side, u, measured)

    def reset_models(self, side: ControllerSide) -> None:
        """Put the stages' models (if any) in the steady state of ``side.u0``."""
        if side.wiring is not None:
            for st in side.wiring.stages:
                st.reset(side)

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
