"""Gain scheduling: a PID or ADRC whose parameters follow a scheduling variable.

A process whose gain or time constants change with the operating point (a
valve's installed characteristic, a tank's level, a flow) is controlled well
by one tuning per operating point.  :class:`GainSchedule` holds a table of
breakpoints of a scheduling variable ``w`` and, for each parameter of the
controller it wraps, its value at each breakpoint.  Every cycle it
interpolates the parameters linearly at the present ``w`` (holding the end
values outside the table, never extrapolating) and, when they changed,
retunes the controller through its own ``configure`` -- which validates the
values and retunes bumplessly (the PID moves its integrator so that its
output is continuous at the change and runs the new law from that sample,
``pid.retune_states``; the ADRC moves its disturbance estimate x4 so that
the new law (4b) of Nowak et al. 2018 gives the old law's value on the same
states, ``adrc.retune_x4``) -- before the controller computes its output.

The controller is always tuned for the schedule's present ``w``: a new
schedule and ``reset()`` start at the first breakpoint ``w_0`` with the
controller configured for it, and ``restore(snapshot())`` puts back ``w``,
retunes for it, then puts back the controller's state.

Equations
---------
For breakpoints ``w_0 < w_1 < ... < w_m`` and values ``p_0 .. p_m`` of one
parameter::

    p(w) = p_i + (p_{i+1} - p_i) (w - w_i) / (w_{i+1} - w_i),   w_i <= w <= w_{i+1}
    p(w) = p_0 for w < w_0,   p(w) = p_m for w > w_m

Every parameter value of the table is checked when the schedule is made (the
controller must accept the parameters of each breakpoint); the bounds the
blocks check are convex (``kp > 0``, ``ti >= 0``, ``ti >= 4 td``, ...), so a
linear interpolation between accepted points is accepted too.

Errors
------
A NaN/inf scheduling variable keeps the parameters in force and sets
``BAD_INPUT`` on the schedule (the controller runs on, with its own status);
``error_id`` otherwise is the controller's.  A table the controller refuses
is a :class:`ParameterError` with the controller's code, naming the breakpoint.
"""

from __future__ import annotations

import bisect
import dataclasses
from typing import Any

from .base import Block, BlockConfig, ErrorCode, ParameterError, is_finite, require_finite

__all__ = ["GainSchedule", "GainScheduleConfig", "interpolate"]


def interpolate(breakpoints: tuple[float, ...], values: tuple[float, ...], w: float) -> float:
    """Piecewise-linear ``p(w)`` through ``(breakpoints, values)``, ends held (see above)."""
    if w <= breakpoints[0]:
        return values[0]
    if w >= breakpoints[-1]:
        return values[-1]
    i = bisect.bisect_right(breakpoints, w) - 1
    w0, w1 = breakpoints[i], breakpoints[i + 1]
    return values[i] + (values[i + 1] - values[i]) * (w - w0) / (w1 - w0)


@dataclasses.dataclass(frozen=True)
class GainScheduleConfig(BlockConfig):
    """Configuration of :class:`GainSchedule`.

    Attributes
    ----------
    breakpoints : tuple of float
        Strictly increasing values of the scheduling variable.
    table : tuple of (name, tuple of float)
        For each scheduled controller parameter, its value at each breakpoint.
    """

    breakpoints: tuple[float, ...] = (0.0,)
    table: tuple[tuple[str, tuple[float, ...]], ...] = ()

    def validate(self) -> None:
        bps = [require_finite(f"breakpoints[{i}]", b) for i, b in enumerate(self.breakpoints)]
        if not bps:
            raise ParameterError(ErrorCode.BAD_PARAMETER, "breakpoints", "must not be empty")
        for i in range(1, len(bps)):
            if bps[i] <= bps[i - 1]:
                raise ParameterError(
                    ErrorCode.BAD_PARAMETER, "breakpoints", "must be strictly increasing"
                )
        if not self.table:
            raise ParameterError(ErrorCode.BAD_PARAMETER, "table", "schedules no parameter")
        for name, values in self.table:
            if len(values) != len(bps):
                raise ParameterError(
                    ErrorCode.BAD_PARAMETER,
                    name,
                    f"has {len(values)} values for {len(bps)} breakpoints",
                )
            for i, v in enumerate(values):
                require_finite(f"{name}[{i}]", v)


