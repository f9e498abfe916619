"""The progress bar drawn on a terminal (imported only then: rich.progress is not small)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    ProgressColumn,
    Task,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from rich.text import Text

# Units that count whole things show whole numbers; the others (seconds of log) one decimal.
COUNTED_UNITS = frozenset({"frames", "cells", "logs"})


class AmountColumn(ProgressColumn):
    """``done/total unit`` with one decimal; ``?`` for a total not known yet (a task's
    total is None until the first update)."""

    def __init__(self, unit: str) -> None:
        super().__init__()
        self.unit = unit

    def render(self, task: Task) -> Text:
        total = "?" if task.total is None else f"{task.total:.1f}"
        return Text(f"{task.completed:.1f}/{total} {self.unit}")


@contextmanager
def drawn_progress_bar(
    description: str, unit: str, console: Console
) -> Iterator[Callable[[float, float], None]]:
    """``flylog.cli.common.progress_bar`` on a terminal."""
    count = MofNCompleteColumn() if unit in COUNTED_UNITS else AmountColumn(unit)
    columns = (
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        count,
        TimeElapsedColumn(),
        TextColumn("ETA"),
        TimeRemainingColumn(),
    )
    with Progress(*columns, console=console) as bar:
        task = bar.add_task(description, total=None)

        def update(done: float, total: float) -> None:
            bar.update(task, completed=done, total=total)

        yield update
