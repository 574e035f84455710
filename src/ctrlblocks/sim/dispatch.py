"""Which engine runs a simulation: the compiled lane where it can, else the Python path.

:func:`simulate` is :func:`ctrlblocks.sim.simulate` with a choice of engine:

``"python"``
    the reference: the block and plant objects, sample by sample
    (:mod:`ctrlblocks.sim.loop`);
``"compiled"``
    the compiled lane (the installed lane ``compiled``,
    :mod:`ctrlblocks.loops.lane`; ctrlblocks' own is ``ctrlblocks.fast.simlane``,
    numba), refused with :class:`CompiledLaneError` (naming the reason) for a
    run it cannot do;
``"auto"`` (default of :func:`~ctrlblocks.sim.run_scenario` and the CLI)
    the compiled lane for every run it can do, else the Python path, with the
    reason logged at DEBUG level (logger ``ctrlblocks.sim.dispatch``).

The simulator does not import the lane: it describes a run as a
:class:`~ctrlblocks.loops.lane.LaneRun` (the controller side with its
wiring, the plants, the actuator and sensor, the per-sample arrays of the
events, the noise) and hands it to the lane that :func:`~ctrlblocks.loops.lane.lanes`
finds.  The lane decides what it can run on the controller side (the
structure's wiring and each block: ``Lane.controller_blockers``) and which
plants it has kernels for (``Lane.process_blockers``); this module decides
for the events and the environment.  ctrlblocks' lane runs the wirings of
``single``, ``cascade``, ``override``, ``feedforward`` with a lead-lag and
``smith``, with PIDs or ADRCs whose configuration its kernels cover (the
blocks decide: ``fast_path_blockers``), linear plants of order <= 3 (any
dead time) or the three-tank process (also as a cascade's inner plant or a
Smith predictor's model), inside the scenario's actuator (range, rate, input
load) and sensor (range, noise, output load), with setpoint steps and ramps,
input, output and inner loads, the three-tank's outlet switch, mode and
manual-value events, ``limits`` events (``set_limits`` of the MV blocks or
of the controller named by ``target``: the limits in force of every sample
are found by the blocks' own ``set_limits`` on copies, so a refused pair
keeps the old ones; the PID's output is limited at once), the faults of the
measurements (``sensor`` events, ``ok`` and ``nan``, also together and
overlapping: every loop on a bad measurement runs its bad-measurement cycle,
as with ``pv_ok`` false, and recovers bumplessly; a cascade's primary holds
while ``y2`` is bad; ``ym`` is recorded NaN during a ``nan`` fault, ``y`` is
the true value), and the warm-up.  Everything else -- the other structures,
``set`` events, a ``limits`` event naming something other than a controller
of the lane (the feed-forward lead-lag, a plant), other plant switches,
numba or the lane not installed -- runs the Python path.

A run in which a block's output guard would act (a measurement, an
output or a control law's result before the limits that is not finite:
``BAD_RESULT``) is stopped on the lane at that sample and redone on the
Python path, with the reason logged.

The lane's traces equal the Python path's (same operations in the same
order; tests/sim/test_dispatch.py, test_dispatch_structures.py,
test_dispatch_sensor.py and test_dispatch_limits.py compare both for every
supported case; test_dispatch_campaign.py, a seeded differential campaign,
on scenarios it generates across the whole domain above, with hostile but
accepted values and options the lane does not cover; and
the stored trace hashes, recorded with the Python path, hold with ``auto``).
The measurement noise is drawn by the scenario's own generator, in the
Python path's order (:meth:`ctrlblocks.plants.Noise.samples`).
"""

from __future__ import annotations

import bisect
import copy
import logging
import math
from typing import Any

import numpy as np

from ..blocks.signals import clamp
from ..loops.lane import Lane, LaneRun, lanes
from ..loops.structures import STRUCTURES
from .loop import Run, _Simulation, played_events
from .loop import simulate as python_simulate
from .process import ProcessSide
from .scenario import Case, ControllerSpec, Event, Scenario

__all__ = ["ENGINES", "CompiledLaneError", "compiled_blockers", "simulate"]

log = logging.getLogger(__name__)

ENGINES = ("auto", "compiled", "python")
"""The engines :func:`simulate` (and ``run_scenario``, the CLI's ``--engine``) accept."""


