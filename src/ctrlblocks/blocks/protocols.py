"""The controller interface that PID, ADRC and every controller role of a structure satisfy.

Åström 1987, section 6 (Listing 6.3): a controller wired into a structure
(selector, cascade, external saturation) is used in two phases --
``compute_output`` (no state committed) and ``update_state`` with the value
actually applied -- and a controller on its own in one call.  The names are
the engineer's: ``sp``, ``pv`` (positional), ``pv_ok`` (quality of the
measurement), ``dt`` (this cycle's period), ``manual`` / ``manual_value``,
``u_min`` / ``u_max`` with ``set_limits``.  The ADRC's older names ``y_ok``
and ``u_man`` stay as documented aliases for one release.

:class:`Controller` is a :class:`typing.Protocol` that holds everything the
loop structures (``ctrlblocks.loops``) use of a controller: the two phases
and the one call, the mode (``manual``, ``manual_value``, ``mode``), the
output and its limits, the error code for a faceplate, and the anti-windup
handshake of a cascade (``awout`` of the secondary goes to ``awin`` of the
primary, Åström 1987, section 3; Nowak et al. 2018, section 5).  A block of
your own that has these members is wired like the shipped ones;
``isinstance(block, Controller)`` checks the members.  A controller without
a handshake keeps ``awin`` as a plain attribute it ignores and ``awout``
False.

Three optional abilities, each its own protocol, which a structure uses
where a controller has them (and does without otherwise):

* :class:`Tracking` -- a TRACK mode (``track``, ``track_value``; the PID,
  Åström 1987, Fig. 4.4): a cascade's primary tracks the secondary's
  measurement with it while the inner loop is open.  A controller without
  one is run that cycle in manual at the value instead (the ADRC: x4 is
  re-solved by (11) of Nowak et al. 2018 at the return to AUTO);
* :class:`ActuatorFeedback` -- a measured actuator position input
  ``actuator_pos`` (the PID's back-calculation on the real MV, controltheplant
  2024, BACK_CALC_REAL); the simulator wires the actuator's real output to it;
* :class:`MeasuredMVConfig` -- a configuration that says whether the
  controller's applied value is the *measured* MV (the ADRC's ``u_real_on``,
  Nowak et al. 2018, section 5).
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

from .base import Mode

__all__ = ["ActuatorFeedback", "Controller", "ManualMode", "MeasuredMVConfig", "Tracking"]


@runtime_checkable
class Controller(Protocol):
    """Two-phase controller block (module docstring)."""

    manual: bool
    """True: the output is ``manual_value`` (bumpless back to auto)."""
    manual_value: float
    """The manual output [MV units] (In/Out: it follows the output in auto)."""
    out: float
    """The output of the last cycle [MV units]."""
    awin: bool
    """Anti-windup input: True freezes the integral action (a cascade's primary while
    its secondary is at a limit)."""
    error_id: int
    """The error code of the last cycle (:class:`~ctrlblocks.ErrorCode`; 0: none)."""

    @property
    def awout(self) -> bool:
        """Anti-windup output: the output is at a limit (a cascade's secondary)."""
        ...

    @property
    def mode(self) -> Mode:
        """The mode in force (:class:`~ctrlblocks.Mode`: AUTO, MANUAL, ...)."""
        ...

    @property
    def u_min(self) -> float:
        """Lower output limit in force [MV units]."""
        ...

    @property
    def u_max(self) -> float:
        """Upper output limit in force [MV units]."""
        ...

    def __call__(
        self, sp: float, pv: float, *, pv_ok: bool = True, dt: float | None = None
    ) -> float:
        """One whole cycle: compute, then update with the block's own output."""
        ...

    def compute_output(
        self, sp: float, pv: float, *, pv_ok: bool = True, dt: float | None = None
    ) -> float:
        """ComputeOutput: this cycle's output, no state committed."""
        ...

    def update_state(self, applied: float) -> None:
        """UpdateState with the value actually applied."""
        ...

    def set_limits(self, u_min: float, u_max: float) -> None:
        """Output limits at run time; a bad pair is a status, never an exception."""
        ...


@runtime_checkable
class ManualMode(Protocol):
    """A block with a manual mode (every :class:`Controller`; also a one-call block such
    as :class:`~ctrlblocks.HeatCoolPID`, whose manual value is its demand)."""

    manual: bool
    """True: the output follows ``manual_value`` (bumpless back to auto)."""
    manual_value: float
    """The manual value (In/Out: it follows the block in auto)."""


@runtime_checkable
class Tracking(Protocol):
    """A controller with a TRACK mode: the output follows ``track_value`` while ``track``."""

    track: bool
    """True: the output is ``track_value``; the integral action follows it (bumpless)."""
    track_value: float
    """The value tracked [MV units]."""


@runtime_checkable
class ActuatorFeedback(Protocol):
    """A controller with a measured actuator position input."""

    actuator_pos: float
    """The actuator's measured position of this cycle [MV units] (NaN: not measured)."""


@runtime_checkable
class MeasuredMVConfig(Protocol):
    """A controller configuration that can make the measured MV the applied value."""

    u_real_on: bool
    """True: ``update_state`` is given the measured MV (the ESO's input of the ADRC)."""
