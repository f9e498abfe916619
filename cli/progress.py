"""The progress bar drawn on a terminal (imported only then: rich.progress is not small)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    ProgressColumn,
    Task,
    TaskID,
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


class DrawnBar:
    """``bar(done, total)`` moves the bar; ``bar.note(text)`` shows ``text`` after the
    description ("" clears it)."""

    def __init__(self, progress: Progress, task: TaskID, description: str) -> None:
        self.progress, self.task, self.description = progress, task, description

    def __call__(self, done: float, total: float) -> None:
        self.progress.update(self.task, completed=done, total=total)

    def note(self, text: str) -> None:
        shown = f"{self.description} ({text})" if text else self.description
        self.progress.update(self.task, description=shown)


@contextmanager
def drawn_progress_bar(description: str, unit: str, console: Console) -> Iterator[DrawnBar]:
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
        yield DrawnBar(bar, bar.add_task(description, total=None), description)
