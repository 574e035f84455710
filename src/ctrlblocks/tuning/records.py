"""Process records from CSV files, as historians and spreadsheets export them.

:func:`read_record` reads a time column and any number of value columns from
a CSV file with a header row; :func:`read_step_csv` reads a bump test (time,
MV, PV) with it.  What real exports contain, and what the reader does:

* **Layout.** ``,`` ``;`` or tab delimiters (detected from the header; Excel's
  ``sep=;`` first line is honoured), decimal commas (``1,25``, detected when
  the delimiter is not a comma), a UTF-8 byte-order mark, Windows-1252 files
  (Excel on Western systems), CRLF line ends, lines of metadata before the
  header (the header is the first line that names the time column), ``#``
  comments, extra columns, units in the header (``pv [degC]``).
* **Time stamps** (:data:`TIME_FORMATS`): seconds (a header unit ``ms``,
  ``min``, ``h``, ``d`` converts), ISO 8601 with or without a zone
  (``2024-05-01T12:00:00.5``, ``2024-05-01 12:00:00.000``, ``...Z``,
  ``...+02:00``; PI Web API, AVEVA/Wonderware and Ignition write these),
  ``dd.mm.yyyy hh:mm:ss,fff`` (WinCC, German Excel), ``mm/dd/yyyy hh:mm:ss
  AM/PM`` (US Excel, PI DataLink, AVEVA Historian Client), ``dd-Mon-yy
  hh:mm:ss`` (PI), Excel serial days, Unix epoch seconds and milliseconds
  (Ignition's ``t_stamp``), and any ``strptime`` pattern (``time_format=``).
  The format is detected from the file; a stamp in no format names the
  accepted ones.
* **Local time.** Stamps without a zone are the wall clock of the place that
  wrote them.  With ``tz="Europe/Berlin"`` they are converted to UTC, so the
  daylight-saving jumps (one hour forward in spring, back in autumn, when the
  wall clock repeats an hour) vanish; without it such a jump is a gap or a
  backward step in time, which is refused where it would corrupt the record
  (below), with the ``tz`` hint.
* **Bad cells.** Historians write ``I/O Timeout``, ``Bad Input``, ``Comm
  Fail``, ``No Data``, blanks or ``NaN`` where a value is missing.  By
  default the first one is refused (file, line, column); ``bad_rows="skip"``
  drops such rows and ``"interpolate"`` fills the cells (linearly in time; a
  *held* column, such as an MV, keeps its last good value), saying how many
  and on which lines.  A row whose time cannot be read is dropped in both.
* **Time order and gaps.** Time must increase.  A duplicated stamp is
  refused (``bad_rows="skip"``/``"interpolate"`` drop the repeated rows); a
  step back in time always is.  A *gap* -- a time step more than
  :data:`GAP_FACTOR` times the median sample time -- inside the experiment
  (from the first move of ``step_column``, the MV, on) is refused unless
  ``gaps`` says what it is: ``"keep"`` (the time passed: data was lost or the
  historian stored nothing), ``"close"`` (the clock jumped: the samples after
  it are moved back to one median sample time after the one before).  A gap
  before the experiment starts is kept, with a note.
* **A window.** ``start``/``end`` cut a long export to the experiment (a
  value as written in the time column: a stamp, or a number in the column's
  unit); only the rows inside are checked.

Every problem raises one :class:`DataFileError` naming the file, the line and
the column; every change the reader made to the data is a note in the result.
"""

from __future__ import annotations

import csv
import datetime
import functools
import logging
import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "BAD_ROWS",
    "CSV_OPTIONS",
    "GAPS",
    "GAP_FACTOR",
    "MAX_MAGNITUDE",
    "MIN_SAMPLES",
    "TIME_FORMATS",
    "DataFileError",
    "Record",
    "StepData",
    "TimeFormat",
    "read_record",
    "read_step_csv",
    "split_unit",
]

_log = logging.getLogger(__name__)

MIN_SAMPLES = 10
"""Fewest samples a record must have."""

MAX_MAGNITUDE = 1e150
"""The largest magnitude of a recorded time, MV or PV value: the fits square deviations of
the data, and a square beyond the float range (~1.8e308) is no fit."""
BEYOND = "+-1e150 (ctrlblocks.tuning.identify.MAX_MAGNITUDE: the fits square the data)"

GAP_FACTOR = 10.0
"""A time step longer than this many median sample times is a gap."""

BAD_ROWS = ("refuse", "skip", "interpolate")
"""What ``bad_rows`` may be: refuse a bad cell, drop its row, or fill it."""

GAPS = ("refuse", "keep", "close")
"""What ``gaps`` may be (a gap inside the experiment): refuse, keep the time, close the hole."""

CSV_OPTIONS: dict[str, str] = {
    "delimiter": "',', ';' or a tab; default: detected from the header",
    "decimal": "'.' or ','; default: ',' when the delimiter is not a comma and the cells use it",
    "encoding": "the text encoding; default: UTF-8, else Windows-1252 with a note",
    "tz": "the time zone of stamps without one (IANA name, e.g. Europe/Berlin): "
    "converted to UTC, daylight-saving jumps handled",
    "time_format": "the time column's format (auto, seconds, iso, dd.mm.yyyy, mm/dd/yyyy, "
    "dd/mm/yyyy, dd-mon-yy, excel, epoch, epoch-ms, or a strptime pattern with %)",
    "bad_rows": "refuse | skip | interpolate: rows with a blank or non-number cell",
    "gaps": "refuse | keep | close: a time step > 10 median sample times inside the experiment",
    "start": "first time to read, as written in the time column (a stamp, or a number)",
    "end": "last time to read, as written in the time column",
}
"""The reading options shared by ``identify``, ``compare``, ``[controllers.tune]`` and the
Python functions (keyword arguments of :func:`read_record`), with a one-line help each."""


class DataFileError(ValueError):
    """A data file cannot be used; names the file, line and column.

    Attributes
    ----------
    path : str
        The file.
    line : int or None
        1-based line number in the file (the header is line 1 unless lines
        come before it), if the problem is on one line.
    column : str or None
        Column name, if the problem is in one column.
    reason : str
        What is wrong.
    """

    def __init__(self, path: str | Path, line: int | None, column: str | None, reason: str) -> None:
        self.path = str(path)
        self.line = line
        self.column = column
        self.reason = reason
        where = self.path
        if line is not None:
            where += f", line {line}"
        if column is not None:
            where += f", column '{column}'"
        super().__init__(f"{where}: {reason}")


# ---------------------------------------------------------------------------
# Results
# ---------------------------------------------------------------------------


