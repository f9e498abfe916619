"""``flylog compare``: thin wrapper over :func:`flylog.metrics.compare.compare_files` and
:func:`flylog.sweep.compare.compare_results`."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import click

from flylog.cli.common import OutputPath, reports_errors, stderr, stdout

EXIT_REGRESSION = 1
STDOUT = "-"

_STYLE = {
    "no change": "green",
    "improvement": "bold green",
    "regression": "bold red",
    "missing": "bold red",
    "inconclusive": "yellow",
}


def _g(x: float, digits: int = 3) -> str:
    """A number in at most about digits + 5 characters (2.2e-5, not 2.2e-05)."""
    if not math.isfinite(x):
        return "—"
    tiny_or_huge = x != 0 and not 1e-3 <= abs(x) < 10**digits
    text = f"{x:.{digits - 1}e}" if tiny_or_huge else f"{x:.{digits}g}"
    mantissa, e, exponent = text.partition("e")
    if not e:
        return text
    if "." in mantissa:
        mantissa = mantissa.rstrip("0").rstrip(".")
    return f"{mantissa}e{int(exponent)}"


@click.command()
@click.argument("paths", nargs=-1, type=click.Path(path_type=Path))
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
    "--alpha",
    type=click.FloatRange(min=0.0, max=0.5, min_open=True, max_open=True),
    default=0.05,
    show_default=True,
    metavar="ALPHA",
    help="Significance: a regression, an improvement or no change is stated with "
    "confidence 1 − ALPHA; the intervals shown are the two-sided 1 − 2·ALPHA ones.",
)
@click.option(
    "--json",
    "json_file",
    type=OutputPath(dir_okay=False, allow_dash=True, path_type=Path),
    is_flag=False,
    flag_value=STDOUT,
    default=None,
    metavar="[FILE]",
    help="Write one JSON object to FILE (or to stdout, instead of the table, with '-' or "
    "no value): per metric its means and sds, shift and interval, the test, its "
    "p-values and n a side, the tolerance and the verdict (per grid point and input for "
    "two sweeps). [default: none]",
)
@click.option(
    "--junit",
    "junit_file",
    type=OutputPath(dir_okay=False, path_type=Path),
    default=None,
    metavar="FILE",
    help="Also write JUnit XML to FILE: one test case per metric, a failure per "
    "regression, a skipped case per metric inconclusive (with the reason and the seeds "
    "needed) or not judged. [default: none]",
)
@reports_errors
def compare(
    paths: tuple[Path, ...],
    bases: tuple[Path, ...],
    candidates: tuple[Path, ...],
    tolerance_file: Path | None,
    tolerance_specs: tuple[str, ...],
    alpha: float,
    json_file: Path | None,
    junit_file: Path | None,
) -> None:
    """Compare the summary metrics of CANDIDATE runs against BASE runs, for CI.

    Either `flylog compare BASE CANDIDATE` or `flylog compare -b B1 -b B2 -c C1 -c C2`.
    Each path is a `flylog metrics -o` output (NAME.parquet; NAME.summary.parquet is read)
    or the summary itself; or BASE and CANDIDATE are two sweeps' results.parquet (or their
    directories), compared grid point by grid point and input by input, paired by seed
    when both ran the same seeds. Each metric's shift gets an exact interval (Wilcoxon
    signed-rank paired, Mann–Whitney unpaired) and a verdict: regression, improvement, no
    change or inconclusive (too few or too noisy runs; not a failure). Wall-clock figures
    are judged only with a tolerance given for them; the log's figures (open loop) never.
    Exit code 1 if the candidate is worse beyond a tolerance with confidence 1 − ALPHA on
    any metric (or lacks one the base has), 0 otherwise, 2 on bad input. See
    docs/metrics.md.
    """
    from flylog.metrics.compare import DEFAULT_TOLERANCES, load_tolerances, override_tolerance
    from flylog.metrics.gate import json_text, write_json, write_junit

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
    from flylog.io.inputs import input_path

    for named in (*bases, *candidates):  # as the user named them: no output may replace one
        input_path(named, "a compared table")
    groups = _groups(bases, candidates, tolerances, alpha)
    if junit_file is not None:
        write_junit(junit_file, groups, tolerances)
    regressed = [
        f"{_title(g)}: {m.name}" if g.key else m.name
        for g in groups
        for m in g.comparison.regressed
    ]
    if json_file == Path(STDOUT):
        click.echo(json_text(groups, tolerances), nl=False)
        if regressed:
            sys.exit(EXIT_REGRESSION)
        return
    if json_file is not None:
        write_json(json_file, groups, tolerances)
    for group in groups:
        _print_table(group)
    if regressed:
        stdout.print("[bold red]regression[/] beyond tolerance:")
        for name in regressed:
            stdout.print(f"  {name}")
        sys.exit(EXIT_REGRESSION)
    stdout.print("[green]no regression[/]")


def _groups(
    bases: tuple[Path, ...], candidates: tuple[Path, ...], tolerances: dict, alpha: float
) -> list:
    """One group for metrics summaries; one per shared grid point and input for sweeps."""
    from flylog.metrics.compare import compare_files
    from flylog.metrics.gate import Group, group_label
    from flylog.sweep.compare import compare_results
    from flylog.sweep.results import is_results

    if len(bases) == len(candidates) == 1 and is_results(bases[0]) and is_results(candidates[0]):
        result = compare_results(bases[0], candidates[0], tolerances, alpha=alpha)
        for side, keys in (("base", result.only_base), ("candidate", result.only_candidate)):
            for key in keys:
                stderr.print(
                    f"[yellow]warning:[/] only the {side} has {group_label(key)}", soft_wrap=True
                )
        return result.groups
    return [Group((), compare_files(bases, candidates, tolerances, alpha=alpha))]


def _title(group) -> str:
    """The group's key as a line, an input shown by its file name (and simulation seed)."""
    parts = []
    for k, v in group.key:
        if k == "input":
            path, at, seed = str(v).partition("@")
            v = Path(path).name + at + seed
        parts.append(f"{k}={v}")
    return ", ".join(parts)


