"""Experiments on the sweep's process pool (``flylog.sweep.executors``): the cells of every
experiment asked for go to ONE pool, the longest first (``flylog.sweep.order``), each
worker with cores / workers numba threads; each experiment is assembled from its cells'
results in its plan's order, so its outputs do not depend on the worker count or on the
order in which cells finish."""

from __future__ import annotations

import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from flylog.experiments import experiment_plan
from flylog.experiments.cell_progress import FileSink, Sink, read_progress, reporting
from flylog.experiments.cells import ExperimentCell, ExperimentPlan, finish_in_order, run_cell
from flylog.experiments.common import ExperimentOptions, ExperimentResult, Progress


def run_plans_serially(
    plans: Sequence[ExperimentPlan], on_progress: Progress | None = None
) -> list[ExperimentResult]:
    """Run every cell in this process, one after the other, in the plans' order;
    ``on_progress(done, total)`` in the cells' expected work, moving within each cell."""
    total = float(sum(cell.work for p in plans for cell in p.cells))
    done = 0.0
    if on_progress is not None:
        on_progress(0.0, total)
    out = []
    for plan in plans:
        results = []
        for cell in plan.cells:
            if on_progress is None:
                results.append(run_cell(cell))
            else:
                report = _serial_sink(on_progress, done, cell.work, total)
                with reporting(report):
                    results.append(run_cell(cell))
            done += cell.work
            if on_progress is not None:
                on_progress(done, total)
        out.append(finish_in_order(plan, results))
    return out


def _serial_sink(on_progress: Progress, before: float, work: float, total: float) -> Sink:
    def report(seconds: float) -> None:
        on_progress(before + min(seconds, work), total)

    return report


def run_cell_reporting(item: tuple[ExperimentCell, Path]) -> Any:
    """:func:`run_cell` in a pool's worker, its progress written to the file ``item[1]``."""
    cell, progress_file = item
    with reporting(FileSink(progress_file)):
        return run_cell(cell)


def run_experiment(
    name: str,
    out_dir: Path,
    options: ExperimentOptions,
    *,
    on_progress: Progress | None = None,
) -> ExperimentResult:
    """Run the experiment ``name`` into ``out_dir/name/``, its cells one after the other in
    this process; ``on_progress(done, total)`` in the cells' expected work (log
    seconds), moving within each cell."""
    return run_plans_serially([experiment_plan(name, out_dir, options)], on_progress)[0]


def run_plans(
    plans: Sequence[ExperimentPlan],
    *,
    workers: int,
    on_progress: Progress | None = None,
) -> list[ExperimentResult]:
    """Run the cells of ``plans`` on a pool of ``workers`` processes (at most one per cell),
    the longest first; the plans' results in their order. ``on_progress(done, total)``
    while cells run (each worker writes its cell's log seconds to a file read twice a
    second) and as they finish, in the cells' expected work (``ExperimentCell.work``: log
    seconds simulated and replayed), so that a progress bar's rate and ETA weigh a 180 s
    closed loop as such and not as one of many 8 s cells; an experiment is assembled as
    soon as its last cell is in."""
    from flylog.sweep.executors import ProcessPool, default_workers
    from flylog.sweep.order import longest_first_order

    cells = [(k, i, cell) for k, plan in enumerate(plans) for i, cell in enumerate(plan.cells)]
    order = [cells[j] for j in longest_first_order([cell.work for _, _, cell in cells])]
    results: list[dict[int, Any]] = [{} for _ in plans]
    finished: dict[int, ExperimentResult] = {}
    total = float(sum(cell.work for _, _, cell in cells))
    done_work = 0.0
    if on_progress is not None:
        on_progress(0.0, total)
    workers = max(1, min(workers, len(cells)))
    pool = ProcessPool(workers, numba_threads=max(1, default_workers() // workers))
    with tempfile.TemporaryDirectory(prefix="flylog-cells-") as scratch:
        files = [Path(scratch) / f"{j}.progress" for j in range(len(order))]
        running = set(range(len(order)))

        def tick() -> None:
            if on_progress is not None:
                within = sum(min(read_progress(files[j]), order[j][2].work) for j in running)
                on_progress(done_work + within, total)

        items = [(cell, files[j]) for j, (_, _, cell) in enumerate(order)]
        try:
            for j, result in pool.map_unordered(run_cell_reporting, items, tick=tick):
                k, i, cell = order[j]
                running.discard(j)
                done_work += cell.work
                results[k][i] = result
                plan = plans[k]
                if len(results[k]) == len(plan.cells):
                    in_order = [results[k][n] for n in range(len(plan.cells))]
                    finished[k] = finish_in_order(plan, in_order)
                tick()
        finally:
            pool.close()
    return [finished[k] for k in range(len(plans))]


def run_experiments(
    names: Sequence[str],
    out_dir: Path,
    options: ExperimentOptions,
    *,
    workers: int,
    on_progress: Progress | None = None,
) -> list[ExperimentResult]:
    """Run the experiments ``names`` into ``out_dir/NAME/`` on ``workers`` processes; their
    results in the order of ``names``. ``on_progress(done, total)`` in expected work (log
    seconds, :func:`run_plans`)."""
    plans = [experiment_plan(name, Path(out_dir), options) for name in names]
    return run_plans(plans, workers=workers, on_progress=on_progress)
