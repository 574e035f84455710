"""The function blocks, as a PLC library would list them."""

# ruff: noqa: E402  (the compiled build, if any, must be loaded before any block module)
from ..compiled import install as _install_compiled

_install_compiled()  # the compiled PID and ADRC, when built (ctrlblocks compile); else nothing

from . import plc_cycle  # noqa: F401  (registers the precision="float32" cycles)
from .adrc import ADRC
from .alarms import Alarm, LoopAlarms
from .base import Block, BlockConfig, ErrorCode, Mode, ParameterError
from .heatcool import HeatCoolPID
from .jumprate import JumpAndRate
from .leadlag import LeadLag
from .manual import ManualStation
from .monitor import CycleMonitor
from .onoff import ThreePoint, TwoPoint
from .pid import PID, AntiWindup, Bumpless
from .pid_forms import (
    isa_to_parallel,
    isa_to_series,
    parallel_to_isa,
    parallel_to_series,
    series_to_isa,
    series_to_parallel,
)
from .pwm import PulseWidth
from .regulator import Regulator
from .schedule import GainSchedule, GainScheduleConfig
from .setpoint import SetpointProgram
from .signals import (
    PT1,
    DeadBand,
    MaxSelector,
    MinSelector,
    MovingAverage,
    RateLimiter,
    Saturation,
    Scale,
    SteadyStateDetector,
    deadband,
    scale,
)
from .stepper import StepController
from .transfer import TransferFunction

__all__ = [
    "ADRC",
    "PID",
    "PT1",
    "Alarm",
    "AntiWindup",
    "Block",
    "BlockConfig",
    "Bumpless",
    "CycleMonitor",
    "DeadBand",
    "ErrorCode",
    "GainSchedule",
    "GainScheduleConfig",
    "HeatCoolPID",
    "JumpAndRate",
    "LeadLag",
    "LoopAlarms",
    "ManualStation",
    "MaxSelector",
    "MinSelector",
    "Mode",
    "MovingAverage",
    "ParameterError",
    "PulseWidth",
    "RateLimiter",
    "Regulator",
    "Saturation",
    "Scale",
    "SetpointProgram",
    "SteadyStateDetector",
    "StepController",
    "ThreePoint",
    "TransferFunction",
    "TwoPoint",
    "deadband",
    "isa_to_parallel",
    "isa_to_series",
    "parallel_to_isa",
    "parallel_to_series",
    "scale",
    "series_to_isa",
    "series_to_parallel",
]