@dataclass(frozen=True)
class Record:
    """Samples of a CSV file: time [s] and named columns.

    Attributes
    ----------
    t : ndarray
        Seconds from the first sample read (UTC-based when the stamps carry
        a zone or ``tz`` was given).
    values : dict of str to ndarray
        The numeric columns, by the name asked for.
    text : dict of str to tuple of str
        The text columns (``text_columns``), stripped.
    units : dict of str to str or None
        Units from the header (``pv [degC]``), by the name asked for (time too).
    lines : ndarray of int
        The file line of each sample.
    path, encoding, delimiter, decimal : str
        The file and how it was read.
    time_format : str
        The name of the time format read (:data:`TIME_FORMATS`).
    start : str
        The first sample's time as ISO 8601 ("" for a time column in seconds).
    notes : tuple of str
        What the reader did to the data, for the user (rows skipped or
        filled, gaps kept, a fallback encoding, the format guessed).
    """

    t: NDArray[np.float64]
    values: dict[str, NDArray[np.float64]]
    text: dict[str, tuple[str, ...]]
    units: dict[str, str | None]
    lines: NDArray[np.int64]
    path: str = ""
    encoding: str = "utf-8"
    delimiter: str = ","
    decimal: str = "."
    time_format: str = "seconds"
    start: str = ""
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class StepData:
    """A bump-test record: time [s], MV and PV as float arrays.

    ``u_unit``/``y_unit`` are the units from the header (``pv [degC]``) or
    None; ``encoding``, ``delimiter``, ``decimal`` and ``time_format`` say how
    the file was read; ``start`` is the first sample's time as ISO 8601 when
    the time column held stamps ("" otherwise; ``t`` then counts seconds from
    it); ``notes`` are remarks for the user (a fallback encoding, rows skipped
    or filled, an added sample for ``u_before``); ``lines`` the file line of
    each sample (0 for an added one).
    """

    t: NDArray[np.float64]
    u: NDArray[np.float64]
    y: NDArray[np.float64]
    path: str = ""
    u_unit: str | None = None
    y_unit: str | None = None
    encoding: str = "utf-8"
    delimiter: str = ","
    decimal: str = "."
    start: str = ""
    notes: tuple[str, ...] = ()
    time_format: str = "seconds"
    lines: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))


# ---------------------------------------------------------------------------
# Time formats
# ---------------------------------------------------------------------------

_EPOCH = datetime.datetime(1970, 1, 1)
_EPOCH_ORDINAL = _EPOCH.toordinal()
_EXCEL_EPOCH_DAYS = 25569.0  # 1970-01-01 as an Excel serial day (day 0 = 1899-12-30)
_MONTHS = {
    m: i + 1
    for i, m in enumerate(
        ("jan", "feb", "mar", "apr", "may", "jun", "jul", "aug", "sep", "oct", "nov", "dec")
    )
}

_CLOCK = r"(\d{1,2}):(\d{2})(?::(\d{2})(?:[.,](\d+))?)?"
_ISO_RE = re.compile(
    r"(\d{4})-(\d{2})-(\d{2})(?:[T ]" + _CLOCK + r")?\s*(Z|z|UTC|[+-]\d{2}(?::?\d{2})?)?"
)
_DOT_RE = re.compile(r"(\d{1,2})\.(\d{1,2})\.(\d{4})[ T]+" + _CLOCK)
_SLASH_RE = re.compile(r"(\d{1,2})/(\d{1,2})/(\d{4})[ T]+" + _CLOCK + r"(?:\s*([AaPp])\.?[Mm]\.?)?")
_PI_RE = re.compile(r"(\d{1,2})-([A-Za-z]{3})-(\d{2}|\d{4})[ T]+" + _CLOCK)

Stamp = tuple[float, int | None]
"""A parsed time: ``(seconds, utc_offset)`` -- seconds since 1970-01-01 of the wall clock
(``utc_offset`` None: no zone known) or of UTC (``utc_offset`` the stamp's offset in s)."""


def _wall(
    y: int, mo: int, d: int, h: str | None, mi: str | None, s: str | None, frac: str | None
) -> float | None:
    """Seconds since 1970-01-01 00:00 of a wall-clock date and time; None if it is no date."""
    hh, mm, ss = int(h or 0), int(mi or 0), int(s or 0)
    if hh > 23 or mm > 59 or ss > 59:
        return None
    days = _days(y, mo, d)
    if days is None:
        return None
    return days * 86400.0 + hh * 3600.0 + mm * 60.0 + ss + (float("0." + frac) if frac else 0.0)


@functools.lru_cache(maxsize=4096)
def _days(y: int, mo: int, d: int) -> int | None:
    """Days from 1970-01-01 to a date; None if it is no date."""
    try:
        return datetime.date(y, mo, d).toordinal() - _EPOCH_ORDINAL
    except ValueError:
        return None


def _offset(zone: str | None) -> int | None:
    """``Z`` -> 0, ``+02:00`` -> 7200 [s]; None for no zone."""
    if not zone:
        return None
    if zone in ("Z", "z", "UTC"):
        return 0
    sign = -1 if zone[0] == "-" else 1
    digits = zone[1:].replace(":", "")
    return sign * (int(digits[:2]) * 3600 + int(digits[2:4] or 0) * 60)


def _parse_iso(cell: str) -> Stamp | None:
    m = _ISO_RE.fullmatch(cell)
    if m is None:
        return None
    y, mo, d, h, mi, s, frac, zone = m.groups()
    wall = _wall(int(y), int(mo), int(d), h, mi, s, frac)
    if wall is None:
        return None
    off = _offset(zone)
    return (wall if off is None else wall - off), off


def _parse_dot(cell: str) -> Stamp | None:
    m = _DOT_RE.fullmatch(cell)
    if m is None:
        return None
    d, mo, y, h, mi, s, frac = m.groups()
    wall = _wall(int(y), int(mo), int(d), h, mi, s, frac)
    return None if wall is None else (wall, None)


def _slash(day_first: bool) -> Callable[[str], Stamp | None]:
    def parse(cell: str) -> Stamp | None:
        m = _SLASH_RE.fullmatch(cell)
        if m is None:
            return None
        a, b, y, h, mi, s, frac, ampm = m.groups()
        d, mo = (a, b) if day_first else (b, a)
        if ampm:
            hour = int(h)
            if not 1 <= hour <= 12:
                return None
            h = str(hour % 12 + (12 if ampm in "Pp" else 0))
        wall = _wall(int(y), int(mo), int(d), h, mi, s, frac)
        return None if wall is None else (wall, None)

    return parse


def _parse_pi(cell: str) -> Stamp | None:
    m = _PI_RE.fullmatch(cell)
    if m is None:
        return None
    d, mon, y, h, mi, s, frac = m.groups()
    month = _MONTHS.get(mon.lower())
    if month is None:
        return None
    year = int(y) + (2000 if len(y) == 2 and int(y) < 70 else 1900 if len(y) == 2 else 0)
    wall = _wall(year, month, int(d), h, mi, s, frac)
    return None if wall is None else (wall, None)


def _strptime(pattern: str) -> Callable[[str], Stamp | None]:
    def parse(cell: str) -> Stamp | None:
        try:
            dt = datetime.datetime.strptime(cell, pattern)
        except ValueError:
            return None
        off = dt.utcoffset()
        wall = (dt.replace(tzinfo=None) - _EPOCH).total_seconds()
        if off is None:
            return wall, None
        return wall - off.total_seconds(), int(off.total_seconds())

    return parse


