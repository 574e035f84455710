"""A seeded mutation campaign over the files users write: scenarios and runtime configurations.

The contract (README, "Bad input"): a file that is refused names the file, the
line and the key path, and nothing else than the loader's own error
(:class:`ScenarioError`, :class:`RuntimeConfigError`) leaves the loader; a
scenario the loader accepts runs.  Each case takes a shipped scenario (or a
configuration of docs/runtime.md), changes one ``key = value`` line -- a hostile
value (a string, NaN, +-inf, 1e400, 1e308, 1e-320, the largest 64-bit integer,
an empty array or table, a date ...), the line deleted, or the key renamed --
and loads the text.

The campaign found, before the fixes of the same commit: a huge finite dead
time (``1e308``, ``2**63 - 1``) or a tiny ``ts`` (``1e-320``) raised
``OverflowError`` while the plant's history buffer was sized; an ``initial.y``
of ``1e308`` on the three-tank process raised ``OverflowError`` in its steady
state inverse; a claim's ``case = []`` raised ``TypeError``; ``u_min = nan`` and
``warmup = inf`` were accepted and failed only in the run.  Each has its own
test below.
"""

from __future__ import annotations

import random
import re
from pathlib import Path

import pytest

from ctrlblocks.sim.scenario import MAX_SAMPLES, ScenarioError, parse_scenario

from ..toml_text import toml_value as _toml

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = sorted((ROOT / "src" / "ctrlblocks" / "scenarios").glob("*.toml"))
HOSTILE = (
    '"text"', "-1", "0", "nan", "inf", "-inf", "1e400", "-1e308", "1e308", "1e-320", "true",
    "[]", '[1, "a"]', "{}", "{a = 1}", "9223372036854775807", "1979-05-27", '""', "0.0",
    "-0.0", "[[1]]", '"y2"', '"nope"',
)  # fmt: skip
KEY_LINE = re.compile(r"^(\s*)([A-Za-z0-9_.\"\-]+)(\s*=\s*)(.*)$")


def mutate(text: str, rng: random.Random) -> tuple[str, str]:
    """``text`` with one ``key = value`` line changed; and what was done (for the message)."""
    lines = text.splitlines()
    cand = [i for i, line in enumerate(lines) if KEY_LINE.match(line)]
    i = rng.choice(cand)
    m = KEY_LINE.match(lines[i])
    assert m is not None
    op = rng.random()
    if op < 0.7:
        lines[i] = m.group(1) + m.group(2) + m.group(3) + rng.choice(HOSTILE)
        what = f"line {i + 1} -> {lines[i].strip()}"
    elif op < 0.85:
        what = f"line {i + 1} deleted: {lines[i].strip()}"
        del lines[i]
    else:
        lines[i] = m.group(1) + m.group(2) + "_x" + m.group(3) + m.group(4)
        what = f"line {i + 1} renamed: {lines[i].strip()}"
    return "\n".join(lines) + "\n", what


def check_refusal(exc: ScenarioError | Exception, file: str, what: str) -> None:
    """A refusal names the file, and the line of a key path that is written in the file."""
    assert exc.file == file, what  # type: ignore[union-attr]
    if exc.key and not exc.problem.startswith("missing"):  # type: ignore[union-attr]
        assert exc.line is not None, f"{what}: {exc}"  # type: ignore[union-attr]


@pytest.mark.slow  # a mutation campaign (pytest -m slow)
@pytest.mark.parametrize("seed", [11, 12])
def test_a_mutated_scenario_is_loaded_or_refused_with_its_file_line_and_key(seed):
    rng = random.Random(seed)
    texts = {p.name: p.read_text(encoding="utf-8") for p in SCENARIOS}
    refused = 0
    for _ in range(600):
        name = rng.choice(sorted(texts))
        text, what = mutate(texts[name], rng)
        try:
            parse_scenario(text, file=name)
        except ScenarioError as exc:  # any other exception fails the test with its traceback
            refused += 1
            check_refusal(exc, name, f"{name}: {what}")
    assert refused > 300  # the campaign reaches the checks, not only harmless lines


