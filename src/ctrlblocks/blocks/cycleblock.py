"""Blocks whose sample is ONE pure cycle function: the block, the float32 lane and the export.

A :class:`CycleBlock` holds no law of its own.  Its sample is a pure function
(``cycle``) over explicit values -- the process inputs, the configuration's
parameters and the memory -- that returns the outputs and the new memory, in
the subset of Python the PLC translator (:mod:`ctrlblocks.plc`) turns into a
FUNCTION_BLOCK (Åström 1987, section 6: the cycle computes from the state,
then updates it).  The same function runs

* in the block, in float64 (``precision="float64"``, the default);
* in the block with every intermediate rounded to float32
  (``precision="float32"``, :func:`.plc_cycle.run_float32`: what a PLC
  computing in REAL does);
* in the PLC as the exported FUNCTION_BLOCK (``ctrlblocks.plc.export``).

Conventions every cycle function here keeps, so that the three agree:

* a value counts as valid only inside the REAL range (``|x| <= 3.402823E38``,
  :func:`.plc_cycle.is_real`), in float64 too: an input beyond it is a bad
  input, a result beyond it an overflow.  Infinite configured limits are
  passed as +-3.402823E38 (:data:`.plc_cycle.REAL_MAX`);
* times that accumulate over samples saturate at :data:`TIME_CAP` (a REAL
  holds it; a sum that grew to inf would turn into NaN);
* the memory stays a finite REAL whatever the inputs (the fuzz campaign
  checks it).

A subclass sets ``_cycle`` (the function), ``_results`` (the names of what it
returns, outputs first, then the new memory under the names of its memory
parameters) and implements ``_parameters()`` (configuration -> parameter
inputs) and ``_initial()`` (the memory after a reset); its ``__call__``
converts the process inputs (:func:`.base.as_input`, :func:`.base.as_flag`)
and calls :meth:`CycleBlock._run`.
"""

from __future__ import annotations

import numbers
from collections.abc import Callable
from typing import Any, ClassVar

from .base import Block, BlockConfig, ErrorCode, ParameterError, require_choice
from .plc_cycle import REAL_MAX, run_float32, to_real
from .precision import PRECISIONS

__all__ = [
    "TIME_CAP",
    "CycleBlock",
    "float_rows",
    "real_limit",
    "require_precision",
    "run_cycle",
    "time_add",
]

TIME_CAP = 1e30
"""The largest time [s] a cycle accumulates (3e22 years; a REAL holds it)."""


def time_add(t: float, h: float) -> float:
    """``t + h`` for a time accumulated over samples, saturating at :data:`TIME_CAP`."""
    s = t + h
    if s > TIME_CAP:
        s = TIME_CAP
    return s


def real_limit(x: float) -> float:
    """A configured limit as the cycle takes it: infinite (or beyond REAL) as +-REAL_MAX."""
    if x > REAL_MAX:
        return REAL_MAX
    if x < -REAL_MAX:
        return -REAL_MAX
    return float(x)


def float_rows(rows: Any) -> Any:
    """A configuration's table of numbers (``((a, b, c), ...)``) as tuples of floats.

    Anything else (a string, a bool, 10**400) is left as given, for ``validate`` to refuse.
    """
    if not (isinstance(rows, tuple | list) and all(isinstance(r, tuple | list) for r in rows)):
        return rows
    out = []
    for r in rows:
        ok = all(isinstance(v, numbers.Real) and not isinstance(v, bool) for v in r)
        try:
            out.append(tuple(float(v) for v in r) if ok else tuple(r))
        except OverflowError:
            out.append(tuple(r))
    return tuple(out)


def require_precision(config: Any) -> None:
    """Refuse an unknown ``precision``; with ``"float32"`` a finite number no REAL holds.

    A PLC's REAL (and the float32 cycle) would turn 1e300 into inf and 1e-50 into 0;
    infinite limits stay allowed (the cycle takes them as +-REAL_MAX).
    """
    require_choice("precision", config.precision, PRECISIONS)
    if config.precision != "float32":
        return
    for name, value in vars(config).items():
        values = value if isinstance(value, tuple) else (value,)
        flat = [x for v in values for x in (v if isinstance(v, tuple) else (v,))]
        for x in flat:
            if isinstance(x, bool) or not isinstance(x, int | float):
                continue
            a = abs(float(x))
            if a != float("inf") and (a > REAL_MAX or 0.0 < a < 7.006e-46):
                raise ParameterError(
                    ErrorCode.BAD_PARAMETER,
                    name,
                    f'{x!r} is outside the range of REAL, which precision="float32" computes in',
                )