@dataclass(frozen=True)
class TimeFormat:
    """One format of a time column.

    ``name`` is its ``time_format`` value, ``looks`` how it looks (for the
    error and the docs), ``numeric`` whether its cells are numbers (read
    with the file's decimal mark), ``scale`` the seconds per unit of a
    numeric cell, ``epoch`` the seconds to add after scaling (Excel's day 0),
    ``utc`` whether a numeric stamp is UTC (epoch) rather than a wall clock
    (Excel), ``absolute`` whether it names a date (not plain seconds), and
    ``parse`` the parser of a text stamp.
    """

    name: str
    looks: str
    numeric: bool = False
    scale: float = 1.0
    epoch: float = 0.0
    utc: bool = False
    absolute: bool = True
    parse: Callable[[str], Stamp | None] | None = None

    def read(self, cell: str, decimal: str) -> Stamp | None:
        """``(seconds, utc_offset)`` of one cell, or None if it is not in this format."""
        if self.parse is not None:
            return self.parse(cell)
        x = _number(cell, decimal)
        if x is None or not math.isfinite(x) or abs(x) > MAX_MAGNITUDE:
            return None
        return x * self.scale + self.epoch, (0 if self.utc else None)


TIME_FORMATS: dict[str, TimeFormat] = {
    f.name: f
    for f in (
        TimeFormat(
            "seconds",
            "seconds, e.g. 12.5 (a header unit converts: t [ms], [min], [h], [d])",
            numeric=True,
            absolute=False,
        ),
        TimeFormat(
            "iso",
            "ISO 8601: 2024-05-01T12:00:00.5, 2024-05-01 12:00:00.000, ...Z, ...+02:00",
            parse=_parse_iso,
        ),
        TimeFormat(
            "dd.mm.yyyy", "dd.mm.yyyy hh:mm:ss,fff, e.g. 01.05.2024 12:00:00,5", parse=_parse_dot
        ),
        TimeFormat(
            "mm/dd/yyyy",
            "mm/dd/yyyy hh:mm:ss AM/PM, e.g. 5/1/2024 12:00:00.5 PM",
            parse=_slash(day_first=False),
        ),
        TimeFormat(
            "dd/mm/yyyy",
            "dd/mm/yyyy hh:mm:ss, e.g. 01/05/2024 12:00:00",
            parse=_slash(day_first=True),
        ),
        TimeFormat(
            "dd-mon-yy", "dd-Mon-yy hh:mm:ss (PI), e.g. 01-May-24 12:00:00.5", parse=_parse_pi
        ),
        TimeFormat(
            "excel",
            "Excel serial days, e.g. 45413.5 (= 2024-05-01 12:00)",
            numeric=True,
            scale=86400.0,
            epoch=-_EXCEL_EPOCH_DAYS * 86400.0,
        ),
        TimeFormat("epoch", "Unix epoch seconds (UTC), e.g. 1714564800.5", numeric=True, utc=True),
        TimeFormat(
            "epoch-ms",
            "Unix epoch milliseconds (UTC), e.g. 1714564800500",
            numeric=True,
            scale=1e-3,
            utc=True,
        ),
    )
}
"""The accepted time formats by their ``time_format`` name (``auto`` detects them; a
``strptime`` pattern with ``%`` reads any other)."""

_DETECT = ("iso", "dd.mm.yyyy", "dd-mon-yy")
"""Text formats tried, in this order, on the first time cell (slash dates: mm/dd/yyyy or
dd/mm/yyyy from the values, :func:`_slash_order`)."""

_TIME_UNITS = {"s": 1.0, "sec": 1.0, "ms": 1e-3, "min": 60.0, "h": 3600.0, "d": 86400.0}


def accepted_formats() -> str:
    """The accepted formats in one sentence, for errors and help."""
    return "; ".join(f.looks for f in TIME_FORMATS.values()) + (
        "; any other with a strptime pattern (time_format / --time-format '%d/%m/%Y %H:%M')"
    )


def time_format(name: str) -> TimeFormat:
    """The :class:`TimeFormat` of a ``time_format`` value (a name, or a strptime pattern)."""
    if name in TIME_FORMATS:
        return TIME_FORMATS[name]
    if "%" in name:
        return TimeFormat(name, f"strptime pattern {name!r}", parse=_strptime(name))
    raise ValueError(
        f"time_format must be auto, {', '.join(TIME_FORMATS)} or a strptime pattern with %; "
        f"got {shown(name)}"
    )


def shown(value: Any, most: int = 60) -> str:
    """``repr(value)``, cut to about ``most`` characters: a user's value in a message."""
    text = repr(value)
    return text if len(text) <= most else text[: most - 5] + "...'" + f" ({len(text)} chars)"


def _number(cell: str, decimal: str) -> float | None:
    """A cell as a float (None if it is not a number); with ``decimal=","`` ``.`` groups digits."""
    s = cell.replace(".", "").replace(",", ".") if decimal == "," else cell
    try:
        return float(s)
    except ValueError:
        return None


# ---------------------------------------------------------------------------
# The file
# ---------------------------------------------------------------------------

_UNIT_RE = re.compile(r"^(?P<name>.*?)\s*[\[(](?P<unit>[^\[\]()]*)[\])]\s*$")
FALLBACK_ENCODING = "cp1252"
"""Encoding tried when a file is not UTF-8 (Windows-1252, what Excel writes on Western systems)."""


def split_unit(header_name: str) -> tuple[str, str | None]:
    """``"pv [degC]"`` -> ``("pv", "degC")``; ``"pv"`` -> ``("pv", None)``."""
    m = _UNIT_RE.match(header_name)
    if m is None or not m.group("name"):
        return header_name, None
    return m.group("name"), m.group("unit").strip() or None


def _decode(path: Path, encoding: str | None) -> tuple[str, str, tuple[str, ...]]:
    """``(text, encoding used, notes)``; UTF-8 (with or without BOM) first, else Windows-1252."""
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise DataFileError(
            path, None, None, f"cannot read the file ({exc.strerror or exc})"
        ) from None
    if encoding is not None:
        try:
            text = raw.decode(encoding)
        except LookupError:
            raise DataFileError(path, None, None, f"unknown encoding {shown(encoding)}") from None
        except UnicodeDecodeError as exc:
            line = raw[: exc.start].count(b"\n") + 1
            raise DataFileError(
                path, line, None, f"not valid {encoding} (byte {raw[exc.start]:#04x})"
            ) from None
        return text.removeprefix("\ufeff"), encoding, ()
    try:
        return raw.decode("utf-8-sig"), "utf-8", ()
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
    note = (
        f"not UTF-8 (first non-UTF-8 byte on line {line}): read as Windows-1252 "
        f"({FALLBACK_ENCODING}); give the encoding to choose another"
    )
    _log.info("%s: %s", path, note)
    return raw.decode(FALLBACK_ENCODING, errors="replace"), FALLBACK_ENCODING, (note,)


def _find_column(names: list[str], want: str) -> int | None:
    w = want.strip()
    idx = next((i for i, n in enumerate(names) if n == w), None)
    if idx is None:
        idx = next((i for i, n in enumerate(names) if split_unit(n)[0] == w), None)
    return idx


