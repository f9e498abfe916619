"""Experiments on the sweep's process pool (``flylog.sweep.executors``): the cells of every
experiment asked for go to ONE pool, the longest first (``flylog.sweep.order``), each
worker with cores / workers numba threads; each experiment is assembled from its cells'
results in its plan's order, so its outputs do not depend on the worker count or on the
order in which cells finish."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from flylog.experiments.cells import ExperimentPlan, finish_in_order, run_cell
from flylog.experiments.common import ExperimentOptions, ExperimentResult, Progress


def run_plans_serially(
    plans: Sequence[ExperimentPlan], on_progress: Progress | None = None
) -> list[ExperimentResult]:
    """Run every cell in this process, one after the other, in the plans' order."""
    total = sum(len(p.cells) for p in plans)
    done = 0
    if on_progress is not None:
        on_progress(0.0, float(total))
    out = []
    for plan in plans:
        results = []
        for cell in plan.cells:
            results.append(run_cell(cell))
            done += 1
            if on_progress is not None:
                on_progress(float(done), float(total))
        out.append(finish_in_order(plan, results))
    return out


def run_plans(
    plans: Sequence[ExperimentPlan],
    *,
    workers: int,
    on_progress: Progress | None = None,
) -> list[ExperimentResult]:
    """Run the cells of ``plans`` on a pool of ``workers`` processes (at most one per cell),
    the longest first; the plans' results in their order. ``on_progress(done, total)`` as
    cells finish, in the cells' expected work (``ExperimentCell.work``: log seconds simulated
    and replayed), so that a progress bar's rate and ETA weigh a 180 s closed loop as such
    and not as one of many 8 s cells; an experiment is assembled as soon as its last cell
    is in."""
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
    try:
        for j, result in pool.map_unordered(run_cell, [cell for _, _, cell in order]):
            k, i, cell = order[j]
            done_work += cell.work
            results[k][i] = result
            plan = plans[k]
            if len(results[k]) == len(plan.cells):
                finished[k] = finish_in_order(plan, [results[k][n] for n in range(len(plan.cells))])
            if on_progress is not None:
                on_progress(done_work, total)
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
    from flylog.experiments import experiment_plan

    plans = [experiment_plan(name, Path(out_dir), options) for name in names]
    return run_plans(plans, workers=workers, on_progress=on_progress)
