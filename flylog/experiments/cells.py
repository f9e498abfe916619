"""An experiment as independent cells: each cell simulates its log(s), replays and scores
them, and returns plain data (rows, curves, the few arrays its figures need); the plan's
``assemble`` turns the cells' results, in the plan's order, into the tables, plots and
Markdown. Cells share no state and every run is seeded on the virtual clock, so where and
in which order the cells run does not change what the experiment writes."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from flylog.experiments.common import ExperimentOptions, ExperimentResult


@dataclass(frozen=True)
class ExperimentCell:
    """One unit of an experiment's work; ``run(task)`` is a top-level function and
    ``task`` picklable, so a worker process can run it."""

    experiment: str
    label: str  # what the cell is, e.g. "turn, seed 3"
    work: float  # estimate of its cost (orders the cells, nothing else)
    run: Callable[[Any], Any]
    task: Any


@dataclass(frozen=True)
class SeedTask:
    """The task of a cell that simulates one seed's log and replays it in the experiment's
    configurations: its directory, the options, the seed, the log's duration (s) and frame
    rate (Hz)."""

    here: Path
    options: ExperimentOptions
    seed: int
    duration: float
    frame_rate: float


def seed_cells(
    experiment: str,
    scene: str,
    task: SeedTask,
    seeds: int,
    engine_runs: int,
    run: Callable[[SeedTask], Any],
) -> tuple[ExperimentCell, ...]:
    """One cell a seed 0…seeds−1, each running ``run`` on ``task`` with its seed: a log of
    ``scene`` simulated once and replayed ``engine_runs`` times."""
    work = log_seconds_work(task.duration, engine_runs)
    return tuple(
        ExperimentCell(experiment, f"{scene}, seed {seed}", work, run, replace(task, seed=seed))
        for seed in range(seeds)
    )


@dataclass(frozen=True)
class ExperimentPlan:
    """An experiment's cells and how their results become its outputs."""

    name: str
    cells: tuple[ExperimentCell, ...]
    assemble: Callable[[list[Any]], ExperimentResult]  # results in the order of ``cells``


def run_cell(cell: ExperimentCell) -> Any:
    """The cell's result; an error it raises names the experiment and the cell."""
    try:
        return cell.run(cell.task)
    except Exception as exc:
        exc.add_note(f"in the {cell.experiment} experiment's cell {cell.label}")
        raise


def log_seconds_work(seconds: float, engine_runs: int, *, pixel_scale: float = 1.0) -> float:
    """A cell's work estimate: the log seconds it simulates (once, ``pixel_scale`` × the
    options' pixels) and replays (``engine_runs`` times)."""
    return seconds * (pixel_scale + engine_runs)


def finish_in_order(plan: ExperimentPlan, results: Sequence[Any]) -> ExperimentResult:
    if len(results) != len(plan.cells):
        msg = f"{plan.name}: {len(results)} results for {len(plan.cells)} cells"
        raise ValueError(msg)
    return plan.assemble(list(results))
