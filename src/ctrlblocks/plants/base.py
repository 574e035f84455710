"""The plant contract: a discrete-time process model driven sample by sample.

A plant is sampled with period ``ts``; its input is held constant over a
sample (zero-order hold, as a DA converter does).  It is strictly proper: the
output ``y`` depends on the state only, so a controller can read ``y``,
compute ``u`` and apply it in the same sample (Åström 1987, section 6:
read, ComputeOutput, ShapeOutput, write, UpdateState).

One sample of a closed loop::

    y = plant.y            # AD conversion
    u = controller(r, y)   # compute (and shape) the output
    plant.step(u)          # DA conversion; the plant advances by ts

``reset(u0)`` puts the plant in the steady state that belongs to the constant
input ``u0`` (for integrating plants: zero state with the input held).

Additions (ctrlblocks' plants all provide them):

* ``plant.u`` -- the input applied in the last ``step`` (``u0`` after reset);
* ``snapshot()`` / ``restore(snap)`` -- copy and put back the dynamic state
  (for "what if" runs from the same point);
* ``find(cls)`` -- the first plant of type ``cls`` in a chain of wrappers
  (:mod:`.wrappers`), e.g. ``chain.find(ThreeTank).outlet = "b"``; a plain
  plant returns itself if it is a ``cls``, else None.

A plant never raises on process data: a non-finite input holds the previous
input.
"""

from __future__ import annotations

import abc
import math
from typing import Any, TypeVar

_P = TypeVar("_P", bound="Plant")


class Plant(abc.ABC):
    """Abstract discrete-time plant (see the module docstring)."""

    ts: float
    u: float

    @property
    @abc.abstractmethod
    def y(self) -> float:
        """Current output (measurement before any sensor effects)."""

    @abc.abstractmethod
    def step(self, u: float) -> float:
        """Hold ``u`` for one sample, advance the state by ``ts``; return the new ``y``."""

    @abc.abstractmethod
    def reset(self, u0: float = 0.0) -> None:
        """Go to the steady state for the constant input ``u0``."""

    def snapshot(self) -> dict[str, Any]:
        """A copy of the dynamic state; :meth:`restore` puts it back."""
        raise NotImplementedError(f"{type(self).__name__} has no snapshot")

    def restore(self, snap: dict[str, Any]) -> None:
        """Put back a state taken by :meth:`snapshot`."""
        raise NotImplementedError(f"{type(self).__name__} has no restore")

    def find(self, cls: type[_P]) -> _P | None:
        """This plant if it is a ``cls``, else None (wrappers search inside)."""
        return self if isinstance(self, cls) else None


def steady_input(models: list[Any], y0: float) -> float | None:
    """The input of the series ``models`` whose steady state gives the output ``y0``.

    A single model with ``u_for_y`` (the three-tank process) inverts its own
    steady state; otherwise ``y0`` over the product of their ``dc_gain``.
    None when that gain is not finite or zero (an integrating plant), or when
    no finite input gives ``y0`` (the inverse is NaN or infinite).
    """
    if len(models) == 1 and hasattr(models[0], "u_for_y"):
        u = float(models[0].u_for_y(y0))
        return u if math.isfinite(u) else None
    gain = 1.0
    for m in models:
        gain *= float(getattr(m, "dc_gain", math.nan))
    if not math.isfinite(gain) or gain == 0.0:
        return None
    u = y0 / gain
    return u if math.isfinite(u) else None
