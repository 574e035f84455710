"""The top-level command line: a help that imports no sub-command, texts that stay true."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from click.testing import CliRunner

from ctrlblocks import cli

HEAVY = ("scipy", "matplotlib", "numba", "pyarrow", "distributed", "asyncua", "fastapi")

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


def test_import_ctrlblocks_plants_does_not_import_scipy():
    probe = "import sys, ctrlblocks.plants; print('scipy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True, timeout=120)  # fmt: skip
    assert out.stdout.strip() == "False"
