"""The test bench exported beside a function block: a recorded trace and the outputs it must give.

:class:`FbModel` is the exported FUNCTION_BLOCK run in Python: the block's PLC
cycle (the function the FB body is translated from) executed in REAL
arithmetic (``precision="float32"``, :func:`.plc_cycle.run_float32`) on
instance variables named as in the PLC, with the FB's guard on ``TS``.  Fed a
trace of input writes (PLC names, only what changes in a sample), it records
the outputs the PLC must show after each call: :func:`record`.

:func:`default_trace` is a day in the life of a block, short enough to paste:
set-point steps and a closed loop on a first-order (PID, lead-lag input) or
second-order (ADRC) plant, manual mode, reset, tracking, hold, anti-windup
input, a bad measurement flag, NaN and infinite measurements, a retune and new
limits.  The exported test program replays the recorded inputs and compares
``MV``, ``ERROR_ID`` and the block's limit flag after every call, bit for bit
(docs/plc.md, "The test bench").
"""

from __future__ import annotations

import inspect
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..blocks import plc_cycle as pc
from .specs import BlockSpec

__all__ = ["Bench", "FbModel", "default_trace", "record"]

CHECKED = {"pid": ("MV", "ERROR_ID", "LIMITS_ACTIVE"), "adrc": ("MV", "ERROR_ID", "AWOUT"),
           "leadlag": ("OUT", "ERROR_ID")}  # fmt: skip
"""The outputs the test bench compares after each call, per block kind (the one-cycle
blocks: every output, :func:`checked`)."""


def checked(spec: BlockSpec) -> tuple[str, ...]:
    """The outputs the test bench of ``spec`` compares after each call."""
    return CHECKED.get(spec.kind) or tuple(v.st for v in spec.outputs)


class FbModel:
    """An instance of the exported FB in Python: ``fb(SP=1.0, ...)`` writes inputs and runs one
    cycle in REAL arithmetic; ``fb["MV"]`` reads a variable by its PLC name."""

    def __init__(self, spec: BlockSpec) -> None:
        self.spec = spec
        self.py = {v.st.upper(): v.py for v in (*spec.inputs, *spec.outputs, *spec.state)}
        self.values: dict[str, Any] = {}
        for k, v in pc.real_args(spec.values).items():
            self.values[k] = np.array(v, dtype=np.float32) if isinstance(v, list) else v
        self.params = list(inspect.signature(spec.cycle).parameters)

    def __call__(self, **inputs: Any) -> None:
        for name, v in inputs.items():
            py = self.py[name.upper()]
            self.values[py] = pc.real_args({py: v})[py]
        if "ts" in self.values and not pc.cycle_time_ok(self.values["ts"]):
            self.values["error_id"] = pc.NO_CYCLE  # the FB's guard: nothing else moves
            return
        res = pc.run_float32(self.spec.cycle, **{p: self.values[p] for p in self.params})
        self.values.update(zip(self.spec.results, res, strict=True))

    def __getitem__(self, name: str) -> Any:
        if name.upper() == "ERROR":
            return self.values["error_id"] != 0
        return self.values[self.py[name.upper()]]


@dataclass
class Bench:
    """A recorded trace: per sample the inputs written and the outputs expected after the call."""

    fb: str
    kind: str
    checked: tuple[str, ...] = ()
    """The outputs compared after each call."""
    inputs: list[dict[str, Any]] = field(default_factory=list)
    expected: list[dict[str, Any]] = field(default_factory=list)


def record(spec: BlockSpec, trace: list[dict[str, Any]], fb_name: str | None = None) -> Bench:
    """Run ``trace`` (per sample ``{PLC input: value}``) through :class:`FbModel`."""
    model = FbModel(spec)
    bench = Bench(fb_name or spec.fb_name, spec.kind, checked(spec))
    for inp in trace:
        model(**inp)
        bench.inputs.append(dict(inp))
        bench.expected.append({k: _plain(model[k]) for k in bench.checked})
    return bench


def _plain(v: Any) -> Any:
    if isinstance(v, bool | np.bool_):
        return bool(v)
    if isinstance(v, int | np.integer):
        return int(v)
    return float(np.float32(v))


