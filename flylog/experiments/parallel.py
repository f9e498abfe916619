"""Several experiments at once on the sweep's process pool (``flylog.sweep.executors``):
each experiment is one task, run whole in one worker (its seeds one after the other, as
:func:`flylog.experiments.run_experiment` runs them), so ``flylog experiment all`` keeps
every core busy. Every run is on the virtual clock and seeded: an experiment's results do
not depend on the process or the numba thread count it ran with."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

from flylog.experiments import run_experiment
from flylog.experiments.common import ExperimentOptions, ExperimentResult


def _run_one(task: tuple[str, Path, ExperimentOptions]) -> ExperimentResult:
    name, out_dir, options = task
    return run_experiment(name, out_dir, options)


def run_experiments(
    names: Sequence[str],
    out_dir: Path,
    options: ExperimentOptions,
    *,
    workers: int,
    on_done: Callable[[ExperimentResult, int, int], None] | None = None,
) -> list[ExperimentResult]:
    """Run ``names`` on ``workers`` processes (each with cores / workers numba threads);
    their results in the order of ``names``. ``on_done(result, done, total)`` as each
    ends. The experiments start in the order given: name the longest first."""
    from flylog.sweep.executors import ProcessPool, default_workers

    workers = max(1, min(workers, len(names)))
    pool = ProcessPool(workers, numba_threads=max(1, default_workers() // workers))
    results: dict[int, ExperimentResult] = {}
    try:
        tasks = [(name, Path(out_dir), options) for name in names]
        for i, result in pool.map_unordered(_run_one, tasks):
            results[i] = result
            if on_done is not None:
                on_done(result, len(results), len(names))
    finally:
        pool.close()
    return [results[i] for i in range(len(names))]


# Every experiment, the longest first, by the log time it simulates and replays per seed at
# its defaults: closed-loop up to 2 × 180 s of closed loop; latency 4 × 8 s on turn and
# 4 × 30 s on corridor (152 s); proprioception 3 × 8 s (24 s); sonar 3 × 5 s (15 s). With
# fewer workers than experiments the longest starts at once.
LONGEST_FIRST = ("closed-loop", "latency", "proprioception", "sonar")
