"""Writing a :class:`MetricsResult` as ``flylog metrics``' Parquet tables
(:mod:`flylog.metrics.tables` holds their schemas)."""

from __future__ import annotations

import json
from pathlib import Path

from flylog.config import to_mapping
from flylog.io.atomic import Batch
from flylog.metrics import tables
from flylog.metrics.result import MetricsResult


def write_reliability(result: MetricsResult, output: str | Path) -> Path | None:
    """Write the reliability table (``NAME.reliability.parquet`` beside ``output``), when the
    result has one; returns its path."""
    if not result.reliability:
        return None
    path = tables.reliability_path(Path(output))
    meta = {tables.METADATA_KEY: json.dumps(to_mapping(result.config))}
    tables.write_table(path, tables.RELIABILITY_COLUMNS, result.reliability, meta)
    return path


def write_metrics(result: MetricsResult, output: str | Path) -> tuple[Path, Path, Path]:
    """Write the snapshot table to ``output`` and the summary and obstacle tables beside it
    (``NAME.summary.parquet``, ``NAME.obstacles.parquet``), published together (all three
    new, or all three as they were); returns the three paths."""
    output = Path(output)
    tables.check_output_name(output)
    meta = {tables.METADATA_KEY: json.dumps(to_mapping(result.config))}
    paths = (output, tables.summary_path(output), tables.obstacles_path(output))
    with Batch() as batch:
        tables.write_table(paths[0], tables.SNAPSHOT_COLUMNS, result.snapshots, meta, batch)
        tables.write_table(paths[1], tables.SUMMARY_COLUMNS, [result.summary], meta, batch)
        tables.write_table(paths[2], tables.OBSTACLE_COLUMNS, result.obstacles, meta, batch)
    return paths
