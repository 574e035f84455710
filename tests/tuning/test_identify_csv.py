"""Bump-test CSV files as people have them: read by the Python API and ``ctrlblocks identify``.

A step at the first sample, European exports (``;`` and decimal commas), ISO
8601 timestamps, Windows-1252 files, units in the header; and no traceback
for a plot that cannot be written.
"""

from __future__ import annotations

import datetime
import json

import numpy as np
import pytest
from click.testing import CliRunner

from ctrlblocks.cli import main
from ctrlblocks.tuning import DataFileError, fit_fopdt, read_step_csv

K, T, L = 2.0, 5.0, 1.0
H = 0.25
TIMES = np.arange(0.0, 50.0, H)


def unit_step_response(t: np.ndarray) -> np.ndarray:
    """FOPDT ``K e^{-L s}/(T s + 1)`` to a unit step at t = 0, from rest."""
    return np.where(t > L, K * (1.0 - np.exp(-(t - L) / T)), 0.0)


def write(path, header: str, rows, *, sep: str = ",", decimal: str = ".", encoding="utf-8"):
    def cell(x):
        s = x if isinstance(x, str) else repr(float(x))
        return s.replace(".", ",") if decimal == "," and not isinstance(x, str) else s

    text = header + "\n" + "".join(sep.join(cell(x) for x in r) + "\n" for r in rows)
    path.write_bytes(text.encode(encoding))
    return path


def test_a_step_at_the_first_sample_identifies_exactly_with_u_before(tmp_path) -> None:
    rows = zip(TIMES, np.ones_like(TIMES), unit_step_response(TIMES), strict=True)
    p = write(tmp_path / "b.csv", "t,u,y", rows)
    with pytest.raises(DataFileError, match=r"never changes .*u_before"):
        read_step_csv(p)
    d = read_step_csv(p, u_before=0.0)
    assert (d.t[0], d.u[0], d.y[0]) == (-H, 0.0, 0.0)
    assert len(d.t) == len(TIMES) + 1
    m = fit_fopdt(d.t, d.u, d.y)
    assert (m.gain, m.time_constant, m.dead_time) == pytest.approx((K, T, L), rel=1e-6)
    assert m.fit < 1e-6


def test_semicolons_with_decimal_commas_are_detected(tmp_path) -> None:
    u = np.where(TIMES >= 5.0, 1.5, 0.5)
    y = 3.0 + unit_step_response(TIMES - 5.0)
    p = write(
        tmp_path / "eu.csv", "Zeit;MV;PV", zip(TIMES, u, y, strict=True), sep=";", decimal=","
    )
    assert "0,25;0,5;3,0" in p.read_text()
    d = read_step_csv(p, time="Zeit", u="MV", y="PV")
    assert (d.delimiter, d.decimal) == (";", ",")
    np.testing.assert_array_equal(d.t, TIMES)
    np.testing.assert_array_equal(d.u, u)
    np.testing.assert_allclose(d.y, y, rtol=0, atol=1e-15)


def test_delimiter_and_decimal_can_be_given(tmp_path) -> None:
    rows = [(f"{t:.2f}".replace(".", ","), "1" if t >= 1 else "0", "1.234,5") for t in TIMES]
    p = write(tmp_path / "x.csv", "t\tu\ty", rows, sep="\t")
    d = read_step_csv(p, delimiter="\t", decimal=",")
    assert d.y[0] == 1234.5  # the '.' is a thousands separator with a decimal comma
    assert d.t[3] == 0.75
    with pytest.raises(ValueError, match="another delimiter"):
        read_step_csv(p, delimiter=",", decimal=",")


@pytest.mark.parametrize(
    "zone", [None, datetime.timezone.utc, datetime.timezone(datetime.timedelta(hours=2))]
)
def test_iso_8601_timestamps_become_seconds_from_the_first(tmp_path, zone) -> None:
    t0 = datetime.datetime(2024, 3, 31, 0, 59, 50, tzinfo=zone)
    stamps = [(t0 + datetime.timedelta(seconds=float(t))).isoformat() for t in TIMES]
    if zone is datetime.timezone.utc:
        stamps = [s.replace("+00:00", "Z") for s in stamps]
    u = np.where(TIMES >= 5.0, 1.0, 0.0)
    p = write(
        tmp_path / "iso.csv",
        "time,u,y",
        zip(stamps, u, unit_step_response(TIMES - 5.0), strict=True),
    )
    d = read_step_csv(p, time="time")
    np.testing.assert_allclose(d.t, TIMES, rtol=0, atol=1e-9)
    assert d.start == t0.isoformat()


