"""``ctrlblocks assess`` on a CSV and on a historian file; user mistakes are one line."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import pytest
from click.testing import CliRunner

from ctrlblocks.cli import main
from ctrlblocks.health.faults import simulate


def _csv(tmp_path: Path, kind: str = "manual") -> Path:
    c = simulate(kind, 0, hours=1.0)
    d = c.data
    p = tmp_path / "loop.csv"
    lines = ["t [s];sp;pv [degC];mv [%];mode"]
    lines += [
        f"{t:g};{s:.4f};{y:.4f};{u:.4f};{'MAN' if m != 'AUTO' else 'AUTO'}".replace(".", ",")
        for t, s, y, u, m in zip(d.t, d.sp, d.y, d.u, d.mode, strict=True)
    ]
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return p


def test_assess_a_csv_with_decimal_commas_finds_the_loop_left_in_manual(tmp_path: Path) -> None:
    p = _csv(tmp_path)
    r = CliRunner().invoke(
        main,
        [
            "assess",
            str(p),
            "--time",
            "t",
            "--sp",
            "sp",
            "--y",
            "pv",
            "--u",
            "mv",
            "--mode",
            "mode",
            "--u-min",
            "0",
            "--u-max",
            "100",
            "--out",
            str(tmp_path / "out"),
            "--json",
        ],
    )
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    kinds = [f["kind"] for f in doc["findings"]]
    assert "manual" in kinds
    f = doc["findings"][kinds.index("manual")]
    assert f["loop"] == "loop" and f["figures"]["time_not_auto"] > 0.1
    assert (tmp_path / "out" / "report.md").is_file() and (tmp_path / "out" / "loop.png").is_file()


def _historian(tmp_path: Path) -> Path:
    from ctrlblocks.runtime.historian import SQLiteHistorian

    db = tmp_path / "h.sqlite"
    h = SQLiteHistorian(db)
    h.open()
    h.close()
    con = sqlite3.connect(db)
    for _j, kind in enumerate(("healthy", "saturated")):
        d = simulate(kind, 1, hours=1.0).data
        con.executemany(
            "INSERT INTO samples (run_id, loop, cycle, t_wall, t, dt, sp, pv, mv, mode, error_id,"
            " pv_ok, write_ok, overrun) VALUES (1, ?, ?, ?, ?, 1.0, ?, ?, ?, ?, 0, 1, 1, 0)",
            [
                (kind, i, 1.7e9 + t, t, s, y, u, m.lower())
                for i, (t, s, y, u, m) in enumerate(zip(d.t, d.sp, d.y, d.u, d.mode, strict=True))
            ],
        )
    con.commit()
    con.close()
    return db


def test_assess_a_historian_file_per_loop_and_in_a_window(tmp_path: Path) -> None:
    db = _historian(tmp_path)
    r = CliRunner().invoke(
        main,
        [
            "assess",
            str(db),
            "--u-min",
            "0",
            "--u-max",
            "100",
            "--pv-span",
            "100",
            "--out",
            str(tmp_path / "o"),
            "--json",
        ],
    )
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    by_loop = {x["loop"]: [f["kind"] for f in x["findings"]] for x in doc["loops"]}
    assert by_loop["healthy"] == [] and "saturation" in by_loop["saturated"]
    r = CliRunner().invoke(
        main,
        [
            "assess",
            str(db),
            "--loop",
            "healthy",
            "--start",
            str(1.7e9 + 600),
            "--end",
            str(1.7e9 + 1800),
            "--no-plots",
            "--out",
            str(tmp_path / "w"),
            "--json",
        ],
    )
    loop = json.loads(r.stdout)["loops"][0]
    assert loop["figures"]["duration_s"] == pytest.approx(1201.0)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["nope.csv", "--time", "t"], "no such file"),
        (["{csv}", "--time", "t", "--sp", "sp", "--y", "pv"], "needs --u"),
        (["{csv}", "--time", "t", "--sp", "x", "--y", "pv", "--u", "mv"], "no such column"),
        (["{db}", "--loop", "nope"], "no loop nope"),
        (["{db}", "--gain", "1"], "needs --gain, --time-constant and --dead-time"),
        (["{db}", "--start", "yesterday"], "neither seconds nor an ISO 8601 time"),
    ],
)
def test_user_mistakes_are_one_line_without_a_traceback(tmp_path: Path, args, message) -> None:
    csv, db = _csv(tmp_path), _historian(tmp_path)
    args = [a.format(csv=csv, db=db) for a in args]
    r = CliRunner().invoke(main, ["assess", *args, "--out", str(tmp_path / "o")])
    assert r.exit_code in (1, 2)
    assert message in r.output and "Traceback" not in r.output
