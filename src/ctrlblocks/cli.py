"""The ``ctrlblocks`` command line.

Sub-commands live next to the code they drive and are imported only when
used, so ``ctrlblocks --help`` stays fast and an optional extra that is not
installed only affects its own command.
"""

from __future__ import annotations

import importlib

import click

# command name -> "module:attribute"; each module owns its command.
_COMMANDS: dict[str, str] = {
    "identify": "ctrlblocks.tuning.cli:identify",
    "tune": "ctrlblocks.tuning.cli:tune",
    "reproduce": "ctrlblocks.sim.cli:reproduce",
    "run": "ctrlblocks.sim.cli:run",
    "serve": "ctrlblocks.web.cli:serve",
    "plant-server": "ctrlblocks.runtime.cli:plant_server",
    "operator": "ctrlblocks.web.cli:operator",
    "history": "ctrlblocks.runtime.cli:history",
    "sweep": "ctrlblocks.fast.cli:sweep_command",
}


class _LazyGroup(click.Group):
    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*super().list_commands(ctx), *_COMMANDS})

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name in _COMMANDS:
            module_name, attr = _COMMANDS[cmd_name].split(":")
            return getattr(importlib.import_module(module_name), attr)
        return super().get_command(ctx, cmd_name)


@click.group(cls=_LazyGroup)
@click.version_option(package_name="ctrlblocks")
def main() -> None:
    """Industrial control function blocks: PID, ADRC, lead-lag, tuning and simulation."""