def test_mixed_time_zones_and_bad_timestamps_name_the_line(tmp_path) -> None:
    rows = [("2024-01-01T00:00:00", 0, 0), ("2024-01-01T00:00:01+01:00", 1, 0)] + [
        (f"2024-01-01T00:00:{i:02d}", 1, 1) for i in range(2, 12)
    ]
    p = write(tmp_path / "mix.csv", "t,u,y", rows)
    with pytest.raises(DataFileError) as e:
        read_step_csv(p)
    assert (e.value.line, e.value.column) == (3, "t") and "time zone are mixed" in str(e.value)
    rows[1] = ("yesterday", 1, 0)
    p = write(tmp_path / "bad.csv", "t,u,y", rows)
    with pytest.raises(
        DataFileError,
        match=r"line 3, column 't': 'yesterday' is not a time in the format of the rows above "
        r"\(ISO 8601",
    ):
        read_step_csv(p)


def test_a_windows_1252_file_is_read_with_a_note_saying_so(tmp_path) -> None:
    u = np.where(TIMES >= 5.0, 1.0, 0.0)
    rows = zip(TIMES, u, unit_step_response(TIMES - 5.0), strict=True)
    p = write(tmp_path / "excel.csv", "t;u [%];Temperatur [°C]", rows, sep=";", encoding="cp1252")
    d = read_step_csv(p, y="Temperatur")
    assert d.encoding == "cp1252" and d.y_unit == "°C" and d.u_unit == "%"
    assert any("Windows-1252" in n for n in d.notes)
    d = read_step_csv(p, y="Temperatur", encoding="latin-1")
    assert d.encoding == "latin-1" and d.notes == () and d.y_unit == "°C"
    with pytest.raises(DataFileError, match=r"line 1: not valid utf-8"):
        read_step_csv(p, y="Temperatur", encoding="utf-8")


def test_units_from_the_header_and_a_time_unit_in_minutes(tmp_path) -> None:
    u = np.where(TIMES >= 5.0, 1.0, 0.0)
    rows = zip(TIMES / 60.0, u, 2.0 * u, strict=True)
    p = write(tmp_path / "u.csv", "time [min],mv (%),pv [bar]", rows)
    d = read_step_csv(p, time="time", u="mv", y="pv [bar]")
    assert (d.u_unit, d.y_unit) == ("%", "bar")
    np.testing.assert_allclose(d.t, TIMES, rtol=1e-12)


# -- the command line ------------------------------------------------------------------


def _excel_file(tmp_path):
    u = np.ones_like(TIMES)
    rows = zip(TIMES, u, 20.0 + unit_step_response(TIMES), strict=True)
    return write(tmp_path / "e.csv", "Zeit;Ventil [%];T [°C]", rows, sep=";", decimal=",",
                 encoding="cp1252")  # fmt: skip


def test_identify_reads_an_excel_export_with_units_in_the_json(tmp_path) -> None:
    p = _excel_file(tmp_path)
    args = ["identify", str(p), "--time", "Zeit", "--u", "Ventil", "--y", "T"]
    res = CliRunner().invoke(main, [*args, "--json"])
    assert res.exit_code == 1
    assert "--u-before" in res.output and "Traceback" not in res.output
    res = CliRunner().invoke(main, [*args, "--json", "--u-before", "0"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    assert (out["gain"], out["time_constant"], out["dead_time"]) == pytest.approx((K, T, L), 1e-6)
    assert (out["y_unit"], out["u_unit"], out["gain_unit"]) == ("°C", "%", "°C/%")
    assert out["encoding"] == "cp1252"
    assert "note:" in res.stderr and "Windows-1252" in res.stderr
    res = CliRunner().invoke(main, [*args, "--json", "--u-before", "0", "--y-unit", "K"])
    assert json.loads(res.stdout)["gain_unit"] == "K/%"


def test_identify_plot_axes_carry_names_and_units(tmp_path, monkeypatch) -> None:
    import ctrlblocks.tuning.plot as tplot

    seen = {}
    real = tplot.plot_identification

    def spy(*a, **kw):
        seen.update(kw)
        return real(*a, **kw)

    monkeypatch.setattr(tplot, "plot_identification", spy)
    p = _excel_file(tmp_path)
    png = tmp_path / "fit.png"
    res = CliRunner().invoke(
        main,
        ["identify", str(p), "--time", "Zeit", "--u", "Ventil", "--y", "T", "--u-before", "0",
         "--plot", str(png)],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    assert (seen["y_label"], seen["u_label"]) == ("PV: T [°C]", "MV: Ventil [%]")
    assert png.stat().st_size > 10_000


def test_identify_plot_into_a_missing_directory_is_an_error_not_a_traceback(tmp_path) -> None:
    p = _excel_file(tmp_path)
    png = tmp_path / "nonexist" / "d" / "fit.png"
    res = CliRunner().invoke(
        main,
        ["identify", str(p), "--time", "Zeit", "--u", "Ventil", "--y", "T", "--u-before", "0",
         "--plot", str(png)],
    )  # fmt: skip
    assert res.exit_code == 1 and isinstance(res.exception, SystemExit)
    assert f"--plot {png}: no such directory {png.parent}" in res.output
