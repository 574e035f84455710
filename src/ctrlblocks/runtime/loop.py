"""One control loop of the runtime: a block, its I/O bindings, its cycle and its commands.

Each cycle (called by the scheduler at an absolute deadline):

1. the :class:`~ctrlblocks.blocks.monitor.CycleMonitor` records the measured
   period; a period above the warning limit is an *overrun*: the loop's
   ``overrun`` status is set and this cycle's block call uses the measured
   period as ``dt`` (otherwise the configured ``ts``);
2. read the bound inputs (PV, and SP, mode, manual value, limits where they
   are bound to I/O), one request per connection, concurrently;
3. apply mode / manual value / limits from I/O (a bound value that cannot
   be read leaves the one in force);
4. run the block: ``block(sp, pv, y_ok=/pv_ok=quality, dt=...)``.  A PV that
   failed, timed out, was stale, NaN or of bad quality sets the quality flag
   false *in this cycle*: ADRC goes to its safe value ``u_sf``, PID to its
   ``safe_value`` or holds (``on_bad_pv``); both recover without a bump when
   the PV returns (the blocks' own rules);
5. write the MV; a failed write is retried ``write_retries`` times at once,
   then reported (``write_ok`` false, ``write_error``) and the next cycle
   writes again.

A loop never raises out of its cycle; faults only change its status.
"""

from __future__ import annotations

import asyncio
import dataclasses
import logging
import math
import time
from collections.abc import Mapping
from typing import Any

from ..blocks.base import ErrorCode, ParameterError, is_finite, require_limits
from ..blocks.monitor import CycleMonitor
from ..loops.structures import ControllerSide
from .config import MEASUREMENTS, MODES, Binding, LoopConfig
from .io import Connection, Reading, bad

__all__ = ["CommandError", "ControlLoop", "Sample"]

log = logging.getLogger(__name__)

_LOOP_LEVEL = ("ts", "safe_value", "u_sf", "u_min", "u_max")


class CommandError(ValueError):
    """A command refused by a loop (bad value, signal bound to I/O, unknown key).

    ``code`` is an :class:`~ctrlblocks.blocks.base.ErrorCode` (``BAD_PARAMETER``
    unless the block gave its own), ``field`` the refused key.
    """

    def __init__(self, field: str, message: str, code: int = ErrorCode.BAD_PARAMETER) -> None:
        self.field, self.message, self.code = field, message, ErrorCode(code)
        super().__init__(f"{field}: {message}")


@dataclasses.dataclass(frozen=True)
class Sample:
    """What the historian records for one loop and one cycle."""

    loop: str
    cycle: int
    t_wall: float
    t: float
    dt: float
    sp: float
    pv: float
    mv: float
    mode: str
    error_id: int
    pv_ok: bool
    write_ok: bool
    overrun: bool