@pytest.mark.slow  # a mutation campaign (pytest -m slow)
def test_accepted_mutated_scenarios_run():
    """Scenarios the loader accepts run (the Python path, a few seconds of each)."""
    from ctrlblocks.sim.runner import run_scenario

    rng = random.Random(13)
    texts = {p.name: p.read_text(encoding="utf-8") for p in SCENARIOS}
    ran = 0
    for _ in range(250):
        name = rng.choice(sorted(texts))
        text, what = mutate(texts[name], rng)
        try:
            sc = parse_scenario(text, file=name)
        except ScenarioError:
            continue
        try:
            run_scenario(sc, quick=True, duration=max(2.0, sc.ts), engine="python")
        except Exception as exc:
            pytest.fail(f"{name}: {what}: accepted, then the run raised {exc!r}")
        ran += 1
    assert ran > 25


def _runtime_configs() -> dict[str, str]:
    text = (ROOT / "docs" / "runtime.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```toml\n(.*?)```", text, re.S)
    assert len(blocks) >= 3
    return {f"runtime{i}.toml": b for i, b in enumerate(blocks)}


@pytest.mark.slow  # a mutation campaign (pytest -m slow)
def test_a_mutated_runtime_configuration_is_loaded_or_refused_with_its_file_line_and_key(
    monkeypatch,
):
    from ctrlblocks.runtime.config import RuntimeConfigError, parse_config

    monkeypatch.setenv("PLC_PASSWORD", "secret")  # the docs' OPC UA example reads it
    rng = random.Random(21)
    texts = _runtime_configs()
    refused = 0
    for _ in range(600):
        name = rng.choice(sorted(texts))
        text, what = mutate(texts[name], rng)
        try:
            parse_config(text, file=name)
        except RuntimeConfigError as exc:
            refused += 1
            check_refusal(exc, name, f"{name}: {what}")
    assert refused > 300


# ---------------------------------------------------------------------------
# the defects the campaign found, one by one
# ---------------------------------------------------------------------------


def _shipped(name: str) -> str:
    return (ROOT / "src" / "ctrlblocks" / "scenarios" / f"{name}.toml").read_text(encoding="utf-8")


def _refused(text: str, key: str) -> ScenarioError:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, file="s.toml")
    exc = info.value
    assert exc.key == key and exc.file == "s.toml" and exc.line is not None, str(exc)
    return exc


@pytest.mark.parametrize("value", ["1e308", "9223372036854775807"])
def test_a_dead_time_beyond_any_buffer_is_refused_at_its_line(value):
    text = _shipped("nowak_smith")
    assert "dead_time = " in text
    text = re.sub(r"(?m)^dead_time = .*$", f"dead_time = {value}", text, count=1)
    exc = _refused(text, "plant.dead_time")
    assert "samples" in exc.problem


def test_a_sample_time_that_makes_a_run_endless_is_refused():
    text = re.sub(r"(?m)^ts = .*$", "ts = 1e-320", _shipped("codesys_deadband"), count=1)
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, file="s.toml")
    assert info.value.line is not None and "samples" in str(info.value)


def test_a_duration_and_a_warmup_of_too_many_samples_are_refused():
    text = _shipped("nowak_fig7")  # ts = 0.1 s
    long = re.sub(r"(?m)^duration = .*$", f"duration = {MAX_SAMPLES * 0.1 * 2:.1f}", text, count=1)
    assert long != text
    assert "more than 10,000,000 samples" in _refused(long, "scenario.duration").problem
    warm = re.sub(r"(?m)^warmup = .*$", "warmup = inf", text, count=1)
    assert warm != text
    _refused(warm, "initial.warmup")


def test_an_initial_measurement_without_a_steady_input_is_refused_not_an_overflow():
    text = _shipped("nowak_fig7")
    for y in ("1e308", "-1.0"):  # overflows; below the atmosphere: no supply pressure gives it
        bad = re.sub(r"(?m)^y = .*$", f"y = {y}", text, count=1)
        assert bad != text
        _refused(bad, "initial.y")