def _header(path: Path, lines: list[tuple[int, str]], time: str, delimiter: str | None):
    """``(index of the header in lines, its line number, delimiter, names)``.

    The header is the first line naming the time column (lines before it are
    an export's metadata); if no line does, the first line (whose error then
    lists its names).
    """
    if lines and (m := re.fullmatch(r"\s*sep=(.)\s*", lines[0][1])):  # Excel's delimiter hint
        delimiter = delimiter or m.group(1)
        lines = lines[1:]
        skip = 1
    else:
        skip = 0
    if not lines:
        raise DataFileError(path, None, None, "no header row with column names")
    for i, (no, text) in enumerate(lines[:50]):
        d = delimiter or max(",;\t", key=text.count)
        names = [c.strip() for c in next(csv.reader([text], delimiter=d))]
        if _find_column(names, time) is not None:
            return i + skip, no, d, names
    no, text = lines[0]
    d = delimiter or max(",;\t", key=text.count)
    return skip, no, d, [c.strip() for c in next(csv.reader([text], delimiter=d))]


@dataclass
class _Row:
    line: int
    cell: str  # the time cell as written
    stamp: Stamp | None
    values: list[float | None]
    bad: list[tuple[str, str]]  # (column, reason) of the bad cells of this row


def read_record(
    path: str | Path,
    time: str,
    columns: Sequence[str],
    *,
    text_columns: Sequence[str] = (),
    hold: Sequence[str] = (),
    step_column: str | None = None,
    delimiter: str | None = None,
    decimal: str | None = None,
    encoding: str | None = None,
    tz: str | datetime.tzinfo | None = None,
    time_format: str | None = None,
    bad_rows: str = "refuse",
    gaps: str = "refuse",
    start: str | float | datetime.datetime | None = None,
    end: str | float | datetime.datetime | None = None,
) -> Record:
    """Read a time column and value columns from a CSV file (module docstring).

    Parameters
    ----------
    path : str or Path
        The file.  Lines starting with ``#`` and blank lines are skipped;
        lines before the header row (the first naming ``time``) are an
        export's metadata and skipped; extra columns are ignored.
    time : str
        Name of the time column (a unit in its header converts a number:
        ``t [ms]``, ``[min]``, ``[h]``, ``[d]``).
    columns : sequence of str
        Names of the numeric columns.  A header cell may carry a unit, ``pv
        [degC]``: it is found as ``pv`` (or by its full text).
    text_columns : sequence of str
        Columns returned as text (e.g. a loop's mode, ``AUTO``/``MAN``).
    hold : sequence of str
        Numeric columns that hold their value between samples (an MV, a set
        point): ``bad_rows="interpolate"`` repeats their last good value
        instead of interpolating linearly.
    step_column : str, optional
        The column whose first change starts the experiment (the MV of a bump
        test): a gap before it is harmless.  Default: every gap counts.
    delimiter, decimal, encoding, tz, time_format, bad_rows, gaps, start, end
        See :data:`CSV_OPTIONS` and the module docstring.  ``tz`` is an IANA
        zone name (``zoneinfo``) or a ``tzinfo``; ``start``/``end`` a stamp
        or number as written in the time column, or a ``datetime``.

    Returns
    -------
    Record

    Raises
    ------
    DataFileError
        Unreadable file, no header, missing column, a bad cell (without
        ``bad_rows``), a time in no accepted format, time not increasing, a
        gap inside the experiment (without ``gaps``), fewer than
        ``MIN_SAMPLES`` rows left.  The message names file, line and column.
    ValueError
        An option out of its range (a bad ``delimiter``, unknown ``tz``, ...).
    """
    path = Path(path)
    opts = _check_options(delimiter, decimal, bad_rows, gaps)
    zone = _zone(tz)
    text, used_encoding, notes_in = _decode(path, encoding)
    notes = list(notes_in)
    lines = [
        (i + 1, ln)
        for i, ln in enumerate(text.splitlines())
        if ln.strip() and not ln.lstrip().startswith("#")
    ]
    if not lines:
        raise DataFileError(
            path, None, None, "the file is empty (a header row with column names is needed)"
        )
    h_index, header_no, delimiter, names = _header(path, lines, time, opts["delimiter"])
    if h_index > (1 if lines[0][1].lstrip().startswith("sep=") else 0):
        notes.append(f"lines {lines[0][0]}-{header_no - 1} before the header row skipped")
    idx: dict[str, int] = {}
    units: dict[str, str | None] = {}
    for want in (time, *columns, *text_columns):
        i = _find_column(names, want)
        if i is None:
            raise DataFileError(
                path, header_no, want, f"no such column; the header has: {', '.join(names)}"
            )
        idx[want], units[want] = i, split_unit(names[i])[1]
    body = lines[h_index + 1 :]
    cells = list(csv.reader((ln for _, ln in body), delimiter=delimiter))
    rows_raw = [(no, r) for (no, _), r in zip(body, cells, strict=True)]
    decimal = opts["decimal"] or _detect_decimal(rows_raw, idx.values(), delimiter)
    if decimal == "," and delimiter == ",":
        raise ValueError("a decimal comma needs another delimiter (';' or a tab)")
    fmt, fmt_notes = _choose_format(
        path, rows_raw, idx[time], time, units[time], time_format, decimal
    )
    notes += fmt_notes
    rows, texts = _parse_rows(
        path, rows_raw, idx, time, list(columns), list(text_columns), fmt, decimal
    )
    _check_zones(path, rows, time)
    rows = _window(path, rows, time, fmt, decimal, zone, start, end, notes)
    if zone is not None:
        notes += _to_utc(rows, zone, fmt, time)
    rows = _bad_rows(path, rows, time, opts["bad_rows"], notes)
    rows = _time_order(path, rows, time, fmt, zone, opts["bad_rows"], notes)
    if len(rows) < MIN_SAMPLES:
        raise DataFileError(
            path,
            rows[-1].line if rows else header_no,
            None,
            f"only {len(rows)} data row(s) left; at least {MIN_SAMPLES} are needed",
        )
    stamps = np.array([r.stamp[0] for r in rows if r.stamp is not None])
    vals = np.array([[np.nan if v is None else v for v in r.values] for r in rows], dtype=float)
    vals = vals.reshape(len(rows), len(columns))
    line_no = np.array([r.line for r in rows], dtype=np.int64)
    t = stamps - stamps[0]
    u_step = None if step_column is None else vals[:, list(columns).index(step_column)]
    t = _gaps(path, t, line_no, rows, time, u_step, opts["gaps"], fmt, zone, step_column, notes)
    if opts["bad_rows"] == "interpolate":
        last = int(line_no[-1])
        vals, t, line_no, kept = _fill(vals, t, line_no, list(columns), set(hold), notes)
        rows = [rows[i] for i in kept]
        if len(rows) < MIN_SAMPLES:
            raise DataFileError(
                path,
                last,
                None,
                f"only {len(rows)} data row(s) left after dropping the rows at the start and "
                f"the end whose bad cells cannot be filled; at least {MIN_SAMPLES} are needed",
            )
    text_out = {k: tuple(by_line[no] for no in line_no.tolist()) for k, by_line in texts.items()}
    for n in notes:
        _log.info("%s: %s", path, n)
    return Record(
        t=t,
        values={c: vals[:, j].copy() for j, c in enumerate(columns)},
        text=text_out,
        units=units,
        lines=line_no,
        path=str(path),
        encoding=used_encoding,
        delimiter=delimiter,
        decimal=decimal,
        time_format=fmt.name,
        start=_iso(rows[0].stamp, fmt) if fmt.absolute else "",
        notes=tuple(notes),
    )


