"""Odometry from a bag: ``nav_msgs/msg/Odometry`` or ``/tf`` odom → base_link, as planar
OdomReadings. A pose leaning more than ``MAX_TILT_DEG`` (roll or pitch) is projected on
the ground plane, with one warning per bag.

In ``/tf``, odometry is odom → base_link, or odom → a frame that the static tree
(``/tf_static``) connects to base_link, as robots publish it (odom → base_footprint, and
base_footprint → base_link static): base_link's pose is then the two composed."""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterator
from typing import Any

import numpy as np

from flylog.geometry import Pose2D
from flylog.ros2.frames import (
    BASE_FRAME,
    ODOM_FRAME,
    StaticTree,
    frame_name,
    planar,
    rotation_matrix,
    stamp_ns,
    tilt,
)
from flylog.sensors import OdomReading

MAX_TILT_DEG = 5.0


class TiltedOdometryWarning(UserWarning):
    """Some odometry poses had roll or pitch beyond MAX_TILT_DEG and were projected."""


class NoOdometryWarning(UserWarning):
    """The bag has no odometry: the engine runs without proprioception."""


class OdometryReader:
    """Converts Odometry or TFMessage messages to OdomReadings, warning once on tilt;
    ``tree``: the static transforms, for /tf odometry to a frame other than base_link."""

    def __init__(self, where: str, *, from_tf: bool, tree: StaticTree | None = None) -> None:
        self._where = where
        self._from_tf = from_tf
        self._tree = tree
        self._base_in: dict[str, tuple[np.ndarray, np.ndarray] | None] = {}
        self._warned = False

    def _tilted(self, t_ns: int, rotation: np.ndarray) -> None:
        if not self._warned and tilt(rotation) > math.radians(MAX_TILT_DEG):
            self._warned = True
            msg = (
                f"{self._where}: the odometry leans more than {MAX_TILT_DEG:g}° (roll or pitch) "
                f"at {t_ns} ns; its poses are projected on the ground plane"
            )
            warnings.warn(msg, TiltedOdometryWarning, stacklevel=5)

    def _pose(self, t_ns: int, position: Any, orientation: Any) -> OdomReading:
        self._tilted(t_ns, rotation_matrix(orientation))
        return OdomReading(t_ns, planar(position, orientation))

    def _base_in_frame(self, frame: str) -> tuple[np.ndarray, np.ndarray] | None:
        """base_link's (position, axes) in ``frame`` from the static tree, if it connects."""
        if frame not in self._base_in:
            tree = self._tree
            self._base_in[frame] = None if tree is None else tree.in_frame(BASE_FRAME, frame)
        return self._base_in[frame]

    def readings(self, msg: Any) -> Iterator[OdomReading]:
        if not self._from_tf:
            pose = msg.pose.pose
            yield self._pose(stamp_ns(msg.header), pose.position, pose.orientation)
            return
        for t in msg.transforms:
            if frame_name(t.header.frame_id) != ODOM_FRAME:
                continue
            child, tr = frame_name(t.child_frame_id), t.transform
            if child == BASE_FRAME:
                yield self._pose(stamp_ns(t.header), tr.translation, tr.rotation)
                continue
            base = self._base_in_frame(child)
            if base is None:
                continue
            rotation = rotation_matrix(tr.rotation)
            x = tr.translation
            position = rotation @ base[0] + np.array([x.x, x.y, x.z], dtype=float)
            axes = rotation @ base[1]
            t_ns = stamp_ns(t.header)
            self._tilted(t_ns, axes)
            heading = math.atan2(axes[1, 0], axes[0, 0])
            yield OdomReading(t_ns, Pose2D(float(position[0]), float(position[1]), heading))
