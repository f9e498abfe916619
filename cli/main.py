"""The ``flylog`` entry point. Subcommands import their heavy modules lazily."""

from __future__ import annotations

import click


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="flylog")
def cli() -> None:
    """flylog: simulate a stereo + sonar + odometry robot, replay its logs through the fly
    algorithm and a harmonic-function planner, and score the runs."""


def main() -> None:
    cli()
