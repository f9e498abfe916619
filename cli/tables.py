"""Tables printed to fit the terminal: as they are when they fit its width, else turned (a
column per row, in as many tables as that takes), else one block per row (its fields one a
line). A table
cut to fit ("0.6…" in every cell) or wrapped letter by letter is never printed: at 80
columns each of flylog's tables is read whole (tests/test_tables_fit.py)."""

from __future__ import annotations

from collections.abc import Sequence

from rich.console import Console
from rich.table import Table


def _table(
    title: str,
    header: Sequence[str],
    rows: Sequence[Sequence[str]],
    right: set[int],
    *,
    show_header: bool = True,
) -> Table:
    table = Table(title=title, title_justify="left", show_header=show_header)
    for i, name in enumerate(header):
        table.add_column(name, justify="right" if i in right else "left", no_wrap=True)
    for row in rows:
        table.add_row(*row)
    return table


def _fits(console: Console, table: Table) -> bool:
    # measured without the terminal's bound (rich clamps a measurement to its max_width)
    unbounded = console.options.update_width(1_000_000)
    return console.measure(table, options=unbounded).maximum <= console.width


def fitted(
    console: Console,
    title: str,
    header: Sequence[str],
    rows: Sequence[Sequence[str]],
    *,
    right: Sequence[int] = (),
    key_columns: int = 1,
) -> list[Table]:
    """The tables that show ``rows`` within ``console``'s width; ``right``: the columns
    aligned right (numbers); ``key_columns``: the leading columns that name a row."""
    wide = _table(title, header, rows, set(right))
    if _fits(console, wide):
        return [wide]

    def name(row: Sequence[str]) -> str:
        return ", ".join(row[:key_columns])

    fields = list(header[key_columns:])

    def turned(part: Sequence[Sequence[str]], suffix: str) -> Table:
        return _table(
            f"{title} (a column per row{suffix})",
            [", ".join(header[:key_columns]), *(name(r) for r in part)],
            [[f, *(r[key_columns + i] for r in part)] for i, f in enumerate(fields)],
            set(range(1, len(part) + 1)),
        )

    # Turned, in as few tables as fit side by side (rows kept in order).
    parts: list[list[Sequence[str]]] = []
    for row in rows:
        if parts and _fits(console, turned([*parts[-1], row], "")):
            parts[-1].append(row)
        else:
            parts.append([row])
    if all(_fits(console, turned(part, "")) for part in parts):
        n = len(parts)
        return [turned(part, f", {k} of {n}" if n > 1 else "") for k, part in enumerate(parts, 1)]
    return [
        _table(
            f"{title}: {name(r)}" if k == 0 else name(r),
            ["field", "value"],
            [list(pair) for pair in zip(fields, r[key_columns:], strict=True)],
            {1},
            show_header=False,
        )
        for k, r in enumerate(rows)
    ]


def print_fitted(
    console: Console,
    title: str,
    header: Sequence[str],
    rows: Sequence[Sequence[str]],
    *,
    right: Sequence[int] = (),
    key_columns: int = 1,
) -> None:
    for table in fitted(console, title, header, rows, right=right, key_columns=key_columns):
        console.print(table)
