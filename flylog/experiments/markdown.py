"""``summary.md``: an experiment's table, its measured findings and its figures; and the
common ending of every experiment (summary, results.json, logs dropped)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from flylog.experiments.common import (
    ExperimentOptions,
    ExperimentResult,
    Table,
    discard_logs,
    format_cell,
    write_results,
)
from flylog.io.atomic import write_text


def markdown_table(table: Table) -> str:
    """A GitHub Markdown table: Spread cells as ``mean ± std``, Count cells as ``k/n``."""
    head = "| " + " | ".join(c.header for c in table.columns) + " |"
    rule = "|" + "|".join("---" for _ in table.columns) + "|"
    body = [
        "| " + " | ".join(format_cell(row.get(c.key), c.fmt) for c in table.columns) + " |"
        for row in table.rows
    ]
    return "\n".join([head, rule, *body])


def write_summary(
    directory: Path,
    *,
    title: str,
    intro: str,
    table: Table,
    findings: Sequence[str],
    figures: Sequence[tuple[Path, str]],
    setup: Sequence[str],
) -> Path:
    """Write ``directory/summary.md``; figures are linked relative to it, with captions."""
    lines = [f"# {title}", "", intro.strip(), "", "## Set-up", ""]
    lines += [f"- {s}" for s in setup]
    lines += ["", f"## {table.title}", "", markdown_table(table), ""]
    if findings:
        lines += ["## Measured", ""] + [f"- {f}" for f in findings] + [""]
    if figures:
        lines += ["## Figures", ""]
        for path, caption in figures:
            lines += [f"![{caption}]({path.name})", "", f"*{caption}*", ""]
    out = directory / "summary.md"
    write_text(out, "\n".join(lines))
    return out


def finish_experiment(
    name: str,
    directory: Path,
    options: ExperimentOptions,
    *,
    title: str,
    intro: str,
    table: Table,
    findings: Sequence[str],
    figures: Sequence[tuple[Path, str]],
    setup: Sequence[str],
    runs: Sequence[dict[str, Any]],
) -> ExperimentResult:
    """Write an experiment's summary.md and results.json, drop its logs unless kept, and
    return its result: the common ending of every experiment."""
    summary = write_summary(
        directory,
        title=title,
        intro=intro,
        table=table,
        findings=findings,
        figures=figures,
        setup=setup,
    )
    write_results(directory, options, table, runs)
    discard_logs(directory, options)
    return ExperimentResult(
        name, table, summary, tuple(p for p, _ in figures), tuple(runs), tuple(findings)
    )
