"""Heating/cooling controller: one PID, two outputs, a cooling factor or own cooling tunings.

What Siemens' PID_Temp offers for a temperature loop with a heater and a cooler
(Siemens, *SIMATIC S7-1500/S7-1200 PID control*, Function Manual
A5E35300227-AC, 03/2017, section 9.3 "PID_Temp"): one controller whose output
``PidOutputSum`` is positive for heating and negative for cooling and is
scaled to the two outputs ``OutputHeat`` and ``OutputCool``; either

* **cooling factor** (``Config.AdvancedCooling = FALSE``): the heating
  tunings act for cooling too, and ``Config.CoolFactor`` -- "the ratio heating
  actuator gain / cooling actuator gain" -- scales the cooling output, "suitable
  if the heating and cooling actuators have a similar time response but
  different gains"; or
* **PID parameter switching** (``Config.AdvancedCooling = TRUE``): a separate
  parameter set for cooling, "suitable if the heating and cooling actuator
  have different time responses and different gains";

and each output as a continuous value or pulse-width modulated
(``OutputHeat_PWM``, ``OutputCool_PWM``).

The law here
------------
One :class:`~ctrlblocks.PID` computes the demand ``v`` [%]: positive heats,
negative cools.  With a neutral zone ``d`` >= 0 [%] between the two (nothing
acts while ``|v| <= d/2``; a noisy temperature at the setpoint then does not
toggle between heating and cooling)::

    heat = v - d/2           for v >  d/2, else 0            (0 .. 100 %)
    cool = f (-v - d/2)      for v < -d/2, else 0            (0 .. 100 %)

``f`` is the cooling factor (1 with own cooling tunings).  The PID's limits
are the demand's range ``-(100/f + d/2) .. 100 + d/2``, so each output
reaches 100 % exactly when the PID is at its limit and the PID's anti-windup
acts there.  Since the cooler lowers the temperature by ``K_c`` per % and
the heater raises it by ``K_h``, the loop gain seen by the PID is ``K_h`` in
heating and ``f K_c = K_h`` in cooling: with the Siemens factor the one
tuning fits both (tested on the shipped heat/cool plant).

Parameter switching (``cool_method="parameters"``): the PID runs the cooling
tunings ``kp_cool``, ``ti_cool``, ``td_cool`` while cooling and the heating
tunings while heating.  The switch is decided on ``v`` with a hysteresis
``switch_hysteresis`` [%] (to cooling below ``-switch_hysteresis``, back above
``+switch_hysteresis``), as Beckhoff's ``FB_CTRL_PARAMETER_SWITCH`` decides it
with a 2-point element on the control value (Beckhoff TF4100), and it is
bumpless: the PID's retune keeps its output (``PID.configure``; Åström &
Hägglund 2006, the bumpless parameter change).

Pulse-width outputs (``pwm_period > 0``): each output drives a
:class:`~ctrlblocks.PulseWidth` (period, minimum on and off times) and is
then 0 or 100 %.  A PWM whose demand falls to 0 is switched off at once and
starts a new period when its demand returns: heater and cooler are never on
in the same sample.

``out = heat - cool`` [%] (exactly one of them is non-zero); :attr:`heat`,
:attr:`cool`, :attr:`demand` (``v``) and :attr:`cooling` (the parameter set
in force) are readable; ``manual`` / ``manual_value`` are the PID's (the
manual value is a demand ``v``).  Bad data are the PID's business (it holds
its output, or its safe value, and sets the error code).
"""

from __future__ import annotations

import dataclasses
from typing import Any

from .base import (
    Block,
    BlockConfig,
    ErrorCode,
    ParameterError,
    as_flag,
    require_choice,
    require_finite,
    require_nonnegative,
    require_positive,
)
from .composite import CompositeBlock
from .pid import PID
from .pwm import PulseWidth

__all__ = ["HeatCoolPID", "HeatCoolPIDConfig", "heat_cool_split"]


def heat_cool_split(v: float, deadzone: float, factor: float) -> tuple[float, float]:
    """``(heat, cool)`` [%] for the demand ``v`` (module docstring), each limited to 0..100."""
    half = 0.5 * deadzone
    heat = v - half if v > half else 0.0
    cool = factor * (-v - half) if v < -half else 0.0
    return min(heat, 100.0), min(cool, 100.0)


@dataclasses.dataclass(frozen=True)
class HeatCoolPIDConfig(BlockConfig):
    """Configuration of :class:`HeatCoolPID`.

    Attributes
    ----------
    kp, ti, td, n, b : float
        The PID's heating tunings (ISA form, :class:`~ctrlblocks.PID`): gain
        [%/PV unit], integral and derivative times [s], derivative filter,
        setpoint weight.
    cool_method : {"factor", "parameters"}
        Cooling factor (Siemens ``AdvancedCooling = FALSE``) or own cooling
        tunings (``AdvancedCooling = TRUE``).
    cool_factor : float
        Heating actuator gain / cooling actuator gain > 0 (``"factor"``).
    kp_cool, ti_cool, td_cool : float
        The cooling tunings (``"parameters"``); ``kp_cool`` 0: the heating ones.
    switch_hysteresis : float
        Hysteresis [%] >= 0 of the switch between the parameter sets.
    deadzone : float
        Neutral zone d [%] >= 0 between heating and cooling.
    pwm_period : float
        PWM period [s] of both outputs; 0: continuous outputs.
    t_min_on, t_min_off : float
        Minimum pulse and pause [s] of the PWM outputs.
    ts : float
        Sample time [s] > 0.
    """

    kp: float = 1.0
    ti: float = 0.0
    td: float = 0.0
    n: float = 10.0
    b: float = 1.0
    cool_method: str = "factor"
    cool_factor: float = 1.0
    kp_cool: float = 0.0
    ti_cool: float = 0.0
    td_cool: float = 0.0
    switch_hysteresis: float = 1.0
    deadzone: float = 0.0
    pwm_period: float = 0.0
    t_min_on: float = 0.0
    t_min_off: float = 0.0
    ts: float = 1.0

    def validate(self) -> None:
        require_choice("cool_method", self.cool_method, ("factor", "parameters"))
        f = require_positive("cool_factor", self.cool_factor)
        if not 1e-3 <= f <= 1e3:
            raise ParameterError(
                ErrorCode.BAD_PARAMETER, "cool_factor", f"must lie in 1e-3 .. 1e3, got {f!r}"
            )
        require_nonnegative("kp_cool", self.kp_cool, ErrorCode.BAD_PID_COEFFS)
        require_nonnegative("ti_cool", self.ti_cool, ErrorCode.BAD_PID_COEFFS)
        require_nonnegative("td_cool", self.td_cool, ErrorCode.BAD_PID_COEFFS)
        for name in ("switch_hysteresis", "deadzone"):
            x = require_nonnegative(name, getattr(self, name), ErrorCode.BAD_LIMITS)
            if x > 100.0:
                raise ParameterError(ErrorCode.BAD_LIMITS, name, f"must be <= 100 %, got {x!r}")
        period = require_nonnegative("pwm_period", self.pwm_period, ErrorCode.BAD_TIME_CONSTANT)
        require_positive("ts", self.ts, ErrorCode.NO_CYCLE)
        if period > 0.0:
            PulseWidth(**self.pwm_params())  # refuses what the PWM refuses
        else:
            require_nonnegative("t_min_on", self.t_min_on, ErrorCode.BAD_TIME_CONSTANT)
            require_nonnegative("t_min_off", self.t_min_off, ErrorCode.BAD_TIME_CONSTANT)
        PID(**self.pid_params(cooling=False))  # refuses bad tunings with the PID's codes
        if self.cool_method == "parameters":
            PID(**self.pid_params(cooling=True))
        require_finite("kp", self.kp)

    def pwm_params(self) -> dict[str, Any]:
        """The parameters of the two :class:`~ctrlblocks.PulseWidth` outputs."""
        return {"period": self.pwm_period, "t_min_on": self.t_min_on,
                "t_min_off": self.t_min_off, "in_lo": 0.0, "in_hi": 100.0,
                "ts": self.ts}  # fmt: skip

    def factor(self) -> float:
        """The cooling factor in force (1 with own cooling tunings)."""
        return float(self.cool_factor) if self.cool_method == "factor" else 1.0

    def pid_params(self, cooling: bool) -> dict[str, Any]:
        """The PID's configuration for heating or (own tunings) for cooling."""
        kp, ti, td = self.kp, self.ti, self.td
        if cooling and self.cool_method == "parameters" and self.kp_cool > 0.0:
            kp, ti, td = self.kp_cool, self.ti_cool, self.td_cool
        half = 0.5 * self.deadzone
        return {"kp": kp, "ti": ti, "td": td, "n": self.n, "b": self.b, "ts": self.ts,
                "u_min": -(100.0 / self.factor() + half), "u_max": 100.0 + half}  # fmt: skip


class HeatCoolPID(CompositeBlock):
    """Heating/cooling controller like Siemens PID_Temp (see the module docstring).

    ``out = hc(sp, pv)`` runs one sample and returns ``heat - cool`` [%].

    Examples
    --------
    Cooling factor 2 (the heater is twice as strong as the cooler): a demand
    of -30 % asks the cooler for 60 %.

    >>> hc = HeatCoolPID(kp=1.0, cool_factor=2.0)
    >>> hc.manual = True; hc.manual_value = -30.0
    >>> hc(20.0, 25.0), hc.heat, hc.cool
    (-60.0, 0.0, 60.0)
    """

    Config = HeatCoolPIDConfig
    _state_fields = ("out", "heat", "cool", "cooling")
    config: HeatCoolPIDConfig
    _config: HeatCoolPIDConfig

    def _apply_config(self, old: BlockConfig | None) -> None:
        c = self._config
        self._f = c.factor()
        if old is None:
            self.pid = PID(**c.pid_params(cooling=False))
            self._pwm = (PulseWidth(**c.pwm_params()), PulseWidth(**c.pwm_params())) \
                if c.pwm_period > 0.0 else None  # fmt: skip
            return
        cooling = getattr(self, "cooling", False)
        self.pid.configure(**c.pid_params(cooling=cooling))  # bumpless retune, new limits
        if c.pwm_period > 0.0:
            if self._pwm is None:
                self._pwm = (PulseWidth(**c.pwm_params()), PulseWidth(**c.pwm_params()))
            else:
                for p in self._pwm:
                    p.configure(**c.pwm_params())
        else:
            self._pwm = None

    def _reset_state(self) -> None:
        self.cooling = False
        self._reconfigure_parts()  # the heating parameter set
        self.pid.reset()
        if self._pwm is not None:
            for p in self._pwm:
                p.reset()
        self.out = 0.0
        self.heat = 0.0
        self.cool = 0.0
        self.cooling = False

    def parts(self) -> dict[str, Block]:
        """The PID and, with PWM outputs, the two PulseWidth blocks."""
        if self._pwm is None:
            return {"pid": self.pid}
        return {"pid": self.pid, "pwm_heat": self._pwm[0], "pwm_cool": self._pwm[1]}

    def _reconfigure_parts(self) -> None:
        c = self._config
        params = c.pid_params(cooling=self.cooling)
        if any(getattr(self.pid.config, k) != v for k, v in params.items()):
            self.pid.configure(**params)

    def output_limits(self) -> tuple[float, float]:
        """``(-100, 100)``: full cooling .. full heating."""
        return -100.0, 100.0

    # -- the PID's mode inputs --------------------------------------------------------------

    @property
    def manual(self) -> bool:
        """Manual mode of the PID (the manual value is a demand ``v`` [%])."""
        return bool(self.pid.manual)

    @manual.setter
    def manual(self, on: Any) -> None:
        self.pid.manual = as_flag(on, False)

    @property
    def manual_value(self) -> float:
        """The manual demand ``v`` [%] (In/Out: outside MANUAL it follows the demand)."""
        return float(self.pid.manual_value)

    @manual_value.setter
    def manual_value(self, v: Any) -> None:
        self.pid.manual_value = v

    @property
    def demand(self) -> float:
        """The PID's demand ``v`` [%] of the last sample."""
        return float(self.pid.out)

    def demand_for(self, net: float) -> float:
        """The demand ``v`` whose outputs give ``heat - cool = net`` (continuous outputs)."""
        half = 0.5 * self._config.deadzone
        if net > 0.0:
            return net + half
        if net < 0.0:
            return net / self._f - half
        return 0.0

    # -- one sample -----------------------------------------------------------------------

    def __call__(
        self, sp: float, pv: float, *, pv_ok: Any = True, dt: float | None = None
    ) -> float:
        """One sample: setpoint, measurement -> ``heat - cool`` [%]."""
        c = self._config
        if c.cool_method == "parameters":
            self._switch(c)
        v = self.pid(sp, pv, pv_ok=pv_ok, dt=dt)
        self.error_id = self.pid.error_id
        heat, cool = heat_cool_split(v, c.deadzone, self._f)
        if self._pwm is not None:
            heat = self._pulse(self._pwm[0], heat, dt)
            cool = self._pulse(self._pwm[1], cool, dt)
        self.heat, self.cool = heat, cool
        self.out = heat - cool
        return self.out

    def _switch(self, c: HeatCoolPIDConfig) -> None:
        """Change the parameter set when the demand crosses the hysteresis (bumplessly)."""
        v = self.pid.out
        want = self.cooling
        if not self.cooling and v < -c.switch_hysteresis:
            want = True
        elif self.cooling and v > c.switch_hysteresis:
            want = False
        if want != self.cooling:
            self.cooling = want
            self.pid.configure(**c.pid_params(cooling=want))

    @staticmethod
    def _pulse(pwm: PulseWidth, demand: float, dt: float | None) -> float:
        if demand <= 0.0:
            if pwm.on or pwm.duty > 0.0:
                pwm.reset()  # off at once; a new period starts when the demand returns
            return 0.0
        return 100.0 * pwm(demand, dt)

