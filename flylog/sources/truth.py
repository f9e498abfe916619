"""What a flylog log says is true: the scene, the camera rig, the true and odometric
trajectories (``/truth/pose``, ``/odom``), and the trajectories a log or run file holds
(``flylog export --tum``). The types (:class:`LogTruth`) are every input's: a ROS 2 bag's
truth (:mod:`flylog.sources.bag`) is one too. The true views themselves are the simulator's
depth path (``flylog.sim.render.Renderer.render_depth``), redone in numpy for batches of
views by ``flylog.sim.depth`` and tested equal to it bit for bit.

The trajectories come from the ``flylog.trajectories`` metadata record the simulator writes
at close (read from the summary section: no image chunk is decompressed) when the log has
one that matches its topics' message counts, else from the topics themselves (older logs,
unfinished ones), in one streaming pass over the log."""

from __future__ import annotations

import dataclasses
import enum
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from flylog.config import from_mapping
from flylog.errors import ConfigError, LogError
from flylog.geometry import StereoRig
from flylog.io import contract, require_topics
from flylog.io.reader import LogReader
from flylog.scene.load import Scene, parse_scene
from flylog.sources.trajectory import Trajectory, trajectory

SCENE_ATTACHMENT = "scene.toml"


class TrajectorySource(enum.Enum):
    """Where a LogTruth's trajectories were read from."""

    METADATA = "metadata"  # the TRAJECTORIES_METADATA record: no chunk decompressed
    TOPICS = "topics"  # /truth/pose and /odom, streamed


@dataclass(frozen=True)
class LogTruth:
    """Ground truth of a sensor log."""

    path: Path
    scene: Scene
    rig: StereoRig
    true: Trajectory
    odom: Trajectory
    source: TrajectorySource = TrajectorySource.TOPICS

    @property
    def goal(self) -> tuple[float, float]:
        return self.scene.goal


def read_scene(reader: LogReader) -> Scene:
    """The scene attached to a log (the ``scene.toml`` attachment)."""
    for att in reader.attachments():
        if att.name == SCENE_ATTACHMENT:
            return parse_scene(att.data.decode("utf-8"), f"{reader.path}:{SCENE_ATTACHMENT}")
    msg = f"{reader.path} has no '{SCENE_ATTACHMENT}' attachment: is it a flylog sensor log?"
    raise LogError(msg)


def read_rig(reader: LogReader, scene: Scene) -> StereoRig:
    """The rig the log was recorded with: metadata ``flylog.simulation`` ``camera`` (it
    holds ``--resolution``), else the scene's camera with the left calibration's size and
    focal length, else the scene's camera."""
    meta = reader.metadata().get(contract.SIMULATION_METADATA, {})
    if "camera" in meta:
        source = f"{reader.path}: metadata {contract.SIMULATION_METADATA}.camera"
        try:
            data: Any = json.loads(meta["camera"])
        except json.JSONDecodeError as exc:
            msg = f"{source}: not valid JSON ({exc})"
            raise ConfigError(msg) from None
        return from_mapping(StereoRig, data, source=source)
    rig = scene.spec.camera
    if contract.LEFT_CALIBRATION in reader.topics():
        first = reader.first(contract.LEFT_CALIBRATION).value
        cx, cy = float(first.K[0, 2]), float(first.K[1, 2])
        centre = ((first.width - 1) / 2.0, (first.height - 1) / 2.0)
        return dataclasses.replace(
            rig,
            width=first.width,
            height=first.height,
            focal_px=float(first.K[0, 0]),
            principal_point=None if (cx, cy) == centre else (cx, cy),
            doffs=rig.doffs * first.width / rig.width,
        )
    return rig


def read_poses(reader: LogReader, topics: list[str]) -> dict[str, Trajectory]:
    """PoseInFrame topics (``/truth/pose``, ``/odom``) as Trajectories of log times, read
    in one pass over the log."""
    found: dict[str, tuple[list[int], list[tuple[float, float, float]]]] = {
        t: ([], []) for t in topics
    }
    for m in reader.messages(topics):
        p = m.value.pose
        times, poses = found[m.topic]
        times.append(m.log_time_ns)
        poses.append((p.x, p.y, p.theta))
    return {t: trajectory(*found[t]) for t in topics}


def read_odom_tf(reader: LogReader) -> Trajectory:
    """The odom → base_link transforms of ``/tf`` as a Trajectory (what a run file holds)."""
    times, poses = [], []
    for m in reader.messages([contract.TF]):
        for tf in m.value:
            if tf.parent == contract.ODOM_FRAME and tf.child == contract.BASE_FRAME:
                qx, qy, qz, qw = tf.rotation
                yaw = math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
                times.append(m.log_time_ns)
                poses.append((tf.translation[0], tf.translation[1], yaw))
    return trajectory(times, poses)


def _series(text: str) -> Trajectory:
    data = json.loads(text)
    xyt = np.column_stack([np.asarray(data[k], dtype=float) for k in ("x", "y", "theta")])
    t_ns = np.asarray(data["t_ns"], dtype=np.int64)
    if xyt.shape != (len(t_ns), 3):
        msg = f"series of {len(t_ns)} times but {xyt.shape} poses"
        raise ValueError(msg)
    return trajectory(t_ns, xyt)


def recorded_trajectories(reader: LogReader) -> dict[str, Trajectory] | None:
    """``/truth/pose`` and ``/odom`` from the TRAJECTORIES_METADATA record, or None if the
    log has none, of another version, unreadable, or not matching the topics' message
    counts (a log filtered by another tool, say): the caller then streams the topics."""
    meta = reader.metadata().get(contract.TRAJECTORIES_METADATA)
    if meta is None or meta.get("version") != contract.TRAJECTORIES_VERSION:
        return None
    try:
        found = {
            contract.TRUTH_POSE: _series(meta["true"]),
            contract.ODOM: _series(meta["odom"]),
        }
    except (KeyError, TypeError, ValueError):  # json.JSONDecodeError is a ValueError
        return None
    present = reader.topics()
    for topic, traj in found.items():
        if topic not in present or present[topic].count != len(traj):
            return None
    return found


def log_truth(reader: LogReader) -> LogTruth:
    """Scene, rig and trajectories of a flylog sensor log (LogError naming what is
    missing)."""
    require_topics(reader, [contract.TRUTH_POSE, contract.ODOM])
    scene = read_scene(reader)
    poses = recorded_trajectories(reader)
    source = TrajectorySource.METADATA
    if poses is None:
        poses = read_poses(reader, [contract.TRUTH_POSE, contract.ODOM])
        source = TrajectorySource.TOPICS
    return LogTruth(
        path=Path(reader.path),
        scene=scene,
        rig=read_rig(reader, scene),
        true=poses[contract.TRUTH_POSE],
        odom=poses[contract.ODOM],
        source=source,
    )


def planned_trajectory(reader: LogReader) -> Trajectory:
    """The first pose of each ``/planner/path`` message, at its log time."""
    times, poses = [], []
    for m in reader.messages([contract.PLANNER_PATH]):
        if len(m.value):
            times.append(m.log_time_ns)
            poses.append(tuple(m.value[0]))
    return trajectory(times, poses)


def log_trajectories(reader: LogReader) -> dict[str, Trajectory]:
    """name (true, odom, planned) → trajectory, for those a log or run file holds."""
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
        planned = planned_trajectory(reader)
        if len(planned):
            out["planned"] = planned
    return out