class CompiledLaneError(ValueError):
    """``engine="compiled"`` for a run the compiled lane cannot do (the message says why)."""


def simulate(
    scenario: Scenario,
    controller: ControllerSpec | str,
    case: Case | str | None = None,
    *,
    duration: float | None = None,
    engine: str = "auto",
    cache: dict[Any, Any] | None = None,
) -> Run:
    """Run one controller of ``scenario`` in one case on ``engine`` (module docstring).

    The other parameters are those of :func:`ctrlblocks.sim.simulate`;
    ``cache`` (a dict, empty at first) lets the runs of one scenario share
    what the lane computes once per case (:func:`~ctrlblocks.sim.run_scenario`
    passes one per call).
    """
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {', '.join(ENGINES)}, got {engine!r}")
    if engine == "python":
        return python_simulate(scenario, controller, case, duration=duration)
    if isinstance(controller, str):
        controller = next(c for c in scenario.controllers if c.name == controller)
    if case is None:
        case = scenario.cases[0]
    elif isinstance(case, str):
        case = scenario.case(case)
    t_end = case.duration if duration is None else min(duration, case.duration)
    cache = {} if cache is None else cache
    proc = _shared_process(scenario, case, t_end, cache)
    sim = _Simulation(scenario, controller, case, t_end, proc)
    why = compiled_blockers(sim, cache)
    run = None if why else _run_lane(sim, cache)
    if run is None and not why:
        why = ["a measurement or an output became non-finite (quality handling)"]
    if run is not None:
        return run
    reason = "; ".join(why)
    where = f"{scenario.name} / {controller.name} / {case.name}"
    if engine == "compiled":
        raise CompiledLaneError(f"{where}: the compiled lane cannot run this: {reason}")
    log.debug("%s: Python path (%s)", where, reason)
    return python_simulate(scenario, controller, case, duration=duration)


# ---------------------------------------------------------------------------
# what the lane covers
# ---------------------------------------------------------------------------


def _lane() -> Lane | None:
    """The installed compiled lane (``ctrlblocks.loops.lane``), or None."""
    return lanes().get("compiled")


def _shared_process(sc: Scenario, case: Case, t_end: float, cache: dict[Any, Any]) -> Any:
    """The :class:`ProcessSide` of ``case`` run to ``t_end``, one for all controllers.

    The compiled lane only reads the process side of a run; what it changes
    (the setpoint profile and the noise generator, by :func:`_signals` and
    :func:`_noise`) it does once per case, and keeps the arrays in ``cache``
    under the same case.  Building the plants, the sensor, the actuator and
    the noise generator, and finding ``initial.y``'s steady input, is done
    once per case instead of once per run.  The Python path builds its own.
    None (each run builds one) for a structure with more than one actuator:
    the controller entry maps the initial MV to them.
    """
    if STRUCTURES[sc.structure].actuators != 1:
        return None
    key = ("process", case.name, t_end)
    if key not in cache:
        cache[key] = ProcessSide(sc, played_events(case, t_end, sc.ts))
    return cache[key]


def compiled_blockers(sim: _Simulation, cache: dict[Any, Any] | None = None) -> list[str]:
    """Why the compiled lane cannot run ``sim`` (empty: it can).

    The structure (with its blocks) decides for the controller side; this
    function for the process side, the events and the environment.  With
    ``cache`` (:func:`simulate`'s) the process side's reasons are found once
    per shared process side (:func:`_shared_process`).
    """
    lane = _lane()
    if lane is None:
        return ["no compiled lane is installed (entry point group ctrlblocks.lanes)"]
    bad = lane.controller_blockers(sim.side)
    if bad:
        return bad  # another structure: the process side does not matter
    key = ("process blockers", id(sim.proc))
    if cache is None or cache.get(key, (None,))[0] is not sim.proc:
        found = _process_blockers(sim, lane)
        if cache is None:
            return found
        cache[key] = (sim.proc, found)
    return list(cache[key][1])