class ControlLoop:
    """A block running against process I/O (see the module docstring).

    Parameters
    ----------
    config : LoopConfig
        The loop's configuration.
    side : ControllerSide
        The structure's blocks (:func:`~ctrlblocks.runtime.config.build_side`).
    connections : mapping
        Connection name -> :class:`~ctrlblocks.runtime.io.Connection`.

    Attributes
    ----------
    block : PID or ADRC
        The block that writes the MV (``side.main``): its status, limits
        and tunings are the faceplate's.
    """

    def __init__(
        self, config: LoopConfig, side: ControllerSide, connections: Mapping[str, Connection]
    ) -> None:
        self.config = config
        self.name = config.name
        self.side = side
        self.block = side.main
        self.connections = connections
        self.ts = config.ts
        self.monitor = CycleMonitor(
            ts=config.ts, warn_limit=config.warn_limit, alarm_limit=config.alarm_limit
        )
        # status for the faceplate
        self.cycle_count = 0
        self.pv = math.nan
        self.pv_ok = False
        self.pv_reason = "no cycle yet"
        self.measurements: dict[str, float] = {}
        self.mv = math.nan
        self.write_ok = True
        self.write_error = ""
        self.write_failures = 0
        self.overrun = False
        self.dt = config.ts
        self.input_errors: dict[str, str] = {}
        self.last_exception = ""
        self._limits_in = (math.nan, math.nan)
        # signal -> binding of the inputs read each cycle
        self._inputs = {n: b for n, b in config.bindings().items() if b.is_io and n != "mv"}
        self.sp = float(config.sp.value) if not config.sp.is_io else math.nan
        mode = config.mode.value if not config.mode.is_io else "auto"
        self._set_mode(mode)
        if config.manual_value is not None and not config.manual_value.is_io:
            self._set_manual_value(float(config.manual_value.value))

    # -- helpers ---------------------------------------------------------------

    @property
    def mode(self) -> str:
        """``"auto"`` or ``"manual"``."""
        return "manual" if self.block.manual else "auto"

    def _set_mode(self, mode: str, *, preset: bool = True) -> None:
        manual = mode == "manual"
        value = None
        if manual and not self.side.manual and preset and not self.is_bound("manual_value"):
            # auto -> manual without a new manual value: continue from the output
            value = next((float(x) for x in (self.mv, self.block.out) if is_finite(x)), None)
        self.side.set_manual(manual, value)

    def _set_manual_value(self, value: float) -> None:
        for b in self.side.mv_blocks:
            b.manual_value = value

    def is_bound(self, signal: str) -> bool:
        """True when ``signal`` comes from process I/O (commands cannot change it)."""
        b = self.config.bindings().get(signal)
        return b is not None and b.is_io

    async def _read_inputs(self) -> dict[str, Reading]:
        by_conn: dict[str, list[tuple[str, Binding]]] = {}
        for sig, b in self._inputs.items():
            by_conn.setdefault(b.connection, []).append((sig, b))  # type: ignore[arg-type]

        async def one(conn_name: str, items: list[tuple[str, Binding]]) -> dict[str, Reading]:
            conn = self.connections.get(conn_name)
            if conn is None:
                return {s: bad(f"no connection {conn_name!r}") for s, _ in items}
            readings = await conn.read([b.address for _, b in items])
            return {s: r for (s, _), r in zip(items, readings, strict=True)}

        results = await asyncio.gather(*(one(c, items) for c, items in by_conn.items()))
        out: dict[str, Reading] = {}
        for r in results:
            out.update(r)
        return out

    def _apply_inputs(self, inputs: Mapping[str, Reading]) -> None:
        errors: dict[str, str] = {}
        for sig, r in inputs.items():
            if sig not in MEASUREMENTS and not r.ok:
                errors[sig] = r.reason
        if "sp" in inputs and inputs["sp"].ok:
            self.sp = inputs["sp"].value  # a bad SP read keeps the last good SP
        if "manual_value" in inputs and inputs["manual_value"].ok:
            self._set_manual_value(inputs["manual_value"].value)
        if "mode" in inputs and inputs["mode"].ok:
            m = inputs["mode"].value
            if m in (0.0, 1.0):
                self._set_mode(MODES[int(m)])
            else:
                errors["mode"] = f"mode input {m!r} is not 0 (auto) or 1 (manual)"
        if "u_min" in inputs:
            lo, hi = inputs["u_min"], inputs["u_max"]
            if lo.ok and hi.ok and (lo.value, hi.value) != self._limits_in:
                self._limits_in = (lo.value, hi.value)
                self.side.set_limits(lo.value, hi.value)
        self.input_errors = errors

    # -- the cycle ----------------------------------------------------------------

    async def cycle(self, t: float, period: float) -> Sample:
        """Run one cycle at time ``t`` [s] after a measured ``period`` [s] (module docstring)."""
        first = self.cycle_count == 0
        dt: float | None = None
        overrun = False
        if not first:
            overrun = bool(self.monitor(period))
            if overrun:
                dt = period
        self.overrun = overrun
        self.dt = self.ts if dt is None else dt
        try:
            inputs = await self._read_inputs()
            self._apply_inputs(inputs)
            # every measurement the structure needs must be good, else the MV
            # blocks see a bad measurement in this cycle (their safe value)
            ok = True
            reasons = []
            meas: dict[str, float] = {}
            for sig, name in MEASUREMENTS.items():
                if sig in inputs:
                    r = inputs[sig]
                    meas[name] = r.value if r.ok else math.nan
                    self.measurements[sig] = r.value
                    if not r.ok:
                        ok = False
                        reasons.append(r.reason if sig == "pv" else f"{sig}: {r.reason}")
            pv = inputs["pv"] if "pv" in inputs else inputs["pv2"]
            self.pv, self.pv_ok, self.pv_reason = pv.value, ok, "; ".join(reasons)
            u = self.side.step(
                self.sp,
                meas.get("y", math.nan),
                y_ok=ok,
                y2=meas.get("y2", math.nan),
                y2_ok=ok,
                dv=meas.get("dv", 0.0),
                dv_ok=ok,
                dt=dt,
            )
            self.mv = u
            await self._write_mv(u)
        except Exception as exc:  # a loop never stops the runtime
            log.exception("loop %s: cycle failed", self.name)
            self.last_exception = f"{type(exc).__name__}: {exc}"
        self.cycle_count += 1
        return Sample(
            loop=self.name,
            cycle=self.cycle_count - 1,
            t_wall=time.time(),
            t=t,
            dt=self.dt,
            sp=self.sp,
            pv=self.pv,
            mv=self.mv,
            mode=self.mode,
            error_id=int(self.block.error_id),
            pv_ok=self.pv_ok,
            write_ok=self.write_ok,
            overrun=overrun,
        )

    async def _write_mv(self, u: float) -> bool:
        b = self.config.mv
        conn = self.connections.get(b.connection)  # type: ignore[arg-type]
        err: str | None = f"no connection {b.connection!r}"
        if conn is not None:
            for _ in range(1 + self.config.write_retries):
                (err,) = await conn.write([(b.address, u)])
                if err is None:
                    break
        self.write_ok = err is None
        if err is not None:
            self.write_failures += 1
            if self.write_error != err:
                log.warning("loop %s: MV write failed: %s", self.name, err)
            self.write_error = err
        else:
            self.write_error = ""
        return self.write_ok

    async def write_stop_value(self) -> bool:
        """Write the configured stop value (``stop_value``, else ``safe_value``) to the MV."""
        v = self.config.stop_value if self.config.stop_value is not None else self.config.safe_value
        ok = await self._write_mv(v)
        self.mv = v
        return ok

    # -- state and commands ---------------------------------------------------------

    def state(self) -> dict[str, Any]:
        """Everything a faceplate shows, as plain values."""
        blk = self.block
        cfg = blk.config
        m = self.monitor
        return {
            "name": self.name,
            "block": self.config.block_type,
            "structure": self.config.structure,
            "ts": self.ts,
            "cycle": self.cycle_count,
            "sp": self.sp,
            "pv": self.pv,
            "mv": self.mv,
            "mode": self.mode,
            "manual_value": float(blk.manual_value),
            "error": bool(blk.error),
            "error_id": int(blk.error_id),
            "error_name": blk.error_name,
            "pv_ok": self.pv_ok,
            "pv_reason": self.pv_reason,
            "write_ok": self.write_ok,
            "write_error": self.write_error,
            "write_failures": self.write_failures,
            "input_errors": dict(self.input_errors),
            "last_exception": self.last_exception,
            "u_min": float(blk.u_min),
            "u_max": float(blk.u_max),
            "safe_value": self.config.safe_value,
            "on_bad_pv": self.config.on_bad_pv,
            "tunings": {
                f.name: getattr(cfg, f.name)
                for f in dataclasses.fields(cfg)
                if f.name not in _LOOP_LEVEL
            },
            "bound": {s: str(b) for s, b in self.config.bindings().items() if b.is_io},
            "overrun": self.overrun,
            "dt": self.dt,
            "measurements": dict(self.measurements),
            "signals": dict(self.side.values),
            "blocks": self.side.inner_states(),
            "period": {
                "last": m.out,
                "mean": m.mean,
                "min": m.min,
                "max": m.max,
                "jitter_std": m.jitter_std,
                "overruns": m.overruns,
                "alarms": m.alarms,
            },
        }

    def command(self, **changes: Any) -> dict[str, Any]:
        """Apply an operator command; all-or-nothing; return the old values of what changed.

        Keys: ``mode`` (``"auto"``/``"manual"``), ``manual_value``, ``sp``,
        ``u_min`` and ``u_max`` (together), ``tunings`` (a dict for the
        block's ``configure``, which validates it and keeps the old
        configuration on refusal; its bumpless rules apply).  A signal bound
        to I/O cannot be commanded.  Raises :class:`CommandError`.
        """
        allowed = {"mode", "manual_value", "sp", "u_min", "u_max", "tunings"}
        unknown = sorted(set(changes) - allowed)
        if unknown:
            raise CommandError(unknown[0], f"unknown command; expected one of {sorted(allowed)}")
        for sig in ("mode", "manual_value", "sp", "u_min", "u_max"):
            if sig in changes and self.is_bound(sig):
                raise CommandError(sig, f"is bound to I/O ({self.config.bindings()[sig]})")
        old: dict[str, Any] = {}
        if "mode" in changes and changes["mode"] not in MODES:
            raise CommandError("mode", f"must be one of {MODES}, got {changes['mode']!r}")
        for sig in ("manual_value", "sp"):
            if sig in changes and not (
                not isinstance(changes[sig], bool) and is_finite(changes[sig])
            ):
                raise CommandError(sig, f"must be a finite number, got {changes[sig]!r}")
        limits = None
        if "u_min" in changes or "u_max" in changes:
            if not ("u_min" in changes and "u_max" in changes):
                raise CommandError("u_min", "give u_min and u_max together")
            try:
                limits = require_limits("u_min", changes["u_min"], "u_max", changes["u_max"])
            except ParameterError as exc:
                raise CommandError(exc.field, exc.message, exc.code) from None
        tunings = changes.get("tunings")
        if tunings is not None:
            if not isinstance(tunings, Mapping) or not tunings:
                raise CommandError("tunings", "must be a non-empty table of block parameters")
            for k in tunings:
                if k in _LOOP_LEVEL:
                    raise CommandError(f"tunings.{k}", "is not a tuning (use its own command)")
            cfg = self.block.config
            try:
                before = {k: getattr(cfg, k) for k in tunings}
            except AttributeError as exc:
                raise CommandError("tunings", f"unknown parameter: {exc}") from None
            try:
                self.block.configure(**dict(tunings))
            except ParameterError as exc:
                raise CommandError(f"tunings.{exc.field}", exc.message, exc.code) from None
            except TypeError as exc:
                raise CommandError("tunings", str(exc)) from None
            old["tunings"] = before
        if limits is not None:
            old["u_min"], old["u_max"] = float(self.block.u_min), float(self.block.u_max)
            self.side.set_limits(*limits)
        if "sp" in changes:
            old["sp"] = self.sp
            self.sp = float(changes["sp"])
        if "manual_value" in changes:
            old["manual_value"] = float(self.block.manual_value)
            self._set_manual_value(float(changes["manual_value"]))
        if "mode" in changes:
            old["mode"] = self.mode
            self._set_mode(changes["mode"], preset="manual_value" not in changes)
        return old
