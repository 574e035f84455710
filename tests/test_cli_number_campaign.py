"""Every number option of every command, given hostile values: an error line, never a traceback.

The contract (README): the CLI never shows a traceback for a user mistake, and
no option can make it exhaust the machine; and what it prints has no number
written with all of its float digits (``tests/text_checks.py``).  For each command with number
options (found by walking the command tree, so a new option is covered the day
it is added), each option is given ``nan``, ``inf``, ``-inf``, ``0``, ``-1``,
``1e308``, ``1e-320`` and ``abc`` in an otherwise valid command line.  The
command may run or refuse (exit status 1 or 2 with an ``Error:`` line); it may
not raise anything else.

Found by this campaign before the fixes of the same commit: ``tune adrc
--observer-ratio 1e-320`` (OverflowError), ``compare --u-before 1e308``
(ZeroDivisionError in the SIMC rule), ``sweep --duration nan`` / ``-1``
(ValueError), ``sweep --workers -1`` (ValueError) -- and ``sweep --workers
100000``, which forked a process per worker for a single parameter set.
"""

from __future__ import annotations

from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from ctrlblocks.cli import main

from .text_checks import long_floats

ROOT = Path(__file__).resolve().parents[1]
CSV = str(ROOT / "docs" / "examples" / "bump_k2.csv")
HOSTILE = ("nan", "inf", "-inf", "0", "-1", "1e308", "1e-320", "abc")

# a valid command line of each command that has number options
BASE: dict[tuple[str, ...], list[str]] = {
    ("tune", "pid"): ["--rule", "amigo", "--gain", "1", "--time-constant", "5",
                      "--dead-time", "1"],
    ("tune", "adrc"): ["--order", "2", "--gain", "1", "--time-constant", "5", "--dead-time", "1"],
    ("identify",): [CSV, "--time", "time_s", "--u", "p_supply_bar", "--y", "p3_bar"],
    ("compare",): [CSV, "--time", "time_s", "--u", "p_supply_bar", "--y", "p3_bar",
                   "--no-corners", "--out", "{tmp}/compare"],
    ("sweep",): ["nowak_fig7", "--vary", "controllers[2].kp=5", "--duration", "2", "--serial",
                 "--out", "{tmp}/sweep.csv"],
    ("assess",): [CSV, "--time", "time_s", "--sp", "p3_bar", "--y", "p3_bar", "--u",
                  "p_supply_bar", "--no-plots", "--out", "{tmp}/assess"],
    ("compile",): ["--status"],  # no hostile --jobs is a valid count: nothing is built
}  # fmt: skip
# further valid command lines of a command whose paths differ by a choice: tune pid's
# default is the designed PID (design_pid), not the rule above -- a gain of 1e308
# once raised ZeroDivisionError there, unseen while only the rule was driven
VARIANTS: dict[tuple[str, ...], list[list[str]]] = {
    ("tune", "pid"): [["--gain", "1", "--time-constant", "5", "--dead-time", "1"]],
}
# commands that start a server or act on a running one: their start-up numbers are
# checked by tests/runtime/test_cli_user_errors.py (busy ports, both ports 0, ...)
SERVERS = {("serve",), ("plant-server",), ("tune-live",)}
# options whose hostile values are slow to run and add nothing (a Monte-Carlo count is
# an IntRange; a seed is any integer)
SKIP = {("compare", "--monte-carlo"), ("compare", "--seed"), ("reproduce", "-j")}


def _number_options() -> list[tuple[tuple[str, ...], str]]:
    ctx = click.Context(main)
    out = []

    def walk(cmd: click.Command, path: tuple[str, ...]) -> None:
        if isinstance(cmd, click.Group):
            for name in cmd.list_commands(ctx):
                sub = cmd.get_command(ctx, name)
                assert sub is not None
                walk(sub, (*path, name))
            return
        for p in cmd.params:
            numeric = isinstance(p.type, (click.types.FloatParamType, click.types.IntParamType))
            if isinstance(p, click.Option) and not p.is_flag and numeric:
                out.append((path, p.opts[-1]))

    walk(main, ())
    return out


OPTIONS = _number_options()


