"""A seeded mutation campaign over a bump-test CSV file: identify (and compare) it.

The contract: a record that cannot be used is refused in one line that names
the file, the line and the column (or, for a record too short or flat to fit,
says why); nothing but the command's error leaves it.  Each case takes the
shipped example (docs/examples/bump_k2.csv) and changes it once: a cell
becomes ``nan``, ``inf``, empty, text, ``1e308``, ``1e-320``, ``1,5`` ...; a line
is deleted, doubled, swapped with another or gets an extra column; the file is
cut to a few lines; the header renames a column; a time becomes ``1e308``; the
time jumps by an hour forward or back (a clock) or by 30 s (a hole).  Every
other case, and every ``compare`` case, adds reading options with right, wrong
or absurd values (``--bad-rows``, ``--gaps``, ``--tz``, ``--time-format``,
``--start``, ``--end``).

Found before the fix of the same commit: a value of ``-1e308`` (finite, so
accepted) made every fit fail inside scipy ("array must not contain infs or
NaNs", "`dydx` must contain only finite values") with no line and no column.
"""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from ctrlblocks.cli import main
from ctrlblocks.tuning import fit_fopdt
from ctrlblocks.tuning.identify import MAX_MAGNITUDE

ROOT = Path(__file__).resolve().parents[2]
SOURCE = (ROOT / "docs" / "examples" / "bump_k2.csv").read_text(encoding="utf-8").splitlines()
HOSTILE = ("nan", "inf", "-inf", "", "abc", "1e308", "-1e308", "1e-320", "0", "1,5", '"x"', " ",
           "I/O Timeout", "Bad Input", "2024-05-01T12:00:00", "31.03.2024 02:30:00,5")  # fmt: skip
# the reading options, each with values a user might give (right, wrong or absurd)
READING = {
    "--bad-rows": ("skip", "interpolate", "refuse"),
    "--gaps": ("keep", "close", "refuse"),
    "--tz": ("Europe/Berlin", "UTC", "+02:00", "Mars/Base", ""),
    "--time-format": ("seconds", "excel", "epoch", "epoch-ms", "iso", "%H", "%Q", "x"),
    "--start": ("10", "40.5", "-1e308", "nan", "2024-05-01", "abc", ""),
    "--end": ("60", "1e308", "5", "inf", "31.12.2099 00:00:00", ""),
}
COLUMNS = ["--time", "time_s", "--u", "p_supply_bar", "--y", "p3_bar"]


def mutate(rng: random.Random) -> tuple[list[str], str]:
    lines = list(SOURCE)
    i = rng.randrange(1, len(lines))
    op = rng.random()
    if op < 0.5:
        cells = lines[i].split(",")
        j = rng.randrange(len(cells))
        cells[j] = rng.choice(HOSTILE)
        lines[i] = ",".join(cells)
        return lines, f"line {i + 1} -> {lines[i]}"
    if op < 0.6:
        del lines[i]
        return lines, f"line {i + 1} deleted"
    if op < 0.7:
        lines.insert(i, lines[i])
        return lines, f"line {i + 1} doubled"
    if op < 0.8:
        lines[i] += ",7"
        return lines, f"line {i + 1} with an extra column"
    if op < 0.85:
        n = rng.randrange(1, 5)
        return lines[:n], f"cut to {n} lines"
    if op < 0.9:
        j = rng.randrange(1, len(lines))
        lines[i], lines[j] = lines[j], lines[i]
        return lines, f"lines {i + 1} and {j + 1} swapped"
    if op < 0.93:
        lines[0] = lines[0].replace("p3_bar", "p3")
        return lines, "the PV column renamed"
    if op < 0.95:
        cells = lines[i].split(",")
        cells[0] = "1e308"
        lines[i] = ",".join(cells)
        return lines, f"line {i + 1}: time 1e308"
    shift = rng.choice((3600.0, -3600.0, 30.0))  # a clock jump, a hole
    for j in range(i, len(lines)):
        cells = lines[j].split(",")
        try:
            cells[0] = repr(float(cells[0]) + shift)
        except ValueError:
            continue
        lines[j] = ",".join(cells)
    return lines, f"time from line {i + 1} on shifted by {shift:g} s"


def reading_options(rng: random.Random) -> list[str]:
    """Zero to three reading options with random values."""
    out: list[str] = []
    for opt in rng.sample(sorted(READING), rng.randrange(0, 4)):
        out += [opt, rng.choice(READING[opt])]
    return out


def _check(args: list[str], what: str) -> str:
    r = CliRunner().invoke(main, args)
    if r.exception is not None and not isinstance(r.exception, SystemExit):
        raise AssertionError(f"{what}: {r.exception!r}")
    if r.exit_code != 0:
        last = r.output.strip().splitlines()[-1]
        assert r.exit_code == 1 and last.startswith("Error: "), (what, r.output)
        return last
    return ""


@pytest.mark.slow  # a mutation campaign (pytest -m slow)
def test_identify_a_mutated_bump_test_gives_a_model_or_names_the_line(tmp_path):
    rng = random.Random(5)
    refused = 0
    for k in range(160):
        lines, what = mutate(rng)
        path = tmp_path / f"m{k}.csv"
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
        opts = reading_options(rng) if k % 2 else []
        last = _check(["identify", str(path), *COLUMNS, *opts], f"{what} {opts}")
        if last:
            refused += 1
            if "is not a number" in last or "beyond" in last or "empty cell" in last:
                assert f"{path}, line " in last and "column" in last, (what, last)
    assert refused > 40


@pytest.mark.slow  # a mutation campaign (pytest -m slow)
def test_compare_a_mutated_bump_test_gives_a_report_or_an_error_line(tmp_path):
    rng = random.Random(6)
    for k in range(12):
        lines, what = mutate(rng)
        path = tmp_path / f"c{k}.csv"
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
        opts = reading_options(rng)
        _check(["compare", str(path), *COLUMNS, *opts, "--no-corners", "--out",
                str(tmp_path / "o")], f"{what} {opts}")  # fmt: skip


def test_a_value_beyond_what_the_fits_can_square_is_refused_at_its_line(tmp_path):
    lines = list(SOURCE)
    lines[154] = lines[154].rsplit(",", 1)[0] + ",-1e308"
    path = tmp_path / "big.csv"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    last = _check(["identify", str(path), *COLUMNS], "y = -1e308")
    assert last.startswith(f"Error: {path}, line 155, column 'p3_bar': '-1e308' is beyond")


def test_the_python_fits_refuse_such_a_value_with_its_index():
    t = np.arange(0.0, 50.0, 0.5)
    u = np.where(t >= 5.0, 1.0, 0.0)
    y = 1.0 - np.exp(-np.clip(t - 6.0, 0.0, None) / 4.0)
    y[30] = -2 * MAX_MAGNITUDE
    with pytest.raises(ValueError, match=r"y\[30\] = -2e\+150 is beyond"):
        fit_fopdt(t, u, y)
