"""The command-line options that read a CSV record, shared by every command that reads one.

``ctrlblocks identify``, ``compare`` (and any command that reads a recorded
file) declare them with :func:`csv_options`; the command then receives one
argument ``csv`` -- the options given, as keyword arguments of
:func:`ctrlblocks.tuning.records.read_record` -- so a new reading option
reaches every command at once.  Click is imported here, not by the readers.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import click

from .records import BAD_ROWS, GAPS

__all__ = ["csv_options", "echo_notes"]

_OPTIONS = [
    click.option(
        "--delimiter",
        type=click.Choice([",", ";", "tab"]),
        default=None,
        help="Column delimiter (default: detected from the header).",
    ),
    click.option(
        "--decimal",
        type=click.Choice([".", ","]),
        default=None,
        help="Decimal mark (default: ',' when the delimiter is not ',' and the cells use commas).",
    ),
    click.option(
        "--encoding",
        default=None,
        help="Text encoding, e.g. cp1252 (default: UTF-8, else Windows-1252, with a note).",
    ),
    click.option(
        "--time-format",
        default=None,
        metavar="FORMAT",
        help="The time column's format: auto (default), seconds, iso, dd.mm.yyyy, mm/dd/yyyy, "
        "dd/mm/yyyy, dd-mon-yy, excel, epoch, epoch-ms, or a strptime pattern ('%d/%m/%Y %H:%M').",
    ),
    click.option(
        "--tz",
        default=None,
        metavar="ZONE",
        help="Time zone of stamps written without one (e.g. Europe/Berlin): read in UTC, so "
        "daylight-saving jumps vanish.",
    ),
    click.option(
        "--bad-rows",
        type=click.Choice(BAD_ROWS),
        default="refuse",
        show_default=True,
        help="Rows with a blank or non-number cell ('I/O Timeout'): refuse, skip them, or "
        "interpolate the cell (an MV holds its last value).",
    ),
    click.option(
        "--gaps",
        type=click.Choice(GAPS),
        default="refuse",
        show_default=True,
        help="A time step over 10 median sample times inside the bump test: refuse, keep "
        "(time passed: data lost), close (the clock jumped).",
    ),
    click.option(
        "--start",
        default=None,
        metavar="TIME",
        help="First time to read, as written in the time column (a stamp or a number).",
    ),
    click.option(
        "--end",
        default=None,
        metavar="TIME",
        help="Last time to read, as written in the time column.",
    ),
]

_NAMES = ("delimiter", "decimal", "encoding", "time_format", "tz", "bad_rows", "gaps", "start",
          "end")  # fmt: skip


def csv_options(
    f: Callable[..., Any] | None = None, *, without: tuple[str, ...] = ()
) -> Any:
    """Decorate a click command with the CSV reading options; it gets them as ``csv``.

    ``csv`` is a dict of the options given (None left out; ``--delimiter tab``
    as a tab), ready for ``read_step_csv(path, ..., **csv)``.  ``without`` names
    options the command declares itself (``assess`` has its own ``start``/``end``
    that also cut a historian file): ``@csv_options(without=("start", "end"))``.
    """
    if f is None:
        return functools.partial(csv_options, without=without)
    unknown = set(without) - set(_NAMES)
    if unknown:
        raise ValueError(f"csv_options: unknown option(s) {sorted(unknown)}")
    names = [n for n in _NAMES if n not in without]

    @functools.wraps(f)
    def command(*args: Any, **kwargs: Any) -> Any:
        given = {name: kwargs.pop(name) for name in names}
        if given.get("delimiter") == "tab":
            given["delimiter"] = "\t"
        kwargs["csv"] = {k: v for k, v in given.items() if v is not None}
        return f(*args, **kwargs)

    for name, opt in reversed(list(zip(_NAMES, _OPTIONS, strict=True))):
        if name in names:
            command = opt(command)
    return command


def echo_notes(file: str, notes: Any) -> None:
    """Print what the reader did to the data (``note: FILE: ...``) on stderr."""
    for note in notes:
        click.echo(f"note: {file}: {note}", err=True)
