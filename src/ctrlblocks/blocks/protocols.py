"""The controller interface that PID, ADRC and every controller role of a structure satisfy.

Åström 1987, section 6 (Listing 6.3): a controller wired into a structure
(selector, cascade, external saturation) is used in two phases --
``compute_output`` (no state committed) and ``update_state`` with the value
actually applied -- and a controller on its own in one call.  The names are
the engineer's: ``sp``, ``pv`` (positional), ``pv_ok`` (quality of the
measurement), ``dt`` (this cycle's period), ``manual`` / ``manual_value``,
``u_min`` / ``u_max`` with ``set_limits``.  The ADRC's older names ``y_ok``
and ``u_man`` stay as documented aliases for one release.

:class:`Controller` is a :class:`typing.Protocol`: a block of your own that
has these members is wired by the loop structures (``ctrlblocks.loops``) like
the shipped ones; ``isinstance(block, Controller)`` checks the members.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

__all__ = ["Controller"]


@runtime_checkable
class Controller(Protocol):
    """Two-phase controller block (module docstring)."""

    manual: bool
    """True: the output is ``manual_value`` (bumpless back to auto)."""
    manual_value: float
    """The manual output [MV units] (In/Out: it follows the output in auto)."""
    out: float
    """The output of the last cycle [MV units]."""

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
