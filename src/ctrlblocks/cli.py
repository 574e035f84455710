"""The ``ctrlblocks`` command line.

Sub-commands live next to the code they drive and are imported only when
used.  ``ctrlblocks --help`` lists them from the static one-line texts below,
so it imports none of them (no numpy, scipy, matplotlib or numba: it starts
in about the time of ``python -c "import numpy"``), and an optional extra that
is not installed only affects its own command.  ``tests/test_cli.py`` checks
that each text equals its command's own first docstring sentence.
"""

from __future__ import annotations

import importlib

import click

# command name -> ("module:attribute", the first sentence of its docstring);
# each module owns its command.
_COMMANDS: dict[str, tuple[str, str]] = {
    "assess": (
        "ctrlblocks.health.cli:assess_command",
        "Assess the performance of loops from a historian file or a CSV; write a report.",
    ),
    "compare": (
        "ctrlblocks.sim.cli:compare_command",
        "Compare ADRC and PID tunings on the process of a bump test in FILE (CSV).",
    ),
    "compile": (
        "ctrlblocks.blocks.cli:compile_command",
        "Build the optional compiled PID and ADRC blocks (Cython) for this Python and source.",
    ),
    "export": (
        "ctrlblocks.plc.cli:export_command",
        "Export a tuned PID, ADRC or LeadLag as PLC code (IEC 61131-3 ST, TIA SCL, PLCopen XML).",
    ),
    "history": (
        "ctrlblocks.runtime.cli:history",
        "Export the historian DATABASE (SQLite file) to OUT (.csv or .parquet).",
    ),
    "identify": (
        "ctrlblocks.tuning.cli:identify",
        "Identify a process model from a bump test in FILE (CSV with a header row).",
    ),
    "operator": (
        "ctrlblocks.web.cli:operator",
        "Manage the operators of the faceplate (users file with scrypt password hashes).",
    ),
    "plant-server": (
        "ctrlblocks.runtime.cli:plant_server",
        "Serve the plant of SCENARIO over OPC UA and Modbus TCP until SIGINT/SIGTERM.",
    ),
    "reproduce": (
        "ctrlblocks.sim.cli:reproduce",
        "Run the shipped scenarios (all, or NAMES) and write report.md with plots and metrics.",
    ),
    "run": (
        "ctrlblocks.sim.cli:run",
        "Run SCENARIO_FILE (TOML): every controller in every case; write traces, metrics, plots.",
    ),
    "serve": (
        "ctrlblocks.web.cli:serve",
        "Run the loops of CONFIG (runtime TOML) with the web faceplate.",
    ),
    "sweep": (
        "ctrlblocks.fast.cli:sweep_command",
        "Run SCENARIO (a TOML file or a shipped name) for every combination of --vary values.",
    ),
    "tune-live": (
        "ctrlblocks.web.tune_cli:tune_live",
        "Auto-tune a loop of a running 'ctrlblocks serve' live: a step or relay test, then accept.",
    ),
    "tune": (
        "ctrlblocks.tuning.cli:tune",
        "Controller settings from an FOPDT model (gain, time constant, dead time).",
    ),
}


def load_command(name: str) -> click.Command:
    """Import the module of sub-command ``name`` and return its command."""
    module_name, attr = _COMMANDS[name][0].split(":")
    return getattr(importlib.import_module(module_name), attr)  # type: ignore[no-any-return]


class _LazyGroup(click.Group):
    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*super().list_commands(ctx), *_COMMANDS})

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name in _COMMANDS:
            return load_command(cmd_name)
        return super().get_command(ctx, cmd_name)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """The command list from the static texts (imports no sub-command)."""
        names = self.list_commands(ctx)
        listed = [
            (n, click.Command(n, help=_COMMANDS[n][1]) if n in _COMMANDS else self.commands[n])
            for n in names
        ]
        listed = [(n, c) for n, c in listed if not c.hidden]
        if not listed:
            return
        limit = formatter.width - 6 - max(len(n) for n, _ in listed)
        with formatter.section("Commands"):
            formatter.write_dl([(n, c.get_short_help_str(limit)) for n, c in listed])


@click.group(cls=_LazyGroup)
@click.version_option(package_name="ctrlblocks")
def main() -> None:
    """Industrial control function blocks: PID, ADRC, lead-lag, tuning and simulation."""
