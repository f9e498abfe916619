"""The worker warm-up loads every compiled kernel, in every argument-type combination, that
a replay from a log calls (a sweep's cell, an experiment's cell): in a fresh worker after
it, the tiny cells of two experiments add no compiled signature. The latency and
closed-loop cells call the same kernels with the same argument types (async, sync and
one-generation replays differ in values only; the warm-up itself is a closed loop); a run
of all four in a worker added none either, but takes minutes."""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from flylog.sweep.executors import ProcessPool

NAMES = ("proprioception", "sonar")


def _signatures() -> dict[str, set[str]]:
    from numba.core.registry import CPUDispatcher

    out: dict[str, set[str]] = {}
    for name, module in list(sys.modules.items()):
        if not name.startswith("flylog") or module is None:
            continue
        for kernel in list(vars(module).values()):
            if isinstance(kernel, CPUDispatcher):
                key = f"{kernel.py_func.__module__}.{kernel.py_func.__qualname__}"
                out[key] = {str(s) for s in kernel.signatures}
    return out


def _compiled_by_cells(names: tuple[str, ...]) -> tuple[int, dict[str, list[str]]]:
    """In a warmed worker: how many kernels it had, and the signatures the cells added."""
    from flylog.experiments import experiment_plan
    from flylog.experiments.cells import run_cell
    from flylog.experiments.common import ExperimentOptions

    before = _signatures()
    tiny = ExperimentOptions(seeds=1, resolution=(48, 36), duration=0.4, flies=64)
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            plan = experiment_plan(name, Path(tmp), tiny)
            plan.assemble([run_cell(cell) for cell in plan.cells])
    added = {
        k: sorted(v - before.get(k, set()))
        for k, v in _signatures().items()
        if v - before.get(k, set())
    }
    return len(before), added


def test_warm_up_leaves_no_kernel_for_the_cells_to_compile() -> None:
    pool = ProcessPool(1)
    try:
        [(_, (kernels, added))] = list(pool.map_unordered(_compiled_by_cells, [NAMES]))
    finally:
        pool.close()
    assert kernels >= 20  # the engine's, renderer's, planner's and metrics' kernels
    assert added == {}
