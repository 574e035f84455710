"""Loop health: the performance assessment of control loops from their data.

* :mod:`.figures` -- the figures (service factors, valve wear, Hägglund's
  oscillation detection, Harris' minimum-variance index, Horch's stiction test);
* :mod:`.assess` -- one loop's assessment: :func:`assess` -> figures and findings;
* :mod:`.report` -- the Markdown + PNG report and the JSON summary;
* :mod:`.live` -- the sliding-window assessment of a running loop;
* :mod:`.faults` -- simulated loops with known faults (the campaign of docs/health.md).

The alarm blocks are blocks (:mod:`ctrlblocks.blocks.alarms`).  See docs/health.md.
"""

from __future__ import annotations

from .assess import Assessment, AssessOptions, Finding, LoopData, Model, assess

__all__ = ["AssessOptions", "Assessment", "Finding", "LoopData", "Model", "assess"]
