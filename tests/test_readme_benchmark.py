"""The README's performance table is what ``python benchmarks/run.py --readme`` prints.

The README used to say "about 30 ns per sample" where a run under load measured
75-112 ns: a number without its conditions, typed from an earlier run.  The
table now sits between two markers, ``benchmarks/run.py --readme`` prints it
from a run (with the machine, the load average and the date), and ``--update
README.md`` writes it in.  This test keeps the two in step: the README's block
has the rows and the header the benchmark writes, and the benchmark's own
formatting and in-place update work (on made-up timings; the timing is the
benchmark's job, not a test's).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _run_module():
    spec = importlib.util.spec_from_file_location("bench_run", ROOT / "benchmarks" / "run.py")
    assert spec and spec.loader
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _rows(run):
    return [
        {"comparison": name, "ctrlblocks": "30 / 31.5 ns", "peer": "C -O2 (x): 27 / 28 ns",
         "ratio min/min": 1.11, "ratio med/med": 1.125}
        for name, _ in run.README_ROWS
    ]  # fmt: skip


def test_the_readme_block_has_the_rows_the_benchmark_prints():
    run = _run_module()
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    block = readme[readme.index(run.README_BEGIN) : readme.index(run.README_END)]
    made = run.readme_table(_rows(run), "conditions")
    n = 3 + len(run.README_ROWS)  # the marker, the header, |---|, the rows
    assert block.splitlines()[0] == made.splitlines()[0] == run.README_BEGIN
    for a, b in zip(block.splitlines()[1:n], made.splitlines()[1:n], strict=True):
        assert a.split("|")[1] == b.split("|")[1]  # the header and the row labels
    assert "load average" in block and "Medians of" in block


def test_the_benchmark_writes_its_table_between_the_markers(tmp_path):
    run = _run_module()
    table = run.readme_table(_rows(run), "Medians of 3 rounds, load average 0.5.")
    assert "| 31.5 ns | 28 ns (C -O2 (x)) | 1.12x |" in table
    p = tmp_path / "README.md"
    p.write_text(f"before\n{run.README_BEGIN}\nold\n{run.README_END}\nafter\n", encoding="utf-8")
    run.update_readme(p, table)
    assert p.read_text(encoding="utf-8") == f"before\n{table}\nafter\n"
