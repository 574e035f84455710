"""A seeded generator of hostile historian exports of a bump test on a known process.

:func:`hostile_file` writes the record of a first-order-plus-dead-time process
``k e^{-L s}/(T s + 1)`` stepped once, as a historian or a spreadsheet would
export it, with some of what real exports contain: the stamps of PI, AVEVA,
WinCC, Ignition and Excel (local time across a daylight-saving jump forward or
back, UTC, epoch seconds and milliseconds, Excel serial days), lost data (a
gap), duplicated stamps, bad cells (blank, ``I/O Timeout``, ``Bad Input``,
``nan``), decimal commas with ``;`` separators, a byte-order mark, CRLF line
ends, metadata lines before the header, Excel's ``sep=`` line, extra columns.
It also returns what an honest user would pass (the zone when they know it,
what a gap is when they say it) and the truth to compare the model with.
"""

from __future__ import annotations

import dataclasses
import datetime
import random
import zoneinfo
from pathlib import Path
from typing import Any

import numpy as np

UTC = datetime.timezone.utc
# daylight-saving transitions of 2024 (UTC instants): (zone, when, +1 h forward / -1 h back)
TRANSITIONS = [
    ("Europe/Berlin", datetime.datetime(2024, 3, 31, 1, 0, tzinfo=UTC), "forward"),
    ("Europe/Berlin", datetime.datetime(2024, 10, 27, 1, 0, tzinfo=UTC), "back"),
    ("America/New_York", datetime.datetime(2024, 3, 10, 7, 0, tzinfo=UTC), "forward"),
    ("America/New_York", datetime.datetime(2024, 11, 3, 6, 0, tzinfo=UTC), "back"),
]
BAD_CELLS = ("", "I/O Timeout", "Bad Input", "nan", "Comm Fail", "No Data", "Shutdown")
# formats: (name, writes local wall-clock time, the --time-format a user must give or None)
FORMATS = [
    ("seconds", False, None),
    ("iso", True, None),
    ("iso-space", True, None),
    ("iso-z", False, None),
    ("iso-offset", False, None),
    ("dd.mm.yyyy", True, None),
    ("mm/dd/yyyy", True, None),
    ("dd-mon-yy", True, None),
    ("excel", True, "excel"),
    ("excel", True, None),  # refused: the user did not say the numbers are days
    ("epoch", False, None),
    ("epoch-ms", False, None),
]


@dataclasses.dataclass
class Hostile:
    path: Path
    columns: tuple[str, str, str]  # time, u, y
    options: dict[str, Any]  # the reading options an honest user gives
    gain: float
    time_constant: float
    dead_time: float
    h: float
    what: list[str]  # what was done to the file, for the failure message
    cells: list[str]  # the time cell of every sample (for start/end)


def _stamp(fmt: str, when: datetime.datetime, zone: zoneinfo.ZoneInfo, t: float) -> str:
    """The cell of the absolute time ``when`` in format ``fmt`` (local ones in ``zone``)."""
    loc = when.astimezone(zone).replace(tzinfo=None)
    ms = f"{loc.microsecond // 1000:03d}"
    if fmt == "seconds":
        return repr(round(t, 6))
    if fmt == "iso":
        return loc.strftime("%Y-%m-%dT%H:%M:%S.") + f"{loc.microsecond:06d}"
    if fmt == "iso-space":
        return loc.strftime("%Y-%m-%d %H:%M:%S.") + ms
    if fmt == "iso-z":
        return when.astimezone(UTC).strftime("%Y-%m-%dT%H:%M:%S.") + f"{ms}Z"
    if fmt == "iso-offset":
        return when.astimezone(zone).isoformat(timespec="milliseconds")
    if fmt == "dd.mm.yyyy":
        return loc.strftime("%d.%m.%Y %H:%M:%S,") + ms
    if fmt == "mm/dd/yyyy":
        hour12 = loc.hour % 12 or 12
        return (f"{loc.month}/{loc.day}/{loc.year} {hour12}:{loc:%M:%S}.{ms} "
                f"{'PM' if loc.hour >= 12 else 'AM'}")  # fmt: skip
    if fmt == "dd-mon-yy":
        return loc.strftime("%d-%b-%y %H:%M:%S.") + ms
    if fmt == "excel":
        days = (loc - datetime.datetime(1899, 12, 30)).total_seconds() / 86400.0
        return f"{days:.10f}"
    if fmt == "epoch":
        return f"{when.timestamp():.3f}"
    if fmt == "epoch-ms":
        return str(round(when.timestamp() * 1000.0))
    raise AssertionError(fmt)


