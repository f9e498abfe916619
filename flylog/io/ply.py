"""Point clouds as PLY files (binary little endian, one ``vertex`` element of float32
properties): what Open3D, CloudCompare, MeshLab and plyfile read. Written whole or not at
all (:mod:`flylog.io.atomic`)."""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from flylog.io.atomic import write_bytes

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def ply_bytes(columns: Sequence[tuple[str, np.ndarray]], comments: Sequence[str] = ()) -> bytes:
    """A PLY file of one vertex per row: one float32 property per ``(name, values (N,))``
    column, in that order (x, y, z first, as readers expect)."""
    if not columns:
        msg = "a PLY point cloud needs at least its x, y, z columns"
        raise ValueError(msg)
    n = len(columns[0][1])
    for name, values in columns:
        if not _NAME.fullmatch(name) or np.shape(values) != (n,):
            msg = f"PLY property {name!r} needs a name and {n} values, got {np.shape(values)}"
            raise ValueError(msg)
    if any("\n" in c for c in comments):
        msg = "a PLY comment is one line"
        raise ValueError(msg)
    header = ["ply", "format binary_little_endian 1.0"]
    header += [f"comment {c}" for c in comments]
    header.append(f"element vertex {n}")
    header += [f"property float {name}" for name, _ in columns]
    header.append("end_header")
    packed = np.empty((n, len(columns)), dtype="<f4")
    for i, (_, values) in enumerate(columns):
        packed[:, i] = values
    return ("\n".join(header) + "\n").encode("ascii") + packed.tobytes()


def write_ply(
    path: str | Path, columns: Sequence[tuple[str, np.ndarray]], comments: Sequence[str] = ()
) -> Path:
    """Write :func:`ply_bytes` to ``path`` atomically; returns the path."""
    path = Path(path)
    write_bytes(path, ply_bytes(columns, comments))
    return path
