"""Scenario files: one experiment as a TOML document, read and checked.

A scenario names the process, the controllers to compare, the events on the
time line, the claims to check and how to plot.  The format is described in
``docs/simulator.md``; the shipped scenarios are in
``ctrlblocks/scenarios/*.toml``.

Every error in a file is reported as a :class:`ScenarioError` that names the
file, the line, the key path (``controllers[2].kp``, ``cases[0].events[3].t``)
and what was expected; the line is looked up in the text only when an error
is raised (:func:`ctrlblocks.loops.toml.located`).  Blocks and plants are
built once while loading, so a parameter a block refuses (its
:class:`~ctrlblocks.blocks.base.ParameterError`) is reported here, with its
key path, and not in the middle of a run.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..blocks.base import ParameterError, require_limits
from ..loops.spec import BlockSpec, ControllerSpec, SpecReader, TuneHook
from ..loops.structures import STRUCTURES as _STRUCTURES
from ..loops.structures import parse_controller as _parse_controller
from ..loops.structures import read_controller
from ..loops.toml import (
    NAME_RE,
    KeyPathError,
    TableReader,
    located,
    read_text,
    read_toml,
    type_name,
    unknown_key_problem,
)
from ..plants import steady_input
from ..plants.wrappers import Noise

__all__ = [
    "EVENT_KINDS",
    "MAX_SAMPLES",
    "NAME_RE",
    "SENSOR_TARGETS",
    "STRUCTURES",
    "BlockSpec",
    "Case",
    "Claim",
    "ControllerSpec",
    "Event",
    "KeyPathError",
    "Scenario",
    "ScenarioError",
    "TableReader",
    "load_scenario",
    "parse_controller",
    "parse_scenario",
    "parse_scenario_doc",
    "read_toml",
    "type_name",
    "unknown_key_problem",
]

STRUCTURES: dict[str, tuple[str, ...]] = {name: s.roles for name, s in _STRUCTURES.items()}
"""The loop structures and the blocks each controller entry needs (from
:data:`ctrlblocks.loops.STRUCTURES`)."""

_SIDE_EVENTS = ("set", "mode", "manual_value", "limits")
"""The events that act on a controller entry's blocks (the others on the process)."""

MAX_SAMPLES = 10_000_000
"""The most samples a run (its duration or warm-up over ``ts``) may have: 10^7 samples
keep a run's traces in a few hundred MB."""

EVENT_KINDS: dict[str, dict[str, tuple[type, ...]]] = {
    # kind -> {field: accepted types}; "t" and "label" are common to all
    "setpoint": {"value": (float,), "ramp": (float,)},
    "load": {"value": (float,), "at": (str,)},
    "mode": {"mode": (str,), "manual_value": (float,), "target": (str,)},
    "manual_value": {"value": (float,), "target": (str,)},
    "limits": {"u_min": (float,), "u_max": (float,), "target": (str,)},
    "plant": {"param": (str,), "value": (float, str, bool), "target": (str,)},
    "sensor": {"ok": (bool,), "nan": (bool,), "target": (str,)},
    "set": {"attr": (str,), "value": (float, bool, str), "target": (str,)},
    "wild": {"value": (float,), "ramp": (float,), "ok": (bool,), "nan": (bool,)},
}
"""Event kinds and their fields (see ``docs/simulator.md``)."""

_REQUIRED_EVENT_FIELDS: dict[str, tuple[str, ...]] = {
    "setpoint": ("value",),
    "load": ("value",),
    "mode": ("mode",),
    "manual_value": ("value",),
    "limits": ("u_min", "u_max"),
    "plant": ("param", "value"),
    "sensor": (),
    "set": ("attr", "value"),
    "wild": (),
}

INITIAL_Y_PROBLEM = "needs a plant with a finite, non-zero static gain (give initial.u instead)"
"""Why ``initial.y`` is refused for an integrating (or zero-gain) plant."""

_LOAD_POINTS = ("input", "output", "inner")
SENSOR_TARGETS = ("y", "y2")
"""The measurements a ``sensor`` event acts on (``target``, default ``y``); ``y2`` only
where a controller measures it (cascade, three-step, an override block on ``y2``)."""
SIGNAL_STATS = ("max", "min", "final", "mean", "max_step")
"""Statistics of a trace signal that a claim with ``signal = "..."`` can check
(``max_step``: the largest change from one sample to the next, ``max |x_k - x_(k-1)|``,
the step into the window's first sample included)."""
_CLAIM_KINDS = ("less", "below", "above", "between", "best", "approx")


_CSV_KEYS = ("file", "time", "u", "y", "u_before", "delimiter", "decimal", "encoding", "tz",
             "time_format", "bad_rows", "gaps", "start", "end")  # fmt: skip
"""The keys of a ``[controllers.tune]`` table that read a recorded bump test (the reading
options are those of ``ctrlblocks.tuning.records.CSV_OPTIONS``; a test keeps them equal)."""


