"""Process models to test the blocks on (see :mod:`.base` for the contract).

Linear models (:mod:`.linear`): :class:`LinearPlant` (transfer function or
state space, exact ZOH, any input dead time) and the convenience models
:class:`PT1`, :class:`PT2`, :class:`PT2Osc`, :class:`PTn`, :class:`IT1`,
:class:`FOPDT`; a pure dead time :class:`DeadTime`.  Wrappers that are
plants themselves (:mod:`.wrappers`): :class:`Actuator` (input load, rate and
range limits), :class:`Sensor` (output load, :class:`Noise`, saturation),
:func:`process` (both).  The pneumatic three-tank process of Nowak et al. 2018,
section 6 (:mod:`.threetank`): :class:`ThreeTank`.  Two-input plants: the
heat/cool thermal process :class:`HeatCool` (:mod:`.heatcool`, a split-range
loop's process).  A sticky control valve
(:mod:`.stiction`, Choudhury et al. 2005): :class:`StictionValve`.  See docs/plants.md.

Note: ``ctrlblocks.plants.PT1`` (a process model) is not the filter block
``ctrlblocks.PT1`` (``ctrlblocks.blocks.signals.PT1``).
"""

from .base import Plant, steady_input
from .deadtime import DeadTime
from .heatcool import HeatCool
from .linear import (
    FOPDT,
    IT1,
    MAX_DEAD_SAMPLES,
    PT1,
    PT2,
    LinearPlant,
    PT2Osc,
    PTn,
    split_dead_time,
)
from .stiction import StictionValve
from .threetank import ThreeTank
from .valve import MotorValve
from .wrappers import Actuator, Noise, Sensor, process

__all__ = [
    "FOPDT",
    "IT1",
    "MAX_DEAD_SAMPLES",
    "PT1",
    "PT2",
    "Actuator",
    "DeadTime",
    "HeatCool",
    "LinearPlant",
    "MotorValve",
    "Noise",
    "PT2Osc",
    "PTn",
    "Plant",
    "Sensor",
    "StictionValve",
    "ThreeTank",
    "process",
    "split_dead_time",
    "steady_input",
]
