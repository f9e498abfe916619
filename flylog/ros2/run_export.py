"""``flylog export RUN --ros2 OUT``: a run (a ``flylog replay`` output or a closed-loop log)
as a rosbag2 directory (MCAP storage) of standard messages, timed as the run, written
atomically; with ``log`` the sensor log's topics too (:mod:`flylog.ros2.export`), so one bag
plays the robot and its flies together.

| run topic | ROS 2 topic | type |
|---|---|---|
| /flies | /flies | sensor_msgs/msg/PointCloud2: x, y, z, fitness [, age, distinct, confidence] |
| /flies (the run's obstacle rule) | /flies/obstacles | sensor_msgs/msg/PointCloud2, same fields |
| /flies (with a rig) | /flies/depth, /flies/depth_confidence | sensor_msgs/msg/Image 32FC1 |
| /planner/map | /map | nav_msgs/msg/OccupancyGrid: 100 detected, 99 inflation, 0 free |
| /planner/potential | /planner/potential | nav_msgs/msg/OccupancyGrid: 100 × U, clipped to 0..100 |
| /planner/path | /plan | nav_msgs/msg/Path |
| /planner/command | /cmd_vel | geometry_msgs/msg/TwistStamped |
| /planner/command's status | /planner/status | std_msgs/msg/String |
| /tf odom → base_link | /planner/odom | nav_msgs/msg/Odometry |
| /tf odom → base_link (without ``log``) | /tf | tf2_msgs/msg/TFMessage |
| /tf base_link → sensors (without ``log``) | /tf_static, once | tf2_msgs/msg/TFMessage |
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from flylog.errors import FlylogError, LogError
from flylog.fly.confidence import ConfidenceModel
from flylog.fly.depth_image import sparse_depth
from flylog.fly.obstacles import ObstacleFlies
from flylog.fly.snapshot_export import cloud_columns
from flylog.geometry import StereoRig
from flylog.io import contract, open_log
from flylog.io.reader import LogReader
from flylog.io.records import FlyCloud, GridValues, LogMessage
from flylog.ros2 import types
from flylog.ros2.export import ExportSummary, _Bag, _Translation
from flylog.ros2.messages import ImageFormat
from flylog.ros2.run_messages import (
    OCCUPANCY_GRID,
    PATH,
    POINT_CLOUD2,
    STRING,
    TWIST_STAMPED,
    RunBuilder,
)
from flylog.ros2.source import GOAL_KEY

FLIES = "/flies"
OBSTACLE_FLIES = "/flies/obstacles"
DEPTH = "/flies/depth"
DEPTH_CONFIDENCE = "/flies/depth_confidence"
MAP = "/map"
POTENTIAL = "/planner/potential"
PLAN = "/plan"
CMD_VEL = "/cmd_vel"
STATUS = "/planner/status"
PLANNER_ODOM = "/planner/odom"

RUN_TOPICS = (
    contract.FLIES,
    contract.PLANNER_MAP,
    contract.PLANNER_POTENTIAL,
    contract.PLANNER_PATH,
    contract.PLANNER_COMMAND,
)


@dataclass(frozen=True)
class RunExport:
    """What the run's translation needs besides the run: the obstacle rule, the left
    camera (None: no depth images), the confidence model (None: no confidence field) and
    whether the sensor log's /tf is written instead of the run's."""

    rule: ObstacleFlies
    rig: StereoRig | None
    camera_frame: str
    confidence: ConfidenceModel | None
    tf: bool


def is_run(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` holds a run's outputs (a /flies or /planner/* topic); False for what
    does not open as a log (the sensor log's export then says why)."""
    try:
        topics = open_log(path).topics()
    except (FlylogError, OSError):
        return False
    return any(t in RUN_TOPICS for t in topics)