class CycleBlock(Block):
    """Base of the blocks run by one pure cycle function (module docstring)."""

    _cycle: ClassVar[Callable[..., tuple[Any, ...]]]
    _results: ClassVar[tuple[str, ...]]
    _state_fields: ClassVar[tuple[str, ...]] = ("out", "_mem")

    _mem: dict[str, Any]

    # -- to override -----------------------------------------------------------------

    def _parameters(self) -> dict[str, Any]:
        """The configuration's parameter inputs of the cycle (Python floats, bools, ints)."""
        raise NotImplementedError

    def _initial(self) -> dict[str, Any]:
        """The cycle's memory after a reset."""
        raise NotImplementedError

    # -- the contract ------------------------------------------------------------------

    def _apply_config(self, old: BlockConfig | None) -> None:
        self._prm = self._parameters()
        self._f32 = getattr(self._config, "precision", "float64") == "float32"
        if old is not None and hasattr(self, "_mem"):
            keep = self._mem
            self._mem = {k: self._plain(v) for k, v in keep.items()}
            self._reconfigured(old)

    def _reconfigured(self, old: BlockConfig) -> None:
        """Adapt the memory to a new configuration (override; default: keep it)."""

    def _reset_state(self) -> None:
        self._mem = self._initial()
        self.out = self._initial_out()

    def _initial_out(self) -> float:
        return 0.0

    def _resume(self, held: float) -> None:
        # the cycle keeps its memory finite itself; a non-finite out (not expected) restarts it
        self._mem = self._initial()
        self.out = held

    @staticmethod
    def _plain(v: Any) -> Any:
        if isinstance(v, bool | int | str):
            return v
        if isinstance(v, list):
            return [float(x) for x in v]
        if type(v).__name__ == "bool_":
            return bool(v)
        if isinstance(v, numbers.Integral):
            return int(v)
        return float(v)

    # -- one sample ----------------------------------------------------------------------

    def _sample_time(self, dt: Any) -> float | None:
        """The sample time of this call (``ts`` or ``dt``); None (``NO_CYCLE``) when unusable.

        A ``dt`` beyond the REAL range is refused as a PLC's TS cannot carry it.
        """
        h = self._cycle_time(dt, float(self._config.ts))  # type: ignore[attr-defined]
        if h is not None and not h <= REAL_MAX:
            self.error_id = ErrorCode.NO_CYCLE
            return None
        return h

    def _run(self, inputs: dict[str, Any], h: float) -> dict[str, Any]:
        """Run the cycle once with the process ``inputs`` and sample time ``h``.

        Commits the new memory and returns every result by name.  In float32 the
        inputs, parameters and memory are REALs and the cycle runs with float32
        arithmetic (:func:`.plc_cycle.run_float32`).
        """
        prm = self._prm if h == self._prm.get("ts", h) else {**self._prm, "ts": h}
        res = run_cycle(type(self)._cycle, self._results, {**inputs, **prm}, self._mem, self._f32)
        self._mem = {k: res[k] for k in self._mem}
        err = int(res["error_id"])
        self.error_id = ErrorCode(err) if err in _CODES else err
        return res

    # -- the export's view ---------------------------------------------------------------

    _process: ClassVar[dict[str, Any]] = {}
    """The process inputs of the cycle and their initial values in the FUNCTION_BLOCK."""
    _outputs: ClassVar[dict[str, Any]] = {}
    """The outputs of the cycle (results that are no memory) and their initial values."""

    def plc_values(self) -> dict[str, Any]:
        """Initial values of every parameter and result of the cycle (the FB's interface)."""
        return {**self._process, **self._parameters(), **self._initial(), **self._outputs}

    @classmethod
    def cycle_function(cls) -> Callable[..., tuple[Any, ...]]:
        """The pure cycle function of the block (what the PLC export translates)."""
        return cls._cycle

    @classmethod
    def cycle_results(cls) -> tuple[str, ...]:
        """The names of the values the cycle function returns: outputs, then the memory."""
        return cls._results

    def memory_names(self) -> tuple[str, ...]:
        """The names of the cycle's memory (the FB's state variables)."""
        return tuple(self._initial())


_CODES = {int(c) for c in ErrorCode}


def run_cycle(
    fn: Callable[..., tuple[Any, ...]],
    results: tuple[str, ...],
    inputs: dict[str, Any],
    memory: dict[str, Any],
    float32: bool,
) -> dict[str, Any]:
    """Run the cycle ``fn`` once on ``inputs`` (process values and parameters) and ``memory``.

    Returns every result by name.  ``float32``: the values as REALs and the
    function with float32 arithmetic (:func:`.plc_cycle.run_float32`).
    """
    if float32:
        args = {k: _real(v) for k, v in {**inputs, **memory}.items()}
        return dict(zip(results, run_float32(fn, **args), strict=True))
    return dict(zip(results, fn(**inputs, **memory), strict=True))


def _real(v: Any) -> Any:
    if isinstance(v, list):
        return [to_real(x) for x in v]
    return to_real(v)