def _check_options(delimiter, decimal, bad_rows, gaps) -> dict[str, Any]:
    if delimiter is not None and delimiter not in (",", ";", "\t"):
        raise ValueError(f"delimiter must be ',', ';' or a tab, got {shown(delimiter)}")
    if decimal is not None and decimal not in (".", ","):
        raise ValueError(f"decimal must be '.' or ',', got {shown(decimal)}")
    if decimal == "," and delimiter == ",":
        raise ValueError("a decimal comma needs another delimiter (';' or a tab)")
    if bad_rows not in BAD_ROWS:
        raise ValueError(f"bad_rows must be one of {', '.join(BAD_ROWS)}; got {shown(bad_rows)}")
    if gaps not in GAPS:
        raise ValueError(f"gaps must be one of {', '.join(GAPS)}; got {shown(gaps)}")
    return {"delimiter": delimiter, "decimal": decimal, "bad_rows": bad_rows, "gaps": gaps}


def _zone(tz: str | datetime.tzinfo | None) -> datetime.tzinfo | None:
    if tz is None or isinstance(tz, datetime.tzinfo):
        return tz
    if isinstance(tz, str) and (m := re.fullmatch(r"(?:UTC)?([+-]\d{2}(?::?\d{2})?)|UTC|Z", tz)):
        off = _offset(m.group(1) or "Z")
        assert off is not None
        return datetime.timezone(datetime.timedelta(seconds=off))
    import zoneinfo

    try:
        return zoneinfo.ZoneInfo(str(tz))
    except (zoneinfo.ZoneInfoNotFoundError, ValueError, TypeError, OSError):
        raise ValueError(
            f"unknown time zone {shown(tz)}: give an IANA name such as Europe/Berlin or "
            "America/Chicago, UTC, or an offset such as +01:00 (on Windows the zone names "
            "come with the tzdata package)"
        ) from None


def _detect_decimal(rows: list, columns, delimiter: str) -> str:
    """``,`` when the delimiter is not a comma and data cells use decimal commas, else ``.``."""
    if delimiter == ",":
        return "."
    sample = [r[i].strip() for _, r in rows[:50] for i in columns if i < len(r)]
    if any(re.fullmatch(r"[-+]?\d*,\d+(?:[eE][-+]?\d+)?", c) for c in sample):
        return ","
    return "."


def _choose_format(path, rows, i_time, time, unit, name, decimal) -> tuple[TimeFormat, list[str]]:
    """The time format: given, from the header unit, or detected from the cells."""
    cells = [(no, r[i_time].strip()) for no, r in rows if i_time < len(r) and r[i_time].strip()]
    scale = _TIME_UNITS.get((unit or "").lower())
    if name not in (None, "", "auto"):
        fmt = time_format(name)
        if fmt.name == "seconds" and scale is not None:
            fmt = TimeFormat("seconds", fmt.looks, numeric=True, scale=scale, absolute=False)
        return fmt, []
    if not cells:
        return TIME_FORMATS["seconds"], []
    no, first = cells[0]
    x = _number(first, decimal)
    if x is not None:
        if unit and scale is None:
            raise DataFileError(
                path,
                no - 1 if no > 1 else None,
                time,
                f"unknown time unit {unit!r} in the header; use s, ms, min, h or d",
            )
        if scale is not None:
            return TimeFormat(
                "seconds", TIME_FORMATS["seconds"].looks, numeric=True, scale=scale, absolute=False
            ), []
        return _numeric_format(path, cells, time, decimal)
    if _SLASH_RE.fullmatch(first):
        return _slash_order(path, cells, time)
    for fname in _DETECT:
        fmt = TIME_FORMATS[fname]
        if fmt.read(first, decimal) is not None:
            return fmt, []
    raise DataFileError(
        path, no, time, f"{first!r} is not a time in an accepted format: {accepted_formats()}"
    )


def _numeric_format(path, cells, time, decimal) -> tuple[TimeFormat, list[str]]:
    """Seconds, epoch milliseconds, or refused as probably Excel serial days."""
    xs = [_number(c, decimal) for _, c in cells[:1000]]
    xs_ok = np.array([x for x in xs if x is not None and math.isfinite(x)])
    if len(xs_ok) and np.all((xs_ok >= 1e11) & (xs_ok < 1e14)):
        return TIME_FORMATS["epoch-ms"], [
            f"time column '{time}' read as Unix epoch milliseconds (values from "
            f"{xs_ok[0]:.0f}; as seconds they would be after the year 5000); "
            "--time-format seconds to read them as seconds"
        ]
    steps = np.diff(xs_ok)
    if (
        len(xs_ok) > 1
        and np.all((xs_ok > 20000) & (xs_ok < 80000))
        and 0 < float(np.median(steps)) < 0.05
    ):
        day = datetime.datetime(1899, 12, 30) + datetime.timedelta(days=float(xs_ok[0]))
        raise DataFileError(
            path,
            cells[0][0],
            time,
            (
                f"{cells[0][1]!r} looks like an Excel serial day ({day:%Y-%m-%d %H:%M:%S}) with "
                f"samples {float(np.median(steps)) * 86400:.3g} s apart, not like seconds: give "
                "--time-format excel (time_format='excel'), or --time-format seconds / a unit in "
                "the header (t [s]) if it is seconds"
            ),
        )
    notes = []
    if len(xs_ok) > 1 and np.all(xs_ok == np.round(xs_ok)) and float(np.median(steps)) >= 50.0:
        notes.append(
            f"time column '{time}' read as seconds (no unit in its header), whole numbers "
            f"{float(np.median(steps)):.4g} s apart: if they are milliseconds, say so in the "
            "header (t [ms]) or with --time-format epoch-ms"
        )
    return TIME_FORMATS["seconds"], notes


def _slash_order(path, cells, time) -> tuple[TimeFormat, list[str]]:
    """mm/dd/yyyy or dd/mm/yyyy, from the values (a field above 12 decides)."""
    first_big = second_big = None
    for no, c in cells:
        m = _SLASH_RE.fullmatch(c)
        if m is None:
            continue
        a, b = int(m.group(1)), int(m.group(2))
        first_big = first_big or (no if a > 12 else None)
        second_big = second_big or (no if b > 12 else None)
    if first_big and second_big:
        raise DataFileError(
            path,
            max(first_big, second_big),
            time,
            (
                f"dates with the day first (line {first_big}) and the month first (line "
                f"{second_big}) are mixed"
            ),
        )
    if first_big:
        return TIME_FORMATS["dd/mm/yyyy"], [
            f"time column '{time}' read as dd/mm/yyyy (line {first_big} has a day above 12)"
        ]
    if second_big:
        return TIME_FORMATS["mm/dd/yyyy"], []
    return TIME_FORMATS["mm/dd/yyyy"], [
        f"time column '{time}' read as mm/dd/yyyy (US; no day above 12 says otherwise): "
        "--time-format dd/mm/yyyy for day-first dates"
    ]


