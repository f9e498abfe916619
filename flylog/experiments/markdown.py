"""``summary.md``: an experiment's table, its measured findings and its figures."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from flylog.experiments.common import Table, format_cell


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
    out.write_text("\n".join(lines))
    return out
