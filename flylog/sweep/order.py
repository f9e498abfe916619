"""The order a sweep hands its cells to the workers: the longest first, by an estimate of
each cell's work (its log's duration × the engine's population), so that the last cells
to start are short ones and the workers finish together. Handed out in spec order, two
cells of 2000 flies after six of 1000 leave one worker idle for the length of one of them.
The estimate only orders the cells: the rows and the results table keep the spec's order.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from flylog.errors import FlylogError
from flylog.sweep.cells import Cell

_NS = 1e-9


def _log_duration(path: Path) -> float:
    """The log's span in seconds; 0 for a log that cannot be read (its cell fails fast)."""
    from flylog.io import open_log

    try:
        reader = open_log(path)
        return (reader.end_ns - reader.start_ns) * _NS
    except (FlylogError, OSError):  # the cell itself reports why the log is unreadable
        return 0.0


def _simulated_duration(cell: Cell) -> float:
    from flylog.scene.load import load_scene
    from flylog.sim.run import SimulationOptions, simulation_duration

    task = cell.simulation
    assert task is not None
    try:
        scene = load_scene(task.scene)
    except (FlylogError, OSError):  # the cell itself reports why
        return 0.0
    return simulation_duration(scene, SimulationOptions(duration=task.duration))


def estimated_work(cells: Sequence[Cell]) -> list[float]:
    """Each cell's work in fly-seconds: the log time it runs × the engine's population."""
    durations: dict[str, float] = {}
    out = []
    for cell in cells:
        if cell.input not in durations:
            if cell.simulation is not None:
                durations[cell.input] = _simulated_duration(cell)
            elif cell.log is not None:
                durations[cell.input] = _log_duration(cell.log)
            else:
                durations[cell.input] = 0.0
        out.append(durations[cell.input] * cell.config.engine.flies)
    return out


def longest_first_order(work: Sequence[float]) -> list[int]:
    """Indices of ``work`` (estimates), the largest first; ties keep their order."""
    return sorted(range(len(work)), key=lambda i: -work[i])


def longest_first(cells: Sequence[Cell]) -> list[Cell]:
    """``cells`` by estimated work, the largest first; ties keep their order."""
    return [cells[i] for i in longest_first_order(estimated_work(cells))]
