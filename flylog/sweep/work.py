"""What a worker does: simulate an input log, or run one cell (replay or closed loop, then
metrics) through the library functions behind ``flylog simulate``, ``replay`` and
``metrics``. Both return plain values (they travel back from other processes), catch every
error of the run and report it, and write what they make atomically: a cell's
``cell.json`` (fingerprint and row) appears only after all its outputs."""

from __future__ import annotations

import json
import os
import time
import traceback
import warnings
from pathlib import Path
from typing import Any

from flylog.errors import FlylogError
from flylog.sweep.cells import Cell, SimulationTask

STATUS_OK = "ok"
STATUS_FAILED = "failed"
# How much of a traceback a failed cell's row keeps (the last lines name the failing call).
_TRACEBACK_LINES = 6


def error_message(exc: BaseException) -> str:
    """A user's mistake as flylog words it; anything else with the end of its traceback."""
    if isinstance(exc, FlylogError):
        return str(exc)
    lines = traceback.format_exception(exc)
    tail = "".join(lines[-_TRACEBACK_LINES:]).strip()
    return f"{type(exc).__name__}: {exc}\n{tail}"


def write_json(path: Path, value: Any) -> None:
    """``value`` as JSON at ``path``, whole or not at all."""
    from flylog.io.atomic import publish, temporary_beside

    fd, tmp = temporary_beside(path)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            json.dump(value, fh, indent=1, sort_keys=True)
        publish(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def read_record(path: Path) -> dict[str, Any] | None:
    """A ``cell.json`` (or an input's ``.json``), None if absent or unreadable."""
    try:
        value = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return value if isinstance(value, dict) else None


def _simulate(task: SimulationTask) -> None:
    from flylog.scene.load import load_scene
    from flylog.sim.run import SimulationOptions, simulate

    scene = load_scene(task.scene)
    options = SimulationOptions(
        duration=task.duration,
        seed=task.seed,
        resolution=task.resolution,
        frame_rate=task.frame_rate,
    )
    make_driver = None
    config = task.config
    if config is not None:
        from flylog.replay.closed_loop import PlannerDriver

        def make_driver(scene, write):
            return PlannerDriver(config, scene.spec.camera, scene.start_pose, scene.goal, write)

    task.output.parent.mkdir(parents=True, exist_ok=True)
    simulate(scene, task.output, options, make_driver=make_driver)


def input_record(task: SimulationTask) -> Path:
    """``NAME.json`` beside a simulated input: its fingerprint, written once the log is."""
    return task.output.with_suffix(".json")


def simulate_input(task: SimulationTask) -> str | None:
    """Simulate a plan-driven input log (unless it exists with the same fingerprint); the
    error message if that failed, else None."""
    record = read_record(input_record(task))
    fresh = record is not None and record.get("fingerprint") == task.fingerprint
    if fresh and task.output.is_file():
        return None
    try:
        _simulate(task)
        write_json(input_record(task), {"fingerprint": task.fingerprint})
    except Exception as exc:
        return error_message(exc)
    return None


def _metrics_row(cell: Cell, log: Path) -> dict[str, Any]:
    from flylog.metrics.score import score_run, write_metrics

    result = score_run(cell.run, log, cell.metrics)
    write_metrics(result, cell.metrics_output)
    return dict(result.summary)


def input_damage(caught: list[warnings.WarningMessage]) -> dict[str, Any]:
    """The row's account of what a cell's reading warned about: the messages its damaged
    input lost (``input_messages_lost``) and every warning's line, in order, once each
    (``input_warnings``)."""
    from flylog.io.scan import messages_lost

    lines = dict.fromkeys(str(w.message).strip() for w in caught)
    lost, _ = messages_lost(w.message for w in caught if isinstance(w.message, Warning))
    return {"input_messages_lost": lost, "input_warnings": "\n".join(lines)}


def run_cell(cell: Cell) -> dict[str, Any]:
    """Run ``cell`` into its directory; the metrics of its row, its status and error
    message, its wall time (``cell_wall_s``), its worker process's CPU time over it
    (``cell_cpu_s``, every thread: engine, planner, reading), and what the reading of its
    input warned about (:func:`input_damage`; the warnings are shown as well)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")  # each line once is input_damage's to keep
        row = _run_cell(cell)
    for w in caught:
        warnings.showwarning(w.message, w.category, w.filename, w.lineno)
    row.update(input_damage(caught))
    if row["status"] == STATUS_OK:
        write_json(cell.record, {"fingerprint": cell.fingerprint, "row": _jsonable(row)})
    return row


def _run_cell(cell: Cell) -> dict[str, Any]:
    t0, cpu0 = time.perf_counter(), time.process_time()
    try:
        cell.directory.mkdir(parents=True, exist_ok=True)
        if cell.simulation is not None:
            _simulate(cell.simulation)
            log = cell.run  # a closed-loop log holds the truth and the run
        else:
            from flylog.replay.run import replay

            if cell.log is None:
                msg = f"cell {cell.index} has neither a log nor a simulation"
                raise ValueError(msg)
            replay(cell.log, cell.run, cell.config)
            log = cell.log
        summary = _metrics_row(cell, log)
    except Exception as exc:
        return {"status": STATUS_FAILED, "error": error_message(exc),
                "cell_wall_s": time.perf_counter() - t0,
                "cell_cpu_s": time.process_time() - cpu0}  # fmt: skip
    timing = {"cell_wall_s": time.perf_counter() - t0, "cell_cpu_s": time.process_time() - cpu0}
    return {**summary, "status": STATUS_OK, "error": None, **timing}


def _jsonable(row: dict[str, Any]) -> dict[str, Any]:
    """NaN as null (JSON has no NaN)."""
    return {k: None if isinstance(v, float) and v != v else v for k, v in row.items()}


def finished_row(cell: Cell) -> dict[str, Any] | None:
    """The row of a cell already run with the same fingerprint whose outputs exist."""
    record = read_record(cell.record)
    if record is None or record.get("fingerprint") != cell.fingerprint:
        return None
    row = record.get("row")
    if not isinstance(row, dict) or row.get("status") != STATUS_OK:
        return None
    if not (cell.run.is_file() and cell.metrics_output.is_file()):
        return None
    return row
