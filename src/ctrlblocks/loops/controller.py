"""How a loop structure drives one block: the controller interface, modes and tracking.

A structure's blocks are used through :class:`Wired`, made once per block
when a controller side is built.  A
:class:`~ctrlblocks.blocks.protocols.Controller` (PID, ADRC, a block of your
own with that interface) runs in two phases (Åström 1987, section 6:
``compute_output`` with ``pv_ok`` and ``dt``, then ``update_state`` with the
value actually applied); its ``ff`` input is wired when its
``compute_output`` has one.  Any other block is called once per sample as
``block(sp, y)``, with NaN for an invalid measurement, and has no mode.

What a controller can do beyond the interface is asked once, by type, from
the optional protocols of :mod:`ctrlblocks.blocks.protocols`: a TRACK mode
(:class:`~ctrlblocks.blocks.protocols.Tracking`, the PID), a measured
actuator position input (:class:`~ctrlblocks.blocks.protocols.ActuatorFeedback`,
the PID) and a configuration that applies the measured MV
(:class:`~ctrlblocks.blocks.protocols.MeasuredMVConfig`, the ADRC's
``u_real_on``).  The structures never probe a block for attributes.
"""

from __future__ import annotations

import inspect
import math
from typing import Any, NamedTuple

from ..blocks.base import Block, Mode
from ..blocks.protocols import (
    ActuatorFeedback,
    Controller,
    ManualMode,
    MeasuredMVConfig,
    Tracking,
)

__all__ = ["Wired", "is_controller", "set_manual", "takes_ff"]


class _Abilities(NamedTuple):
    """What a block type can do in a structure (:func:`_abilities`)."""

    two_phase: bool  # a Controller
    takes_ff: bool  # its compute_output (a plain block: its call) has an ``ff`` input
    tracks: bool  # a TRACK mode (Tracking)
    feedback: bool  # a measured actuator position input (ActuatorFeedback)
    measured_mv: bool  # its configuration may apply the measured MV (MeasuredMVConfig)
    manual_mode: bool  # a manual mode (ManualMode; every Controller has one)


_KNOWN: dict[type, _Abilities] = {}


def _abilities(block: Any) -> _Abilities:
    """The :class:`_Abilities` of ``block``'s type, found once per type.

    The protocols' runtime check looks at the members of an instance (they
    may be set in ``__init__``), so the first block of a type decides for
    all of its type (blocks of one class have the same members).
    """
    cls = type(block)
    found = _KNOWN.get(cls)
    if found is None:
        two_phase = isinstance(block, Controller)
        found = _KNOWN[cls] = _Abilities(
            two_phase,
            _has_ff(cls.compute_output if two_phase else block),
            two_phase and isinstance(block, Tracking),
            two_phase and isinstance(block, ActuatorFeedback),
            two_phase and isinstance(block, Block) and isinstance(block.config, MeasuredMVConfig),
            two_phase or isinstance(block, ManualMode),
        )
    return found


def is_controller(block: Any) -> bool:
    """Whether ``block`` is a :class:`~ctrlblocks.blocks.protocols.Controller` (two phases)."""
    return _abilities(block).two_phase


def takes_ff(block: Any) -> bool:
    """Whether ``block`` has a feed-forward input ``ff`` (its ``compute_output``, or its call)."""
    return _abilities(block).takes_ff


def _has_ff(fn: Any) -> bool:
    """Whether the callable ``fn`` takes a keyword ``ff``."""
    try:
        return "ff" in inspect.signature(fn).parameters
    except (TypeError, ValueError):  # pragma: no cover - builtins without signature
        return False


def set_manual(block: Any, on: bool, value: float | None = None) -> None:
    """Switch ``block`` to manual (``on``) or auto, with a new manual value when given.

    A block without a manual mode (:class:`~ctrlblocks.blocks.protocols.ManualMode`;
    every :class:`~ctrlblocks.blocks.protocols.Controller` has one): nothing happens.
    """
    if not _abilities(block).manual_mode:
        return
    if value is not None:
        block.manual_value = value
    block.manual = on


