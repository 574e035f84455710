"""The top-level command line: a help that imports no sub-command, texts that stay true."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from click.testing import CliRunner

from ctrlblocks import cli

HEAVY = ("scipy", "matplotlib", "numba", "pyarrow", "distributed", "asyncua", "fastapi")
#: third-party packages no ``--help`` may import (each is the library of one command's work)
HEAVY_ALL = (
    *HEAVY, "pymodbus", "psycopg", "uvicorn", "websockets", "httpx", "httpx2", "control", "dask"
)  # fmt: skip

PROBE = """
import json, sys
from ctrlblocks.cli import main
try:
    main({args!r})
except SystemExit:
    pass
print(json.dumps(sorted({{m.split(".")[0] for m in sys.modules}} & set({heavy!r}))))
print(json.dumps(sorted(m for m in sys.modules if m.startswith("ctrlblocks."))))
"""


def _imported(args: list[str]) -> tuple[list[str], list[str]]:
    out = subprocess.run([sys.executable, "-c", PROBE.format(args=args, heavy=HEAVY)],
                         capture_output=True, text=True, check=True, timeout=120)  # fmt: skip
    heavy, ours = (json.loads(line) for line in out.stdout.strip().splitlines()[-2:])
    return heavy, ours


def test_help_imports_neither_scipy_nor_matplotlib_nor_numba_nor_any_subcommand():
    heavy, ours = _imported(["--help"])
    assert heavy == []
    layers = ("sim", "fast", "plants", "tuning", "runtime", "web")
    assert not [m for m in ours if m.split(".")[1] in layers]


def test_help_lists_every_command_with_its_own_first_sentence():
    text = CliRunner().invoke(cli.main, ["--help"], terminal_width=200).output
    for name, (_target, summary) in cli._COMMANDS.items():
        assert f"{name}  " in text
        assert summary in text


@pytest.mark.parametrize("name", sorted(cli._COMMANDS))
def test_static_help_text_equals_the_commands_docstring(name: str):
    cmd = cli.load_command(name)
    assert cli._COMMANDS[name][1] == cmd.get_short_help_str(limit=10**6)


def test_sweep_help_does_not_import_numba_and_run_help_not_scipy_signal():
    heavy, _ = _imported(["sweep", "--help"])
    assert "numba" not in heavy and "matplotlib" not in heavy
    probe = PROBE.format(args=["run", "--help"], heavy=HEAVY) + (
        "print(json.dumps('scipy.signal' in sys.modules))\n"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True, timeout=120)  # fmt: skip
    assert json.loads(out.stdout.strip().splitlines()[-1]) is False


EVERY_HELP = """
import json, sys
from ctrlblocks.cli import _COMMANDS, main
heavy = set({heavy!r})
out = {{}}
for args in [[name] for name in sorted(_COMMANDS)] + [["tune", "pid"], ["tune", "adrc"]]:
    try:
        main([*args, "--help"])
    except SystemExit:
        pass
    out[" ".join(args)] = sorted({{m.split(".")[0] for m in sys.modules}} & heavy)
print(json.dumps(out))
"""


def test_every_commands_help_imports_no_heavy_library():
    # one process for all: a library any --help imported stays in sys.modules, so the
    # first command listing it is the one that imported it
    out = subprocess.run([sys.executable, "-c", EVERY_HELP.format(heavy=HEAVY_ALL)],
                         capture_output=True, text=True, check=True, timeout=180)  # fmt: skip
    imported = json.loads(out.stdout.strip().splitlines()[-1])
    assert len(imported) == len(cli._COMMANDS) + 2
    assert {name: mods for name, mods in imported.items() if mods} == {}


def test_lazy_package_exports_import_their_module_on_first_use():
    probe = ("import json, sys, ctrlblocks.runtime as r, ctrlblocks.tuning as t\n"
             "before = ['ctrlblocks.runtime.historian' in sys.modules, 'scipy' in sys.modules]\n"
             "from ctrlblocks.runtime import export_history\n"
             "simc = t.simc\n"
             "print(json.dumps([before, export_history.__module__, simc.__module__,\n"
             "                  'simc' in dir(t)]))")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True, timeout=120)  # fmt: skip
    before, hist_mod, simc_mod, listed = json.loads(out.stdout.strip())
    assert before == [False, False]
    assert (hist_mod, simc_mod, listed) == ("ctrlblocks.runtime.historian",
                                            "ctrlblocks.tuning.pid_rules", True)  # fmt: skip
    import ctrlblocks.tuning

    with pytest.raises(AttributeError, match="no attribute 'nonexistent'"):
        ctrlblocks.tuning.nonexistent  # noqa: B018


def test_import_ctrlblocks_plants_does_not_import_scipy():
    probe = "import sys, ctrlblocks.plants; print('scipy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True, timeout=120)  # fmt: skip
    assert out.stdout.strip() == "False"
