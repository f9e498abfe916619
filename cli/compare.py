"""``flylog compare``: thin wrapper over :func:`flylog.metrics.compare.compare_files`."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import click

from flylog.cli.common import reports_errors, stdout

EXIT_REGRESSION = 1

_STYLE = {"ok": "green", "better": "bold green", "regression": "bold red", "missing": "bold red"}


def _pm(mean: float, std: float, n: int) -> str:
    if math.isnan(mean):
        return "—"
    return f"{mean:.4g}" if n < 2 else f"{mean:.4g} ± {std:.2g}"


@click.command()
@click.argument("paths", nargs=-1, type=click.Path(dir_okay=False, path_type=Path))
@click.option(
    "-b",
    "--base",
    "bases",
    multiple=True,
    type=click.Path(dir_okay=False, path_type=Path),
    help="A base metrics output (repeat for several runs, e.g. seeds).",
)
@click.option(
    "-c",
    "--candidate",
    "candidates",
    multiple=True,
    type=click.Path(dir_okay=False, path_type=Path),
    help="A candidate metrics output (repeat for several runs).",
)
@click.option(
    "--tolerances",
    "tolerance_file",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="TOML file: one table per metric with direction ('higher'|'lower'), absolute, "
    "relative; applied over the defaults.",
)
@click.option(
    "-t",
    "--tolerance",
    "tolerance_specs",
    multiple=True,
    metavar="NAME=VALUE[%]",
    help="Override one metric's tolerance: absolute (precision=0.05) or relative "
    "(ate_m=20%). Repeatable; applied after --tolerances.",
)
@reports_errors
def compare(
    paths: tuple[Path, ...],
    bases: tuple[Path, ...],
    candidates: tuple[Path, ...],
    tolerance_file: Path | None,
    tolerance_specs: tuple[str, ...],
) -> None:
    """Compare the summary metrics of CANDIDATE runs against BASE runs, for CI.

    Either `flylog compare BASE CANDIDATE` or `flylog compare -b B1 -b B2 -c C1 -c C2`.
    Each path is a `flylog metrics -o` output (NAME.parquet; NAME.summary.parquet is read)
    or the summary itself. With several runs a side, means ± standard deviations are
    compared. Exit code 1 if the candidate is worse than the base beyond a tolerance on any
    metric (or lacks one the base has), 0 otherwise, 2 on bad input.
    """
    from rich.table import Table

    from flylog.metrics.compare import (
        DEFAULT_TOLERANCES,
        compare_files,
        load_tolerances,
        override_tolerance,
    )

    if paths and (bases or candidates):
        msg = "give BASE CANDIDATE or --base/--candidate, not both"
        raise click.UsageError(msg)
    if paths:
        if len(paths) != 2:
            msg = f"expected BASE CANDIDATE (2 paths), got {len(paths)}"
            raise click.UsageError(msg)
        bases, candidates = (paths[0],), (paths[1],)
    if not bases or not candidates:
        msg = "give at least one base and one candidate"
        raise click.UsageError(msg)
    tolerances = dict(DEFAULT_TOLERANCES)
    if tolerance_file is not None:
        tolerances = load_tolerances(tolerance_file, base=tolerances)
    for spec in tolerance_specs:
        tolerances = override_tolerance(tolerances, spec)
    result = compare_files(bases, candidates, tolerances)

    table = Table(title="candidate vs base", title_justify="left")
    table.add_column("metric")
    table.add_column(f"base (n={result.n_base})", justify="right")
    table.add_column(f"candidate (n={result.n_candidate})", justify="right")
    table.add_column("delta", justify="right")
    table.add_column("allowed", justify="right")
    table.add_column("verdict")
    for m in result.metrics:
        style = _STYLE.get(m.verdict.value, "dim")
        table.add_row(
            m.name,
            _pm(m.base_mean, m.base_std, result.n_base),
            _pm(m.candidate_mean, m.candidate_std, result.n_candidate),
            "—" if math.isnan(m.delta) else f"{m.delta:+.4g}",
            "—" if math.isnan(m.allowed) else f"{m.allowed:.3g}",
            f"[{style}]{m.verdict.value}[/]",
        )
    stdout.print(table)
    if result.regressed:
        names = ", ".join(m.name for m in result.regressed)
        stdout.print(f"[bold red]regression[/] beyond tolerance: {names}")
        sys.exit(EXIT_REGRESSION)
    stdout.print("[green]no regression[/]")