class Wired:
    """One block as a structure drives it (module docstring).

    Parameters
    ----------
    block : Controller or callable
        The block.
    """

    __slots__ = ("_ab", "block", "last", "pv", "sp")

    def __init__(self, block: Any) -> None:
        self.block = block
        self._ab = _abilities(block)
        self.sp = self.pv = self.last = math.nan  # the inputs and output of the last compute

    @property
    def two_phase(self) -> bool:
        """The block is a Controller (two phases; else it is called once per sample)."""
        return self._ab.two_phase

    @property
    def takes_ff(self) -> bool:
        """The block has a feed-forward input ``ff``."""
        return self._ab.takes_ff

    # -- the two phases --------------------------------------------------------------

    def _inputs(self, y: float, ok: bool, dt: float | None) -> tuple[float, dict[str, Any]]:
        """``y`` and the keyword arguments for the quality flag and ``dt``."""
        kw: dict[str, Any] = {}
        if self._ab.two_phase:
            kw["pv_ok"] = ok
            if dt is not None:
                kw["dt"] = dt
        elif not ok:
            y = math.nan  # a block without a quality flag sees an invalid value
        return y, kw

    def output(
        self, sp: float, y: float, ok: bool, ff: float = 0.0, dt: float | None = None
    ) -> float:
        """ComputeOutput (a plain block: its one call) for ``sp`` and the measurement ``y``."""
        self.sp, self.pv = sp, y
        y, kw = self._inputs(y, ok, dt)
        if self._ab.takes_ff:
            kw["ff"] = ff
        if self._ab.two_phase:
            v = float(self.block.compute_output(sp, y, **kw))
        else:
            v = float(self.block(sp, y, **kw))
        self.last = v
        return v

    def cycle(self, sp: float, y: float, ok: bool, dt: float | None = None) -> float:
        """The whole cycle in one call, ``block(sp, y, ...)``: compute, then update with ``v``.

        The blocks document it as identical to ``compute_output`` +
        ``update_state(v)`` (their fast lane; tests/fast checks it).
        """
        self.sp, self.pv = sp, y
        y, kw = self._inputs(y, ok, dt)
        v = self.last = float(self.block(sp, y, **kw))
        return v

    def update(self, applied: float, measured: float | None = None) -> None:
        """UpdateState with the applied value (a plain block has none).

        ``measured`` is the actuator's real output of this sample (after load,
        rate and range).  It is wired where the block is configured to use a
        measured MV: the PID's ``actuator_pos`` input (BACK_CALC_REAL,
        controltheplant 2024) and the ADRC's ``u_real_on`` (Nowak et al.
        2018, section 5).
        """
        ab = self._ab
        if not ab.two_phase:
            return
        b = self.block
        if measured is not None:
            if ab.feedback:
                b.actuator_pos = measured
            if ab.measured_mv and b.config.u_real_on:
                applied = measured
        b.update_state(applied)

    # -- modes, handshake, tracking ----------------------------------------------------

    @property
    def auto(self) -> bool:
        """The block runs its own law (mode AUTO; a block without modes always does)."""
        return not self._ab.two_phase or self.block.mode == Mode.AUTO

    @property
    def manual(self) -> bool:
        """The block is in manual (a block without modes never is)."""
        return self._ab.two_phase and bool(self.block.manual)

    @property
    def out(self) -> float:
        """The block's output of the last cycle (a plain block: its last result)."""
        return float(self.block.out) if self._ab.two_phase else self.last

    @property
    def awout(self) -> bool:
        """The block's anti-windup output (False without one)."""
        return self._ab.two_phase and bool(self.block.awout)

    def set_awin(self, on: bool) -> None:
        """The block's anti-windup input (nothing without one)."""
        if self._ab.two_phase:
            self.block.awin = on

    def follow(self, value: float) -> tuple[str, Any, Any] | None:
        """Make the block output ``value`` in the next compute; what :meth:`restore` puts back.

        A block with a TRACK mode (the PID: ``track``, ``track_value``,
        Åström 1987, Fig. 4.4: the integrator is set so that ``P + I + D +
        FF`` is the output, and the first cycle back in AUTO continues from
        it; the ADRC: its law is kept on the tracked output by the handover
        offset) tracks; one with only a manual mode runs that cycle in
        manual at ``value``.  The mode inputs are the
        user's: they are put back right after the compute (the blocks commit
        the mode of the computed cycle, so the manual value still follows the
        output, In/Out).  A block without modes runs its own law (None).
        """
        b = self.block
        if self._ab.tracks:
            saved = ("track", b.track, b.track_value)
            b.track, b.track_value = True, value
            return saved
        if self._ab.two_phase:
            saved = ("manual", b.manual, b.manual_value)
            b.manual, b.manual_value = True, value
            return saved
        return None

    def restore(self, saved: tuple[str, Any, Any] | None) -> None:
        """Put back the mode inputs :meth:`follow` changed."""
        if saved is None:
            return
        name, on, value = saved
        b = self.block
        if name == "track":
            b.track, b.track_value = on, value
        else:
            b.manual, b.manual_value = on, value

    def state(self) -> dict[str, Any]:
        """What a faceplate shows: the setpoint and measurement the structure gave the
        block in its last compute, its output, mode and error code."""
        b = self.block
        err = b.error_id if self._ab.two_phase or isinstance(b, Block) else 0
        return {
            "sp": _num(self.sp),
            "pv": _num(self.pv),
            "out": _num(self.out),
            "mode": "manual" if self.manual else "auto",
            "error_id": int(err),
        }


def _num(x: Any) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan
