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
from .cycleblock import run_cycle
from .pid import PID
from .plc_cycle import REAL_MAX, is_real
from .precision import PRECISIONS
from .pwm import PulseWidth, pwm_cycle

__all__ = [
    "HEAT_COOL_RESULTS",
    "HeatCoolPID",
    "HeatCoolPIDConfig",
    "heat_cool_cycle",
    "heat_cool_split",
]

NO_ERROR = int(ErrorCode.NO_ERROR)
BAD_INPUT = int(ErrorCode.BAD_INPUT)


def heat_cool_split(v: float, deadzone: float, factor: float) -> tuple[float, float]:
    """``(heat, cool)`` [%] for the demand ``v`` (module docstring), each limited to 0..100."""
    half = 0.5 * deadzone
    heat = v - half if v > half else 0.0
    cool = factor * (-v - half) if v < -half else 0.0
    return min(heat, 100.0), min(cool, 100.0)


HEAT_COOL_RESULTS = (
    "out", "error_id", "heat", "cool", "cooling_out", "cooling", "h_on", "h_t_in", "h_t_on",
    "h_applied", "h_asked", "h_carry", "h_duty", "h_started", "c_on", "c_t_in", "c_t_on",
    "c_applied", "c_asked", "c_carry", "c_duty", "c_started",
)  # fmt: skip
"""Names of the values :func:`heat_cool_cycle` returns: outputs, then the new memory."""


def heat_cool_cycle(
    v: float,
    deadzone: float,
    factor: float,
    switching: bool,
    switch_hysteresis: float,
    pwm: bool,
    period: float,
    t_min_on: float,
    t_min_off: float,
    ts: float,
    cooling: bool,
    h_on: bool,
    h_t_in: float,
    h_t_on: float,
    h_applied: float,
    h_asked: float,
    h_carry: float,
    h_duty: float,
    h_started: bool,
    c_on: bool,
    c_t_in: float,
    c_t_on: float,
    c_applied: float,
    c_asked: float,
    c_carry: float,
    c_duty: float,
    c_started: bool,
) -> tuple[Any, ...]:
    """One sample of the heat/cool output stage (module docstring) for the PID's demand ``v``.

    The split into ``heat`` and ``cool`` (:func:`heat_cool_split`), the parameter
    set for the next sample (``cooling``, with ``switching``: to cooling below
    ``-switch_hysteresis``, back above ``+switch_hysteresis``) and, with ``pwm``,
    the two pulse-width outputs (:func:`.pwm.pwm_cycle`, memories ``h_*`` and
    ``c_*``; an output whose demand falls to 0 is off at once and starts a new
    period when it returns).  A ``v`` that is no finite REAL switches both off
    (``BAD_INPUT``).  Returns :data:`HEAT_COOL_RESULTS`.
    """
    err = NO_ERROR
    heat = 0.0
    cool = 0.0
    if is_real(v):
        if switching:
            if not cooling and v < -switch_hysteresis:
                cooling = True
            elif cooling and v > switch_hysteresis:
                cooling = False
        heat, cool = heat_cool_split(v, deadzone, factor)
    else:
        err = BAD_INPUT
    if pwm:
        h_on, h_t_in, h_t_on, h_applied, h_asked, h_carry, h_duty, h_started = pwm_output(
            heat, period, t_min_on, t_min_off, ts, h_on, h_t_in, h_t_on, h_applied, h_asked,
            h_carry, h_duty, h_started,
        )  # fmt: skip
        c_on, c_t_in, c_t_on, c_applied, c_asked, c_carry, c_duty, c_started = pwm_output(
            cool, period, t_min_on, t_min_off, ts, c_on, c_t_in, c_t_on, c_applied, c_asked,
            c_carry, c_duty, c_started,
        )  # fmt: skip
        heat = 0.0
        if h_on:
            heat = 100.0
        cool = 0.0
        if c_on:
            cool = 100.0
    return (
        heat - cool, err, heat, cool, cooling, cooling, h_on, h_t_in, h_t_on, h_applied,
        h_asked, h_carry, h_duty, h_started, c_on, c_t_in, c_t_on, c_applied, c_asked, c_carry,
        c_duty, c_started,
    )  # fmt: skip


def pwm_output(
    demand: float,
    period: float,
    t_min_on: float,
    t_min_off: float,
    ts: float,
    on: bool,
    t_in: float,
    t_on: float,
    applied: float,
    asked: float,
    carry: float,
    duty: float,
    started: bool,
) -> tuple[bool, float, float, float, float, float, float, bool]:
    """One output's PWM (:func:`.pwm.pwm_cycle`, 0..100 %) for ``demand``; its new memory.

    A demand of 0 switches the output off at once (a pulse in progress ends) and
    the next demand starts a new period.  Returns ``(on, t_in, t_on, applied,
    asked, carry, duty, started)``.
    """
    if demand <= 0.0:
        if on or duty > 0.0:
            # off at once; a new period starts when the demand returns
            t_in, t_on, applied, asked, carry, duty = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
            started = False
        return False, t_in, t_on, applied, asked, carry, duty, started
    out, _err, t_in, t_on, applied, asked, carry, duty, started = pwm_cycle(
        demand, period, t_min_on, t_min_off, 0.0, 100.0, ts, t_in, t_on, applied, asked, carry,
        duty, started,
    )  # fmt: skip
    return out > 0.5, t_in, t_on, applied, asked, carry, duty, started


def _stage_memory() -> dict[str, Any]:
    """The stage's memory after a reset (both PWMs at rest, the heating set)."""
    mem: dict[str, Any] = {"cooling": False}
    for p in ("h", "c"):
        mem.update({f"{p}_on": False, f"{p}_t_in": 0.0, f"{p}_t_on": 0.0, f"{p}_applied": 0.0,
                    f"{p}_asked": 0.0, f"{p}_carry": 0.0, f"{p}_duty": 0.0,
                    f"{p}_started": False})  # fmt: skip
    return mem


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
    precision : str
        ``"float64"`` or ``"float32"``: the PID and the output stage computed as a
        PLC's REAL does.
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
    precision: str = "float64"

    def validate(self) -> None:
        require_choice("precision", self.precision, PRECISIONS)
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
                "u_min": -(100.0 / self.factor() + half), "u_max": 100.0 + half,
                "precision": self.precision}  # fmt: skip


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
    _state_fields = ("out", "heat", "cool", "cooling", "_mem")
    config: HeatCoolPIDConfig
    _config: HeatCoolPIDConfig
    _mem: dict[str, Any]

    def _apply_config(self, old: BlockConfig | None) -> None:
        c = self._config
        self._f = c.factor()
        self._f32 = c.precision == "float32"
        self._prm = self._parameters()
        if old is None:
            self.pid = PID(**c.pid_params(cooling=False))
            return
        self.pid.configure(**c.pid_params(cooling=self.cooling))  # bumpless retune, new limits
        if c.pwm_period <= 0.0:
            self._mem = {**self._mem, **{k: v for k, v in _stage_memory().items()
                                         if k != "cooling"}}  # fmt: skip

    def _parameters(self) -> dict[str, Any]:
        c = self._config
        return {"deadzone": float(c.deadzone), "factor": self._f,
                "switching": c.cool_method == "parameters",
                "switch_hysteresis": float(c.switch_hysteresis), "pwm": c.pwm_period > 0.0,
                "period": float(c.pwm_period), "t_min_on": float(c.t_min_on),
                "t_min_off": float(c.t_min_off), "ts": float(c.ts)}  # fmt: skip

    def _reset_state(self) -> None:
        self.cooling = False
        self._reconfigure_parts()  # the heating parameter set
        self.pid.reset()
        self.out = 0.0
        self.heat = 0.0
        self.cool = 0.0
        self._mem = _stage_memory()

    def parts(self) -> dict[str, Block]:
        """The PID."""
        return {"pid": self.pid}

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
        want = bool(self._mem["cooling"])
        if want != self.cooling:  # the set the stage chose on the last demand (bumpless)
            self.cooling = want
            self.pid.configure(**c.pid_params(cooling=want))
        v = self.pid(sp, pv, pv_ok=pv_ok, dt=dt)
        self.error_id = self.pid.error_id
        h = self._cycle_time(dt, float(c.ts))
        if h is None or (self._f32 and not h <= REAL_MAX):
            return self.out  # the PID held too (NO_CYCLE)
        prm = self._prm if h == self._prm["ts"] else {**self._prm, "ts": h}
        res = run_cycle(heat_cool_cycle, HEAT_COOL_RESULTS, {"v": v, **prm}, self._mem, self._f32)
        self._mem = {k: res[k] for k in self._mem}
        self.heat, self.cool = float(res["heat"]), float(res["cool"])
        self.out = float(res["out"])
        return self.out

    # -- the export's view (the output stage CB_HEATCOOL; the PID is CB_PID) -----------------

    def plc_values(self) -> dict[str, Any]:
        """Initial values of every parameter and result of the stage's cycle."""
        return {"v": 0.0, **self._parameters(), **_stage_memory(), "out": 0.0, "error_id": 0,
                "heat": 0.0, "cool": 0.0, "cooling_out": False}  # fmt: skip

    @staticmethod
    def cycle_function() -> Any:
        """The stage's pure cycle (what the PLC export translates, as ``CB_HEATCOOL``)."""
        return heat_cool_cycle

    @staticmethod
    def cycle_results() -> tuple[str, ...]:
        """The names of the values the stage's cycle returns."""
        return HEAT_COOL_RESULTS

    @staticmethod
    def memory_names() -> tuple[str, ...]:
        """The stage's memory (the FB's state variables)."""
        return tuple(_stage_memory())