def _print_table(group) -> None:
    """The judged metrics as a table readable at 80 columns; the others named below it."""
    from rich.table import Table

    from flylog.metrics.gate import interval_level
    from flylog.metrics.judge import Verdict

    result = group.comparison
    how = "paired by seed" if result.paired else "unpaired"
    title = f"candidate vs base: {_title(group)}" if group.key else "candidate vs base"
    stdout.print(f"[bold]{title}[/]", soft_wrap=True)
    level = f"{interval_level(result.alpha):.0%}"
    stdout.print(
        f"runs: {result.n_base} base, {result.n_candidate} candidate, {how}; "
        f"shift: candidate − base, {level} interval",
        soft_wrap=True,
    )
    for line in group.input_damage:
        stdout.print(f"[bold yellow]input damaged[/]: {line}", soft_wrap=True)
    table = Table(box=None, padding=(0, 1), pad_edge=False, collapse_padding=True)
    for name, justify in (
        ("metric", "left"),
        ("base", "right"),
        ("cand.", "right"),
        (f"shift, {level}", "right"),
        ("tol.", "right"),
        ("verdict", "left"),
    ):
        table.add_column(name, justify=justify, no_wrap=True)  # type: ignore[arg-type]
    notes: list[str] = []
    unjudged: dict[str, list[str]] = {}
    for m in result.metrics:
        j = m.judgement
        if j.verdict is Verdict.UNJUDGED:
            unjudged.setdefault(j.reason, []).append(m.name)
            continue
        s = j.shift
        interval = "—" if s is None else f"[{_g(s.low, 2)}, {_g(s.high, 2)}]"
        if j.verdict is Verdict.INCONCLUSIVE:
            notes.append(f"{m.name}: {j.reason}")
        style = _STYLE.get(j.verdict.value, "dim")
        table.add_row(
            m.name,
            _g(m.base_mean),
            _g(m.candidate_mean),
            interval,
            _g(j.allowed, 2),
            f"[{style}]{j.verdict.value}[/]",
        )
    stdout.print(table)
    for note in notes:
        stdout.print(f"[yellow]inconclusive[/] {note}", soft_wrap=False)
    for reason, names in unjudged.items():
        stdout.print(f"[dim]not judged ({reason}): {', '.join(names)}[/]", soft_wrap=False)
    stdout.print()
