"""``flylog sweep``: simulate the inputs a spec asks for, run every cell not already run with
the same fingerprint on an executor, and write ``DIR/results.parquet``."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from flylog.errors import LogError
from flylog.sweep.cells import Cell, SimulatedInput, simulated_inputs, sweep_cells
from flylog.sweep.executors import (
    Backend,
    Executor,
    check_backend,
    default_workers,
    make_executor,
)
from flylog.sweep.limits import SweepLimits, check_sweep
from flylog.sweep.lock import sweep_lock
from flylog.sweep.order import longest_first
from flylog.sweep.results import RESULTS_NAME, cell_row, write_results
from flylog.sweep.spec import SweepSpec, load_spec
from flylog.sweep.work import (
    STATUS_FAILED,
    STATUS_OK,
    finished_row,
    input_record,
    read_record,
    run_cell,
    simulate_input,
)


@dataclass(frozen=True)
class SweepOptions:
    backend: Backend = Backend.PROCESSES
    workers: int | None = None  # None: the cores this process may use
    address: str | None = None  # Ray: a running cluster's address
    force: bool = False  # run every cell (and simulate every input) again
    limits: SweepLimits = SweepLimits()  # checked before anything is planned or written


@dataclass(frozen=True)
class Progress:
    """Where a sweep is: cells finished (ok or failed), failed, being run, in all."""

    phase: str  # "inputs" (simulating logs) or "cells"
    done: int
    failed: int
    running: int
    total: int


@dataclass(frozen=True)
class SweepResult:
    spec: SweepSpec
    results: Path
    rows: list[dict[str, Any]]
    ran: int  # cells run now
    reused: int  # cells found finished with the same fingerprint
    wall_seconds: float

    @property
    def failed(self) -> list[dict[str, Any]]:
        return [r for r in self.rows if r["status"] != STATUS_OK]


def _needs_simulation(item: SimulatedInput, force: bool) -> bool:
    if force or not item.task.output.is_file():
        return True
    record = read_record(input_record(item.task))
    return record is None or record.get("fingerprint") != item.task.fingerprint


class _Run:
    """The executor, created only when there is work, and the progress reports."""

    def __init__(
        self, options: SweepOptions, on_progress: Callable[[Progress], None] | None
    ) -> None:
        self.options = options
        self.on_progress = on_progress
        self.executor: Executor | None = None

    def get(self) -> Executor:
        if self.executor is None:
            o = self.options
            self.executor = make_executor(
                o.backend, o.workers or default_workers(), address=o.address
            )
        return self.executor

    def report(self, phase: str, done: int, failed: int, total: int) -> None:
        if self.on_progress is not None:
            running = self.executor.running if self.executor is not None else 0
            self.on_progress(Progress(phase, done, failed, running, total))

    def close(self) -> None:
        if self.executor is not None:
            self.executor.close()

    def abort(self) -> None:
        """Stop at once: queued calls cancelled, running ones stopped (their workers remove
        their partial outputs)."""
        if self.executor is not None:
            self.executor.abort()


def _simulate_inputs(items: list[SimulatedInput], run: _Run, force: bool) -> dict[str, str]:
    """Simulate the inputs that need it; input label → error message of those that failed."""
    todo = [s for s in items if _needs_simulation(s, force)]
    errors: dict[str, str] = {}
    if not todo:
        return errors
    if force:
        for s in todo:
            input_record(s.task).unlink(missing_ok=True)
    run.report("inputs", 0, 0, len(todo))
    tasks = [s.task for s in todo]
    results = run.get().map_unordered(simulate_input, tasks, lost=lambda i, message: message)
    for done, (i, error) in enumerate(results, start=1):
        if error is not None:
            errors[todo[i].label] = error
        run.report("inputs", done, len(errors), len(todo))
    return errors


def _lost_cell(index: int, message: str) -> dict[str, Any]:
    return {"status": STATUS_FAILED, "error": message}


def run_sweep(
    spec: SweepSpec | Path,
    out_dir: Path,
    options: SweepOptions = SweepOptions(),
    *,
    on_progress: Callable[[Progress], None] | None = None,
) -> SweepResult:
    """Run the sweep ``spec`` (a SweepSpec or the path of SPEC.toml) into ``out_dir``."""
    t0 = time.perf_counter()
    if not isinstance(spec, SweepSpec):
        spec = load_spec(spec)
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        msg = f"{out_dir}: not a directory (give -o a directory for the sweep's outputs)"
        raise LogError(msg)
    check_backend(options.backend, options.address)
    check_sweep(spec, options.limits)
    out_dir.mkdir(parents=True, exist_ok=True)
    with sweep_lock(out_dir):
        return _run_sweep(spec, out_dir, options, on_progress, t0)


def _run_sweep(
    spec: SweepSpec,
    out_dir: Path,
    options: SweepOptions,
    on_progress: Callable[[Progress], None] | None,
    t0: float,
) -> SweepResult:
    simulated = simulated_inputs(spec, out_dir)
    cells = sweep_cells(spec, out_dir, simulated)
    run = _Run(options, on_progress)
    rows: dict[int, dict[str, Any]] = {}
    try:
        input_errors = _simulate_inputs(simulated, run, options.force)
        todo: list[Cell] = []
        reused = 0
        for cell in cells:
            found = None if options.force else finished_row(cell)
            if found is not None:
                rows[cell.index] = cell_row(cell, found, out_dir)
                reused += 1
            elif cell.input in input_errors:
                error = f"simulating {cell.input} failed: {input_errors[cell.input]}"
                outcome = {"status": STATUS_FAILED, "error": error}
                rows[cell.index] = cell_row(cell, outcome, out_dir)
            else:
                cell.record.unlink(missing_ok=True)
                todo.append(cell)
        failed = sum(r["status"] != STATUS_OK for r in rows.values())
        run.report("cells", len(rows), failed, len(cells))
        if todo:
            todo = longest_first(todo)
            outcomes = run.get().map_unordered(run_cell, todo, lost=_lost_cell)
            for i, outcome in outcomes:
                cell = todo[i]
                rows[cell.index] = cell_row(cell, outcome, out_dir)
                failed += outcome["status"] != STATUS_OK
                run.report("cells", len(rows), failed, len(cells))
    except BaseException:  # Ctrl-C, a stop signal: stop now, not when every cell is done
        run.abort()
        raise
    finally:
        run.close()
    ordered = [rows[c.index] for c in cells]
    results = out_dir / RESULTS_NAME
    write_results(results, spec.grid, ordered, spec.source)
    return SweepResult(
        spec=spec,
        results=results,
        rows=ordered,
        ran=len(todo),
        reused=reused,
        wall_seconds=time.perf_counter() - t0,
    )