def default_trace(spec: BlockSpec, n: int = 120) -> list[dict[str, Any]]:
    """``n`` samples exercising the block (module docstring), as FB input writes.

    The loop is closed through :class:`FbModel` (the PLC's output drives the
    plant), so the recorded inputs are those the FB meets in operation; the
    bench replays them open-loop.
    """
    if spec.kind not in CHECKED:
        return _cycle_trace(spec, n)
    model = FbModel(spec)
    trace: list[dict[str, Any]] = []
    y, dy = 20.0, 0.0
    u = float(model["OUT" if spec.kind == "leadlag" else "MV"])
    lo, hi = _limits(spec)
    for k in range(n):
        f = k / n
        inp: dict[str, Any] = {}
        if spec.kind == "leadlag":
            x = 1.0 if f > 0.1 else 0.0
            x += 2.0 if f > 0.5 else 0.0
            inp["IN"] = math.nan if k == int(0.3 * n) else x + 0.01 * math.sin(k)
            if k in (int(0.4 * n), int(0.45 * n)):
                inp["ENABLE"] = k != int(0.4 * n)
            if k == int(0.6 * n):
                inp["T_LEAD"] = float(spec.values["t_lead"]) * 0.5
        else:
            sp = 30.0 if f < 0.15 else 60.0 if f < 0.55 else 40.0
            pv = y + 0.05 * math.sin(1.7 * k)
            if k == int(0.5 * n):
                pv = math.nan
            if k == int(0.8 * n):
                pv = math.inf
            inp.update(SP=sp, PV=pv)
            if k in (int(0.6 * n), int(0.62 * n)):
                inp["PV_OK"] = k != int(0.6 * n)
            if k in (int(0.3 * n), int(0.36 * n)):
                inp["MANUAL"] = k == int(0.3 * n)
                if inp["MANUAL"]:
                    inp["MAN_VALUE"] = lo + 0.35 * (hi - lo)
            if k == int(0.45 * n):
                key = "K" if spec.kind == "pid" else "OMEGA_C"
                inp[key] = float(model[key]) * 1.5  # a retune (bumpless)
            if k == int(0.7 * n):
                inp["U_MIN"], inp["U_MAX"] = lo + 0.1 * (hi - lo), lo + 0.6 * (hi - lo)
            if k in (int(0.65 * n), int(0.68 * n)):
                inp["AWIN"] = k == int(0.65 * n)
            if spec.kind == "pid":
                if k in (int(0.4 * n), int(0.41 * n)):
                    inp["RST"] = k == int(0.4 * n)
                if k in (int(0.2 * n), int(0.22 * n)):
                    inp["TRACK"] = k == int(0.2 * n)
                    inp["TRACK_VALUE"] = lo + 0.42 * (hi - lo)
                if k in (int(0.25 * n), int(0.27 * n)):
                    inp["HOLD"] = k == int(0.25 * n)
        model(**inp)
        trace.append(inp)
        u = float(model["OUT" if spec.kind == "leadlag" else "MV"])
        if spec.kind == "pid":  # y' = (2 u/(hi - lo) 50 - y)/5
            y += float(spec.values["ts"]) * (100.0 * (u - lo) / (hi - lo) - y) / 5.0
        elif spec.kind == "adrc":  # y'' = -0.5 y' + b u - 0.1 y, scaled to the limits
            b = 100.0 / max(hi - lo, 1e-9) * 0.05
            h = float(spec.values["ts"])
            y, dy = y + h * dy, dy + h * (-0.5 * dy + b * (u - lo) - 0.1 * y)
    return trace


def _cycle_trace(spec: BlockSpec, n: int) -> list[dict[str, Any]]:
    """The exercise of a one-cycle block (two/three-point, transfer function, set-point
    program, heat/cool stage), open loop: its REAL process inputs swing through +-60 around
    0 (SP steps between 0 and 1) with a NaN and an infinite sample; each BOOL process input
    takes the other value for a few samples twice."""
    trace: list[dict[str, Any]] = []
    names = [v for v in spec.inputs if v.st in spec.process]
    for k in range(n):
        inp: dict[str, Any] = {}
        for j, v in enumerate(names):
            default = spec.values[v.py]
            if isinstance(default, bool):
                flip = k in range(int(0.3 * n), int(0.3 * n) + 3) or k == int(0.7 * n) + j
                inp[v.st] = (not default) if flip else default
            elif v.st == "SP":
                inp[v.st] = 0.0 if k < n // 2 else 1.0
            else:
                x = 60.0 * math.sin(2.0 * math.pi * k / 40.0) + 0.5 * math.sin(1.7 * k + j)
                inp[v.st] = math.nan if k == int(0.5 * n) else math.inf if k == int(0.8 * n) else x
        trace.append(inp)
    return trace


def _limits(spec: BlockSpec) -> tuple[float, float]:
    """Finite output limits for the exercise (infinite ones: 0..100)."""
    lo = float(spec.values.get("u_min", spec.values.get("out_min", 0.0)))
    hi = float(spec.values.get("u_max", spec.values.get("out_max", 100.0)))
    lo = lo if math.isfinite(lo) else (min(0.0, hi - 100.0) if math.isfinite(hi) else 0.0)
    hi = hi if math.isfinite(hi) else lo + 100.0
    return lo, hi
