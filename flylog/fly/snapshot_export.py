"""``flylog export RUN --ply DIR``: a run's fly snapshots as PLY point clouds, one file a
snapshot (or the one nearest a time), for Open3D, CloudCompare or MeshLab.

Each vertex is a fly in base_link at the snapshot's time: x, y, z (m), fitness and, when
the run has them, age (generations) and distinct, then confidence (the calibrated
probability of lying on a surface, :mod:`flylog.fly.confidence`) when a model is given.
Files are named by the snapshot's log time, ``flies_<seconds>.ply`` with the seconds
zero-padded so that names sort as times; the directory appears whole or not at all.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flylog.errors import LogError
from flylog.fly.confidence import ConfidenceModel
from flylog.io import contract, open_log
from flylog.io.ply import write_ply
from flylog.io.records import FlyCloud, LogMessage


@dataclass(frozen=True)
class PlyExport:
    output: Path
    files: int
    points: int


def cloud_columns(
    cloud: FlyCloud, confidence: ConfidenceModel | None
) -> list[tuple[str, np.ndarray]]:
    """The snapshot's per-fly columns, in the order the exports write them."""
    columns = [
        ("x", cloud.xyz[:, 0]),
        ("y", cloud.xyz[:, 1]),
        ("z", cloud.xyz[:, 2]),
        ("fitness", cloud.fitness),
    ]
    if cloud.age is not None:
        columns.append(("age", cloud.age))
    if cloud.distinct is not None:
        columns.append(("distinct", cloud.distinct))
    if confidence is not None:
        columns.append(("confidence", confidence.of_cloud(cloud)))
    return columns


def snapshot_name(t_ns: int) -> str:
    return f"flies_{t_ns / 1e9:010.3f}.ply"


def export_ply(
    run: str | os.PathLike[str],
    output: str | os.PathLike[str],
    *,
    at: float | None = None,
    confidence: ConfidenceModel | None = None,
    on_progress: Callable[[float, float], None] | None = None,
) -> PlyExport:
    """Write the /flies snapshots of ``run`` (only the one nearest ``at`` seconds after the
    run's start, when given) as PLY files into the new directory ``output``."""
    run, output = Path(run), Path(output)
    if output.exists():
        msg = f"{output} exists: the PLY export writes a new directory, choose another DIR"
        raise LogError(msg)
    if not output.parent.is_dir():
        msg = f"cannot write {output}: directory {output.parent} does not exist"
        raise LogError(msg)
    reader = open_log(run)
    if contract.FLIES not in reader.topics():
        msg = f"{run} has no {contract.FLIES} topic: is it a run (`flylog replay` output)?"
        raise LogError(msg)
    t0, span = reader.start_ns, max(1, reader.end_ns - reader.start_ns)
    messages: Iterator[LogMessage] = reader.messages([contract.FLIES])
    if at is not None:
        target = t0 + round(at * 1e9)
        best = min(messages, key=lambda m: abs(m.log_time_ns - target))
        messages = iter([best])
    staging = Path(tempfile.mkdtemp(prefix=f".{output.name}.", suffix=".part", dir=output.parent))
    files = points = 0
    try:
        directory = staging / output.name
        directory.mkdir()
        for m in messages:
            comments = [f"flylog run {run.name}", f"log time {m.log_time_ns} ns, frame base_link"]
            write_ply(
                directory / snapshot_name(m.log_time_ns),
                cloud_columns(m.value, confidence),
                comments,
            )
            files += 1
            points += len(m.value.xyz)
            if on_progress is not None:
                on_progress((m.log_time_ns - t0) / 1e9, span / 1e9)
        os.replace(directory, output)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return PlyExport(output, files, points)
