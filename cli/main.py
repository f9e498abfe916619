"""The ``flylog`` entry point. Subcommands import their heavy modules lazily so that
``--help`` answers at once."""

from __future__ import annotations

import importlib

import click

# command name → (module in flylog.cli, function name)
_COMMANDS = {
    "simulate": ("simulate", "simulate"),
    "replay": ("replay", "replay"),
    "metrics": ("metrics", "metrics"),
    "compare": ("compare", "compare"),
    "export": ("export", "export"),
    "experiment": ("experiment", "experiment"),
}


class _LazyGroup(click.Group):
    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(_COMMANDS)

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        if name not in _COMMANDS:
            return None
        module, attr = _COMMANDS[name]
        return getattr(importlib.import_module(f"flylog.cli.{module}"), attr)


@click.group(cls=_LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="flylog")
def cli() -> None:
    """flylog: simulate a stereo + sonar + odometry robot, replay its logs through the fly
    algorithm and a harmonic-function planner, and score the runs."""


def main() -> None:
    cli()