def _process_blockers(sim: _Simulation, lane: Lane) -> list[str]:
    """:func:`compiled_blockers` of the process side, the events and the environment."""
    proc = sim.proc
    bad = lane.process_blockers([proc.model, proc.inner_model])
    if proc.plant.fault is not None:
        bad.append("a sensor fault is set")
    if not math.isfinite(proc.plant.y_true):
        bad.append("the initial measurement is not finite")
    return bad + [why for ev in sim.events if (why := _event_blocker(sim, ev))]


def _event_blocker(sim: _Simulation, ev: Event) -> str | None:
    f, k = ev.fields, ev.kind
    where = f"event at t={ev.t:g} ({k})"
    if k == "setpoint":
        return None
    if k == "load":
        at = f.get("at", "input")
        ok = at in ("input", "output") or sim.proc.inner is not None  # else ignored (warning)
        return None if ok else f"{where}: load at {at!r}"
    if k == "plant":
        outlet = f.get("target", "plant") == "plant" and f["param"] == "outlet"
        if outlet and hasattr(sim.proc.model, "discrete_model"):  # the three-tank's valve
            return None
        return f"{where}: plant parameter {f['param']!r} switched"
    if k in ("mode", "manual_value"):
        if "target" in f:
            return f"{where}: names a target"
        v = f.get("manual_value" if k == "mode" else "value")
        if v is not None and not math.isfinite(v):
            return f"{where}: non-finite manual value"
        return None
    if k == "limits":
        # set_limits of the MV blocks or the named one, mirrored per sample (_limits)
        role = f.get("target")
        if role is None or role in sim.side.wiring.roles:
            return None
        return f"{where}: names {role!r}, not a controller of the lane"
    if k == "sensor":
        # every loop on the bad measurement runs its bad cycle (an override's blocks run on
        # both flags); a cascade's primary holds while y2 is bad (Wiring.follow)
        return None
    return f"{where}: not covered"


# ---------------------------------------------------------------------------
# the run
# ---------------------------------------------------------------------------


def _run_lane(sim: _Simulation, cache: dict[Any, Any]) -> Run | None:
    """The run on the compiled lane; None when it stopped at a non-finite value.

    ``cache`` keeps the per-sample arrays of a case (events, noise) for the
    scenario's other controllers: the process side is the same for all.
    """
    lane = _lane()
    assert lane is not None  # compiled_blockers said so
    sc, proc, h, n, side = sim.sc, sim.proc, sim.ts, sim.n, sim.side
    kind = side.kind
    blocks = [side.blocks[r] for r in side.wiring.roles]
    mv = [any(b is m for m in side.mv_blocks) for b in blocks]
    ini = sc.initial
    inner = proc.inner
    y2_w = math.nan if inner is None else inner.y
    if ini["warmup"] > 0 or ini["mode"] == "manual":  # _Simulation._warmup
        nw = round(ini["warmup"] / h)
        kind.hold_for_warmup(side, proc.u0, y2_w)
        manual0 = [ini["mode"] == "manual"] * len(blocks)
    else:
        nw, manual0 = 0, [bool(b.manual) for b in blocks]
    sensor, act = proc.plant, proc.actuator
    key = (sim.case.name, n, nw)
    if key not in cache:
        cache[key] = _signals(sim, n) | {"noise": _noise(sensor, nw, n)}
    sig = cache[key]
    manual = [
        _piecewise([(0, float(m0)), *(sig["manual_changes"] if is_mv else ())], n)
        for m0, is_mv in zip(manual0, mv, strict=True)
    ]
    limits = flags = None
    if sig["limits_changes"]:
        limits, flags = _limits(side, blocks, sig["limits_changes"], n)
    per_sample = {k: sig[k] for k in _PER_SAMPLE}
    if flags is not None:
        per_sample["limits_event"] = flags
    res = lane.run(LaneRun(
        side=side, model=proc.model, inner_model=proc.inner_model,
        actuator=(act.u_min, act.u_max, act.rate * act.ts, act.u),
        sensor=(sensor.y_min, sensor.y_max), warmup=nw, sp_warmup=sig["sp_warmup"],
        y_warmup=proc.plant.y_true, y2_warmup=y2_w, dv_warmup=act.load,
        u_man=[float(b.manual_value) for b in blocks], manual=manual, signals=per_sample,
        limits=limits, noise=sig["noise"],
    ))  # fmt: skip
    if res.stopped >= 0:
        return None
    signals = {
        "sp": sig["sp"].copy(),
        "y": res.y,
        "ym": res.ym,
        "u": res.u,
        "v": res.u.copy(),
        "u_act": res.u_act,
        "load": sig["load_in"].copy(),
    }
    if inner is not None:
        signals["y2"] = res.y2
    signals |= res.signals
    signals["t"] = np.arange(n) * h
    return Run(
        scenario=sc.name,
        controller=sim.ctrl_spec.name,
        case=sim.case.name,
        ts=h,
        signals=signals,
        events=sim.events,
        duration=n * h,
    )


