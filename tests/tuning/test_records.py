"""The CSV reader on what historians write: time formats, local time, bad cells, gaps, windows.

Each test writes the file a historian or spreadsheet writes and checks the
seconds read against the stamps' true instants (``datetime`` arithmetic, an
independent reference), or the one-line refusal: file, line, column, and the
way on.  The issue these answer: local-time stamps across the spring
daylight-saving jump gave a dead time of 3,617 s for a process with 9 s.
"""

from __future__ import annotations

import datetime
import zoneinfo

import numpy as np
import pytest
from click.testing import CliRunner

from ctrlblocks.cli import main
from ctrlblocks.tuning import DataFileError, fit_fopdt, read_record, read_step_csv
from ctrlblocks.tuning.records import TIME_FORMATS, accepted_formats

BERLIN = zoneinfo.ZoneInfo("Europe/Berlin")
UTC = datetime.timezone.utc
K, T, L, H = 2.0, 20.0, 9.0, 0.5  # the process: 0.5 s samples, 9 s dead time


def bump(n: int = 600, t_step: float = 90.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(n) * H
    u = np.where(t >= t_step, 60.0, 50.0)
    s = t - t_step - L
    return t, u, 40.0 + np.where(s > 0.0, K * 10.0 * -np.expm1(-np.maximum(s, 0.0) / T), 0.0)


def write(path, header: str, cells: list[str], u, y, sep: str = ";", dec: str = ",") -> str:
    """A CSV file: the time cells as given, the values with the decimal mark ``dec``."""
    rows = [
        f"{c}{sep}" + f"{a:.4f}{sep}{b:.6f}".replace(".", dec)
        for c, a, b in zip(cells, u, y, strict=True)
    ]
    header = header.replace(";", sep)
    path.write_text(header + "\n" + "\n".join(rows) + "\n", encoding="utf-8")
    return str(path)


def dst_file(tmp_path, month: int) -> str:
    """The issue's bump test with Berlin wall-clock stamps that cross the jump of
    2024-03-31 (month 3: forward) or 2024-10-27 (month 10: back) at 01:00 UTC, 2 min in."""
    t, u, y = bump()
    start = datetime.datetime(2024, month, 31 if month == 3 else 27, 0, 58, tzinfo=UTC)
    return write(tmp_path / "dst.csv", "Zeit;MV [%];PV [degC]", local_cells(start, t), u, y)


def local_cells(start_utc: datetime.datetime, t: np.ndarray) -> list[str]:
    """WinCC-style local wall-clock stamps (dd.mm.yyyy hh:mm:ss,fff) in Berlin."""
    out = []
    for x in t:
        d = (start_utc + datetime.timedelta(seconds=float(x))).astimezone(BERLIN)
        out.append(d.strftime("%d.%m.%Y %H:%M:%S,") + f"{d.microsecond // 1000:03d}")
    return out


# -- daylight saving -----------------------------------------------------------------


def test_the_spring_jump_inside_the_bump_test_is_refused_with_the_tz_hint(tmp_path):
    t, _, _ = bump()
    p = dst_file(tmp_path, 3)
    with pytest.raises(DataFileError) as e:
        read_step_csv(p, "Zeit", "MV", "PV")
    assert (e.value.line, e.value.column) == (242, "Zeit")
    assert "time jumps 3600 s from line 241 (31.03.2024 01:59:59,500) to line 242" in str(e.value)
    assert "7,201 times the median sample time 0.5 s" in str(e.value)
    assert "--tz Europe/Berlin" in str(e.value) and "--gaps keep" in str(e.value)
    d = read_step_csv(p, "Zeit", "MV", "PV", tz="Europe/Berlin")
    np.testing.assert_allclose(d.t, t, rtol=0, atol=1e-6)
    m = fit_fopdt(d.t, d.u, d.y)
    assert (m.gain, m.time_constant, m.dead_time) == pytest.approx((K, T, L), rel=1e-3)
    assert d.start == "2024-03-31T01:58:00+01:00"


def test_the_autumn_hour_read_twice_is_refused_and_read_in_order_with_tz(tmp_path):
    t, _, _ = bump()
    p = dst_file(tmp_path, 10)
    with pytest.raises(DataFileError) as e:
        read_step_csv(p, "Zeit", "MV", "PV")
    assert e.value.line == 242
    assert "time 27.10.2024 02:00:00,000 is not after 27.10.2024 02:59:59,500 on line 241" in str(
        e.value
    )
    assert "went back an hour" in str(e.value) and "--tz" in str(e.value)
    d = read_step_csv(p, "Zeit", "MV", "PV", tz="Europe/Berlin")
    np.testing.assert_allclose(d.t, t, rtol=0, atol=1e-6)
    assert "repeated" in d.notes[0]


def test_a_wall_time_the_spring_jump_skips_is_a_bad_cell(tmp_path):
    t, u, y = bump(40, 5.0)
    cells = [f"31.03.2024 01:59:{int(x):02d},000" for x in t[:20]] + [
        f"31.03.2024 02:00:{int(x - 10):02d},000" for x in t[20:]
    ]
    p = write(tmp_path / "gap.csv", "Zeit;MV;PV", cells, u, y)
    with pytest.raises(DataFileError, match=r"line 22, column 'Zeit': '31.03.2024 02:00:00,000' "
                       r"does not exist in Europe/Berlin"):  # fmt: skip
        read_step_csv(p, "Zeit", "MV", "PV", tz="Europe/Berlin")


@pytest.mark.parametrize("tz", ["Europe/Berln", "+25:00x", ""])
def test_an_unknown_zone_is_refused_naming_the_accepted_forms(tmp_path, tz):
    t, u, y = bump(40, 5.0)
    p = write(tmp_path / "b.csv", "t;MV;PV", [repr(x) for x in t], u, y)
    with pytest.raises(ValueError, match=r"unknown time zone .*Europe/Berlin.*tzdata"):
        read_step_csv(p, "t", "MV", "PV", tz=tz)


# -- time formats ------------------------------------------------------------------------

T0 = datetime.datetime(2024, 5, 1, 13, 4, 5, 250000)  # a Wednesday afternoon, wall clock
FORMAT_CASES = [
    # (time_format given or None for auto, cell of T0 + x seconds)
    (None, lambda d: d.isoformat()),  # PI Web API, ISO 8601
    (None, lambda d: d.strftime("%Y-%m-%d %H:%M:%S.") + f"{d.microsecond // 1000:03d}"),  # AVEVA
    (None, lambda d: d.strftime("%d.%m.%Y %H:%M:%S,") + f"{d.microsecond // 1000:03d}"),  # WinCC
    (None, lambda d: f"{d.month}/{d.day}/{d.year} {d.hour % 12 or 12}:{d:%M:%S}."
     f"{d.microsecond // 1000:03d} {'PM' if d.hour >= 12 else 'AM'}"),  # US Excel, PI DataLink
    (None, lambda d: d.strftime("%d-%b-%y %H:%M:%S.") + f"{d.microsecond // 1000:03d}"),  # PI
    ("excel", lambda d: f"{(d - datetime.datetime(1899, 12, 30)).total_seconds() / 86400:.11f}"),
    ("dd/mm/yyyy", lambda d: d.strftime("%d/%m/%Y %H:%M:%S.") + f"{d.microsecond:06d}"),
    ("%Y%m%d %H%M%S.%f", lambda d: d.strftime("%Y%m%d %H%M%S.%f")),
]  # fmt: skip


@pytest.mark.parametrize(("given", "cell"), FORMAT_CASES)
def test_historian_time_formats_give_the_seconds_between_the_stamps(tmp_path, given, cell):
    t, u, y = bump(60, 10.0)
    t = t * 37.0  # 18.5 s apart: the stamps cross minutes and an hour
    cells = [cell(T0 + datetime.timedelta(seconds=float(x))) for x in t]
    p = write(tmp_path / "f.csv", "time;u;y", cells, u, y, sep=";", dec=".")
    d = read_step_csv(p, "time", "u", "y", time_format=given)
    np.testing.assert_allclose(d.t, t, rtol=0, atol=2e-6)
    assert d.start.startswith("2024-05-01T13:04:05")


def test_epoch_stamps_are_utc_and_milliseconds_are_recognised_with_a_note(tmp_path):
    t, u, y = bump(60, 10.0)
    epoch = datetime.datetime(2024, 5, 1, 11, 4, 5, tzinfo=UTC).timestamp()
    p = write(tmp_path / "ms.csv", "t_stamp,u,y", [str(round((epoch + x) * 1000)) for x in t],
              u, y, sep=",", dec=".")  # fmt: skip
    d = read_step_csv(p, "t_stamp", "u", "y")
    np.testing.assert_allclose(d.t, t, rtol=0, atol=1e-9)
    assert d.time_format == "epoch-ms" and "epoch milliseconds" in d.notes[0]
    assert d.start == "2024-05-01T11:04:05+00:00"
    p = write(tmp_path / "s.csv", "t,u,y", [f"{epoch + x:.1f}" for x in t], u, y, sep=",",
              dec=".")  # fmt: skip
    d = read_step_csv(p, "t", "u", "y", time_format="epoch")
    np.testing.assert_allclose(d.t, t, rtol=0, atol=1e-6)
    assert d.start == "2024-05-01T11:04:05+00:00"


def test_excel_serial_days_are_not_read_as_seconds_without_being_told(tmp_path):
    t, u, y = bump(60, 10.0)
    serial = [f"{45413.5 + x / 86400.0:.10f}" for x in t]
    p = write(tmp_path / "xl.csv", "Date;u;y", serial, u, y, sep=";", dec=".")
    with pytest.raises(DataFileError) as e:
        read_step_csv(p, "Date", "u", "y")
    assert e.value.line == 2 and e.value.column == "Date"
    assert "looks like an Excel serial day (2024-05-01 12:00:00)" in str(e.value)
    assert "--time-format excel" in str(e.value)
    d = read_step_csv(p, "Date", "u", "y", time_format="excel")
    np.testing.assert_allclose(d.t, t, rtol=0, atol=1e-5)


def test_a_stamp_in_no_format_is_refused_listing_the_accepted_ones(tmp_path):
    t, u, y = bump(40, 5.0)
    cells = ["13:04:05"] * len(t)
    p = write(tmp_path / "x.csv", "Zeit;u;y", cells, u, y)
    with pytest.raises(DataFileError) as e:
        read_step_csv(p, "Zeit", "u", "y")
    assert (e.value.line, e.value.column) == (2, "Zeit")
    assert accepted_formats() in str(e.value)
    for name in ("ISO 8601", "dd.mm.yyyy hh:mm:ss,fff", "AM/PM", "Excel serial days", "epoch"):
        assert name in str(e.value)


def test_day_first_slash_dates_are_recognised_from_a_day_above_12(tmp_path):
    t, u, y = bump(40, 5.0)
    cells = [f"13/05/2024 10:00:{int(2 * x):02d}" for x in t]
    p = write(tmp_path / "uk.csv", "t;u;y", cells, u, y)
    d = read_step_csv(p, "t", "u", "y")
    assert d.time_format == "dd/mm/yyyy" and d.start == "2024-05-13T10:00:00"
    np.testing.assert_allclose(d.t, 2 * t, atol=0)
    assert "read as dd/mm/yyyy (line 2 has a day above 12)" in d.notes[0]


def test_12_am_is_midnight_and_12_pm_is_noon():
    parse = TIME_FORMATS["mm/dd/yyyy"].parse
    assert parse is not None
    midnight = parse("5/1/2024 12:00:00 AM")
    noon = parse("5/1/2024 12:00:00 PM")
    assert midnight is not None and noon is not None
    assert noon[0] - midnight[0] == 12 * 3600
    assert parse("5/1/2024 13:00:00 PM") is None


# -- bad cells -----------------------------------------------------------------------------


def _with_bad_cells(tmp_path):
    t, u, y = bump(200, 30.0)
    lines = ["t;MV;PV"] + [f"{a:g};{b:g};{c:.6f}" for a, b, c in zip(t, u, y, strict=True)]
    lines[17] = f"{t[16]:g};{u[16]:g};I/O Timeout"
    lines[18] = f"{t[17]:g};;{y[17]:.6f}"
    lines[101] = f"{t[100]:g};Bad Input;{y[100]:.6f}"
    p = tmp_path / "pi.csv"
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return p, t, u, y


def test_an_io_timeout_cell_is_refused_naming_line_column_and_the_way_on(tmp_path):
    p, *_ = _with_bad_cells(tmp_path)
    with pytest.raises(DataFileError) as e:
        read_step_csv(p, "t", "MV", "PV")
    assert str(e.value) == (
        f"{p}, line 18, column 'PV': 'I/O Timeout' is not a number; 2 more row(s) like it "
        "(--bad-rows skip or interpolate, bad_rows=, to go on without such rows)"
    )


def test_bad_rows_skip_drops_them_and_says_where(tmp_path):
    p, t, _u, _y = _with_bad_cells(tmp_path)
    d = read_step_csv(p, "t", "MV", "PV", bad_rows="skip")
    assert len(d.t) == len(t) - 3 and 16 * H not in d.t
    assert d.notes[0] == (
        "skipped 3 row(s) with a bad cell: line 18 (PV: 'I/O Timeout' is not a number), "
        "line 19 (MV: empty cell), line 102 (MV: 'Bad Input' is not a number)"
    )


def test_bad_rows_interpolate_fills_the_pv_linearly_and_holds_the_mv(tmp_path):
    p, t, u, y = _with_bad_cells(tmp_path)
    d = read_step_csv(p, "t", "MV", "PV", bad_rows="interpolate")
    np.testing.assert_array_equal(d.t, t)
    assert d.y[16] == pytest.approx((y[15] + y[17]) / 2.0, abs=1e-6)
    assert d.u[17] == u[16] and d.u[100] == u[99]  # held, not interpolated
    assert "PV on line(s) 18 (interpolated)" in d.notes[0]
    assert "MV on line(s) 19, 102 (held)" in d.notes[0]


def test_duplicated_stamps_are_refused_or_dropped(tmp_path):
    t, u, y = bump(40, 5.0)
    lines = ["t;MV;PV"] + [f"{a:g};{b:g};{c:.6f}" for a, b, c in zip(t, u, y, strict=True)]
    lines.insert(6, lines[5])
    p = tmp_path / "dup.csv"
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(DataFileError, match=r"line 7, column 't': time 2 repeats line 6 "
                       r"\(a duplicated stamp; --bad-rows skip"):  # fmt: skip
        read_step_csv(p, "t", "MV", "PV")
    d = read_step_csv(p, "t", "MV", "PV", bad_rows="skip")
    np.testing.assert_array_equal(d.t, t)
    assert "dropped 1 row(s) whose time repeats the row before: lines 7" in d.notes


# -- gaps and windows --------------------------------------------------------------------------


def _lost(tmp_path, first: int, last: int):
    t, u, y = bump(600, 90.0)
    keep = np.r_[0:first, last : len(t)]
    p = write(tmp_path / "lost.csv", "t [s];MV;PV", [f"{x:g}" for x in t[keep]], u[keep], y[keep],
              sep=",", dec=".")  # fmt: skip
    return p, t[keep], u[keep], y[keep]


def test_lost_data_in_the_bump_test_is_refused_then_kept_as_time_that_passed(tmp_path):
    p, t, _u, _y = _lost(tmp_path, 300, 330)  # 15 s lost while the PV rises
    with pytest.raises(DataFileError) as e:
        read_step_csv(p, "t", "MV", "PV")
    assert (e.value.line, e.value.column) == (302, "t")
    assert (  # the example of docs/tuning.md
        "time jumps 15.5 s from line 301 (149.5) to line 302 (165), 31 times the median sample "
        "time 0.5 s, inside the experiment (after MV first moves on line 182)"
    ) in str(e.value)
    d = read_step_csv(p, "t", "MV", "PV", gaps="keep")
    np.testing.assert_array_equal(d.t, t)
    m = fit_fopdt(d.t, d.u, d.y)
    assert m.dead_time == pytest.approx(L, rel=1e-3)
    assert "kept as time that passed" in d.notes[0]


def test_a_gap_before_the_step_is_kept_with_a_note(tmp_path):
    p, t, _u, _y = _lost(tmp_path, 50, 80)
    d = read_step_csv(p, "t", "MV", "PV")
    np.testing.assert_array_equal(d.t, t - t[0])
    assert "before the experiment starts (MV first moves on line 152), kept" in d.notes[0]


def test_a_gap_the_step_falls_into_is_refused_even_when_kept(tmp_path):
    p, *_ = _lost(tmp_path, 170, 200)  # the MV moves at sample 180
    with pytest.raises(DataFileError, match=r"MV moves across it \(50 -> 60\): when it moved is "
                       "lost, and with it the dead time"):  # fmt: skip
        read_step_csv(p, "t", "MV", "PV", gaps="keep")


def test_gaps_close_removes_a_clock_jump(tmp_path):
    t, _, _ = bump()
    p = dst_file(tmp_path, 3)
    d = read_step_csv(p, "Zeit", "MV", "PV", gaps="close")
    np.testing.assert_allclose(d.t, t, rtol=0, atol=1e-6)
    assert "closed to one sample time" in d.notes[0]


def test_start_and_end_cut_a_long_export_to_the_bump_test(tmp_path):
    t, u, y = bump()
    start = datetime.datetime(2024, 5, 1, 10, 0, tzinfo=UTC)
    cells = local_cells(start, t)
    lines_ = ["Zeit;MV;PV"] + [f"{c};{a:g};{b:.6f}".replace(".", ",", 0) for c, a, b in
                               zip(cells, u, y, strict=True)]  # fmt: skip
    lines_[5] = "01.05.2024 12:00:02,000;I/O Timeout;40"  # outside the window: not read
    p = tmp_path / "long.csv"
    p.write_text("\n".join(lines_) + "\n", encoding="utf-8")
    d = read_step_csv(p, "Zeit", "MV", "PV", start="01.05.2024 12:00:30,000",
                      end="01.05.2024 12:03:00")  # fmt: skip
    np.testing.assert_allclose(d.t, t[60:361] - 30.0, rtol=0, atol=1e-6)
    assert d.start == "2024-05-01T12:00:30"
    assert d.notes[0] == "start/end: lines 62-362 read (301 of 600 rows)"
    rec = read_record(p, "Zeit", ["PV"], start="2024-05-01T12:04:00")
    assert rec.lines[0] == 482 and rec.values["PV"][0] == pytest.approx(y[480], abs=1e-6)
    with pytest.raises(DataFileError, match="no row from start"):
        read_step_csv(p, "Zeit", "MV", "PV", start="02.05.2024 00:00:00")


# -- layout ---------------------------------------------------------------------------------


def test_metadata_lines_before_the_header_and_excels_sep_line_are_skipped(tmp_path):
    t, u, y = bump(40, 5.0)
    rows = zip(t, u, y, strict=True)
    body = "\n".join(f"{a:g};{b:g};{c:.6f}".replace(".", ",") for a, b, c in rows)
    p = tmp_path / "m.csv"
    p.write_bytes(("\ufeffsep=;\r\nExport of 01.05.2024\r\nTag;FIC101;TIC101\r\nt [s];MV;PV\r\n"
                   + body.replace("\n", "\r\n")).encode("utf-8"))  # fmt: skip
    d = read_step_csv(p, "t", "MV", "PV")
    np.testing.assert_allclose(d.t, t)
    assert (d.delimiter, d.decimal) == (";", ",")
    assert d.notes == ("lines 1-3 before the header row skipped",)


def test_text_columns_come_back_as_text_beside_the_numbers(tmp_path):
    p = tmp_path / "loop.csv"
    rows = [f"{i},{'AUTO' if i % 7 else 'MAN'},{i * 0.5}" for i in range(20)]
    p.write_text("t,mode,pv\n" + "\n".join(rows) + "\n", encoding="utf-8")
    rec = read_record(p, "t", ["pv"], text_columns=["mode"])
    assert rec.text["mode"][:8] == ("MAN", *["AUTO"] * 6, "MAN")
    np.testing.assert_array_equal(rec.values["pv"], np.arange(20) * 0.5)


# -- the command line ---------------------------------------------------------------------------


def test_identify_reads_the_dst_export_with_tz_and_refuses_it_without(tmp_path):
    p = dst_file(tmp_path, 3)
    args = ["identify", p, "--time", "Zeit", "--u", "MV", "--y", "PV", "--json"]
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 1 and isinstance(r.exception, SystemExit)
    last = r.output.strip().splitlines()[-1]
    assert last.startswith(f"Error: {p}, line 242, column 'Zeit': time jumps 3600 s")
    r = CliRunner().invoke(main, [*args, "--tz", "Europe/Berlin"])
    assert r.exit_code == 0, r.output
    assert "note: " in r.stderr and "converted to UTC" in r.stderr
    import json

    out = json.loads(r.stdout)
    assert out["dead_time"] == pytest.approx(L, rel=1e-3)


@pytest.mark.parametrize(
    ("option", "value", "error"),
    [
        ("--tz", "Mars/Olympus", "unknown time zone 'Mars/Olympus'"),
        ("--time-format", "hh:mm", "time_format must be auto, seconds, iso"),
        ("--start", "yesterday", "start = 'yesterday' is not a time like those"),
        ("--end", "1e999x", "end = '1e999x' is not a time like those"),
    ],
)
def test_a_bad_reading_option_is_one_error_line(option, value, error):
    from pathlib import Path

    csv = str(Path(__file__).resolve().parents[2] / "docs" / "examples" / "bump_k2.csv")
    args = ["identify", csv, "--time", "time_s", "--u", "p_supply_bar", "--y", "p3_bar"]
    r = CliRunner().invoke(main, [*args, option, value])
    assert r.exit_code == 1 and isinstance(r.exception, SystemExit), r.output
    assert r.output.strip().splitlines()[-1].startswith("Error: ") and error in r.output


def test_the_tuning_guide_lists_every_time_format_and_reading_option():
    from pathlib import Path

    from ctrlblocks.tuning.records import CSV_OPTIONS

    text = (Path(__file__).resolve().parents[2] / "docs" / "tuning.md").read_text(encoding="utf-8")
    table = text[text.index("| `--time-format` | looks like |") :].split("\n\n")[0]
    listed = {row.split("`")[1] for row in table.splitlines()[2:] if row.startswith("| `")}
    assert listed == set(TIME_FORMATS)
    for name in CSV_OPTIONS:
        assert f"{name}=" in text or f"--{name.replace('_', '-')}" in text, name