def export_run_ros2(
    run: str | os.PathLike[str],
    output: str | os.PathLike[str],
    *,
    log: str | os.PathLike[str] | None = None,
    image_format: ImageFormat = ImageFormat.RGB8,
    truth: bool = False,
    confidence: ConfidenceModel | None = None,
    on_progress: Callable[[float, float], None] | None = None,
) -> ExportSummary:
    """Write the outputs of ``run`` (and with ``log``, that sensor log's topics as
    :func:`flylog.ros2.export.export_ros2` writes them, with ``truth`` its true pose) as the
    rosbag2 directory ``output``; nothing is left behind on failure. The depth images need
    the rig: from ``log``, else from the run when it is a closed-loop log, else from the log
    the run's metadata names when it is there; without one they are left out."""
    run, output = Path(run), Path(output)
    if output.exists():
        msg = f"{output} exists: the ROS 2 export writes a new directory, choose another OUT"
        raise LogError(msg)
    if not output.parent.is_dir():
        msg = f"cannot write {output}: directory {output.parent} does not exist"
        raise LogError(msg)
    reader = open_log(run)
    present = reader.topics()
    if not any(t in present for t in RUN_TOPICS):
        msg = (
            f"{run} holds no run topics ({', '.join(RUN_TOPICS)}): a sensor log exports "
            "with `flylog export LOG --ros2 OUT`, without --with-log"
        )
        raise LogError(msg)
    log_reader = open_log(log) if log is not None else None
    if log_reader is not None:
        _check_pair(reader, log_reader)
    rig, frame = _left_camera(log_reader if log_reader is not None else _rig_source(reader))
    setup = RunExport(_rule(reader), rig, frame, confidence, tf=log_reader is None)
    goal = reader.metadata().get(contract.REPLAY_METADATA, {}).get("goal")
    staging = Path(tempfile.mkdtemp(prefix=f".{output.name}.", suffix=".part", dir=output.parent))
    try:
        bag = _Bag(staging / output.name)
        if goal is not None:
            bag.writer.set_custom_data(GOAL_KEY, json.dumps(json.loads(goal)))
        with bag.writer:
            if log_reader is not None:
                _Translation(bag, image_format).run(log_reader, truth, on_progress)
            RunTranslation(bag, setup).run(reader, on_progress)
        os.replace(staging / output.name, output)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return ExportSummary(output, bag.count, bag.topics)


def _rule(reader: LogReader) -> ObstacleFlies:
    from flylog.metrics.config import MetricsConfig
    from flylog.metrics.score import run_facts

    return run_facts(reader, MetricsConfig()).rule


def _check_pair(run: LogReader, log: LogReader) -> None:
    """LogError when the run's metadata names another log than ``log`` (its fingerprint)."""
    from flylog.metrics.provenance import check_run_log

    replayed = run.metadata().get(contract.REPLAY_METADATA, {})
    if contract.LEFT_IMAGE not in log.topics():
        msg = f"--with-log {log.path} has no {contract.LEFT_IMAGE}: is it a flylog sensor log?"
        raise LogError(msg)
    check_run_log(run.path, log.path, replayed)


def _rig_source(run: LogReader) -> LogReader:
    """Where the run's rig is: the run itself (a closed-loop log), else the log its metadata
    names (as named, else by that name beside the run) when that file is there and is the
    one replayed."""
    replayed = run.metadata().get(contract.REPLAY_METADATA, {})
    named = replayed.get("log")
    if contract.LEFT_CALIBRATION in run.topics() or named is None:
        return run
    if not Path(named).is_file():  # a relative name: from where replay ran, or beside the run
        named = str(Path(run.path).parent / Path(named).name)
        if not Path(named).is_file():
            return run
    from flylog.metrics.provenance import check_run_log

    try:
        check_run_log(run.path, named, replayed)
        return open_log(named)
    except LogError:
        return run


def _left_camera(reader: LogReader) -> tuple[StereoRig | None, str]:
    """The rig of a log with calibration topics (None for a run without them) and the left
    camera's frame."""
    frame = contract.CAMERA_FRAMES["left"]
    present = reader.topics()
    if not all(t in present for t in contract.CALIBRATION_TOPICS.values()):
        return None, frame
    from flylog.replay.inputs import log_rig

    dataset = reader.metadata().get(contract.DATASET_METADATA, {})
    mounted = dataset.get("mount") != contract.MOUNT_NONE
    return log_rig(reader, mounted=mounted), frame


