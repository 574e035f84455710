"""Loop structures, each described once, and the controller side that runs them.

The public names of the structures, from the modules that hold them (one
concept each):

* :mod:`.structure` -- :class:`Structure`, everything ctrlblocks knows about
  one loop structure;
* :mod:`.wiring` -- :class:`Wiring`, what a structure does in one sample
  (its stages, loops, MV and output stage), described once as data and run
  by the Python path and the simulator's compiled lane;
* :mod:`.controller` -- :class:`Wired`, how a structure drives one block
  (the :class:`~ctrlblocks.blocks.protocols.Controller` interface, modes,
  tracking), and :func:`set_manual`;
* :mod:`.side` -- :class:`ControllerSide`, a controller entry's blocks run in
  Åström's computational order (Åström 1987, section 6);
* :mod:`.registry` -- :data:`STRUCTURES` and reading a controller entry;
* one module per structure: :mod:`.single` (``single``, ``open_loop``),
  :mod:`.cascade`, :mod:`.override`, :mod:`.feedforward`, :mod:`.smith`,
  :mod:`.split` (``split_range``), :mod:`.ratio`, :mod:`.output`
  (``pulse_width``, ``three_step``), :mod:`.schedule` (``scheduled``),
  :mod:`.heatcool` (``heat_cool``).

Structures and what they read (``structure`` -> measurements):

=============  ==========================================================
``single``     ``y``
``cascade``    ``y`` (primary), ``y2`` (secondary)
``override``   ``y`` and/or ``y2``, as each block's ``measure`` says
``feedforward``  ``y``, ``dv`` (through the lead-lag into the PID's ``ff``)
``smith``      ``y`` (the controller sees ``y + y_model_fast - y_model``)
``split_range``  ``y``; one controller, two actuators (:mod:`.split`)
``ratio``      ``y`` (the controlled flow), ``w`` (the wild flow; the
               setpoint input is the ratio, :mod:`.ratio`)
``pulse_width``  ``y``; the controller output through a PWM (on/off MV)
``three_step``  ``y``, ``y2`` (the valve position: end switches, feedback);
               a step controller's OPEN/CLOSE commands are the MV
``scheduled``  ``y``; the controller's parameters follow the setpoint or ``y``
``heat_cool``  ``y``; a HeatCoolPID's heat and cool outputs on two actuators
``open_loop``  none (the block is driven by the setpoint)
=============  ==========================================================

Actuators: a structure writes one MV, except ``split_range`` and
``heat_cool``, which write two (:attr:`Structure.actuators`; :meth:`ControllerSide.actuator_values`
maps the controller output to them).
"""

from __future__ import annotations

from .cascade import Cascade
from .controller import Wired, set_manual
from .feedforward import FeedForward, FeedForwardStage
from .heatcool import HeatCoolOutput, HeatCoolStructure
from .output import PulseWidthStructure, ThreeStepStructure
from .override import Override
from .ratio import RatioStructure
from .registry import STRUCTURES, parse_controller, read_controller, register_structure
from .schedule import ScheduledStructure
from .side import ControllerSide
from .single import OpenLoop, Single
from .smith import Smith, SmithPredictor
from .split import SplitRangeStructure
from .structure import Structure
from .wiring import Loop, Measured, OutputStage, Stage, Wiring

__all__ = [
    "STRUCTURES",
    "Cascade",
    "ControllerSide",
    "FeedForward",
    "FeedForwardStage",
    "HeatCoolOutput",
    "HeatCoolStructure",
    "Loop",
    "Measured",
    "OpenLoop",
    "OutputStage",
    "Override",
    "PulseWidthStructure",
    "RatioStructure",
    "ScheduledStructure",
    "Single",
    "Smith",
    "SmithPredictor",
    "SplitRangeStructure",
    "Stage",
    "Structure",
    "ThreeStepStructure",
    "Wired",
    "Wiring",
    "parse_controller",
    "read_controller",
    "register_structure",
    "set_manual",
]