class ScenarioError(KeyPathError):
    """A scenario file is malformed.

    Attributes
    ----------
    file : str
        The file (or ``"<string>"``).
    key : str
        Key path of the offending value, e.g. ``controllers[1].kp`` (empty for
        syntax errors).
    problem : str
        What is wrong and what was expected.
    line : int or None
        The line that writes the key path (or its table's header, or its
        array-of-tables entry); None for a document built in Python.
    """


# ---------------------------------------------------------------------------
# The parsed scenario
# ---------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Event:
    """One event on the time line."""

    t: float
    kind: str
    fields: Mapping[str, Any]
    label: str
    key: str = dataclasses.field(default="", compare=False)
    """Its key path in the file (``events[2]``, ``cases[1].events[0]``), for error messages."""


@dataclasses.dataclass(frozen=True)
class Case:
    """A run condition (events sorted by time, duration); every controller runs every case."""

    name: str
    duration: float
    events: tuple[Event, ...]


@dataclasses.dataclass(frozen=True)
class Claim:
    """A statement from the source, checked on the metrics after the runs."""

    text: str
    metric: str
    kind: str
    args: Mapping[str, Any]
    case: str | None
    window: int | None
    source: str


@dataclasses.dataclass(frozen=True)
class Scenario:
    """A parsed, checked scenario (see the module docstring)."""

    name: str
    title: str
    source: str
    description: str
    structure: str
    ts: float
    duration: float
    quick_duration: float
    seed: int
    plant: BlockSpec | None
    inner_plant: BlockSpec | None
    sensor: Mapping[str, Any]
    actuator: Mapping[str, Any]
    initial: Mapping[str, Any]
    controllers: tuple[ControllerSpec, ...]
    cases: tuple[Case, ...]
    claims: tuple[Claim, ...]
    plot: Mapping[str, Any]
    metrics: Mapping[str, Any]
    notes: str
    file: str

    def case(self, name: str) -> Case:
        """The case called ``name``."""
        for c in self.cases:
            if c.name == name:
                return c
        raise KeyError(name)


# ---------------------------------------------------------------------------
# Loading
# ---------------------------------------------------------------------------


def load_scenario(path: str | Path) -> Scenario:
    """Read and check the scenario file ``path``; raise :class:`ScenarioError` if malformed."""
    p = Path(path)
    return parse_scenario(read_text(p, ScenarioError), file=str(p))


def parse_scenario(text: str, *, file: str = "<string>") -> Scenario:
    """Parse scenario TOML ``text``; ``file`` names it in error messages (with the line)."""
    return parse_scenario_doc(read_toml(text, file, ScenarioError), file=file, text=text)


def parse_scenario_doc(
    doc: dict[str, Any], *, file: str = "<string>", text: str | None = None
) -> Scenario:
    """Check an already parsed scenario document (a dict as from ``tomllib``).

    ``text``: the TOML text ``doc`` was read from (and perhaps changed after,
    as a sweep does); an error then names the line of its key path there,
    looked up only when it is raised.  Without it errors have no line.
    """
    with located(text):
        return _Parser(file).scenario(doc)


def parse_controller(
    entry: dict[str, Any], structure: str, ts: float, *, key: str, file: str = "<string>"
) -> ControllerSpec:
    """Check one controller entry of ``structure`` (the tables of a ``[[controllers]]`` entry).

    ``key`` is its key path in ``file`` (error messages: :class:`ScenarioError`
    with ``key.role.param``).  The runtime reads its loops' structures with it.
    """
    return _parse_controller(entry, structure, ts, key=key, file=file, error=ScenarioError)


