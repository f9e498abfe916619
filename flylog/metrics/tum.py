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
from flylog.io import contract, open_log
from flylog.io.atomic import write_text
from flylog.io.collisions import Role, check_outputs
from flylog.metrics.trajectory import Trajectory, trajectory
from flylog.metrics.truth import read_odom_tf, read_poses, recorded_trajectories
from flylog.ros2.detect import is_bag

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


def planned_trajectory(path: str | Path) -> Trajectory:
    """The first pose of each ``/planner/path`` message, at its log time."""
    times, poses = [], []
    for m in open_log(path).messages([contract.PLANNER_PATH]):
        if len(m.value):
            times.append(m.log_time_ns)
            poses.append(tuple(m.value[0]))
    return trajectory(times, poses)


def log_trajectories(path: str | Path) -> dict[str, Trajectory]:
    """name (true, odom, planned) → trajectory, for those the file (or ROS 2 bag) holds."""
    if is_bag(path):
        from flylog.ros2.truth import bag_trajectories

        return bag_trajectories(path)
    reader = open_log(path)
    present = reader.topics()
    out: dict[str, Trajectory] = {}
    pose_topics = [t for t in (contract.TRUTH_POSE, contract.ODOM) if t in present]
    found = recorded_trajectories(reader) or (
        read_poses(reader, pose_topics) if pose_topics else {}
    )
    if contract.TRUTH_POSE in found:
        out["true"] = found[contract.TRUTH_POSE]
    if contract.ODOM in found:
        out["odom"] = found[contract.ODOM]
    elif contract.TF in present:
        odom = read_odom_tf(reader)
        if len(odom):
            out["odom"] = odom
    if contract.PLANNER_PATH in present:
        planned = planned_trajectory(path)
        if len(planned):
            out["planned"] = planned
    return out


def export_tum(path: str | Path, out_dir: str | Path) -> dict[str, Path]:
    """Write ``true.tum``, ``odom.tum``, ``planned.tum`` (those present) into ``out_dir``
    (created if needed); returns name → written path. LogError if there is none."""
    out_dir = Path(out_dir)
    check_outputs(
        [Role(Path(path), "the source", "path")],
        [Role(out_dir / f"{name}.tum", f"the {name} trajectory", "out_dir") for name in TUM_NAMES],
    )
    trajectories = log_trajectories(path)
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