def test_every_command_with_number_options_is_in_the_campaign():
    commands = {path for path, _opt in OPTIONS}
    assert commands - SERVERS - {("reproduce",)} <= set(BASE), commands - set(BASE)
    assert ("tune", "adrc") in commands and ("sweep",) in commands


@pytest.mark.parametrize(
    ("path", "option"),
    [(p, o) for p, o in OPTIONS if p in BASE and (p[0], o) not in SKIP],
    ids=lambda x: " ".join(x) if isinstance(x, tuple) else x,
)
@pytest.mark.slow  # a campaign over every option (pytest -m slow)
def test_a_hostile_number_gives_an_error_line_not_a_traceback(tmp_path, path, option):
    for line in (BASE[path], *VARIANTS.get(path, [])):
        _campaign(tmp_path, path, option, [a.replace("{tmp}", str(tmp_path)) for a in line])


def _campaign(tmp_path, path, option, base):
    for value in HOSTILE:
        args = list(base)
        if option in args:
            args[args.index(option) + 1] = value
        else:
            args += [option, value]
        r = CliRunner().invoke(main, [*path, *args])
        if r.exception is not None and not isinstance(r.exception, SystemExit):
            raise AssertionError(f"{' '.join(path)} {option} {value}: {r.exception!r}")
        if r.exit_code != 0:
            assert r.exit_code in (1, 2) and "Error" in r.output, (option, value, r.output)
        # what the command printed: no number with all its float digits (55.349999999999994)
        assert long_floats(r.output, allowed=args) == [], (option, value, r.output)


def test_sweep_never_starts_more_processes_than_parameter_sets():
    from ctrlblocks.sim.sweep import process_pool

    with process_pool(100_000, 3) as pool:
        assert pool._max_workers == 3
    with process_pool(None, 1) as pool:
        assert pool._max_workers == 1


# the reading options of every command that reads a CSV record (tuning/csv_options.py): text
# a user might type, right or absurd; the command may run or refuse, in one line
READING_HOSTILE = ("", " ", "nan", "1e308", "-1", "abc", "%", "%Q%Q", "2024-13-45 25:61:61",
                   "Europe/Berlin", "UTC", "+99:99", "../../etc/passwd", "x" * 5000)  # fmt: skip


def _reading_options() -> list[tuple[tuple[str, ...], str]]:
    from ctrlblocks.tuning.csv_options import _NAMES

    names = {"--" + n.replace("_", "-") for n in _NAMES} - {"--delimiter", "--decimal"}
    ctx = click.Context(main)
    out = []
    for name in main.list_commands(ctx):
        cmd = main.get_command(ctx, name)
        for p in getattr(cmd, "params", []):
            if isinstance(p, click.Option) and p.opts[-1] in names and not isinstance(
                p.type, click.Choice
            ):
                out.append(((name,), p.opts[-1]))
    return out


def test_identify_and_compare_take_the_reading_options():
    found = {(path, opt) for path, opt in _reading_options()}
    for cmd in (("identify",), ("compare",)):
        for opt in ("--tz", "--time-format", "--start", "--end", "--encoding"):
            assert (cmd, opt) in found


@pytest.mark.parametrize(
    ("path", "option"), _reading_options(), ids=lambda x: " ".join(x) if isinstance(x, tuple) else x
)
@pytest.mark.slow  # a campaign over every reading option (pytest -m slow)
def test_a_hostile_reading_option_gives_an_error_line_not_a_traceback(tmp_path, path, option):
    base = [a.replace("{tmp}", str(tmp_path)) for a in BASE[path]]
    for value in READING_HOSTILE:
        r = CliRunner().invoke(main, [*path, *base, option, value])
        if r.exception is not None and not isinstance(r.exception, SystemExit):
            raise AssertionError(f"{' '.join(path)} {option} {value[:40]}: {r.exception!r}")
        if r.exit_code != 0:
            last = r.output.strip().splitlines()[-1]
            assert r.exit_code in (1, 2) and last.startswith("Error"), (option, value, r.output)
            assert len(last) < 2000, (option, len(last))  # a 5000-character value is not echoed