def hostile_file(rng: random.Random, folder: Path, name: str = "export.csv") -> Hostile:
    """Write one hostile export of a bump test into ``folder``; see the module docstring."""
    what: list[str] = []
    k = rng.choice((-1.0, 1.0)) * rng.uniform(0.5, 3.0)
    T = rng.uniform(5.0, 40.0)
    L = rng.uniform(1.0, 15.0)
    h = rng.choice((0.25, 0.5, 1.0))
    pre = round(rng.uniform(20.0, 120.0) / h) * h  # the MV steps at a sample
    post = L + 6.0 * T
    n = int((pre + post) / h)
    t = np.arange(n) * h
    u0, du = rng.uniform(10.0, 60.0), rng.choice((-1.0, 1.0)) * rng.uniform(5.0, 20.0)
    u = np.where(t >= pre, u0 + du, u0)
    s = t - pre - L
    y = 50.0 + np.where(s > 0.0, k * du * -np.expm1(-np.maximum(s, 0.0) / T), 0.0)
    y = y + np.random.default_rng(rng.randrange(2**32)).normal(0.0, 0.002 * abs(k * du), n)

    fmt, local, user_format = rng.choice(FORMATS)
    zone_name, instant, direction = rng.choice(TRANSITIONS)
    zone = zoneinfo.ZoneInfo(zone_name)
    where = rng.choice(("before the step", "in the experiment", "nowhere"))
    at = {"before the step": rng.uniform(0.1, 0.9) * pre,
          "in the experiment": pre + rng.uniform(0.0, 1.0) * post,
          "nowhere": -3600.0 * 5}[where]  # fmt: skip
    start = instant - datetime.timedelta(seconds=at)
    options: dict[str, Any] = {}
    if user_format:
        options["time_format"] = user_format
    if local and fmt != "seconds":
        what.append(f"{fmt} local time in {zone_name}, {direction} jump {where}")
        if rng.random() < 0.5:
            options["tz"] = zone_name
        elif direction == "forward" and where != "nowhere" and rng.random() < 0.3:
            options["gaps"] = "close"  # the user knows the clock jumped (and of no lost data)
    else:
        what.append(f"time as {fmt}")
    keep = np.ones(n, dtype=bool)
    dup: set[int] = set()
    bad: dict[tuple[int, int], str] = {}
    clock_gap = local and direction == "forward" and where == "in the experiment"
    if rng.random() < 0.3 and options.get("gaps") != "close":  # lost data: rows missing
        i0 = rng.randrange(1, n - 40)
        m = rng.randrange(12, 40)
        keep[i0 : i0 + m] = False
        what.append(f"rows {i0}..{i0 + m} lost")
        # "the time passed" is true of every gap, unless the clock jumped inside too
        if rng.random() < 0.5 and not (clock_gap and "tz" not in options):
            options["gaps"] = "keep"
    if rng.random() < 0.3:
        dup = {rng.randrange(1, n) for _ in range(rng.randrange(1, 4))}
        what.append(f"duplicated rows {sorted(dup)}")
    if rng.random() < 0.5:
        for _ in range(rng.randrange(1, 6)):
            bad[(rng.randrange(n), rng.randrange(1, 3))] = rng.choice(BAD_CELLS)
        what.append(f"bad cells {bad}")
    bad_rows = rng.choice(("refuse", "skip", "interpolate"))
    if bad_rows != "refuse":
        options["bad_rows"] = bad_rows
    european = fmt in ("dd.mm.yyyy",) or rng.random() < 0.3
    sep, dec = (";", ",") if european else (rng.choice((",", "\t")), ".")
    if european:
        what.append("';' with decimal commas")
    newline = "\r\n" if rng.random() < 0.3 else "\n"
    head: list[str] = []
    if rng.random() < 0.2:
        head.append(f"sep={sep}")
    if rng.random() < 0.3:
        head += ["Exported by a historian", f"Tags: FIC101.OUT{sep}TIC101.PV"]
        what.append("metadata lines")
    tcol = {"seconds": "t [s]"}.get(fmt, "Timestamp")
    cols = [tcol, "FIC101.OUT [%]", "TIC101.PV [degC]"]
    extra = rng.random() < 0.3
    if extra:
        cols.append("Quality")
    lines = [*head, sep.join(cols)]

    def num(x: float) -> str:
        text = f"{x:.6f}"
        return text.replace(".", dec)

    stamps = []
    for i in range(n):
        when = start + datetime.timedelta(seconds=float(t[i]))
        stamps.append(_stamp(fmt, when, zone, float(t[i])))
        if dec == "," and fmt in ("seconds", "excel", "epoch"):
            stamps[-1] = stamps[-1].replace(".", ",")
    if rng.random() < 0.2:  # a window: from half way through the steady state to the end
        options["start"] = stamps[int(pre / h / 2)]
        options["end"] = stamps[-1]
    for i in range(n):
        if not keep[i]:
            continue
        cells = [stamps[i], num(u[i]), num(y[i])]
        for j in (1, 2):
            if (i, j) in bad:
                cells[j] = bad[(i, j)]
        if extra:
            cells.append("Good")
        lines.append(sep.join(cells))
        if i in dup:
            lines.append(sep.join(cells))
    text = newline.join(lines) + newline
    data = text.encode("utf-8")
    if rng.random() < 0.3:
        data = b"\xef\xbb\xbf" + data
        what.append("BOM")
    path = folder / name
    path.write_bytes(data)
    return Hostile(path, ("Timestamp" if fmt != "seconds" else "t", "FIC101.OUT",
                          "TIC101.PV"), options, k, T, L, h, what, stamps)  # fmt: skip
