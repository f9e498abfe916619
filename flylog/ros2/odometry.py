"""Odometry from a bag: ``nav_msgs/msg/Odometry`` or ``/tf`` odom → base_link, as planar
OdomReadings. A pose leaning more than ``MAX_TILT_DEG`` (roll or pitch) is projected on
the ground plane, with one warning per bag."""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterator
from typing import Any

from flylog.ros2.frames import (
    BASE_FRAME,
    ODOM_FRAME,
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
    """Converts Odometry or TFMessage messages to OdomReadings, warning once on tilt."""

    def __init__(self, where: str, *, from_tf: bool) -> None:
        self._where = where
        self._from_tf = from_tf
        self._warned = False

    def _pose(self, t_ns: int, position: Any, orientation: Any) -> OdomReading:
        if not self._warned and tilt(rotation_matrix(orientation)) > math.radians(MAX_TILT_DEG):
            self._warned = True
            msg = (
                f"{self._where}: the odometry leans more than {MAX_TILT_DEG:g}° (roll or pitch) "
                f"at {t_ns} ns; its poses are projected on the ground plane"
            )
            warnings.warn(msg, TiltedOdometryWarning, stacklevel=4)
        return OdomReading(t_ns, planar(position, orientation))

    def readings(self, msg: Any) -> Iterator[OdomReading]:
        if not self._from_tf:
            pose = msg.pose.pose
            yield self._pose(stamp_ns(msg.header), pose.position, pose.orientation)
            return
        for t in msg.transforms:
            if frame_name(t.header.frame_id) == ODOM_FRAME and (
                frame_name(t.child_frame_id) == BASE_FRAME
            ):
                tr = t.transform
                yield self._pose(stamp_ns(t.header), tr.translation, tr.rotation)