class RunTranslation:
    """The run's messages, one by one, as ROS 2 messages."""

    def __init__(self, bag: _Bag, setup: RunExport) -> None:
        self.bag = bag
        self.setup = setup
        self.build = RunBuilder(bag.store)
        self.static_written = False

    def run(self, reader: LogReader, on_progress: Callable[[float, float], None] | None) -> None:
        present = reader.topics()
        topics = [t for t in (*RUN_TOPICS, contract.TF) if t in present]
        handlers: dict[str, Callable[[int, Any], None]] = {
            contract.FLIES: self._flies,
            contract.PLANNER_MAP: self._map,
            contract.PLANNER_POTENTIAL: self._potential,
            contract.PLANNER_PATH: self._path,
            contract.PLANNER_COMMAND: self._command,
            contract.TF: self._tf,
        }
        t0, span = reader.start_ns, max(1, reader.end_ns - reader.start_ns)
        message: LogMessage
        for i, message in enumerate(reader.messages(topics)):
            t = message.log_time_ns
            handlers[message.topic](t, message.value)
            if on_progress is not None and i % 64 == 0:
                on_progress((t - t0) / 1e9, span / 1e9)

    def _write(self, topic: str, t: int, msgtype: str, message: Any) -> None:
        self.bag.write(topic, t, msgtype, message)

    def _flies(self, t: int, cloud: FlyCloud) -> None:
        setup = self.setup
        columns = cloud_columns(cloud, setup.confidence)
        confidence = columns[-1][1] if setup.confidence is not None else None
        frame = contract.BASE_FRAME
        self._write(FLIES, t, POINT_CLOUD2, self.build.point_cloud(t, frame, columns))
        if setup.rule.uses_distinctness and cloud.distinct is None:
            msg = (
                f"the run's obstacle rule reads each fly's distinctness, but its /flies "
                f"snapshot at {t / 1e9:.3f} s has no 'distinct' field"
            )
            raise LogError(msg)
        keep = setup.rule.mask(cloud.xyz, cloud.fitness, cloud.age, cloud.distinct)
        kept = [(name, values[keep]) for name, values in columns]
        self._write(OBSTACLE_FLIES, t, POINT_CLOUD2, self.build.point_cloud(t, frame, kept))
        if setup.rig is not None:
            weight = cloud.fitness if confidence is None else confidence
            image = sparse_depth(cloud.xyz, weight, setup.rig)
            camera = setup.camera_frame
            self._write(DEPTH, t, types.IMAGE, self.build.float_image(t, camera, image.depth))
            message = self.build.float_image(t, camera, image.weight)
            self._write(DEPTH_CONFIDENCE, t, types.IMAGE, message)

    def _map(self, t: int, grid: GridValues) -> None:
        cells = np.asarray(grid.values, dtype=np.int8)
        message = self.build.occupancy_grid(t, contract.ODOM_FRAME, cells, grid.origin, grid.cell)
        self._write(MAP, t, OCCUPANCY_GRID, message)

    def _potential(self, t: int, grid: GridValues) -> None:
        cells = np.rint(100.0 * np.clip(np.asarray(grid.values, dtype=np.float64), 0.0, 1.0))
        message = self.build.occupancy_grid(
            t, contract.ODOM_FRAME, cells.astype(np.int8), grid.origin, grid.cell
        )
        self._write(POTENTIAL, t, OCCUPANCY_GRID, message)

    def _path(self, t: int, poses: np.ndarray) -> None:
        self._write(PLAN, t, PATH, self.build.path(t, contract.ODOM_FRAME, poses))

    def _command(self, t: int, command: dict[str, Any]) -> None:
        twist = self.build.twist(t, contract.BASE_FRAME, command["linear"], command["angular"])
        self._write(CMD_VEL, t, TWIST_STAMPED, twist)
        self._write(STATUS, t, STRING, self.build.text(str(command["status"])))

    def _tf(self, t: int, transforms: list[Any]) -> None:
        moving = [tr for tr in transforms if tr.parent == contract.ODOM_FRAME]
        static = [tr for tr in transforms if tr.parent != contract.ODOM_FRAME]
        for tr in moving:
            if tr.child == contract.BASE_FRAME:
                message = self.build.odometry(t, tr.translation, tr.rotation, tr.child)
                self._write(PLANNER_ODOM, t, types.ODOMETRY, message)
        if not self.setup.tf:
            return
        rows = [(tr.parent, tr.child, tr.translation, tr.rotation) for tr in static]
        if rows and not self.static_written:
            self._write(types.TF_STATIC, t, types.TF_MESSAGE, self.build.tf(t, rows))
            self.static_written = True
        rows = [(tr.parent, tr.child, tr.translation, tr.rotation) for tr in moving]
        if rows:
            self._write(types.TF, t, types.TF_MESSAGE, self.build.tf(t, rows))