def _parse_rows(path, rows_raw, idx, time, columns, text_columns, fmt, decimal):
    """Every data row parsed: its stamp and values, and what is bad in it."""
    rows: list[_Row] = []
    texts: dict[str, dict[int, str]] = {c: {} for c in text_columns}
    i_time = idx[time]
    for no, r in rows_raw:
        bad: list[tuple[str, str]] = []
        cell = r[i_time].strip() if i_time < len(r) else ""
        stamp = fmt.read(cell, decimal) if cell else None
        if stamp is None:
            why = (
                "empty cell"
                if not cell
                else f"{cell!r} is not a time in the format of the rows above ({fmt.looks})"
            )
            bad.append((time, why))
        elif abs(stamp[0]) > MAX_MAGNITUDE:
            bad.append((time, f"{cell!r} is beyond {BEYOND}"))
            stamp = None
        values: list[float | None] = []
        for c in columns:
            j = idx[c]
            s = r[j].strip() if j < len(r) else ""
            x = _number(s, decimal) if s else None
            if not s:
                bad.append((c, "empty cell"))
            elif x is None:
                bad.append((c, f"{s!r} is not a number"))
            elif not math.isfinite(x):
                bad.append((c, f"{s!r} is not a finite number"))
                x = None
            elif abs(x) > MAX_MAGNITUDE:
                bad.append((c, f"{s!r} is beyond {BEYOND}"))
                x = None
            values.append(x)
        for c in text_columns:
            j = idx[c]
            texts[c][no] = r[j].strip() if j < len(r) else ""
        rows.append(_Row(no, cell, stamp, values, bad))
    return rows, texts


def _check_zones(path, rows: list[_Row], time: str) -> None:
    """Stamps with and without a zone cannot be mixed."""
    first = next((r for r in rows if r.stamp is not None), None)
    if first is None:
        return
    aware = first.stamp[1] is not None  # type: ignore[index]
    for r in rows:
        if r.stamp is not None and (r.stamp[1] is not None) != aware:
            raise DataFileError(
                path, r.line, time, f"{r.cell!r}: timestamps with and without a time zone are mixed"
            )


def _local(wall: float, zone: datetime.tzinfo, fold: int) -> float:
    """UTC offset [s] of the wall-clock time ``wall`` in ``zone`` (PEP 495 ``fold``).

    Offsets change only at transitions, which are on a quarter hour in every
    zone: the offset is looked up once per quarter hour of the record.
    """
    return _quarter_offset(math.floor(wall / 900.0), zone, fold)


@functools.lru_cache(maxsize=65536)
def _quarter_offset(quarter: int, zone: datetime.tzinfo, fold: int) -> float:
    dt = (_EPOCH + datetime.timedelta(seconds=quarter * 900.0)).replace(tzinfo=zone, fold=fold)
    off = dt.utcoffset()
    return 0.0 if off is None else off.total_seconds()


def _to_utc(rows: list[_Row], zone: datetime.tzinfo, fmt: TimeFormat, time: str) -> list[str]:
    """Wall-clock stamps in ``zone`` -> UTC, the repeated autumn hour resolved by the order.

    A wall time that occurs twice (the hour the clocks go back) is taken as
    the first occurrence until the stamps step back in time, and as the
    second from there to the end of the repeated hour.  A wall time that does
    not exist (the hour the clocks go forward) is a bad cell.
    """
    if fmt.utc or all(r.stamp is None or r.stamp[1] is not None for r in rows):
        return []
    second = False
    prev = -math.inf
    repeated = 0
    for r in rows:
        if r.stamp is None or r.stamp[1] is not None:
            continue
        wall = r.stamp[0]
        o0, o1 = _local(wall, zone, 0), _local(wall, zone, 1)
        if o0 == o1:
            second = False
            off = o0
        elif not _exists(wall, zone, o0):
            r.stamp = None
            r.bad.append(
                (time, f"{r.cell!r} does not exist in {zone} (the clocks went forward over it)")
            )
            continue
        else:
            if not second and wall - o0 < prev:
                second = True
            off = o1 if second else o0
            repeated += second
        r.stamp = (wall - off, int(off))
        prev = wall - off
    note = f"the stamps are local time in {zone}, converted to UTC"
    if repeated:
        note += f" ({repeated} stamp(s) in the hour repeated when the clocks went back)"
    return [note]


def _exists(wall: float, zone: datetime.tzinfo, off: float) -> bool:
    """False for a wall time in the hour skipped when the clocks go forward."""
    utc = (_EPOCH + datetime.timedelta(seconds=wall - off)).replace(tzinfo=datetime.timezone.utc)
    back = utc.astimezone(zone).replace(tzinfo=None)
    return abs((back - _EPOCH).total_seconds() - wall) < 1.0  # else an hour off


def _window(path, rows, time, fmt, decimal, zone, start, end, notes) -> list[_Row]:
    """The rows from the first at or after ``start`` to the last at or before ``end``.

    In file order, on the times as written (wall-clock times are compared as
    such, before any ``tz`` conversion), so a window across a repeated hour
    keeps what the file has between the two stamps.
    """
    if start is None and end is None:
        return rows
    aware = next((r.stamp[1] is not None for r in rows if r.stamp is not None), False)
    lo = -math.inf if start is None else _bound("start", start, fmt, decimal, zone, aware)
    hi = math.inf if end is None else _bound("end", end, fmt, decimal, zone, aware)
    timed = [i for i, r in enumerate(rows) if r.stamp is not None]
    first = next((i for i in timed if rows[i].stamp[0] >= lo), None)  # type: ignore[index]
    last = next((i for i in reversed(timed) if rows[i].stamp[0] <= hi), None)  # type: ignore[index]
    if first is None or last is None or last < first:
        span = f"{rows[timed[0]].cell} .. {rows[timed[-1]].cell}" if timed else "unreadable"
        raise DataFileError(
            path,
            None,
            time,
            f"no row from start {shown(start)} to end {shown(end)} (the file runs {span})",
        )
    out = rows[first : last + 1]
    notes.append(
        f"start/end: lines {out[0].line}-{out[-1].line} read ({len(out)} of {len(rows)} rows)"
    )
    return out


def _bound(what, v, fmt: TimeFormat, decimal, zone, aware: bool) -> float:
    """``start``/``end`` in the seconds of the stamps as parsed (wall clock unless they carry
    a zone; then UTC, a bound without a zone read in ``tz``, or as UTC)."""
    if isinstance(v, datetime.datetime):
        off = v.utcoffset()
        wall = (v.replace(tzinfo=None) - _EPOCH).total_seconds()
        stamp: Stamp | None = (
            (wall, None) if off is None else (wall - off.total_seconds(), int(off.total_seconds()))
        )
    elif isinstance(v, (int, float)) and not isinstance(v, bool):
        if not fmt.numeric:
            raise ValueError(
                f"{what} = {shown(v)}: the time column holds stamps; give {what} as one "
                f"({fmt.looks})"
            )
        stamp = fmt.read(repr(float(v)), ".")
    else:
        s = str(v).strip()
        stamp = fmt.read(s, decimal) or (fmt.read(s, ".") if fmt.numeric else None)
        if stamp is None and not fmt.numeric:
            stamp = _parse_iso(s)
    if stamp is None:
        raise ValueError(
            f"{what} = {shown(v)} is not a time like those of the time column ({fmt.looks})"
        )
    sec, off_ = stamp
    if aware and off_ is None:  # a wall time against UTC stamps
        return sec - (_local(sec, zone, 0) if zone is not None else 0.0)
    if not aware and off_ is not None:  # a UTC time against wall-clock stamps
        return sec + (_local_of_utc(sec, zone) if zone is not None else off_)
    return sec


