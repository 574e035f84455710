"""Closed-loop simulation: scenarios, wiring in Åström's computational order, metrics, plots.

The main entry points:

* :func:`load_scenario` reads a scenario file (TOML) and checks it;
* :func:`simulate` runs one controller in one case and returns its trace;
* :class:`ControllerSide` is a controller entry's blocks wired for its
  structure (single, cascade, override, feed-forward, Smith) in Åström's
  computational order, without the plant (the runtime runs it against I/O);
* :class:`ProcessSide` is a scenario's plant (in its actuator and sensor
  wrappers) with the setpoint profile and the process events, without the
  controllers (the runtime's plant server serves it);
* :func:`run_scenario` runs all controllers in all cases, computes the
  metrics (per run and per event window) and checks the source's claims;
* :func:`write_result` writes traces, ``metrics.json`` and plots;
* :func:`load_shipped` loads the scenarios that ship with the package
  (``ctrlblocks reproduce`` runs them all);
* :func:`sweep` runs a scenario for many parameter sets on a
  ``concurrent.futures`` executor (a process pool, a Dask cluster:
  :func:`dask_executor`), :func:`write_rows` writes the rows (:mod:`.sweep`).

See ``docs/simulator.md`` for the scenario format.
"""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:  # pragma: no cover
    from ..loops.structures import ControllerSide
    from .loop import Run, simulate
    from .metrics import METRIC_NAMES, compute_metrics
    from .plant_process import PlantProcess
    from .process import ProcessSide, SetpointProfile
    from .report import load_shipped, shipped_scenarios
    from .results import write_result
    from .runner import ClaimResult, ScenarioResult, metric_table, run_scenario
    from .scenario import Scenario, ScenarioError, load_scenario, parse_scenario

# imported now: cheap (standard library only), and the function ``sweep`` must
# shadow the submodule of the same name
from .sweep import SweepError, dask_executor, sweep, write_rows

# imported on first use (PEP 562): ``ctrlblocks run --help`` imports none of them
_WHERE = {
    "..loops.structures": ("ControllerSide",),
    ".loop": ("Run", "simulate"),
    ".metrics": ("METRIC_NAMES", "compute_metrics"),
    ".plant_process": ("PlantProcess",),
    ".process": ("ProcessSide", "SetpointProfile"),
    ".report": ("load_shipped", "shipped_scenarios"),
    ".results": ("write_result",),
    ".runner": ("ClaimResult", "ScenarioResult", "metric_table", "run_scenario"),
    ".scenario": ("Scenario", "ScenarioError", "load_scenario", "parse_scenario"),
}

__all__ = [
    "METRIC_NAMES",
    "ClaimResult",
    "ControllerSide",
    "PlantProcess",
    "ProcessSide",
    "Run",
    "Scenario",
    "ScenarioError",
    "ScenarioResult",
    "SetpointProfile",
    "SweepError",
    "compute_metrics",
    "dask_executor",
    "load_scenario",
    "load_shipped",
    "metric_table",
    "parse_scenario",
    "run_scenario",
    "shipped_scenarios",
    "simulate",
    "sweep",
    "write_result",
    "write_rows",
]

__getattr__, __dir__ = lazy_exports(__name__, _WHERE)
