"""``flylog report``: thin wrapper over :func:`flylog.report.run.run_report` and
:func:`flylog.report.sweep.sweep_report`."""

from __future__ import annotations

from pathlib import Path

import click

from flylog.cli.common import OutputPath, reports_errors, stdout


@click.command()
@click.argument("target", type=click.Path(exists=True, path_type=Path))
@click.option(
    "--log",
    "log",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="For a run: the sensor log it was made from (ground truth). [default: RUN itself, "
    "for a closed-loop log]",
)
@click.option(
    "--metrics",
    "metrics",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="For a run: its `flylog metrics -o` output (NAME.parquet, with NAME.summary.parquet "
    "beside it), shown as it is. [default: the run is scored now, with the default "
    "thresholds]",
)
@click.option(
    "-o",
    "--output",
    type=OutputPath(dir_okay=False, path_type=Path),
    default=None,
    help="REPORT.html to write (atomically), one self-contained file: images embedded, "
    "nothing fetched from a network. [default: DIR/report.html for a sweep's directory, "
    "RUN.html beside RUN.mcap for a run]",
)
@reports_errors
def report(target: Path, log: Path | None, metrics: Path | None, output: Path | None) -> None:
    """Draw TARGET on one HTML page. TARGET is a run (RUN.mcap from `flylog replay`, or a
    closed-loop log): its metrics summary, a top-down map with the trajectories and
    obstacle flies, left frames with the flies drawn, curves over time and its
    configuration. Or TARGET is a sweep's directory (`flylog sweep -o DIR`): each metric
    against each grid key, a line per variant, and the results table."""
    if target.is_dir():
        if log is not None or metrics is not None:
            raise click.UsageError("--log and --metrics go with a run, not a sweep's directory")
        from flylog.report.sweep import sweep_report

        path = sweep_report(target, target / "report.html" if output is None else output)
    else:
        from flylog.report.run import run_report

        output = target.with_suffix(".html") if output is None else output
        path = run_report(target, log, output, metrics=metrics)
    stdout.print(f"wrote {path} ({path.stat().st_size / 1024:.0f} KiB)", soft_wrap=True)