class GainSchedule(Block):
    """A controller whose parameters follow a scheduling variable (see the module docstring).

    ``GainSchedule(controller, breakpoints=(...), **{param: (values...)})``;
    one cycle is ``u = gs(sp, pv, w)`` with ``w`` the scheduling variable and
    any further keyword passed to the controller.  The two-phase form is
    ``gs.compute_output(sp, pv, w, ...)`` then ``gs.update_state(applied)``.

    >>> from ctrlblocks import PID
    >>> gs = GainSchedule(PID(kp=1.0, ti=10.0, ts=0.1), breakpoints=(0.0, 100.0),
    ...                   kp=(1.0, 3.0), ti=(10.0, 20.0))
    >>> u = gs(50.0, 45.0, w=50.0)
    >>> gs.controller.config.kp, gs.controller.config.ti
    (2.0, 15.0)
    """

    Config = GainScheduleConfig
    _state_fields = ("w",)
    _config: GainScheduleConfig
    controller: Any  # a PID or an ADRC: called with (sp, pv, ...) and reconfigured

    def __init__(
        self,
        controller: Block,
        config: GainScheduleConfig | None = None,
        /,
        *,
        breakpoints: tuple[float, ...] | list[float] | None = None,
        **tables: Any,
    ) -> None:
        self.controller = controller
        if config is None:
            config = GainScheduleConfig(
                breakpoints=tuple(breakpoints or ()),
                table=tuple((name, tuple(v)) for name, v in sorted(tables.items())),
            )
        elif breakpoints is not None or tables:
            raise TypeError("GainSchedule: give a config or breakpoints and tables, not both")
        super().__init__(config)

    # -- configuration ---------------------------------------------------------

    def _apply_config(self, old: BlockConfig | None) -> None:
        """Check that the controller accepts the parameters of every breakpoint."""
        c: GainScheduleConfig = self._config
        base = self.controller.config
        for i, bp in enumerate(c.breakpoints):
            params = {name: float(values[i]) for name, values in c.table}
            try:
                trial = dataclasses.replace(base, **params)  # type: ignore[arg-type]
                trial.validate()
            except TypeError as exc:
                raise ParameterError(ErrorCode.BAD_PARAMETER, "table", str(exc)) from None
            except ParameterError as exc:
                raise ParameterError(
                    exc.code, f"table at breakpoint {bp!r}: {exc.field}", exc.message
                ) from None

    def _reset_state(self) -> None:
        self.w = float(self._config.breakpoints[0])  # type: ignore[attr-defined]
        self._bad_w = False
        # the controller is always tuned for ``w`` (restore() relies on it): also at the start
        self._retune()

    def reset(self) -> None:
        """Reset the schedule and the controller."""
        super().reset()
        self.controller.reset()

    def snapshot(self, *, copy: bool = True) -> dict[str, Any]:
        """The schedule's state with the controller's snapshot inside."""
        snap = super().snapshot(copy=copy)
        snap["controller"] = self.controller.snapshot(copy=copy)
        return snap

    def restore(self, snapshot: dict[str, Any]) -> None:
        """Put back a :meth:`snapshot`: the controller's parameters at the restored
        scheduling variable, then its state."""
        super().restore(snapshot)
        self._retune()
        self.controller.restore(snapshot["controller"])

    # -- outputs -----------------------------------------------------------------

    @property
    def out(self) -> float:  # type: ignore[override]
        """The controller's output."""
        return self.controller.out

    @property
    def parameters(self) -> dict[str, float]:
        """The parameters the table gives at the present scheduling variable."""
        c: GainScheduleConfig = self._config
        return {name: interpolate(c.breakpoints, values, self.w) for name, values in c.table}

    # -- the cycle ---------------------------------------------------------------

    def schedule(self, w: float) -> None:
        """Retune the controller for the scheduling variable ``w`` (bumpless)."""
        if not is_finite(w):
            self._bad_w = True
            return
        self._bad_w = False
        self.w = float(w)
        self._retune()

    def _retune(self) -> None:
        """Configure the controller with the table's parameters at ``self.w`` if they changed."""
        params = self.parameters
        cfg = self.controller.config
        if any(getattr(cfg, name) != value for name, value in params.items()):
            self.controller.configure(**params)

    def __call__(self, sp: float, pv: float, w: float, **kwargs: Any) -> float:
        """One cycle: retune for ``w``, then run the controller on ``(sp, pv)``."""
        self.schedule(w)
        out = self.controller(sp, pv, **kwargs)
        self._status()
        return out

    def compute_output(self, sp: float, pv: float, w: float, **kwargs: Any) -> float:
        """Retune for ``w``, then the controller's ComputeOutput (Åström 1987, section 6)."""
        self.schedule(w)
        out = self.controller.compute_output(sp, pv, **kwargs)  # type: ignore[attr-defined]
        self._status()
        return out

    def update_state(self, applied: float) -> None:
        """The controller's UpdateState with the value actually applied."""
        self.controller.update_state(applied)  # type: ignore[attr-defined]
        self._status()

    def _status(self) -> None:
        if self._bad_w:
            self.error_id = ErrorCode.BAD_INPUT
        else:
            self.error_id = self.controller.error_id
