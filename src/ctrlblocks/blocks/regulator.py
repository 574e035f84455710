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
setpoint; NaN/inf: the setpoint holds, ``BAD_INPUT``), the four buttons
``sp_inc``, ``sp_dec``, ``out_inc``, ``out_dec``; the switches are the
attributes :attr:`Regulator.auto` and :attr:`Regulator.remote`.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from .base import (
    Block,
    BlockConfig,
    ErrorCode,
    as_flag,
    as_input,
    require_finite,
    require_limits,
    require_nonnegative,
    require_positive,
)
from .composite import CompositeBlock
from .manual import ManualStation
from .pid import PID
from .signals import clamp

__all__ = ["Regulator", "RegulatorConfig"]


@dataclasses.dataclass(frozen=True)
class RegulatorConfig(BlockConfig):
    """Configuration of :class:`Regulator`.

    Attributes
    ----------
    kp, ti, td, n, b : float
        The PID (ISA form, :class:`~ctrlblocks.PID`).
    u_min, u_max : float
        Output range [%] (the PID's limits and the manual station's range).
    sp_min, sp_max : float
        Range of the local setpoint [PV units].
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

    def validate(self) -> None:
        require_limits("u_min", self.u_min, "u_max", self.u_max, allow_infinite=False)
        require_limits("sp_min", self.sp_min, "sp_max", self.sp_max, allow_infinite=False)
        require_finite("sp0", self.sp0)
        require_finite("u0", self.u0)
        require_nonnegative("tr", self.tr, ErrorCode.BACK_CALC_T)
        require_positive("ts", self.ts, ErrorCode.NO_CYCLE)
        PID(**self.pid_params())
        for which in ("sp", "out"):
            ManualStation(**self.station_params(which))

    def pid_params(self) -> dict[str, Any]:
        """The PID's configuration."""
        return {"kp": self.kp, "ti": self.ti, "td": self.td, "n": self.n, "b": self.b,
                "ts": self.ts, "u_min": self.u_min, "u_max": self.u_max,
                "sp_rate": self.sp_rate, "reset_value": self.u0}  # fmt: skip

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
    _state_fields = ("out", "sp", "auto", "remote")
    config: RegulatorConfig
    _config: RegulatorConfig

    def _apply_config(self, old: BlockConfig | None) -> None:
        c = self._config
        if old is None:
            self.pid = PID(**c.pid_params())
            self.sp_station = ManualStation(**c.station_params("sp"))
            self.out_station = ManualStation(**c.station_params("out"))
            return
        self.pid.configure(**c.pid_params())
        self.sp_station.configure(**c.station_params("sp"))
        self.out_station.configure(**c.station_params("out"))
        self.out = clamp(self.out, c.u_min, c.u_max)

    def _reset_state(self) -> None:
        for b in self.parts().values():
            b.reset()
        c = self._config
        self.out = clamp(float(c.u0), c.u_min, c.u_max)
        self.sp = self.sp_station.out
        self.auto = True
        self.remote = False

    def parts(self) -> dict[str, Block]:
        """The PID and the two manual stations."""
        return {"pid": self.pid, "sp_station": self.sp_station, "out_station": self.out_station}

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
        err = ErrorCode.NO_ERROR
        # switch 1: the setpoint
        if as_flag(self.remote, False):
            r = as_input(sp_remote)
            if math.isfinite(r):
                self.sp = r
                self.sp_station(track=r, dt=h)  # the local setpoint follows: bumpless to local
            else:
                err = ErrorCode.BAD_INPUT  # the setpoint holds
        else:
            self.sp = self.sp_station(as_flag(sp_inc, False), as_flag(sp_dec, False), dt=h)
        # switch 2: the output
        pid = self.pid
        if as_flag(self.auto, True):
            pid.manual = False
            u = pid(self.sp, pv, pv_ok=pv_ok, dt=h)
            self.out_station(track=u, dt=h)  # the manual output follows: bumpless to manual
        else:
            u = self.out_station(as_flag(out_inc, False), as_flag(out_dec, False), dt=h)
            pid.manual = True  # the PID tracks the station's output: bumpless to automatic
            pid.manual_value = u
            pid(self.sp, pv, pv_ok=pv_ok, dt=h)
        self.out = u
        self.error_id = err if err != ErrorCode.NO_ERROR else pid.error_id
        return self.out
