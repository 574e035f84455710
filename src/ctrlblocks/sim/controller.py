"""The controller side of a loop structure: one implementation for the simulator and the runtime.

:class:`ControllerSide` holds the blocks of one ``[[controllers]]`` entry
(a scenario's, or a runtime loop's) and wires them for the structure in
Åström's computational order (Åström 1987, section 6, Listing 6.3):

1. the caller reads the measurements (``y``; ``y2`` of a cascade's or an
   override's inner variable; ``dv``, the measured disturbance of a
   feed-forward structure) -- *Adin*;
2. :meth:`ControllerSide.compute` -- *ComputeOutput* of every block and
   *ShapeOutput* (the primary's output is the secondary's setpoint; the min
   or max selector of an override) -- returns the MV; no block state is
   committed;
3. the caller writes the MV -- *Daout*;
4. :meth:`ControllerSide.update` -- *UpdateState* of every block with the
   value actually applied (the secondary's ``awout`` goes to the primary's
   ``awin`` first: the AW handshake of Nowak et al. 2018, section 5 and Åström 1987
   section 3; every override block tracks the selected MV, Åström 1987
   Figs. 3.8/3.9; the Smith predictor's models advance with the MV, Nowak et al. 2018
   section 3.1).

:meth:`ControllerSide.step` is 2 + 4 in one call, for a caller that applies
the MV as computed (the runtime).

Structures and what they read (``structure`` -> measurements):

=============  ==========================================================
``single``     ``y``
``cascade``    ``y`` (primary), ``y2`` (secondary)
``override``   ``y`` and/or ``y2``, as each block's ``measure`` says
``feedforward``  ``y``, ``dv`` (through the lead-lag into the PID's ``ff``)
``smith``      ``y`` (the controller sees ``y + y_model_fast - y_model``)
``open_loop``  none (the block is driven by the setpoint)
=============  ==========================================================

Quality flags (``y_ok``, ``y2_ok``, ``dv_ok``): a block is called with the
flag of what it measures (cascade: primary ``y_ok``, secondary ``y2_ok``;
override: every block ``y_ok and y2_ok``); a bad ``dv`` freezes the
lead-lag (not called) and keeps its last output as ``ff``.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
from typing import Any

from .scenario import BlockSpec, ControllerSpec, build

__all__ = ["ControllerSide", "set_manual"]


class _Controller:
    """Uniform two-phase access to a controller block."""

    def __init__(self, block: Any) -> None:
        self.block = block
        self.two_phase = hasattr(block, "compute_output") and hasattr(block, "update_state")
        fn = block.compute_output if self.two_phase else block
        try:
            params = inspect.signature(fn).parameters
        except (TypeError, ValueError):  # pragma: no cover
            params = {}
        self.ok_name = next((n for n in ("y_ok", "pv_ok") if n in params), None)
        self.takes_ff = "ff" in params
        self.takes_dt = "dt" in params

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


def set_manual(block: Any, on: bool, value: float | None = None) -> None:
    """Switch ``block`` to manual (``on``) or auto, with a new manual value when given."""
    if value is not None:
        if hasattr(block, "manual_value"):
            block.manual_value = value
        elif hasattr(block, "u_man"):
            block.u_man = value
    if hasattr(block, "manual"):
        block.manual = on


class ControllerSide:
    """The blocks of one controller entry, wired for its structure (module docstring).

    Parameters
    ----------
    structure : str
        ``single``, ``cascade``, ``override``, ``feedforward``, ``smith`` or
        ``open_loop``.
    spec : ControllerSpec
        The controller entry (its blocks by role).
    ts : float
        Sample time [s].
    u0 : float
        The initial MV (the Smith predictor's models start in its steady state).
    file : str
        Names the file in error messages of :func:`~ctrlblocks.sim.scenario.build`.

    Attributes
    ----------
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
    """

    def __init__(
        self,
        structure: str,
        spec: ControllerSpec,
        ts: float,
        *,
        u0: float = 0.0,
        file: str = "<scenario>",
    ) -> None:
        self.structure = structure
        self.spec = spec
        self.ts = ts
        self.file = file
        self.u0 = u0
        self.blocks: dict[str, Any] = {}
        if structure == "override":
            self.override_specs: list[BlockSpec] = list(spec.blocks["blocks"])
            for i, s in enumerate(self.override_specs):
                self.blocks[f"blocks[{i}]"] = self._make(s, "block")
            # per block: its role, whether it measures y2, its fixed setpoint (None: sp)
            self._override = [
                (f"blocks[{i}]", s.extra.get("measure", "y") == "y2", _fixed_sp(s))
                for i, s in enumerate(self.override_specs)
            ]
        else:
            for role, s in spec.blocks.items():
                if role != "model":
                    self.blocks[role] = self._make(s, "block")
        self.ctrls = {
            role: _Controller(b)
            for role, b in self.blocks.items()
            if role != "feedforward" and structure != "open_loop"
        }
        if structure == "smith":
            model: BlockSpec = spec.blocks["model"]
            self.model = self._make(model, "plant")
            fast = dataclasses.replace(model, params={**model.params, "dead_time": 0.0})
            self.model_fast = self._make(fast, "plant")
            self.reset_models()
        if structure == "cascade":
            self.mv_blocks = [self.blocks["secondary"]]
        elif structure == "override":
            self.mv_blocks = [self.blocks[r] for r in self.ctrls]
        else:
            self.mv_blocks = [self.blocks["main"]]
        self.aw_handshake = bool(spec.options.get("aw_handshake", True))
        self.selector = spec.options.get("selector", "min")
        self.ff = 0.0
        self.u = u0
        self.values: dict[str, float] = {}
        self._pending: tuple[float, ...] = ()

    def _make(self, spec: BlockSpec, kind: str) -> Any:
        return build(spec, self.ts, kind=kind, file=self.file)

    @property
    def main(self) -> Any:
        """The block that writes the MV (``main``, the cascade's ``secondary``, ``blocks[0]``)."""
        return self.mv_blocks[0]

    @property
    def measurements(self) -> tuple[str, ...]:
        """The measurements :meth:`compute` needs: ``y``, ``y2``, ``dv`` (module docstring)."""
        s = self.structure
        if s == "open_loop":
            return ()
        if s == "cascade":
            return ("y", "y2")
        if s == "feedforward":
            return ("y", "dv")
        if s == "override":
            used = {"y2" if on_y2 else "y" for _, on_y2, _ in self._override}
            return tuple(m for m in ("y", "y2") if m in used)
        return ("y",)

    def reset_models(self) -> None:
        """Put the Smith predictor's models in the steady state of ``u0``."""
        if self.structure == "smith":
            self.model.reset(self.u0)
            self.model_fast.reset(self.u0)

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
        dt: float | None = None,
    ) -> float:
        """ComputeOutput and ShapeOutput: the MV of this sample (no block state committed).

        Parameters
        ----------
        sp : float
            The setpoint (of the primary in a cascade) [PV units].
        y, y2, dv : float
            The measurements the structure reads (:attr:`measurements`).
        y_ok, y2_ok, dv_ok : bool
            Their quality flags (module docstring).
        dt : float, optional
            This sample's period [s] for the controllers (default ``ts``).

        Returns
        -------
        float
            The MV ``u``; the structure's signals are in :attr:`values`.
        """
        s = self.structure
        vals: dict[str, float] = {}
        if s == "open_loop":
            u = float(self.blocks["main"](sp))
        elif s in ("single", "feedforward", "smith"):
            ff = 0.0
            y_fb = y
            if s == "feedforward":
                if dv_ok and math.isfinite(dv):
                    self.ff = float(self.blocks["feedforward"](dv))
                ff = vals["ff"] = self.ff
            elif s == "smith":
                y_fb = vals["y_pred"] = y + self.model_fast.y - self.model.y
            u = self.ctrls["main"].output(sp, y_fb, y_ok, ff, dt)
        elif s == "cascade":
            v1 = self.ctrls["primary"].output(sp, y, y_ok, dt=dt)
            u = self.ctrls["secondary"].output(v1, y2, y2_ok, dt=dt)
            vals["sp2"] = v1
            self._pending = (v1,)
        elif s == "override":
            ok = y_ok and y2_ok
            vs = [
                self.ctrls[role].output(sp if sp_i is None else sp_i, y2 if on_y2 else y, ok, dt=dt)
                for role, on_y2, sp_i in self._override
            ]
            u = min(vs) if self.selector == "min" else max(vs)
            for i, vi in enumerate(vs):
                vals[f"v{i + 1}"] = vi
        else:  # pragma: no cover - guarded by the parser
            raise ValueError(s)
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
        s = self.structure
        u = self.u if applied is None else applied
        if s == "open_loop":
            return
        if s in ("single", "feedforward", "smith"):
            self.ctrls["main"].update(u, measured=measured)
            if s == "smith":
                self.model.step(u)
                self.model_fast.step(u)
        elif s == "cascade":
            (v1,) = self._pending
            self.ctrls["secondary"].update(u)
            prim, sec = self.blocks["primary"], self.blocks["secondary"]
            if hasattr(prim, "awin") and self.aw_handshake:
                prim.awin = bool(getattr(sec, "awout", False))
            self.ctrls["primary"].update(v1)
        else:  # override: every block tracks the selected MV
            for role in self.ctrls:
                self.ctrls[role].update(u)

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
        result as the two phases, on the block's fast lane).
        """
        if self.structure == "single":
            u = self.u = self.ctrls["main"].cycle(sp, y, y_ok, dt)
            self.values = {"v": u}
            return u
        u = self.compute(sp, y, y_ok=y_ok, dt=dt, **measurements)
        self.update(u)
        return u

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
