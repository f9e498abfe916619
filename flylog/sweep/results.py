"""``DIR/results.parquet``: one row per cell, its columns documented like the metrics
tables (unit and description in the field metadata and, for readers that drop it, in the
file's key-value metadata ``flylog.columns``); ``flylog.sweep`` holds the grid's keys."""

from __future__ import annotations

import dataclasses
import enum
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from flylog.errors import LogError
from flylog.io.inputs import input_path
from flylog.io.tables import Column
from flylog.metrics.tables import SUMMARY_COLUMNS, write_table
from flylog.replay.config import ReplayConfig
from flylog.sweep.cells import Cell
from flylog.sweep.overrides import leaf_field

RESULTS_NAME = "results.parquet"
METADATA_KEY = "flylog.sweep"

HEAD_COLUMNS = (
    Column("cell", "int64", "", "the cell's place in the sweep (input, variant, grid, seed)"),
    Column("input", "string", "", "the log replayed (its path), or scene@seed simulated"),
    Column("input_kind", "string", "", "log, simulate (simulated, then replayed) or closed_loop"),
    Column("input_seed", "int64", "", "seed of the simulation (null for a given log)"),
    Column("seed", "int64", "", "seed of the engine's random generator"),
    Column("variant", "string", "", "the [[variants]] entry ('default' without variants)"),
)
# The summary's own file names are replaced by run_dir (the rows of two sweeps of the same
# spec are then equal wherever they were written).
METRIC_COLUMNS = tuple(c for c in SUMMARY_COLUMNS if c.name not in ("run", "log"))
TAIL_COLUMNS = (
    Column(
        "cell_wall_s",
        "float64",
        "s",
        "wall time of the cell: replay (or the closed loop) + metrics",
    ),
    Column(
        "cell_cpu_s",
        "float64",
        "s",
        "CPU time of the worker process over the cell, all its threads",
    ),
    Column(
        "input_messages_lost",
        "int64",
        "",
        "messages of the cell's input lost to damage, as its reading warned (0: none)",
    ),
    Column(
        "input_warnings",
        "string",
        "",
        "the warnings of the cell's run, one a line (empty: none): a damaged, truncated "
        "or incomplete input",
    ),
    Column("status", "string", "", "ok, or failed (the sweep went on)"),
    Column("error", "string", "", "why the cell failed (null if ok)"),
    Column("run_dir", "string", "", "the cell's outputs, relative to the sweep's directory"),
    Column("fingerprint", "string", "", "SHA-256 of input content, configuration and version"),
)
# Columns that measure the machine, not the algorithm: they differ between two runs of a cell.
TIMING_COLUMNS = ("wall_s", "metrics_wall_s", "evaluations_per_s", "cell_wall_s", "cell_cpu_s")


def _grid_type(values: Sequence[Any]) -> str:
    kinds = {type(v) for v in values}
    if kinds <= {bool}:
        return "bool"
    if kinds <= {int}:
        return "int64"
    if kinds <= {int, float}:
        return "float64"
    return "string"


def column_value(value: Any) -> Any:
    """A grid value as its column holds it: enums by value, tuples as JSON."""
    if isinstance(value, enum.Enum):
        return value.value
    if isinstance(value, tuple):
        return json.dumps([column_value(v) for v in value])
    return value


def grid_columns(grid: Sequence[tuple[str, Sequence[Any]]]) -> tuple[Column, ...]:
    """One column per grid key, with the unit and help of its configuration field."""
    out = []
    for key, values in grid:
        _, field = leaf_field(ReplayConfig, key)
        unit = field.metadata.get("unit", "") if isinstance(field, dataclasses.Field) else ""
        help_ = field.metadata.get("help", "")
        kind = _grid_type([column_value(v) for v in values])
        out.append(Column(key, kind, unit, f"grid key: {help_}"))
    return tuple(out)


def results_columns(grid: Sequence[tuple[str, Sequence[Any]]]) -> tuple[Column, ...]:
    return (*HEAD_COLUMNS, *grid_columns(grid), *METRIC_COLUMNS, *TAIL_COLUMNS)


def cell_row(cell: Cell, outcome: Mapping[str, Any], out_dir: Path) -> dict[str, Any]:
    """The results row of ``cell`` from what its run returned."""
    row: dict[str, Any] = {
        "cell": cell.index,
        "input": cell.input,
        "input_kind": cell.input_kind,
        "input_seed": cell.input_seed,
        "seed": cell.seed,
        "variant": cell.variant,
    }
    row.update({k: column_value(v) for k, v in cell.point})
    row.update({c.name: outcome.get(c.name) for c in METRIC_COLUMNS})
    row.update(
        cell_wall_s=outcome.get("cell_wall_s"),
        cell_cpu_s=outcome.get("cell_cpu_s"),
        input_messages_lost=int(outcome.get("input_messages_lost") or 0),
        input_warnings=outcome.get("input_warnings") or "",
        status=outcome.get("status"),
        error=outcome.get("error"),
        run_dir=str(cell.directory.relative_to(out_dir)),
        fingerprint=cell.fingerprint,
    )
    return row


def write_results(
    path: Path,
    grid: Sequence[tuple[str, Sequence[Any]]],
    rows: Sequence[Mapping[str, Any]],
    spec_source: Path,
) -> None:
    meta = {
        METADATA_KEY: json.dumps(
            {"spec": str(spec_source), "grid_keys": [k for k, _ in grid], "cells": len(rows)}
        )
    }
    write_table(path, results_columns(grid), sorted(rows, key=lambda r: r["cell"]), meta)


def results_path(path: Path) -> Path:
    """A sweep's results.parquet, given it or its directory."""
    path = Path(path)
    return path / RESULTS_NAME if path.is_dir() else path


def is_results(path: Path) -> bool:
    """Whether ``path`` (a file or a sweep's directory) is a sweep's results table;
    LogError for a Parquet file that cannot be read."""
    found = results_path(path)
    if not found.is_file() or found.suffix != ".parquet":
        return False
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        meta = pq.read_schema(input_path(found, "the table")).metadata or {}
    except (pa.ArrowException, OSError) as exc:  # a cut or damaged file
        msg = f"{found}: not a readable Parquet file ({exc}); it is damaged or cut short"
        raise LogError(msg) from None
    return METADATA_KEY.encode() in meta


def read_results(path: Path) -> tuple[list[str], list[dict[str, Any]]]:
    """(grid keys, rows) of a sweep's results table (given it or its directory)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    found = results_path(path)
    try:
        table = pq.read_table(input_path(found, "the sweep results"))
    except (pa.ArrowInvalid, OSError) as exc:
        msg = f"{found}: not a readable sweep results table ({exc})"
        raise LogError(msg) from None
    raw = (table.schema.metadata or {}).get(METADATA_KEY.encode())
    if raw is None:
        msg = f"{found}: not a sweep's results (no {METADATA_KEY} metadata; made by flylog sweep)"
        raise LogError(msg)
    return list(json.loads(raw)["grid_keys"]), table.to_pylist()