_PER_SAMPLE = ("sp", "load_in", "load_out", "u_man", "g3o", "load_mid", "y2_ok", "y_ok", "y_nan")
"""The per-sample arrays of :func:`_signals` a :class:`~ctrlblocks.loops.lane.LaneRun` takes."""


def _limits(
    side: Any, blocks: list[Any], events: list[tuple[int, Any]], n: int
) -> tuple[np.ndarray, np.ndarray]:
    """The limits in force of every lane controller and sample, and where an event is due.

    ``limits`` events (``set_limits`` of the blocks
    ``ControllerSide.event_blocks`` names, as the Python path) are played on copies of the
    blocks, so that the blocks themselves decide what a pair does: a valid
    pair is in force from its sample on, a refused one (reversed, NaN:
    ``BAD_LIMITS``) leaves the old limits.  Returns ``(limits, flags)``:
    ``limits[j, 0 or 1, k]`` the limits in force, ``limits[j, 2 or 3, k]``
    the bounds the held output is limited to at an event's sample, and
    ``flags[k] = 1`` where an event is due.  Several events in one sample
    limit the output one after the other (``Block._relimit`` at each), which
    is one limitation to the pair ``clamp(lo_1, lo_2, hi_2)``,
    ``clamp(hi_1, lo_2, hi_2)`` (and so on): not to the last pair alone.
    """
    copies = [copy.deepcopy(b) for b in blocks]
    changes = [[(0, *b.output_limits())] for b in copies]
    held: list[dict[int, tuple[float, float]]] = [{} for _ in copies]  # k -> bounds of out
    flags = np.zeros(n)
    for k, f in events:
        flags[k] = 1.0
        acts = side.event_blocks("limits", f.get("target"))
        for j, b in enumerate(copies):
            if any(blocks[j] is a for a in acts):
                b.set_limits(f["u_min"], f["u_max"])
                lo, hi = b.output_limits()
                changes[j].append((k, lo, hi))
                if k in held[j]:  # out was limited before in this sample
                    a, c = held[j][k]
                    lo, hi = clamp(a, lo, hi), clamp(c, lo, hi)
                held[j][k] = (lo, hi)
    lim = np.empty((len(copies), 4, n))
    for j, ch in enumerate(changes):
        lim[j, 0] = _piecewise([(k, v[0]) for k, *v in ch], n)
        lim[j, 1] = _piecewise([(k, v[1]) for k, *v in ch], n)
        lim[j, 2:] = lim[j, :2]
        for k, bounds in held[j].items():
            lim[j, 2:, k] = bounds
    return lim, flags


def _noise(sensor: Any, nw: int, n: int) -> np.ndarray:
    """The sensor's noise value of each recorded sample, as the Python path draws them.

    One value is drawn at every plant step and every reset; the warm-up does
    both in each of its ``nw`` samples.
    """
    gen = sensor.noise
    if gen is None or n == 0:
        return np.zeros(n)
    seq = np.concatenate(([sensor.noise_value], gen.samples(2 * nw + n - 1)))
    return np.ascontiguousarray(seq[2 * nw : 2 * nw + n])


def _due_sample(t_ev: float, h: float) -> int:
    """The first sample ``k`` at which an event at ``t_ev`` is due (ProcessSide.due)."""
    k = max(0, math.floor((t_ev - 0.5 * h) / h))
    while k > 0 and t_ev <= (k - 1) * h + 0.5 * h:
        k -= 1
    while t_ev > k * h + 0.5 * h:
        k += 1
    return k