def test_a_nan_in_a_scenario_is_refused_where_it_is_written():
    text = _shipped("codesys_deadband")
    bad = re.sub(r"(?m)^u_min = .*$", "u_min = nan", text, count=1)
    assert bad != text
    exc = _refused(bad, _key_of(bad))
    assert exc.key.endswith("u_min") and "NaN" in exc.problem


def _key_of(text: str) -> str:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, file="s.toml")
    return info.value.key


@pytest.mark.parametrize("value", ["[]", "{}", "3"])
def test_a_claim_names_its_case_as_a_string(value):
    text = _shipped("nowak_fig7")
    bad = re.sub(r'(?m)^case = ".*"$', f"case = {value}", text, count=1)
    assert bad != text
    exc = _refused(bad, _key_of(bad))
    assert exc.key.endswith(".case") and "must be a string" in exc.problem


def test_a_huge_dead_time_leaves_a_plant_unchanged():
    from ctrlblocks.blocks import ParameterError
    from ctrlblocks.plants import FOPDT, MAX_DEAD_SAMPLES, DeadTime

    with pytest.raises(ParameterError):
        FOPDT(k=1.0, t=2.0, dead_time=1e308, ts=0.1)
    with pytest.raises(ParameterError):
        DeadTime(1e9, ts=1e-3)
    plant = FOPDT(k=1.0, t=2.0, dead_time=0.5, ts=0.1)
    FOPDT(k=1.0, t=2.0, dead_time=MAX_DEAD_SAMPLES * 0.1, ts=0.1)  # the longest accepted
    with pytest.raises(ParameterError):
        plant.set_parameter("dead_time", MAX_DEAD_SAMPLES * 0.1 * 1.01)
    assert plant.dead_time == 0.5 and plant.dead_samples == 5


def test_the_three_tank_inverse_is_nan_where_no_supply_pressure_gives_the_level():
    from ctrlblocks.plants import ThreeTank, steady_input

    tank = ThreeTank(ts=0.1)
    assert tank.u_for_y(1e308) != tank.u_for_y(1e308)  # NaN
    assert tank.u_for_y(-1.0) != tank.u_for_y(-1.0)
    assert steady_input([tank], -1.0) is None
    u = tank.u_for_y(1.5)
    assert 1.5 < u < 5.0  # an ordinary level still has its supply pressure


# ---------------------------------------------------------------------------
# controller-side events are checked when the file is read, not in the run
# ---------------------------------------------------------------------------

_PI_ON_PT1 = """
[scenario]
name = "ev"
title = "events on a PI"
ts = 0.1
duration = 10.0

[plant]
type = "PT1"
k = 1.0
t = 2.0

[[controllers]]
name = "PI"
type = "PID"
kp = 1.0
ti = 2.0
u_min = 0.0
u_max = 10.0

[[events]]
t = 1.0
do = "setpoint"
value = 1.0
"""


def _event(**fields: object) -> str:
    body = "".join(f"{k} = {_toml(v)}\n" for k, v in fields.items())
    return _PI_ON_PT1 + "\n[[events]]\n" + body


@pytest.mark.parametrize(
    ("fields", "key", "says"),
    [
        (dict(t=2.0, do="set", attr="kpp", value=2.0), "events[1].attr",
         "the PID of controller 'PI' has no parameter or input 'kpp'"),
        (dict(t=2.0, do="set", attr="_i", value=2.0), "events[1].attr", "no parameter or input"),
        (dict(t=2.0, do="set", attr="kp", value=-1.0), "events[1].value", "refuses it"),
        (dict(t=2.0, do="set", attr="u_min", value=20.0), "events[1].value", "refuses it"),
        (dict(t=2.0, do="limits", target="nope", u_min=0.0, u_max=1.0), "events[1].target",
         "controller 'PI' has no block 'nope'; expected one of: main"),
        (dict(t=2.0, do="mode", mode="manual", target="plant"), "events[1].target",
         "a 'mode' event acts on a block, not plant"),
    ],
)  # fmt: skip
def test_a_controller_event_the_run_could_not_apply_is_refused_at_its_line(fields, key, says):
    with pytest.raises(ScenarioError) as info:
        parse_scenario(_event(**fields), file="ev.toml")
    exc = info.value
    assert exc.key == key and exc.line is not None and says in exc.problem, str(exc)


