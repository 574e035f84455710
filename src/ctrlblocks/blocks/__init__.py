"""The function blocks, as a PLC library would list them."""

from .base import Block, BlockConfig, ErrorCode, Mode, ParameterError
from .jumprate import JumpAndRate
from .leadlag import LeadLag
from .manual import ManualStation
from .monitor import CycleMonitor
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

__all__ = [
    "PT1",
    "Block",
    "BlockConfig",
    "CycleMonitor",
    "DeadBand",
    "ErrorCode",
    "JumpAndRate",
    "LeadLag",
    "ManualStation",
    "MaxSelector",
    "MinSelector",
    "Mode",
    "MovingAverage",
    "ParameterError",
    "RateLimiter",
    "Saturation",
    "Scale",
    "SteadyStateDetector",
    "deadband",
    "scale",
]
