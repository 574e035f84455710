"""The public seam of a *lane*: one closed-loop run of a structure, described as data.

A lane runs a controller side's :class:`~.wiring.Wiring` in a closed loop --
actuator, plant(s), sensor -- over arrays, sample for sample in Åström's
computational order (Åström 1987, section 6), where the Python path calls
the block and plant objects.  The simulator (``ctrlblocks.sim.dispatch``)
describes a run as a :class:`LaneRun` and gives it to a lane found with
:func:`lanes`; the compiled lane of ``ctrlblocks.fast.simlane`` (numba) is
the one ctrlblocks ships.  The simulator and the lane meet here and import
nothing of each other: a lane is an installed plugin, named in the entry
point group :data:`GROUP` of its package's metadata (ctrlblocks' own
``pyproject.toml`` names ``compiled``), so a package of your own may add one.

What a lane promises: its traces equal the Python path's bit for bit where
it runs (the same operations in the same order), it says why it cannot run
a controller side or a process model (:meth:`Lane.controller_blockers`,
:meth:`Lane.process_blockers`), and it stops at the first sample whose
measurement, output or control law's result before the limits is not
finite (:attr:`LaneResult.stopped`: the blocks' output guard would act
there, and the caller runs the Python path instead).
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Mapping, Sequence
from importlib import metadata
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from .side import ControllerSide

__all__ = ["GROUP", "Lane", "LaneResult", "LaneRun", "lanes"]

log = logging.getLogger(__name__)

GROUP = "ctrlblocks.lanes"
"""The entry point group of the installed lanes (name -> a :class:`Lane` object)."""


@dataclasses.dataclass(frozen=True)
class LaneRun:
    """One run for a lane: the warm-up and ``n`` recorded samples of a closed loop.

    Attributes
    ----------
    side : ControllerSide
        The controllers, wired, in their state before the warm-up (the lane
        does not advance them); the wiring's loops in order.
    model, inner_model : plant
        The measured plant and the inner one of a series structure (None: no
        inner plant; ``y2`` is its output), in their initial states.
    actuator : tuple
        ``(u_min, u_max, rate * ts, u)``: range, largest step per sample and
        the input applied before the first sample.
    sensor : tuple
        ``(y_min, y_max)``, the measuring range.
    warmup : int
        Samples of the warm-up: every loop in manual at its ``u_man``,
        setpoint ``sp_warmup``, measurements ``y_warmup``, ``y2_warmup``,
        ``dv_warmup`` (the plants held in their steady state).
    u_man : sequence of float
        Per loop: its manual value before the run.
    manual : sequence of arrays
        Per loop: 1 where it is in manual, per sample.
    signals : mapping
        Per sample (arrays of ``n``): ``sp``, ``load_in`` (at the plant's
        input; the measured disturbance ``dv`` of a feed-forward), ``load_out``
        (at its output), ``u_man`` (the manual value set at a sample, NaN:
        unchanged; it acts on the MV loops), ``g3o`` (the three-tank's outlet
        coefficient; anything for another plant), ``load_mid`` (between series
        plants), ``y_ok``, ``y2_ok`` (0 while the measurement is bad, flagged
        or NaN), ``y_nan`` (1 while ``y`` is measured NaN), ``limits_event``
        (1 where a ``limits`` event is due).
    limits : array or None
        ``(loop, 4, sample)``: the output limits in force of every loop and
        sample, and the bounds its held output is limited to at an event's
        sample (rows 2 and 3); None: the blocks' own throughout.
    noise : array
        The measurement noise of every sample.
    """

    side: ControllerSide
    model: Any
    inner_model: Any
    actuator: tuple[float, float, float, float]
    sensor: tuple[float, float]
    warmup: int
    sp_warmup: float
    y_warmup: float
    y2_warmup: float
    dv_warmup: float
    u_man: Sequence[float]
    manual: Sequence[np.ndarray]
    signals: Mapping[str, np.ndarray]
    limits: np.ndarray | None
    noise: np.ndarray


@dataclasses.dataclass
class LaneResult:
    """The traces of a :class:`LaneRun` (arrays of ``n`` samples), or where it stopped."""

    y: np.ndarray
    """The true process output (with the output load)."""
    ym: np.ndarray
    """The measurement (noise, range; NaN during a ``nan`` fault)."""
    u: np.ndarray
    """The MV the controllers computed."""
    u_act: np.ndarray
    """The input applied to the process (after load, rate and range)."""
    y2: np.ndarray
    """The inner plant's output (NaN without one)."""
    signals: dict[str, np.ndarray]
    """The wiring's signals (:attr:`~.wiring.Wiring.signals`: ``sp2``, ``v1``, ``ff``, ...)."""
    stopped: int
    """The first sample that was not finite (the traces stop there), or -1."""
    compiled: bool
    """The lane ran compiled (False: the same code interpreted)."""


@runtime_checkable
class Lane(Protocol):
    """A lane (module docstring)."""

    def controller_blockers(self, side: ControllerSide) -> list[str]:
        """Why the lane cannot run ``side``'s wiring and blocks (empty: it can)."""
        ...

    def process_blockers(self, models: Sequence[Any]) -> list[str]:
        """Why the lane cannot run these process models, or at all here (empty: it can)."""
        ...

    def run(self, run: LaneRun) -> LaneResult:
        """The run's traces (:class:`LaneResult`)."""
        ...


_found: dict[str, Lane] | None = None


def lanes() -> dict[str, Lane]:
    """The installed lanes by name (entry point group :data:`GROUP`), loaded once.

    A lane that fails to load is left out, with the reason logged at WARNING
    level (logger ``ctrlblocks.loops.lane``).
    """
    global _found
    if _found is None:
        found: dict[str, Lane] = {}
        for ep in metadata.entry_points(group=GROUP):
            try:
                lane = ep.load()
            except Exception as exc:  # a broken plugin must not break the simulator
                log.warning("lane %r (%s) not loaded: %s", ep.name, ep.value, exc)
                continue
            if isinstance(lane, Lane):
                found[ep.name] = lane
            else:
                log.warning("lane %r (%s) is not a Lane", ep.name, ep.value)
        _found = found
    return _found