def test_set_events_are_checked_in_their_order():
    """Raising u_min above the old u_max is fine after u_max was raised first (as in the run)."""
    from ctrlblocks.sim.runner import run_scenario

    text = _event(t=2.0, do="set", attr="u_max", value=30.0)
    text += '\n[[events]]\nt = 3.0\ndo = "set"\nattr = "u_min"\nvalue = 20.0\n'
    sc = parse_scenario(text, file="ev.toml")
    result = run_scenario(sc, engine="python")
    u = result.runs[0].signals["u"]
    assert min(u[int(3.0 / 0.1) + 1 :]) >= 20.0 - 1e-9  # the new limits act
    wrong_order = text.replace('t = 2.0\ndo = "set"', 't = 4.0\ndo = "set"')
    assert wrong_order != text
    with pytest.raises(ScenarioError, match="refuses it"):
        parse_scenario(wrong_order, file="ev.toml")


def test_a_valid_input_attribute_of_a_block_may_be_set():
    sc = parse_scenario(_event(t=2.0, do="set", attr="hold", value=True), file="ev.toml")
    assert sc.cases[0].events[-1].fields["attr"] == "hold"


_NUMBER_LINE = re.compile(r"^(\s*[A-Za-z0-9_]+\s*=\s*)([-+]?[0-9][0-9_.eE+-]*)\s*(#.*)?$")


@pytest.mark.slow  # every number of every shipped scenario, three values each (pytest -m slow)
@pytest.mark.parametrize("value", ["inf", "-inf", "1e308"])
def test_every_number_of_every_scenario_beyond_finite_is_refused_at_its_line_or_runs(value):
    """The campaign's ``noise = inf`` find, swept over its class: no field takes a value
    the run cannot (it raised in the sensor, past the parser that should have refused it)."""
    from ctrlblocks.sim.runner import run_scenario

    swept = 0
    for p in SCENARIOS:
        lines = p.read_text(encoding="utf-8").splitlines()
        for i, line in enumerate(lines):
            m = _NUMBER_LINE.match(line)
            if not m:
                continue
            text = "\n".join([*lines[:i], m.group(1) + value, *lines[i + 1 :]]) + "\n"
            what = f"{p.name}: line {i + 1} -> {m.group(1)}{value}"
            swept += 1
            try:
                sc = parse_scenario(text, file=p.name)
            except ScenarioError as exc:
                check_refusal(exc, p.name, what)
                continue
            try:
                run_scenario(sc, quick=True, duration=max(2.0, sc.ts), engine="python")
            except Exception as exc:
                pytest.fail(f"{what}: accepted, then the run raised {exc!r}")
    assert swept > 200


@pytest.mark.parametrize(
    ("name", "key", "value", "field"),
    [
        ("tuned_three_tank", "noise", "inf", "sensor.noise"),  # was: raised in the run
        ("codesys_bumpless", "noise", "1e308", "sensor.noise"),  # was: OverflowError in the run
        ("nowak_fig1", "y_max", "-inf", "sensor.y_max"),  # was: BAD_LIMITS in the run
        ("astrom_fig31_33", "ts", "1e308", "scenario.ts"),  # was: KeyError('t'), no sample
        ("nowak_fig7", "warmup", "-inf", "initial.warmup"),
    ],
)
def test_a_number_the_run_cannot_take_is_refused_at_its_line(name, key, value, field):
    text = _shipped(name)
    bad = re.sub(rf"(?m)^{key} = .*$", f"{key} = {value}", text, count=1)
    assert bad != text
    _refused(bad, field)


def test_a_run_shorter_than_one_sample_is_refused_by_name():
    from ctrlblocks.sim.runner import run_scenario

    sc = parse_scenario(_shipped("astrom_fig31_33"), file="s.toml")
    with pytest.raises(ValueError, match="no sample"):
        run_scenario(sc, duration=sc.ts / 2, engine="python")
