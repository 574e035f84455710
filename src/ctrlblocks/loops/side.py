"""The controller side: the blocks of one controller entry, wired for its structure.

:class:`ControllerSide` holds the blocks of one controller entry (a
scenario's, or a runtime loop's) and runs them for its structure in Åström's
computational order (Åström 1987, section 6, Listing 6.3):

1. the caller reads the measurements (``y``; ``y2`` of a cascade's or an
   override's inner variable; ``dv``, the measured disturbance of a
   feed-forward structure; ``w``, a ratio's wild flow) -- *Adin*;
2. :meth:`ControllerSide.compute` -- *ComputeOutput* of every block and
   *ShapeOutput* -- returns the MV; no block state is committed;
3. the caller writes the MV -- *Daout*;
4. :meth:`ControllerSide.update` -- *UpdateState* of every block with the
   value actually applied.

:meth:`ControllerSide.step` is 2 + 4 in one call, for a caller that applies
the MV as computed (the runtime).  What happens in 2 and 4 is the
structure's :class:`~.wiring.Wiring` (:mod:`.wiring`).

Quality flags (``y_ok``, ``y2_ok``, ``dv_ok``, ``w_ok``): a block is called
with the flags its loop names (cascade: primary ``y_ok``, secondary
``y2_ok``; override: every block ``y_ok and y2_ok``); a bad ``dv`` freezes
the lead-lag (not called) and keeps its last output as ``ff``; a bad ``w``
makes the ratio station hold the last good setpoint.
"""

from __future__ import annotations

import math
from typing import Any

from .controller import Wired, set_manual
from .registry import STRUCTURES
from .spec import BlockSpec, ControllerSpec, build
from .toml import KeyPathError
from .wiring import Measured

__all__ = ["ControllerSide"]


class ControllerSide:
    """The blocks of one controller entry, wired for its structure (module docstring).

    Parameters
    ----------
    structure : str
        A name of :data:`~.structures.STRUCTURES`: ``single``, ``cascade``,
        ``override``, ``feedforward``, ``smith``, ...
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
    wiring : Wiring or None
        What the structure does in a sample (:mod:`.wiring`).
    blocks : dict
        Role -> block (``main``, ``feedforward``; ``primary``, ``secondary``;
        ``blocks[0]``, ``blocks[1]``, ... of an override).
    ctrls : dict
        Role -> :class:`~.controller.Wired`, the blocks of the wiring's loops.
    parts : dict
        The stages' objects by stage name (the Smith predictor's models, the
        ratio station, the gain schedule, the output block).
    mv_blocks : list
        The blocks whose output is (or is selected as) the MV: ``main``,
        the cascade's ``secondary``, every override block.  Mode, manual
        value and MV limits act on them.
    values : dict
        The structure's signals of the last :meth:`compute`: ``v`` (the MV)
        and the wiring's (``sp2``, ``v1``, ``v2``, ..., ``ff``, ``y_pred``).
    tracking : dict
        Role -> what the block tracks in the last :meth:`compute` instead of
        running its own law, for a faceplate: the cascade's primary while
        the inner loop is open, ``"y2"`` (the secondary not in AUTO) or
        ``"hold"`` (``y2`` bad: its last output, :meth:`.Wiring.follow`).
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
        self.parts: dict[str, Any] = {}
        self.wiring = self.kind.wiring_of(self)
        self.kind.setup(self)
        self.ctrls = {r: Wired(self.blocks[r]) for r in self.kind.controller_roles(self)}
        self.mv_blocks = [self.blocks[r] for r in self.kind.mv_roles_of(self)]
        self.u = u0
        self.values: dict[str, float] = {}
        self.pending: Any = ()
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
        """The measurements :meth:`compute` needs: ``y``, ``y2``, ``dv``, ``w``."""
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
        m = Measured(y, y_ok, y2, y2_ok, dv, dv_ok, dt, w, w_ok)
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
        result as the two phases, on the block's fast lane; :meth:`.Wiring.step`).
        """
        return self.kind.step(self, sp, y, y_ok, dt, measurements)

    # -- mode, manual value, limits -------------------------------------------------

    @property
    def manual(self) -> bool:
        """True when the MV block is in manual."""
        w = self.ctrls.get(self.kind.mv_roles_of(self)[0])
        return w is not None and w.manual

    def set_manual(self, on: bool, value: float | None = None) -> None:
        """Mode (and manual value) of the MV blocks (:attr:`mv_blocks`)."""
        for b in self.mv_blocks:
            set_manual(b, on, value)

    def set_modes(self, manual: bool) -> None:
        """The mode of every controller of the side (the simulator's warm-up ends with it)."""
        for w in self.ctrls.values():
            set_manual(w.block, manual)

    def set_limits(self, u_min: float, u_max: float) -> None:
        """MV limits of the MV blocks."""
        for b in self.mv_blocks:
            b.set_limits(u_min, u_max)

    def inner_states(self) -> dict[str, dict[str, Any]]:
        """What a faceplate shows of every controller: role -> sp, pv, out, mode, error_id
        (``sp`` and ``pv``: what the structure gave it in the last compute)."""
        return {role: w.state() for role, w in self.ctrls.items()}