def _piecewise(changes: list[tuple[int, float]], n: int) -> np.ndarray:
    """``n`` samples holding each value of ``(k, value)`` (sorted by ``k``) from its ``k`` on."""
    a = np.empty(n)
    for j, (k, v) in enumerate(changes):
        a[k : changes[j + 1][0] if j + 1 < len(changes) else n] = v
    return a


def _signals(sim: _Simulation, n: int) -> dict[str, Any]:
    """Per-sample arrays of the events (:attr:`~ctrlblocks.loops.lane.LaneRun.signals`).

    The mode is left as its changes (``manual_changes``): its initial value
    depends on the controller.
    """
    proc, h = sim.proc, sim.ts
    model = proc.model
    tank = model.discrete_model() if hasattr(model, "discrete_model") else None
    g3o = tank.g[5] if tank is not None else 0.0
    changes: dict[str, list[tuple[int, float]]] = {
        "load_in": [(0, proc.actuator.load)],
        "load_out": [(0, proc.plant.load)],
        "g3o": [(0, g3o)],
        "load_mid": [(0, proc.inner_load)],
    }
    manual: list[tuple[int, float]] = []
    limits: list[tuple[int, dict[str, Any]]] = []
    y2_flag: list[tuple[int, float]] = [(0, float(proc.sensor2_ok))]
    y2_nan: list[tuple[int, float]] = [(0, 0.0)]
    y_flag: list[tuple[int, float]] = [(0, float(proc.sensor_ok))]
    y_nan: list[tuple[int, float]] = [(0, 0.0)]
    u_man = np.full(n, math.nan)
    by_k: dict[int, list[Event]] = {}
    for ev in proc.pending:
        k = _due_sample(ev.t, h)
        if k >= n:
            continue
        by_k.setdefault(k, []).append(ev)
        f = ev.fields
        if ev.kind == "load":
            at = f.get("at", "input")
            key = "load_in" if at == "input" else "load_out" if at == "output" else "load_mid"
            changes[key].append((k, f["value"]))
        elif ev.kind == "plant":
            changes["g3o"].append((k, tank.outlet_g[f["value"]]))  # type: ignore[union-attr]
        elif ev.kind == "mode":
            manual.append((k, float(f["mode"] == "manual")))
            if "manual_value" in f:
                u_man[k] = f["manual_value"]
        elif ev.kind == "manual_value":
            u_man[k] = f["value"]
        elif ev.kind == "limits":
            limits.append((k, f))
        elif ev.kind == "sensor":
            flag, nan = (y2_flag, y2_nan) if f.get("target", "y") == "y2" else (y_flag, y_nan)
            if "ok" in f:
                flag.append((k, float(f["ok"])))
            if "nan" in f:
                nan.append((k, float(f["nan"])))
    out: dict[str, Any] = {"sp_warmup": proc.setpoint.value, "u_man": u_man}
    out |= {name: _piecewise(ch, n) for name, ch in changes.items()}
    # ProcessSide.apply: the flag and the NaN are set apart; y2 is good when both say so
    out["y2_ok"] = _piecewise(y2_flag, n) * (1.0 - _piecewise(y2_nan, n))
    # y: the same (loop._sample: ok = sensor_ok and ym finite); the NaN is also recorded (ym)
    out["y_nan"] = _piecewise(y_nan, n)
    out["y_ok"] = _piecewise(y_flag, n) * (1.0 - out["y_nan"])
    out["manual_changes"] = manual
    out["limits_changes"] = limits
    out["sp"] = _setpoints(proc.setpoint, by_k, n, h)
    return out


def _setpoints(prof: Any, by_k: dict[int, list[Event]], n: int, h: float) -> np.ndarray:
    """The setpoint of every sample: ``advance(h)``, then the setpoint events (loop.run)."""
    sp = np.empty(n)
    keys = sorted(by_k)
    k = 0
    while k < n:
        if k > 0:
            prof.advance(h)
        for ev in by_k.get(k, ()):
            if ev.kind == "setpoint":
                prof.step_to(ev.fields["value"], ev.fields.get("ramp"))
        sp[k] = prof.value
        if prof.value == prof.target:  # constant up to the next event (advance does nothing)
            j = bisect.bisect_right(keys, k)
            nxt = keys[j] if j < len(keys) else n
            sp[k + 1 : nxt] = prof.value
            k = nxt
        else:
            k += 1
    return sp
