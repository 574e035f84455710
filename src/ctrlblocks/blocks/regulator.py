"""The complete regulator of Åström 1987, Fig. 4.6: PID, manual station, local/remote setpoint.

Source
------
Åström 1987, section 4 "Manual Control": "Using the module for PID control,
introduced in Figure 3.6, and the manual control module in Figure 4.5 it is
straightforward to construct a complete regulator.  Figure 4.6 shows a PID
regulator with internal or external setpoints via increase/decrease buttons
and manual automatic mode.  Notice that the system only has two switches."
The figure is lost in the text extraction; the assembly below follows the
text and Fig. 4.4's principle that each integrator "must be reset to a proper
value" while it is not in use, by tracking:

* **setpoint**: a :class:`~ctrlblocks.ManualStation` holds the internal
  (local) setpoint, moved by its increase/decrease buttons.  Switch 1 selects
  it or the external (remote) setpoint.  While remote, the station tracks the
  remote setpoint, so that switching to local keeps the setpoint where it was
  (bumpless).  Switching to remote jumps to the remote setpoint, as the switch
  does (the PID's ``sp_rate`` makes that a ramp where it matters);
* **output**: switch 2 selects the PID's output (automatic) or a second
  ManualStation's (manual, increase/decrease buttons for the output).  In
  automatic the station tracks the PID's output; in manual the PID tracks the
  station's (its manual mode, Åström 1987, Fig. 4.4: "the feedback from the
  output v of the PID regulator tracks the output v"), so both switches are
  bumpless, whatever the control error at the switch.  Anti-windup is the
  PID's (tracking or clamping at the output limits).

Tracking time constant ``tr`` (Åström's ``T_r`` of the manual module): 0
(default) is ideal tracking -- each switch is exactly bumpless; ``tr > 0``
lets the idle station follow with that lag (a bump up to the lag's error).

Inputs of each sample: ``pv`` (and ``pv_ok``), ``sp_remote`` (the external
setpoint; NaN, inf or beyond the REAL range: the setpoint holds, ``BAD_INPUT``),
the four buttons ``sp_inc``, ``sp_dec``, ``out_inc``, ``out_dec``; the switches
are the attributes :attr:`Regulator.auto` and :attr:`Regulator.remote`.

One cycle for the block, the float32 lane and the PLC
-----------------------------------------------------
The two stations and the two switches are one pure function,
:func:`regulator_cycle`, in the subset the PLC translator accepts (each station
is :func:`.manual.manual_station_step`, the ManualStation block's own sample).
It runs *before* the PID: from the switches, the buttons, the remote setpoint
and the PID's output of the last cycle it gives the PID's working setpoint
``sp``, its mode ``manual`` and ``man_value``; the PID then computes the output
(in manual ``man_value`` itself: the station stays inside the PID's limits).
The tracking of the output station in automatic ("must be reset to a proper
value", Åström 1987, section 4) needs the PID's output of that cycle, so it is
done at the start of the next one with that output and that cycle's sample
time: the same operations in the same order as tracking right after the PID,
and what a PLC does when the regulator's FUNCTION_BLOCK ``CB_REGULATOR`` reads
``CB_PID.MV`` before calling ``CB_PID`` (docs/plc.md).  The block runs the
cycle in float64 and, with ``precision="float32"``, rounded to REAL with the
PID's float32 lane: then it is ``CB_REGULATOR`` wired to ``CB_PID``, bit for bit.

Limits and manual parameters written at run time (in the PLC) that are no
finite REAL, reversed limits, a ``tm`` or ``t_accel`` <= 0, ``accel_max`` < 1
or ``tr`` < 0 are refused by the cycle (``BAD_LIMITS``, ``BAD_PARAMETER``) and
the ones in force stay, as :meth:`Regulator.configure` refuses them.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from .base import (
    Block,
    BlockConfig,
    ErrorCode,
    ParameterError,
    as_flag,
    as_input,
    require_finite,
    require_limits,
    require_nonnegative,
    require_positive,
)
from .composite import CompositeBlock
from .cycleblock import TIME_CAP, CycleBlock, require_precision, run_cycle
from .manual import ManualStation, manual_station_step
from .pid import PID
from .plc_cycle import REAL_MAX, is_real
from .signals import clamp

__all__ = ["REGULATOR_RESULTS", "Regulator", "RegulatorConfig", "regulator_cycle"]

NO_ERROR = int(ErrorCode.NO_ERROR)
BAD_INPUT = int(ErrorCode.BAD_INPUT)
BAD_RESULT = int(ErrorCode.BAD_RESULT)
BAD_LIMITS = int(ErrorCode.BAD_LIMITS)
BAD_PARAMETER = int(ErrorCode.BAD_PARAMETER)

LIMIT_MAX = 1e30
"""The largest magnitude of a configured limit (a REAL holds it and the span between two)."""


# ---------------------------------------------------------------------------
# The cycle (the PLC translator's subset)
# ---------------------------------------------------------------------------


def station_rate(lo: float, hi: float, tm: float) -> float:
    """The base rate ``span / Tm`` of a station over ``lo .. hi`` (span 1 for an empty range)."""
    span = hi - lo
    if not span > 0.0:
        span = 1.0
    return span / tm


def regulator_station(
    inc: bool,
    dec: bool,
    w: float,
    tracking: bool,
    h: float,
    rate: float,
    tr: float,
    t_accel: float,
    accel_max: float,
    lo: float,
    hi: float,
    v: float,
    held: float,
    direction: int,
) -> tuple[float, float, int, bool]:
    """One sample of a station (:func:`.manual.manual_station_step`) in the REAL range.

    A result that is no finite REAL (an overflow from extreme but finite data) holds
    the station (the ManualStation block's output guard); the last value is False then.
    Returns ``(v, held, direction, ok)``.
    """
    v_new, held_new, d_new = manual_station_step(
        inc, dec, w, tracking, h, rate, tr, t_accel, accel_max, lo, hi, REAL_MAX, v, held,
        direction,
    )  # fmt: skip
    if is_real(v_new):
        return v_new, held_new, d_new, True
    return v, 0.0, 0, False


def limit_pair(lo: float, hi: float) -> bool:
    """True for a usable pair of limits written at run time: finite REALs, ``lo <= hi``."""
    if is_real(lo) and is_real(hi):
        return lo <= hi
    return False


def station_parameters_ok(
    tm_sp: float, tm_out: float, t_accel: float, accel_max: float, tr: float
) -> bool:
    """True for usable manual parameters: finite REALs, ``Tm``, ``t_accel`` > 0,
    ``accel_max`` >= 1, ``Tr`` >= 0 (what :class:`RegulatorConfig` accepts)."""
    ok = is_real(tm_sp) and is_real(tm_out) and is_real(t_accel)
    ok = ok and is_real(accel_max) and is_real(tr)
    if ok:
        ok = tm_sp > 0.0 and tm_out > 0.0 and t_accel > 0.0 and accel_max >= 1.0 and tr >= 0.0
    return ok


REGULATOR_RESULTS = (
    "sp_out", "manual", "man_value", "error_id", "sp_w", "sp_v", "sp_held", "sp_dir", "u_v",
    "u_held", "u_dir", "follow", "h_prev", "sp_lo", "sp_hi", "u_lo", "u_hi", "tm_sp_f",
    "tm_out_f", "t_accel_f", "accel_max_f", "tr_f",
)  # fmt: skip
"""Names of the values :func:`regulator_cycle` returns: outputs, then the new memory."""


def regulator_cycle(
    pid_mv: float,
    sp_remote: float,
    auto: bool,
    remote: bool,
    sp_inc: bool,
    sp_dec: bool,
    out_inc: bool,
    out_dec: bool,
    sp_min: float,
    sp_max: float,
    u_min: float,
    u_max: float,
    tm_sp: float,
    tm_out: float,
    t_accel: float,
    accel_max: float,
    tr: float,
    ts: float,
    sp_w: float,
    sp_v: float,
    sp_held: float,
    sp_dir: int,
    u_v: float,
    u_held: float,
    u_dir: int,
    follow: bool,
    h_prev: float,
    sp_lo: float,
    sp_hi: float,
    u_lo: float,
    u_hi: float,
    tm_sp_f: float,
    tm_out_f: float,
    t_accel_f: float,
    accel_max_f: float,
    tr_f: float,
) -> tuple[Any, ...]:
    """The stations and switches of Åström 1987, Fig. 4.6, before the PID (module docstring).

    ``pid_mv`` is the PID's output of the last cycle; switch 1 (``remote``) takes
    ``sp_remote`` or the local station's setpoint (``sp_inc``/``sp_dec``), the local
    station tracking the remote setpoint; switch 2 (``auto``) leaves the PID in
    automatic, its output station tracking ``pid_mv`` (at the start of the next
    cycle, ``follow``, with that cycle's sample time ``h_prev``), or puts it in
    manual at the output station's value (``out_inc``/``out_dec``).  The memory
    ``*_f``, ``sp_lo`` ... ``u_hi`` is the parameter set in force.  Returns
    :data:`REGULATOR_RESULTS`.
    """
    err = NO_ERROR
    ok = True
    if follow:
        # automatic in the last cycle: the output station tracks the PID's output of it, with
        # that cycle's sample time and parameters (those in force before this cycle's)
        if is_real(pid_mv):
            u_v, u_held, u_dir, ok = regulator_station(
                False, False, pid_mv, True, h_prev, station_rate(u_lo, u_hi, tm_out_f), tr_f,
                t_accel_f, accel_max_f, u_lo, u_hi, u_v, u_held, u_dir,
            )  # fmt: skip
        else:
            err = BAD_INPUT
    # limits and manual parameters written at run time: a bad set keeps the one in force
    if limit_pair(sp_min, sp_max):
        sp_lo = sp_min
        sp_hi = sp_max
    else:
        err = BAD_LIMITS
    if limit_pair(u_min, u_max):
        u_lo = u_min
        u_hi = u_max
    else:
        err = BAD_LIMITS
    if station_parameters_ok(tm_sp, tm_out, t_accel, accel_max, tr):
        tm_sp_f = tm_sp
        tm_out_f = tm_out
        t_accel_f = t_accel
        accel_max_f = accel_max
        tr_f = tr
    else:
        err = BAD_PARAMETER
    sp_v = clamp(sp_v, sp_lo, sp_hi)
    u_v = clamp(u_v, u_lo, u_hi)
    rate_sp = station_rate(sp_lo, sp_hi, tm_sp_f)
    rate_u = station_rate(u_lo, u_hi, tm_out_f)
    # switch 1: the setpoint; while remote the local station tracks the remote setpoint
    # (bumpless back to local) and a remote setpoint that is no finite REAL holds SP
    ok_sp = True
    if remote:
        if is_real(sp_remote):
            sp_w = sp_remote
            sp_v, sp_held, sp_dir, ok_sp = regulator_station(
                False, False, sp_remote, True, ts, rate_sp, tr_f, t_accel_f, accel_max_f, sp_lo,
                sp_hi, sp_v, sp_held, sp_dir,
            )  # fmt: skip
        else:
            err = BAD_INPUT
    else:
        sp_v, sp_held, sp_dir, ok_sp = regulator_station(
            sp_inc, sp_dec, 0.0, False, ts, rate_sp, tr_f, t_accel_f, accel_max_f, sp_lo, sp_hi,
            sp_v, sp_held, sp_dir,
        )  # fmt: skip
        sp_w = sp_v
    # switch 2: the output; in manual the PID tracks the station (its MANUAL mode)
    ok_u = True
    if not auto:
        u_v, u_held, u_dir, ok_u = regulator_station(
            out_inc, out_dec, 0.0, False, ts, rate_u, tr_f, t_accel_f, accel_max_f, u_lo, u_hi,
            u_v, u_held, u_dir,
        )  # fmt: skip
    if not (ok and ok_sp and ok_u):
        err = BAD_RESULT
    follow = auto
    h_prev = ts
    return (
        sp_w, not auto, u_v, err, sp_w, sp_v, sp_held, sp_dir, u_v, u_held, u_dir, follow,
        h_prev, sp_lo, sp_hi, u_lo, u_hi, tm_sp_f, tm_out_f, t_accel_f, accel_max_f, tr_f,
    )  # fmt: skip


# ---------------------------------------------------------------------------
# The block
# ---------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class RegulatorConfig(BlockConfig):
    """Configuration of :class:`Regulator`.

    Attributes
    ----------
    kp, ti, td, n, b : float
        The PID (ISA form, :class:`~ctrlblocks.PID`).
    u_min, u_max : float
        Output range [%] (the PID's limits and the manual station's range),
        finite, within +-1e30.
    sp_min, sp_max : float
        Range of the local setpoint [PV units], finite, within +-1e30.
    tm_sp, tm_out : float
        Manual time constants [s] of the setpoint and output stations: a held
        button moves through the whole range in that time at the base rate.
    t_accel, accel_max : float
        Acceleration of a held button (:class:`~ctrlblocks.ManualStation`).
    tr : float
        Tracking time constant [s] of the idle station; 0: ideal tracking.
    sp0, u0 : float
        Local setpoint and output after a reset.
    sp_rate : float
        The PID's setpoint ramp [PV units/s]; 0: off.
    ts : float
        Sample time [s].
    precision : str
        ``"float64"`` or ``"float32"``: the stations, the switches and the PID
        computed as a PLC's REAL does (``CB_REGULATOR`` wired to ``CB_PID``).
    """

    kp: float = 1.0
    ti: float = 0.0
    td: float = 0.0
    n: float = 10.0
    b: float = 1.0
    u_min: float = 0.0
    u_max: float = 100.0
    sp_min: float = 0.0
    sp_max: float = 100.0
    tm_sp: float = 50.0
    tm_out: float = 20.0
    t_accel: float = 2.0
    accel_max: float = 5.0
    tr: float = 0.0
    sp0: float = 0.0
    u0: float = 0.0
    sp_rate: float = 0.0
    ts: float = 0.1
    precision: str = "float64"

    def validate(self) -> None:
        for lo, hi in (("u_min", "u_max"), ("sp_min", "sp_max")):
            a, z = require_limits(lo, getattr(self, lo), hi, getattr(self, hi),
                                  allow_infinite=False)  # fmt: skip
            if max(abs(a), abs(z)) > LIMIT_MAX:
                raise ParameterError(
                    ErrorCode.BAD_LIMITS, f"{lo}/{hi}", f"must lie within +-1e30, got {a!r}, {z!r}"
                )
        require_finite("sp0", self.sp0)
        require_finite("u0", self.u0)
        require_nonnegative("tr", self.tr, ErrorCode.BACK_CALC_T)
        require_positive("ts", self.ts, ErrorCode.NO_CYCLE)
        PID(**self.pid_params())  # refuses bad tunings (and precisions) with the PID's codes
        for which in ("sp", "out"):
            ManualStation(**self.station_params(which))
        for name in ("tm_sp", "tm_out", "t_accel", "accel_max", "tr"):
            x = float(getattr(self, name))
            if x > TIME_CAP:
                raise ParameterError(ErrorCode.BAD_PARAMETER, name, f"must be <= 1e30, got {x!r}")
        require_precision(self)  # last: every field is a number by now

    def pid_params(self) -> dict[str, Any]:
        """The PID's configuration."""
        return {"kp": self.kp, "ti": self.ti, "td": self.td, "n": self.n, "b": self.b,
                "ts": self.ts, "u_min": self.u_min, "u_max": self.u_max,
                "sp_rate": self.sp_rate, "reset_value": self.u0,
                "precision": self.precision}  # fmt: skip

    def station_params(self, which: str) -> dict[str, Any]:
        """The setpoint (``"sp"``) or output (``"out"``) station's configuration."""
        if which == "sp":
            lo, hi, tm, y0 = self.sp_min, self.sp_max, self.tm_sp, self.sp0
        else:
            lo, hi, tm, y0 = self.u_min, self.u_max, self.tm_out, self.u0
        span = hi - lo if hi > lo else 1.0
        return {"tm": tm, "tr": self.tr, "span": span, "t_accel": self.t_accel,
                "accel_max": self.accel_max, "out_min": lo, "out_max": hi, "ts": self.ts,
                "y0": y0}  # fmt: skip


class Regulator(CompositeBlock):
    """PID with manual station and local/remote setpoint (Åström 1987, Fig. 4.6).

    ``u = reg(pv, sp_remote, sp_inc=..., out_inc=...)`` runs one sample.
    ``reg.auto`` (default True) and ``reg.remote`` (default False) are the two
    switches; :attr:`sp` is the working setpoint.  See the module docstring.

    Examples
    --------
    Manual at 40 %: the PID tracks the station; back in automatic the output
    continues from 40 % (bumpless, whatever the error).

    >>> reg = Regulator(kp=2.0, ti=10.0, sp0=50.0, u0=40.0, ts=1.0)
    >>> reg.auto = False
    >>> reg(30.0)
    40.0
    >>> reg.auto = True
    >>> reg(30.0), reg(30.0)  # from 40 on, the integral adds 2/10 x 20 x 1 a sample
    (40.0, 44.0)
    """

    Config = RegulatorConfig
    _state_fields = ("out", "sp", "auto", "remote", "_mem")
    config: RegulatorConfig
    _config: RegulatorConfig
    _mem: dict[str, Any]

    def _apply_config(self, old: BlockConfig | None) -> None:
        c = self._config
        self._f32 = c.precision == "float32"
        self._prm = self._parameters()
        if old is None:
            self.pid = PID(**c.pid_params())
            return
        self.pid.configure(**c.pid_params())
        self.out = clamp(self.out, c.u_min, c.u_max)
        # the new set comes into force with the next cycle (as a PLC writing the inputs)

    def _parameters(self) -> dict[str, Any]:
        c = self._config
        return {"sp_min": float(c.sp_min), "sp_max": float(c.sp_max), "u_min": float(c.u_min),
                "u_max": float(c.u_max), "tm_sp": float(c.tm_sp), "tm_out": float(c.tm_out),
                "t_accel": float(c.t_accel), "accel_max": float(c.accel_max),
                "tr": float(c.tr), "ts": float(c.ts)}  # fmt: skip

    def _initial(self) -> dict[str, Any]:
        """The cycle's memory after a reset: the stations at ``sp0`` and ``u0``."""
        c = self._config
        sp0 = clamp(float(c.sp0), float(c.sp_min), float(c.sp_max))
        u0 = clamp(float(c.u0), float(c.u_min), float(c.u_max))
        return {"sp_w": sp0, "sp_v": sp0, "sp_held": 0.0, "sp_dir": 0, "u_v": u0,
                "u_held": 0.0, "u_dir": 0, "follow": False, "h_prev": float(c.ts),
                "sp_lo": float(c.sp_min), "sp_hi": float(c.sp_max), "u_lo": float(c.u_min),
                "u_hi": float(c.u_max), "tm_sp_f": float(c.tm_sp), "tm_out_f": float(c.tm_out),
                "t_accel_f": float(c.t_accel), "accel_max_f": float(c.accel_max),
                "tr_f": float(c.tr)}  # fmt: skip

    def _reset_state(self) -> None:
        self.pid.reset()
        self._mem = self._initial()
        c = self._config
        self.out = clamp(float(c.u0), c.u_min, c.u_max)
        self.sp = float(self._mem["sp_v"])
        self.auto = True
        self.remote = False

    def parts(self) -> dict[str, Block]:
        """The PID (the stations and switches are the cycle's memory)."""
        return {"pid": self.pid}

    def output_limits(self) -> tuple[float, float]:
        """``(u_min, u_max)``."""
        return float(self._config.u_min), float(self._config.u_max)

    def __call__(
        self,
        pv: float,
        sp_remote: float = math.nan,
        *,
        sp_inc: Any = False,
        sp_dec: Any = False,
        out_inc: Any = False,
        out_dec: Any = False,
        pv_ok: Any = True,
        dt: float | None = None,
    ) -> float:
        """One sample (module docstring); return the output."""
        h = self._cycle_time(dt, float(self._config.ts))
        if h is None:
            return self.out
        if self._f32 and not h <= REAL_MAX:
            self.error_id = ErrorCode.NO_CYCLE  # a PLC's TS cannot carry it
            return self.out
        pid = self.pid
        inputs = {"pid_mv": float(pid.out), "sp_remote": as_input(sp_remote),
                  "auto": as_flag(self.auto, True), "remote": as_flag(self.remote, False),
                  "sp_inc": as_flag(sp_inc, False), "sp_dec": as_flag(sp_dec, False),
                  "out_inc": as_flag(out_inc, False),
                  "out_dec": as_flag(out_dec, False)}  # fmt: skip
        prm = self._prm if h == self._prm["ts"] else {**self._prm, "ts": h}
        res = run_cycle(regulator_cycle, REGULATOR_RESULTS, {**inputs, **prm}, self._mem,
                        self._f32)  # fmt: skip
        self._mem = {k: CycleBlock._plain(res[k]) for k in self._mem}
        self.sp = float(res["sp_out"])
        pid.manual = bool(res["manual"])
        pid.manual_value = float(res["man_value"])
        self.out = pid(self.sp, pv, pv_ok=pv_ok, dt=h)
        err = int(res["error_id"])
        self.error_id = ErrorCode(err) if err != NO_ERROR else pid.error_id
        return self.out

    # -- the export's view (the stations and switches CB_REGULATOR; the PID is CB_PID) -------

    def plc_values(self) -> dict[str, Any]:
        """Initial values of every parameter and result of the cycle (the FB's interface)."""
        mem = self._initial()
        return {"pid_mv": mem["u_v"], "sp_remote": 0.0, "auto": True, "remote": False,
                "sp_inc": False, "sp_dec": False, "out_inc": False, "out_dec": False,
                **self._parameters(), **mem, "sp_out": mem["sp_w"], "manual": False,
                "man_value": mem["u_v"], "error_id": 0}  # fmt: skip

    @staticmethod
    def cycle_function() -> Any:
        """The pure cycle of the stations and switches (exported as ``CB_REGULATOR``)."""
        return regulator_cycle

    @staticmethod
    def cycle_results() -> tuple[str, ...]:
        """The names of the values :func:`regulator_cycle` returns."""
        return REGULATOR_RESULTS

    def memory_names(self) -> tuple[str, ...]:
        """The cycle's memory (the FB's state variables)."""
        return tuple(self._initial())
