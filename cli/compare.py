"""``flylog compare``: thin wrapper over :func:`flylog.metrics.compare.compare_files`."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import click

from flylog.cli.common import OutputPath, reports_errors, stderr, stdout

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
@click.option(
    "--json",
    "as_json",
    is_flag=True,
    help="Print one JSON object instead of the table: each metric's base and candidate "
    "mean and sd, delta, tolerance and verdict (per grid point for two sweeps).",
)
@click.option(
    "--junit",
    "junit_file",
    type=OutputPath(dir_okay=False, path_type=Path),
    default=None,
    metavar="FILE",
    help="Also write JUnit XML to FILE: one test case per metric, a failure per "
    "regression, a skipped case per metric without tolerance. [default: none]",
)
@reports_errors
def compare(
    paths: tuple[Path, ...],
    bases: tuple[Path, ...],
    candidates: tuple[Path, ...],
    tolerance_file: Path | None,
    tolerance_specs: tuple[str, ...],
    as_json: bool,
    junit_file: Path | None,
) -> None:
    """Compare the summary metrics of CANDIDATE runs against BASE runs, for CI.

    Either `flylog compare BASE CANDIDATE` or `flylog compare -b B1 -b B2 -c C1 -c C2`.
    Each path is a `flylog metrics -o` output (NAME.parquet; NAME.summary.parquet is read)
    or the summary itself; or BASE and CANDIDATE are two sweeps' results.parquet, compared
    grid point by grid point (rows matched by variant and grid keys). With several runs a
    side, means ± standard deviations are compared. Exit code 1 if the candidate is worse
    than the base beyond a tolerance on any metric (or lacks one the base has), 0
    otherwise, 2 on bad input.
    """
    from flylog.metrics.compare import DEFAULT_TOLERANCES, load_tolerances, override_tolerance
    from flylog.metrics.gate import comparison_json, group_label, write_junit

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
    groups = _groups(bases, candidates, tolerances)
    if junit_file is not None:
        write_junit(junit_file, groups, tolerances)
    if as_json:
        report = comparison_json(groups, tolerances)
        click.echo(json.dumps(report, indent=2))
        if report["regressed"]:
            sys.exit(EXIT_REGRESSION)
        return
    for group in groups:
        _print_table(group)
    regressed = [
        f"{group_label(g.key)}: {m.name}" if g.key else m.name
        for g in groups
        for m in g.comparison.regressed
    ]
    if regressed:
        stdout.print(f"[bold red]regression[/] beyond tolerance: {', '.join(regressed)}")
        sys.exit(EXIT_REGRESSION)
    stdout.print("[green]no regression[/]")


def _groups(bases: tuple[Path, ...], candidates: tuple[Path, ...], tolerances: dict) -> list:
    """One group for metrics summaries; one per shared grid point for two sweeps."""
    from flylog.metrics.compare import compare_files
    from flylog.metrics.gate import Group, group_label
    from flylog.sweep.compare import compare_results
    from flylog.sweep.results import damaged_inputs, is_results, read_results

    if len(bases) == len(candidates) == 1 and is_results(bases[0]) and is_results(candidates[0]):
        result = compare_results(bases[0], candidates[0], tolerances)
        for side, path in (("base", bases[0]), ("candidate", candidates[0])):
            for line in damaged_inputs(read_results(path)[1]):
                stderr.print(f"[yellow]note:[/] the {side}'s {line}", soft_wrap=True)
        for side, keys in (("base", result.only_base), ("candidate", result.only_candidate)):
            for key in keys:
                stderr.print(f"[yellow]warning:[/] only the {side} has {group_label(key)}")
        return result.groups
    return [Group((), compare_files(bases, candidates, tolerances))]


def _print_table(group) -> None:
    from rich.table import Table

    from flylog.metrics.gate import group_label

    result = group.comparison
    title = "candidate vs base" + (f": {group_label(group.key)}" if group.key else "")
    table = Table(title=title, title_justify="left")
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