def _local_of_utc(utc: float, zone: datetime.tzinfo) -> float:
    """UTC offset [s] in ``zone`` at the UTC time ``utc``."""
    dt = (_EPOCH + datetime.timedelta(seconds=utc)).replace(tzinfo=datetime.timezone.utc)
    off = dt.astimezone(zone).utcoffset()
    return 0.0 if off is None else off.total_seconds()


def _bad_rows(path, rows: list[_Row], time: str, policy: str, notes: list[str]) -> list[_Row]:
    """Refuse the first bad cell, or drop bad rows (skip; interpolate: those without a time)."""
    bad = [r for r in rows if r.bad]
    if not bad:
        return rows
    if policy == "refuse":
        r = bad[0]
        col, why = r.bad[0]
        more = f"; {len(bad) - 1} more row(s) like it" if len(bad) > 1 else ""
        raise DataFileError(
            path,
            r.line,
            col,
            f"{why}{more} (--bad-rows skip or interpolate, bad_rows=, to go on without such rows)",
        )
    if policy == "skip":
        notes.append(f"skipped {len(bad)} row(s) with a bad cell: {_where(bad)}")
        return [r for r in rows if not r.bad]
    no_time = [r for r in bad if r.stamp is None]
    if no_time:
        notes.append(f"skipped {len(no_time)} row(s) without a readable time: {_where(no_time)}")
    return [r for r in rows if r.stamp is not None]


def _where(rows: list[_Row], most: int = 5) -> str:
    """``line 17 (y: 'I/O Timeout'), line 18 (y: empty cell), ... and 3 more``."""
    parts = [f"line {r.line} ({r.bad[0][0]}: {r.bad[0][1]})" for r in rows[:most]]
    return ", ".join(parts) + (f" and {len(rows) - most} more" if len(rows) > most else "")


def _time_order(path, rows, time, fmt, zone, policy, notes) -> list[_Row]:
    """Refuse time that steps back; repeated stamps: refused, or dropped (skip/interpolate)."""
    out: list[_Row] = []
    dropped: list[_Row] = []
    for r in rows:
        if out and r.stamp is not None and out[-1].stamp is not None:
            prev = out[-1]
            dt = r.stamp[0] - prev.stamp[0]
            if dt == 0.0:
                if policy == "refuse":
                    raise DataFileError(
                        path,
                        r.line,
                        time,
                        (
                            f"time {r.cell} repeats line {prev.line} (a duplicated stamp; "
                            "--bad-rows skip or interpolate drop the repeated rows)"
                        ),
                    )
                dropped.append(r)
                continue
            if dt < 0.0:
                raise DataFileError(path, r.line, time, _backwards(r, prev, dt, fmt, zone))
        out.append(r)
    if dropped:
        notes.append(
            f"dropped {len(dropped)} row(s) whose time repeats the row before: lines "
            + ", ".join(str(r.line) for r in dropped[:5])
            + (f" and {len(dropped) - 5} more" if len(dropped) > 5 else "")
        )
    return out


def _backwards(r: _Row, prev: _Row, dt: float, fmt: TimeFormat, zone) -> str:
    msg = (
        f"time {r.cell} is not after {prev.cell} on line {prev.line} (time must increase "
        f"strictly; it steps back {_seconds(-dt)})"
    )
    naive = r.stamp is not None and r.stamp[1] is None and fmt.absolute and not fmt.utc
    if naive and zone is None and abs(-dt - 3600.0) <= 0.02 * 3600.0 + 1.0:
        msg += (
            ": the wall clock went back an hour, as at the end of daylight-saving time; "
            "give the stamps' time zone (e.g. --tz Europe/Berlin; tz= in Python) to read them "
            "in UTC"
        )
    return msg


def _seconds(x: float) -> str:
    return f"{x:.4g} s"


def _times(ratio: float) -> str:
    """``7200 times`` / ``12.5 times`` (no exponent)."""
    return f"{ratio:,.0f} times" if ratio >= 100 else f"{ratio:.3g} times"


def _first_change(u: NDArray[np.float64]) -> int | None:
    """Index of the first sample whose value differs from the first good one (None: never)."""
    good = np.flatnonzero(np.isfinite(u))
    if len(good) == 0:
        return None
    u0 = u[good[0]]
    rng = float(np.nanmax(u) - np.nanmin(u))
    moved = good[np.abs(u[good] - u0) > 1e-12 * max(rng, abs(u0), 1e-300)]
    return int(moved[0]) if len(moved) else None


def _gaps(
    path, t, line_no, rows, time, u, policy, fmt, zone, step_column, notes
) -> NDArray[np.float64]:
    """Find time steps > GAP_FACTOR median steps; refuse, keep or close those inside.

    ``u`` is the step column (or None).  A gap across which it moves (by more
    than a tenth of its range) is refused unless closed: when it moved is
    lost, and with it the dead time.
    """
    step_i = None if u is None else _first_change(u)
    dt = np.diff(t)
    if len(dt) == 0:
        return t
    h = float(np.median(dt))
    where = np.flatnonzero(dt > GAP_FACTOR * h) + 1  # index of the sample after each gap
    if len(where) == 0:
        return t
    t = t.copy()
    for i in where.tolist():
        size = float(dt[i - 1])
        desc = (
            f"time jumps {_seconds(size)} from line {line_no[i - 1]} ({rows[i - 1].cell}) "
            f"to line {line_no[i]} ({rows[i].cell}), {_times(size / h)} the median sample "
            f"time {_seconds(h)}"
        )
        if step_i is not None and i < step_i and policy != "close":
            notes.append(
                f"{desc}: before the experiment starts ({step_column} first moves on "
                f"line {line_no[step_i]}), kept"
            )
            continue
        if u is not None and policy != "close" and (moved := _moved_across(u, i)):
            raise DataFileError(
                path,
                int(line_no[i]),
                time,
                f"{desc}, and {step_column} moves across it ({moved}): when it moved is lost, "
                "and with it the dead time: repeat the bump test, or cut the record to a later "
                "move with --start/--end (--gaps close if the clock jumped)",
            )
        if policy == "refuse":
            inside = (
                f"inside the experiment (after {step_column} first moves on line {line_no[step_i]})"
                if step_i is not None
                else "inside the record"
            )
            raise DataFileError(
                path,
                int(line_no[i]),
                time,
                f"{desc}, {inside}: " + _gap_hint(size, rows[i], fmt, zone),
            )
        if policy == "keep":
            notes.append(f"{desc}: kept as time that passed (gaps='keep')")
            continue
        t[i:] -= size - h
        notes.append(
            f"{desc}: closed to one sample time (gaps='close': the samples after it "
            f"moved {_seconds(size - h)} earlier)"
        )
    return t