class _Parser(SpecReader):
    error = ScenarioError
    measured: tuple[str, ...] = ("y",)
    """What the scenario's controllers measure (:meth:`sensor_target`), set before the cases."""

    # -- sections ----------------------------------------------------------------

    def scenario(self, doc: dict[str, Any]) -> Scenario:
        self.check_keys(
            doc,
            {
                "scenario",
                "plant",
                "inner_plant",
                "actuator",
                "sensor",
                "initial",
                "controllers",
                "cases",
                "events",
                "claims",
                "plot",
                "metrics",
            },
            "",
        )
        head = self.table(doc, "scenario", "scenario", required=True)
        self.check_keys(
            head,
            {
                "name",
                "title",
                "source",
                "description",
                "structure",
                "ts",
                "duration",
                "quick_duration",
                "seed",
                "notes",
            },
            "scenario",
        )
        name = self.string(head, "name", "scenario.name")
        if not NAME_RE.match(name):
            raise self.fail("scenario.name", f"must be letters, digits, _ . - only; got {name!r}")
        title = self.string(head, "title", "scenario.title")
        structure = self.string(head, "structure", "scenario.structure", default="single")
        if structure not in _STRUCTURES:  # the live registry: a registered structure counts
            raise self.fail(
                "scenario.structure", f"must be one of {', '.join(_STRUCTURES)}; got {structure!r}"
            )
        ts = self.number(head, "ts", "scenario.ts", positive=True)
        duration = self.number(head, "duration", "scenario.duration", positive=True)
        quick = self.number(
            head, "quick_duration", "scenario.quick_duration", default=duration, positive=True
        )
        for field, length in (("ts", duration), ("quick_duration", quick)):
            if length < ts:  # a run of no sample
                raise self.fail(f"scenario.{field}", f"leaves a run of no sample: ts {ts!r} s is "
                                f"longer than the duration {length!r} s")  # fmt: skip
        seed = head.get("seed", 0)
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise self.fail("scenario.seed", f"must be an integer >= 0, got {seed!r}")

        plant = None
        inner = None
        if _STRUCTURES[structure].closed_loop:
            plant = self.block_spec(self.table(doc, "plant", "plant", True), "plant", ts)
        if _STRUCTURES[structure].series_plant:
            inner = self.block_spec(
                self.table(doc, "inner_plant", "inner_plant", True), "inner_plant", ts
            )
        elif "inner_plant" in doc:
            raise self.fail(
                "inner_plant", f"only for the cascade and override structures, not {structure!r}"
            )
        sensor = self.sensor(self.table(doc, "sensor", "sensor", False))
        actuator = self.actuator(self.table(doc, "actuator", "actuator", False))
        initial = self.initial(self.table(doc, "initial", "initial", False))

        self.samples(duration, ts, "scenario.duration")
        self.samples(initial["warmup"], ts, "initial.warmup")
        controllers = self.controllers(doc, structure, ts, plant, initial)
        self.measured = self.measured_by(doc, structure)
        cases = self.cases(doc, duration, ts)
        for i, case in enumerate(cases):
            if case.duration != duration:
                self.samples(case.duration, ts, f"cases[{i}].duration")
        self.controller_events(structure, ts, controllers, cases)
        self.structure_inputs(doc, structure, initial, cases)
        claims = self.claims(doc, controllers, cases)
        self.quotes(head, claims, controllers, cases)
        plot = self.table(doc, "plot", "plot", False)
        self.check_keys(
            plot,
            {
                "upper",
                "lower",
                "upper_label",
                "lower_label",
                "title",
                "ylim_upper",
                "ylim_lower",
                "legend",
                "lower_per_controller",
            },
            "plot",
        )
        if not isinstance(plot.get("lower_per_controller", False), bool):
            raise self.fail("plot.lower_per_controller", "must be true or false")
        if "legend" in plot and not (
            isinstance(plot["legend"], dict)
            and all(isinstance(v, str) for v in plot["legend"].values())
        ):
            raise self.fail("plot.legend", 'must be a table of signal = "legend text"')
        for k in ("upper", "lower"):
            if k in plot and (
                not isinstance(plot[k], list) or not all(isinstance(s, str) for s in plot[k])
            ):
                raise self.fail(f"plot.{k}", "must be a list of signal names")
        metrics = self.table(doc, "metrics", "metrics", False)
        self.check_keys(metrics, {"band", "windows"}, "metrics")
        if "band" in metrics:
            self.number(metrics, "band", "metrics.band", positive=True)
        if "windows" in metrics and not isinstance(metrics["windows"], bool):
            raise self.fail("metrics.windows", "must be true or false")
        sc = Scenario(
            name=name,
            title=title,
            source=self.string(head, "source", "scenario.source", default=""),
            description=self.string(head, "description", "scenario.description", default=""),
            structure=structure,
            ts=ts,
            duration=duration,
            quick_duration=min(quick, duration),
            seed=seed,
            plant=plant,
            inner_plant=inner,
            sensor=sensor,
            actuator=actuator,
            initial=initial,
            controllers=tuple(controllers),
            cases=tuple(cases),
            claims=tuple(claims),
            plot=plot,
            metrics=metrics,
            notes=self.string(head, "notes", "scenario.notes", default=""),
            file=self.file,
        )
        if plant is not None and not math.isnan(initial["y"]):
            self.initial_y(plant, inner, initial["y"], ts)
        return sc

    def structure_inputs(
        self, doc: dict[str, Any], structure: str, initial: Mapping[str, Any], cases: list[Case]
    ) -> None:
        """The wild flow only for the ratio structure; no ``initial.y`` for two actuators."""
        kind = _STRUCTURES[structure]
        if "w" not in kind.measurements:
            if "wild" in doc.get("initial", {}):
                raise self.fail("initial.wild", f"only for the ratio structure, not {structure!r}")
            for c in cases:
                for ev in c.events:
                    if ev.kind == "wild":
                        raise self.fail(
                            "events", f"a 'wild' event (t={ev.t:g}) needs the ratio structure"
                        )
        if kind.actuators > 1 and not math.isnan(initial["y"]):
            raise self.fail(
                "initial.y",
                f"the {structure} structure starts from initial.u, the controller output "
                "(its two actuators have no unique steady state for a temperature)",
            )

    def measured_by(self, doc: dict[str, Any], structure: str) -> tuple[str, ...]:
        """The measurements the controllers of ``doc`` read (an override: its blocks')."""
        kind = _STRUCTURES[structure]
        used = {m for e in doc["controllers"] for m in kind.measurements_in(e)}
        return tuple(m for m in kind.measurements if m in used)

    def sensor_target(self, target: str, key: str) -> None:
        """A ``sensor`` event's ``target``: ``y``, or ``y2`` where a controller measures it."""
        valid = [m for m in SENSOR_TARGETS if m == "y" or m in self.measured]
        if target == "y2" and target not in valid:
            have = " and ".join(self.measured) or "nothing"
            raise self.fail(
                key,
                "'y2' needs a controller that measures y2 (cascade, three_step, or an "
                f'override block with measure = "y2"); the controllers here measure {have}',
            )
        if target not in valid:
            raise self.fail(key, f"unknown target {target!r}; expected one of: {', '.join(valid)}")

    def initial_y(self, plant: BlockSpec, inner: BlockSpec | None, y0: float, ts: float) -> None:
        """``initial.y`` needs an MV whose steady state gives it: refused here, not in a run."""
        chain = [self.build(s, ts, kind="plant") for s in (inner, plant) if s]
        if steady_input(chain, y0) is None:
            raise self.fail("initial.y", INITIAL_Y_PROBLEM)

    def limit_pair(self, out: dict[str, Any], lo: str, hi: str, table: str) -> None:
        """A range that leaves a finite value (the blocks' own check, ``require_limits``)."""
        try:
            require_limits(lo, out[lo], hi, out[hi])
        except ParameterError as exc:
            field = hi if out[lo] <= out[hi] and out[lo] != math.inf else lo
            raise self.fail(f"{table}.{field}", exc.message) from None

    def sensor(self, d: dict[str, Any]) -> dict[str, Any]:
        self.check_keys(d, {"y_min", "y_max", "noise", "noise_kind", "noise_t_corr"}, "sensor")
        out: dict[str, Any] = {}
        out["y_min"] = self.number(d, "y_min", "sensor.y_min", default=-math.inf, limit=True)
        out["y_max"] = self.number(d, "y_max", "sensor.y_max", default=math.inf, limit=True)
        self.limit_pair(out, "y_min", "y_max", "sensor")
        out["noise"] = self.number(d, "noise", "sensor.noise", default=0.0)
        if out["noise"] < 0:
            raise self.fail("sensor.noise", f"must be >= 0, got {out['noise']!r}")
        kind = self.string(d, "noise_kind", "sensor.noise_kind", default="uniform")
        if kind not in ("uniform", "gaussian"):
            raise self.fail("sensor.noise_kind", f"must be 'uniform' or 'gaussian', got {kind!r}")
        out["noise_kind"] = kind
        out["noise_t_corr"] = self.number(d, "noise_t_corr", "sensor.noise_t_corr", default=0.0)
        if out["noise_t_corr"] < 0:
            raise self.fail("sensor.noise_t_corr", "must be >= 0")
        try:  # the noise block's own checks, here at the line, not in a run
            Noise(out["noise"], kind=kind, t_corr=out["noise_t_corr"], ts=1.0)
        except ParameterError as exc:
            field = {"level": "noise", "kind": "noise_kind"}.get(exc.field, "noise_t_corr")
            raise self.fail(f"sensor.{field}", exc.message) from None
        return out

    def actuator(self, d: dict[str, Any]) -> dict[str, Any]:
        self.check_keys(d, {"u_min", "u_max", "rate"}, "actuator")
        out = {
            "u_min": self.number(d, "u_min", "actuator.u_min", default=-math.inf, limit=True),
            "u_max": self.number(d, "u_max", "actuator.u_max", default=math.inf, limit=True),
            "rate": self.number(d, "rate", "actuator.rate", default=math.inf, limit=True),
        }
        self.limit_pair(out, "u_min", "u_max", "actuator")
        if not out["rate"] > 0:
            raise self.fail("actuator.rate", f"must be > 0, got {out['rate']!r}")
        return out

    def initial(self, d: dict[str, Any]) -> dict[str, Any]:
        self.check_keys(d, {"u", "y", "sp", "load", "mode", "warmup", "wild"}, "initial")
        if "u" in d and "y" in d:
            raise self.fail("initial.y", "give either initial.u or initial.y, not both")
        out = {
            "u": self.number(d, "u", "initial.u", default=0.0),
            "y": self.number(d, "y", "initial.y", default=math.nan),
            "sp": self.number(d, "sp", "initial.sp", default=math.nan),
            "load": self.number(d, "load", "initial.load", default=0.0),
            "warmup": self.number(d, "warmup", "initial.warmup", default=0.0),
            "mode": self.string(d, "mode", "initial.mode", default="auto"),
            "wild": self.number(d, "wild", "initial.wild", default=0.0),
        }
        if out["mode"] not in ("auto", "manual"):
            raise self.fail("initial.mode", f"must be 'auto' or 'manual', got {out['mode']!r}")
        if out["warmup"] < 0:
            raise self.fail("initial.warmup", "must be >= 0")
        return out

    def samples(self, seconds: float, ts: float, key: str) -> None:
        """Refuse a time span of more than :data:`MAX_SAMPLES` samples of ``ts`` (or infinite).

        A finite but absurd duration or warm-up (``1e308`` s, or ``ts = 1e-320``)
        would otherwise reach the simulator as an overflow or an allocation of
        many gigabytes.
        """
        n = seconds / ts
        if not n <= MAX_SAMPLES:
            raise self.fail(
                key,
                f"{seconds!r} s is more than {MAX_SAMPLES:,} samples of scenario.ts = {ts!r} s",
            )

    # -- blocks and plants -------------------------------------------------------

    def controllers(
        self,
        doc: dict[str, Any],
        structure: str,
        ts: float,
        plant_spec: BlockSpec | None = None,
        initial: Mapping[str, Any] | None = None,
    ) -> list[ControllerSpec]:
        entries = doc.get("controllers")
        if entries is None:
            raise self.fail("controllers", "missing: give at least one [[controllers]] entry")
        if not isinstance(entries, list) or not entries:
            raise self.fail("controllers", "must be a non-empty array of tables ([[controllers]])")
        tune = None
        if plant_spec is not None:  # a bump test on the scenario's plant
            tune = functools.partial(self.tune, plant_spec=plant_spec, initial=initial)
        out: list[ControllerSpec] = []
        names: set[str] = set()
        for i, e in enumerate(entries):
            key = f"controllers[{i}]"
            self.as_table(e, key)
            name = self.string(e, "name", f"{key}.name")
            if name in names:
                raise self.fail(f"{key}.name", f"duplicate controller name {name!r}")
            names.add(name)
            out.append(self.controller(e, key, structure, ts, tune))
        return out

    def controller(
        self,
        e: dict[str, Any],
        key: str,
        structure: str,
        ts: float,
        tune: TuneHook | None = None,
    ) -> ControllerSpec:
        """One controller entry (its blocks for ``structure``); errors name ``key``."""
        return read_controller(self, e, key, structure, ts, tune)

    def tune(
        self,
        d: Any,
        key: str,
        block_type: str,
        ts: float,
        plant_spec: BlockSpec,
        initial: Mapping[str, Any] | None,
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Tune from a simulated bump test on the scenario's plant (``[controllers.tune]``).

        The keys are checked here; the bump test (the plant without actuator
        and sensor, stepped by ``du`` from the initial MV), the FOPDT fit, the
        rule (``migo``: the PID design of ``ctrlblocks compare``; ``amigo``,
        ``simc``, ``zn``, ``lambda``; or ``adrc``: Nowak et al. 2018's inverse
        half-rule and bandwidths with ``settling_time``, without it the ADRC
        design of ``ctrlblocks compare``, both designs to ``ms`` on the FOPDT or
        SOPDT fit with the smaller BIC) and the margins of the tuned parameters on the fit
        are :func:`ctrlblocks.tuning.bump.tune_from_bump_test` (the
        report recomputes them for the whole block table).  The parameters
        found replace those of the block table.

        With ``file = "bump.csv"`` the recorded bump test of the real process
        is fitted instead (path relative to the scenario file; the keys
        ``time``, ``u``, ``y``, ``u_before`` and the reading options
        ``delimiter``, ``decimal``, ``encoding``, ``tz``, ``time_format``,
        ``bad_rows``, ``gaps``, ``start``, ``end`` are those of ``ctrlblocks
        identify``, read by
        :func:`ctrlblocks.tuning.identify.read_step_csv`); ``du`` is then the
        record's.
        """
        from ..tuning.bump import PID_RULES, tune_from_bump_test

        self.as_table(d, key)
        allowed = {"rule", "du", "duration", "controller", "order", "settling_time", "ms"}
        self.check_keys(d, allowed | set(_CSV_KEYS), key)
        rule = self.string(d, "rule", f"{key}.rule")
        if block_type == "ADRC":
            if rule != "adrc":
                raise self.fail(f"{key}.rule", f"for an ADRC must be 'adrc', got {rule!r}")
        elif rule not in PID_RULES:
            raise self.fail(f"{key}.rule", f"must be one of {', '.join(PID_RULES)}; got {rule!r}")
        record = self._tune_record(d, key) if "file" in d else None
        du = 0.0 if record is not None else self.number(d, "du", f"{key}.du")
        if du == 0.0 and record is None:
            raise self.fail(f"{key}.du", "must be non-zero (the size of the bump)")
        duration = self.number(d, "duration", f"{key}.duration", default=None, positive=True)
        order = d.get("order", 2)
        if order not in (1, 2, 3) or isinstance(order, bool):
            raise self.fail(f"{key}.order", f"must be 1, 2 or 3, got {order!r}")
        st = self.number(d, "settling_time", f"{key}.settling_time", default=None, positive=True)
        ms = self.number(d, "ms", f"{key}.ms", default=None, positive=True)
        ctrl = self.string(d, "controller", f"{key}.controller", default="pid")
        if ctrl not in ("pi", "pid"):
            raise self.fail(f"{key}.controller", f"must be 'pi' or 'pid', got {ctrl!r}")
        plant = self.build(plant_spec, ts, kind="plant")
        ini = dict(initial or {})
        u0 = float(ini.get("u", 0.0))
        y0 = ini.get("y", math.nan)
        if y0 is not None and not math.isnan(y0):
            u_y = steady_input([plant], y0)  # None: initial.y is refused after the controllers
            if u_y is not None:
                u0 = u_y
        try:
            return tune_from_bump_test(
                plant, block_type, rule, du, ts=ts, u0=u0, duration=duration, controller=ctrl,
                order=order, settling_time=st, ms=ms, record=record,
            )  # fmt: skip
        except ValueError as exc:  # ParameterError, or a record the fit cannot use
            raise self.fail(key, f"tuning failed: {exc}") from None

    def _tune_record(self, d: Mapping[str, Any], key: str) -> tuple[Any, Any, Any]:
        """The recorded bump test ``file`` of a ``[controllers.tune]`` table: ``(t, u, y)``."""
        from ..tuning.identify import DataFileError, read_step_csv

        strings = {}
        for name in _CSV_KEYS:
            if name in d and name not in ("u_before", "start", "end"):
                strings[name] = self.string(d, name, f"{key}.{name}")
        for name in ("start", "end"):  # a stamp, or a number as in the time column
            if name in d and not isinstance(d[name], str):
                strings[name] = self.number(d, name, f"{key}.{name}")
            elif name in d:
                strings[name] = self.string(d, name, f"{key}.{name}")
        u_before = self.number(d, "u_before", f"{key}.u_before", default=None)
        path = Path(strings.pop("file"))
        if not path.is_absolute() and not self.file.startswith("<"):
            path = Path(self.file).parent / path
        try:
            data = read_step_csv(
                path, strings.pop("time", "t"), strings.pop("u", "u"), strings.pop("y", "y"),
                u_before=u_before, **strings,
            )  # fmt: skip
        except (DataFileError, OSError) as exc:
            raise self.fail(f"{key}.file", str(exc)) from None
        except ValueError as exc:  # a reading option out of its range (tz, gaps, ...)
            raise self.fail(key, str(exc)) from None
        return data.t, data.u, data.y

    # -- time line ---------------------------------------------------------------

    def cases(self, doc: dict[str, Any], duration: float, ts: float) -> list[Case]:
        common = self.events(doc.get("events", []), "events", duration)
        raw = doc.get("cases")
        if raw is None:  # a case's time line is sorted by time (stable: file order at equal t)
            return [Case("main", duration, tuple(sorted(common, key=lambda e: e.t)))]
        if not isinstance(raw, list) or not raw:
            raise self.fail("cases", "must be a non-empty array of tables ([[cases]])")
        out = []
        names = set()
        for i, c in enumerate(raw):
            key = f"cases[{i}]"
            self.as_table(c, key)
            self.check_keys(c, {"name", "duration", "events"}, key)
            name = self.string(c, "name", f"{key}.name")
            if name in names:
                raise self.fail(f"{key}.name", f"duplicate case name {name!r}")
            names.add(name)
            dur = self.number(c, "duration", f"{key}.duration", default=duration, positive=True)
            if dur < ts:
                raise self.fail(f"{key}.duration", f"must be at least one sample (ts {ts!r} s), "
                                f"got {dur!r}")  # fmt: skip
            ev = self.events(c.get("events", []), f"{key}.events", dur)
            out.append(Case(name, dur, tuple(sorted([*common, *ev], key=lambda e: e.t))))
        return out

    def events(self, raw: Any, key: str, duration: float) -> list[Event]:
        if not isinstance(raw, list):
            raise self.fail(key, f"must be an array of tables ([[{key}]]), got {type_name(raw)}")
        out = []
        for i, e in enumerate(raw):
            ekey = f"{key}[{i}]"
            self.as_table(e, ekey)
            t = self.number(e, "t", f"{ekey}.t")
            if not (0.0 <= t <= duration):
                raise self.fail(
                    f"{ekey}.t", f"must lie in 0..{duration:g} s (the duration), got {t!r}"
                )
            kind = self.string(e, "do", f"{ekey}.do")
            if kind not in EVENT_KINDS:
                raise self.fail(
                    f"{ekey}.do",
                    f"unknown event {kind!r}; expected one of: {', '.join(EVENT_KINDS)}",
                )
            spec = EVENT_KINDS[kind]
            self.check_keys(e, {"t", "do", "label", *spec}, ekey)
            fields: dict[str, Any] = {}
            for f in _REQUIRED_EVENT_FIELDS[kind]:
                if f not in e:
                    raise self.fail(f"{ekey}.{f}", f"missing (required for a {kind!r} event)")
            for f, types in spec.items():
                if f not in e:
                    continue
                v = e[f]
                ok = any(
                    (tp is float and not isinstance(v, bool) and isinstance(v, (int, float)))
                    or (tp is not float and isinstance(v, tp))
                    for tp in types
                )
                if not ok:
                    want = " or ".join("number" if tp is float else tp.__name__ for tp in types)
                    raise self.fail(f"{ekey}.{f}", f"must be a {want}, got {type_name(v)} {v!r}")
                fields[f] = float(v) if isinstance(v, int) and not isinstance(v, bool) else v
            if kind == "load" and fields.get("at", "input") not in _LOAD_POINTS:
                raise self.fail(f"{ekey}.at", f"must be one of {', '.join(_LOAD_POINTS)}")
            if kind == "mode" and fields["mode"] not in ("auto", "manual"):
                raise self.fail(
                    f"{ekey}.mode", f"must be 'auto' or 'manual', got {fields['mode']!r}"
                )
            if kind == "sensor":
                self.sensor_target(fields.get("target", "y"), f"{ekey}.target")
            if kind == "setpoint" and "ramp" in fields and fields["ramp"] <= 0:
                raise self.fail(f"{ekey}.ramp", "must be > 0 (a rate in units per second)")
            label = self.string(e, "label", f"{ekey}.label", default=_default_label(kind, fields))
            out.append(Event(t, kind, fields, label, ekey))
        return out

    def controller_events(
        self, structure: str, ts: float, controllers: list[ControllerSpec], cases: list[Case]
    ) -> None:
        """Refuse a controller-side event that the run could not apply.

        ``set``, ``mode``, ``manual_value`` and ``limits`` act on the blocks of
        every controller entry (the simulator's ``_apply``); each case's events
        are played, in time order, on blocks built for the check: a target that
        is not one of the entry's blocks, ``limits`` on a block without output
        limits, a mode on a block without a manual mode, a ``set`` of a name
        the block does not have or of a value its ``configure`` refuses -- each
        is refused here, at the event's line, instead of stopping the run (or,
        for a misspelt attribute, doing nothing at all).
        """
        if not any(e.kind in _SIDE_EVENTS for c in cases for e in c.events):
            return
        from ..loops.structures import ControllerSide

        for spec in controllers:
            for case in cases:
                side = ControllerSide(structure, spec, ts, file=self.file, error=ScenarioError)
                for ev in case.events:
                    if ev.kind in _SIDE_EVENTS:
                        self.controller_event(side, spec.name, ev)

    def controller_event(self, side: Any, controller: str, ev: Event) -> None:
        """:meth:`controller_events` for one event on one controller entry's ``side``."""
        f, kind = ev.fields, ev.kind
        name = f.get("target")
        if name in ("plant", "inner_plant"):
            if kind != "set":
                raise self.fail(f"{ev.key}.target", f"a {kind!r} event acts on a block, not {name}")
            return  # a plant attribute (plant events change plant parameters)
        try:
            blocks = side.event_blocks(kind, name)  # as the run resolves it (loop._targets)
        except KeyError:
            raise self.fail(
                f"{ev.key}.target",
                f"controller {controller!r} has no block {name!r}; "
                f"expected one of: {', '.join(side.blocks)}",
            ) from None
        for b in blocks:
            what = f"{type(b).__name__} of controller {controller!r}"
            if kind == "limits" and not hasattr(b, "set_limits"):
                raise self.fail(f"{ev.key}.target", f"the {what} has no output limits")
            if kind in ("mode", "manual_value") and not hasattr(b, "manual"):
                raise self.fail(f"{ev.key}.target", f"the {what} has no manual mode")
            if kind == "limits":
                b.set_limits(f["u_min"], f["u_max"])  # a refused pair is the block's status
            elif kind == "set":
                self.set_event(b, what, ev)

    def set_event(self, block: Any, what: str, ev: Event) -> None:
        """Apply a ``set`` event to ``block`` as the run will, refusing what would fail there."""
        attr, value = ev.fields["attr"], ev.fields["value"]
        cfg = getattr(block, "config", None)
        if dataclasses.is_dataclass(cfg) and attr in {f.name for f in dataclasses.fields(cfg)}:
            try:
                block.configure(**{attr: value})
            except (ValueError, TypeError) as exc:  # ParameterError is a ValueError
                raise self.fail(f"{ev.key}.value", f"the {what} refuses it: {exc}") from None
        elif attr.startswith("_") or not hasattr(block, attr):
            raise self.fail(f"{ev.key}.attr", f"the {what} has no parameter or input {attr!r}")

    # -- claims -------------------------------------------------------------------

    def quotes(
        self,
        head: dict[str, Any],
        claims: list[Claim],
        controllers: list[ControllerSpec],
        cases: list[Case],
    ) -> None:
        """Every quote of a run's number in the texts names a metric, case, controller and
        window that exist (:mod:`ctrlblocks.sim.quotes`)."""
        from .metrics import windows_from_events
        from .quotes import check_quotes

        count = {
            c.name: len(windows_from_events([(e.t, e.label) for e in c.events], c.duration))
            for c in cases
        }
        names = [c.name for c in controllers]
        texts = [(f"scenario.{k}", head.get(k, "")) for k in ("description", "notes")]
        texts += [(f"claims[{i}].text", c.text) for i, c in enumerate(claims)]
        for key, text in texts:
            problem = check_quotes(str(text), names, list(count), count.get)
            if problem:
                raise self.fail(key, problem)

    def claims(
        self, doc: dict[str, Any], controllers: list[ControllerSpec], cases: list[Case]
    ) -> list[Claim]:
        from .metrics import METRIC_NAMES

        raw = doc.get("claims", [])
        if not isinstance(raw, list):
            raise self.fail("claims", "must be an array of tables ([[claims]])")
        names = {c.name for c in controllers}
        case_names = {c.name for c in cases}
        out = []
        for i, c in enumerate(raw):
            key = f"claims[{i}]"
            self.as_table(c, key)
            self.check_keys(
                c,
                {
                    "text",
                    "metric",
                    "signal",
                    "case",
                    "window",
                    "source",
                    "controller",
                    "tol",
                    *_CLAIM_KINDS,
                    "factor",
                },
                key,
            )
            text = self.string(c, "text", f"{key}.text")
            metric = self.string(c, "metric", f"{key}.metric")
            signal = c.get("signal")
            if signal is not None:
                if not isinstance(signal, str):
                    raise self.fail(f"{key}.signal", "must be a signal name such as 'y2'")
                if metric not in SIGNAL_STATS:
                    raise self.fail(
                        f"{key}.metric",
                        f"with a signal, must be one of {', '.join(SIGNAL_STATS)}; got {metric!r}",
                    )
            elif metric not in METRIC_NAMES:
                raise self.fail(
                    f"{key}.metric",
                    f"unknown metric {metric!r}; expected one of: {', '.join(METRIC_NAMES)}",
                )
            kinds = [k for k in _CLAIM_KINDS if k in c]
            if len(kinds) != 1:
                raise self.fail(key, f"give exactly one of {', '.join(_CLAIM_KINDS)}")
            kind = kinds[0]
            args: dict[str, Any] = {"value": c[kind]}
            refs: list[str] = []
            if kind == "less":
                v = c[kind]
                if not (isinstance(v, list) and len(v) == 2 and all(isinstance(s, str) for s in v)):
                    raise self.fail(f"{key}.less", "must be [controller_a, controller_b]")
                refs = list(v)
                args["factor"] = self.number(
                    c, "factor", f"{key}.factor", default=1.0, positive=True
                )
            elif kind == "best":
                refs = [self.string(c, "best", f"{key}.best")]
            else:
                refs = [self.string(c, "controller", f"{key}.controller")]
                if kind == "between":
                    v = c[kind]
                    if not (
                        isinstance(v, list)
                        and len(v) == 2
                        and all(
                            isinstance(x, (int, float)) and not isinstance(x, bool) and x == x
                            for x in v
                        )
                    ):
                        raise self.fail(f"{key}.between", "must be [low, high] (numbers)")
                else:
                    self.number(c, kind, f"{key}.{kind}")
                if kind == "approx":
                    args["tol"] = self.number(c, "tol", f"{key}.tol", positive=True)
            for r in refs:
                if r not in names:
                    raise self.fail(key, f"names controller {r!r}, which is not in [[controllers]]")
            case = self.string(c, "case", f"{key}.case", default=None)
            if case is not None and case not in case_names:
                raise self.fail(f"{key}.case", f"unknown case {case!r}")
            if case is None and len(cases) > 1:
                raise self.fail(f"{key}.case", "missing: the scenario has several cases")
            window = c.get("window")
            if window is not None and (isinstance(window, bool) or not isinstance(window, int)):
                raise self.fail(f"{key}.window", "must be an event-window index (integer)")
            out.append(
                Claim(
                    text=text,
                    metric=metric,
                    kind=kind,
                    args=args | {"refs": refs, "signal": signal},
                    case=case if case is not None else cases[0].name,
                    window=window,
                    source=self.string(c, "source", f"{key}.source", default=""),
                )
            )
        return out


def _default_label(kind: str, f: Mapping[str, Any]) -> str:
    if kind == "setpoint":
        return f"SP -> {f['value']:g}" + (f" (ramp {f['ramp']:g}/s)" if "ramp" in f else "")
    if kind == "load":
        return f"load {f.get('at', 'input')} = {f['value']:g}"
    if kind == "mode":
        return f["mode"].upper()
    if kind == "manual_value":
        return f"manual value {f['value']:g}"
    if kind == "limits":
        return f"limits {f['u_min']:g}..{f['u_max']:g}"
    if kind == "plant":
        return f"{f['param']} = {f['value']}"
    if kind == "wild":
        parts = []
        if "value" in f:
            ramp = f" (ramp {f['ramp']:g}/s)" if "ramp" in f else ""
            parts.append(f"wild -> {f['value']:g}{ramp}")
        if f.get("nan"):
            parts.append("wild NaN")
        elif "ok" in f:
            parts.append("wild ok" if f["ok"] else "wild fault")
        return ", ".join(parts) or "wild"
    if kind == "sensor":
        what = "y2 sensor" if f.get("target", "y") == "y2" else "sensor"
        if f.get("nan"):
            return f"{what} NaN"
        return f"{what} ok" if f.get("ok", True) else f"{what} fault"
    return f"{f.get('attr')} = {f.get('value')}"
