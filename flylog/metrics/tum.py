"""Trajectories in the TUM format, for evo's own tools (``evo_ape tum true.tum odom.tum``).

One pose a line, ``timestamp tx ty tz qx qy qz qw``: the timestamp in seconds (the log
time, written exactly from its nanoseconds), the position in metres (z = 0: the robot is
planar), the heading as a unit quaternion about z.

From a log or run file: ``true.tum`` (``/truth/pose``), ``odom.tum`` (``/odom``, else the
odom → base_link transforms of ``/tf``), ``planned.tum`` (the first pose of each
``/planner/path`` message: where the planner planned from, at each planning instant).
Only the trajectories the file holds are written.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from flylog.errors import LogError
from flylog.io import contract
from flylog.io.atomic import write_text
from flylog.io.collisions import Role, check_outputs
from flylog.sources import input_at
from flylog.sources.trajectory import Trajectory

# The trajectories a file may hold, each written to NAME.tum.
TUM_NAMES = ("true", "odom", "planned")


def tum_line(t_ns: int, x: float, y: float, theta: float) -> str:
    sec, nsec = divmod(int(t_ns), 1_000_000_000)
    qz, qw = np.sin(theta / 2.0), np.cos(theta / 2.0)
    return f"{sec}.{nsec:09d} {x:.6f} {y:.6f} 0.000000 0.000000000 0.000000000 {qz:.9f} {qw:.9f}"


def tum_text(traj: Trajectory) -> str:
    return "".join(
        tum_line(int(t), *(float(v) for v in p)) + "\n"
        for t, p in zip(traj.t_ns, traj.xyt, strict=True)
    )


def write_tum(path: Path, traj: Trajectory) -> None:
    """Write one TUM file atomically."""
    write_text(path, tum_text(traj), encoding="ascii")


def export_tum(path: str | Path, out_dir: str | Path) -> dict[str, Path]:
    """Write ``true.tum``, ``odom.tum``, ``planned.tum`` (those present) into ``out_dir``
    (created if needed); returns name → written path. LogError if there is none."""
    out_dir = Path(out_dir)
    check_outputs(
        [Role(Path(path), "the source", "path")],
        [Role(out_dir / f"{name}.tum", f"the {name} trajectory", "out_dir") for name in TUM_NAMES],
    )
    trajectories = input_at(path).trajectories()
    if not trajectories:
        msg = (
            f"{path} holds no trajectory: none of {contract.TRUTH_POSE}, {contract.ODOM}, "
            f"{contract.TF} (odom → base_link), {contract.PLANNER_PATH}"
        )
        raise LogError(msg)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        msg = f"cannot create {out_dir}: {exc.strerror}"
        raise LogError(msg) from None
    written = {}
    for name, traj in trajectories.items():
        target = out_dir / f"{name}.tum"
        write_tum(target, traj)
        written[name] = target
    return written