def _moved_across(u: NDArray[np.float64], i: int) -> str:
    """``"50 -> 60"`` when ``u`` changes by over a tenth of its range between the last good
    value before sample ``i`` and the first good one from it on, else ""."""
    before = np.flatnonzero(np.isfinite(u[:i]))
    after = np.flatnonzero(np.isfinite(u[i:]))
    if len(before) == 0 or len(after) == 0:
        return ""
    a, b = float(u[before[-1]]), float(u[i + after[0]])
    rng = float(np.nanmax(u) - np.nanmin(u))
    return f"{a:.6g} -> {b:.6g}" if abs(b - a) > 0.1 * rng else ""


def _gap_hint(size: float, r: _Row, fmt: TimeFormat, zone) -> str:
    naive = r.stamp is not None and fmt.absolute and not fmt.utc and zone is None
    dst = naive and abs(size - 3600.0) <= 0.02 * 3600.0 + 1.0
    hint = ""
    if dst:
        hint = (
            "the wall clock jumped an hour, as at the start of daylight-saving time: give the "
            "stamps' time zone (e.g. --tz Europe/Berlin; tz= in Python) to read them in UTC; "
            "otherwise "
        )
    return hint + (
        "say what the gap is: --gaps keep (the time passed: data lost), --gaps close "
        "(the clock jumped), or cut the record with --start/--end"
    )


def _fill(vals, t, line_no, columns, hold, notes):
    """Fill the bad cells: linearly in time, or the last good value for ``hold`` columns.

    Rows before the first and after the last complete row cannot be filled and are dropped.
    """
    ok = np.all(np.isfinite(vals), axis=1)
    if ok.all():
        return vals, t, line_no, list(range(len(t)))
    good = np.flatnonzero(ok)
    if len(good) == 0:
        return vals[:0], t[:0], line_no[:0], []
    lo, hi = int(good[0]), int(good[-1]) + 1
    cut = (lo, len(t) - hi)
    vals, t2, line_no2 = vals[lo:hi].copy(), t[lo:hi], line_no[lo:hi]
    filled: list[str] = []
    for j, c in enumerate(columns):
        x = vals[:, j]
        bad = ~np.isfinite(x)
        if not bad.any():
            continue
        gi = np.flatnonzero(~bad)
        if c in hold:
            last = np.maximum.accumulate(np.where(bad, 0, np.arange(len(x))))
            vals[:, j] = x[last]
        else:
            vals[:, j] = np.where(bad, np.interp(t2, t2[gi], x[gi]), x)
        lines = line_no2[bad].tolist()
        how = "held" if c in hold else "interpolated"
        filled.append(
            f"{c} on line(s) {', '.join(map(str, lines[:5]))}"
            + (f" and {len(lines) - 5} more" if len(lines) > 5 else "")
            + f" ({how})"
        )
    notes.append("filled bad cells: " + "; ".join(filled))
    if cut[0] or cut[1]:
        notes.append(
            f"dropped {cut[0]} row(s) at the start and {cut[1]} at the end with a bad "
            "cell that cannot be filled"
        )
    t2 = t2 - t2[0]
    return vals, t2, line_no2, list(range(lo, hi))


def _iso(stamp: Stamp | None, fmt: TimeFormat) -> str:
    """The ISO 8601 text of a stamp (with its UTC offset when known)."""
    if stamp is None:
        return ""
    sec, off = stamp
    if off is None:
        return (_EPOCH + datetime.timedelta(seconds=sec)).isoformat()
    zone = datetime.timezone(datetime.timedelta(seconds=off))
    return (_EPOCH + datetime.timedelta(seconds=sec + off)).replace(tzinfo=zone).isoformat()


# ---------------------------------------------------------------------------
# A bump test
# ---------------------------------------------------------------------------


def read_step_csv(
    path: str | Path,
    time: str = "t",
    u: str = "u",
    y: str = "y",
    *,
    u_before: float | None = None,
    **options: Any,
) -> StepData:
    """Read a bump test (time, MV, PV) from a CSV file, as people export them.

    Parameters
    ----------
    path : str or Path
        The file (see :func:`read_record` for what it may contain).
    time, u, y : str
        Names of the time, MV and PV columns.
    u_before : float, optional
        The MV before the record.  For a record whose step is at the first
        sample (the MV constant from t = 0, the PV at rest there): a sample
        ``(t0 - h, u_before, y[0])`` is put in front (``h`` the first sample
        interval), so the MV steps at ``t0``.
    **options
        The reading options of :func:`read_record` (:data:`CSV_OPTIONS`):
        ``delimiter``, ``decimal``, ``encoding``, ``tz``, ``time_format``,
        ``bad_rows``, ``gaps``, ``start``, ``end``.  The MV is the column
        that starts the experiment (gaps before its first move are kept) and
        is held, not interpolated, by ``bad_rows="interpolate"``.

    Returns
    -------
    StepData

    Raises
    ------
    DataFileError
        As :func:`read_record`, and no change in the MV column.
    """
    unknown = set(options) - set(CSV_OPTIONS)
    if unknown:
        raise TypeError(f"read_step_csv() got unexpected keyword(s): {', '.join(sorted(unknown))}")
    rec = read_record(path, time, (u, y), hold=(u,), step_column=u, **options)
    tv, uv, yv = rec.t, rec.values[u], rec.values[y]
    lines = rec.lines
    notes = rec.notes
    if u_before is not None:
        if not math.isfinite(u_before):
            raise ValueError(f"u_before must be finite, got {u_before!r}")
        if abs(u_before) > MAX_MAGNITUDE:
            raise ValueError(f"u_before = {u_before!r} is beyond {BEYOND}")
        h = float(tv[1] - tv[0])
        tv = np.concatenate(([tv[0] - h], tv))
        uv = np.concatenate(([float(u_before)], uv))
        yv = np.concatenate(([yv[0]], yv))
        lines = np.concatenate(([0], lines))
        notes = (*notes, f"MV {u_before:g} before the record: a sample added at t = {tv[0]:g} s")
    if constant(uv):
        raise DataFileError(
            rec.path,
            None,
            u,
            f"the MV never changes (constant {uv[0]:g}): there is no step to identify from"
            + (
                "; if the step is at the first sample, give the MV before it "
                "(--u-before, u_before=)"
                if u_before is None
                else ""
            ),
        )
    return StepData(
        tv,
        uv,
        yv,
        rec.path,
        u_unit=rec.units[u],
        y_unit=rec.units[y],
        encoding=rec.encoding,
        delimiter=rec.delimiter,
        decimal=rec.decimal,
        start=rec.start,
        notes=tuple(notes),
        time_format=rec.time_format,
        lines=lines,
    )


def constant(u: NDArray) -> bool:
    """True when the MV record never changes (within rounding): nothing to identify."""
    return bool(np.ptp(u) <= 1e-12 * max(1.0, float(np.max(np.abs(u)))))
