"""``flylog describe``: thin wrapper over :func:`flylog.io.tables.describe_table`."""

from __future__ import annotations

from pathlib import Path

import click

from flylog.cli.common import reports_errors, stdout


@click.command()
@click.argument("table", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@reports_errors
def describe(table: Path) -> None:
    """Show each column of TABLE (a Parquet file flylog wrote: a replay's steps, metrics,
    a sweep's results) with its type, unit and meaning, from the file's key-value metadata
    (pandas, polars and DuckDB do not show it)."""
    from rich.table import Table

    from flylog.io.tables import describe_table

    rows, columns = describe_table(table)
    shown = Table(title=f"{table}: {rows} rows, {len(columns)} columns", title_justify="left")
    for name in ("column", "type", "unit"):
        shown.add_column(name, no_wrap=True)
    shown.add_column("meaning", ratio=1)  # prose: wrapped at words to the terminal's width
    for c in columns:
        shown.add_row(c.name, c.type, c.unit, c.description)
    stdout.print(shown)
