"""``flylog calibrate``: thin wrapper over :func:`flylog.metrics.calibration.calibrate`."""

from __future__ import annotations

import math
import shlex
import sys
from pathlib import Path

import click

from flylog.cli.common import Finite, OutputPath, reports_errors, stdout

_PAIR = click.Path(dir_okay=False, exists=True, path_type=Path)


@click.command()
@click.option(
    "--fit",
    "fit",
    type=(_PAIR, _PAIR),
    multiple=True,
    required=True,
    metavar="RUN LOG",
    help="A run and the simulated sensor log it was replayed from, to fit on (repeatable).",
)
@click.option(
    "--held-out",
    "held_out",
    type=(_PAIR, _PAIR),
    multiple=True,
    metavar="RUN LOG",
    help="A run and its log not fitted on (other scenes and seeds), for the held-out ECE "
    "(repeatable). [default: none]",
)
@click.option(
    "-o",
    "--output",
    type=OutputPath(dir_okay=False, path_type=Path),
    required=True,
    help="The model's JSON file (flylog/fly/confidence.json is the packaged one).",
)
@click.option(
    "--tau",
    type=Finite(0.0, 1.0),
    default=0.05,
    show_default=True,
    help="Relative depth tolerance of 'on a surface'.",
)
@reports_errors
def calibrate(
    fit: tuple[tuple[Path, Path], ...],
    held_out: tuple[tuple[Path, Path], ...],
    output: Path,
    tau: float,
) -> None:
    """Fit the flies' confidence (the probability that a fly lies within tau of a true
    surface, from its fitness's rank in its snapshot) on runs of simulated logs, and report
    the expected calibration error (ECE) on each run, held-out ones apart."""
    from rich.table import Table

    from flylog.io.atomic import write_text
    from flylog.metrics.calibration import calibrate as fit_confidence
    from flylog.metrics.config import MetricsConfig

    # the files by name: the command as a reader reruns it from the runs' directory
    command = "flylog calibrate " + shlex.join(
        Path(a).name if a.endswith((".mcap", ".json")) else a for a in sys.argv[2:]
    )
    model, rows = fit_confidence(list(fit), list(held_out), MetricsConfig(tau=tau), command=command)
    write_text(output, model.to_json())
    table = Table("run", "scene", "seed", "role", "flies", "on a surface", "ECE")
    for r in rows:
        share = r["on_surface_share"]
        table.add_row(
            r["run"],
            str(r["scene"]),
            str(r["seed"]),
            r["role"],
            str(r["flies"]),
            "—" if math.isnan(share) else f"{share:.3f}",
            f"{r['ece']:.4f}",
        )
    stdout.print(table)
    stdout.print(f"{output}: {model.kind} on {', '.join(model.names)}, engine {model.engine}")
