"""``flylog export``: thin wrapper over :func:`flylog.metrics.tum.export_tum`."""

from __future__ import annotations

from pathlib import Path

import click

from flylog.cli.common import reports_errors, stdout


@click.command()
@click.argument("source", type=click.Path(dir_okay=False, path_type=Path))
@click.option(
    "--tum",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    required=True,
    metavar="OUTDIR",
    help="Write true.tum, odom.tum and planned.tum (those the file holds) into OUTDIR.",
)
@reports_errors
def export(source: Path, out_dir: Path) -> None:
    """Export the trajectories of SOURCE (a sensor log, closed-loop log or run file) in the
    TUM format (`timestamp tx ty tz qx qy qz qw`), for evo: `evo_ape tum true.tum odom.tum
    --align`. planned.tum holds the first pose of each /planner/path message."""
    from flylog.metrics.tum import export_tum

    written = export_tum(source, out_dir)
    for name, path in written.items():
        stdout.print(f"{name}: {path}")
