"""Transforms from ``tf2_msgs/msg/TFMessage``: the static tree (``/tf_static``) looked up
between any two of its frames, quaternions, stamps and planar poses.

A robot's tree is not always rooted at base_link: a ZED-like driver hangs base_link below
base_footprint (``base_footprint → base_link`` in /tf_static) and its sonars or cameras
from either. A frame is placed in base_link through the tree's root, up from each frame and
down again, whichever of the two is the other's ancestor (or neither)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from flylog.geometry import Pose2D
from flylog.geometry.stereo import quaternion_matrix
from flylog.io.decode import yaw_of

BASE_FRAME = "base_link"
ODOM_FRAME = "odom"


def stamp_ns(header: Any) -> int:
    """Integer nanoseconds of a std_msgs/Header's stamp."""
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


def frame_name(frame_id: str) -> str:
    """A frame id without the leading slash some ROS 1 converted bags keep."""
    return str(frame_id).lstrip("/")


def rotation_matrix(q: Any) -> np.ndarray:
    """3×3 rotation of a geometry_msgs/Quaternion, normalised first unless it is a unit
    quaternion to 1e-12 already (then it converts as flylog's log reader converts it, so
    an exported log's mounts read back bit for bit)."""
    x, y, z, w = float(q.x), float(q.y), float(q.z), float(q.w)
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if n == 0.0:
        return np.eye(3)
    if abs(n - 1.0) > 1e-12:
        x, y, z, w = x / n, y / n, z / n, w / n
    return quaternion_matrix((x, y, z, w))


def tilt(rotation: np.ndarray) -> float:
    """How far (rad) a body's z axis leans from the vertical: roll and pitch together."""
    return math.acos(max(-1.0, min(1.0, float(rotation[2, 2]))))


def planar(position: Any, orientation: Any) -> Pose2D:
    """A pose projected on the ground plane: x, y and the heading of its x axis projected
    on the ground (the quaternion's yaw, computed as flylog's decoder does, so a pose
    exported from a flylog log reads back bit for bit)."""
    return Pose2D(float(position.x), float(position.y), yaw_of(orientation))


class StaticTree:
    """The static transforms of a bag: child frame → (parent, translation, rotation)."""

    def __init__(self) -> None:
        self._parent: dict[str, tuple[str, np.ndarray, np.ndarray]] = {}

    def add(self, message: Any) -> None:
        """Add every transform of a TFMessage (a later one for the same child wins)."""
        for t in message.transforms:
            tr = t.transform.translation
            self._parent[frame_name(t.child_frame_id)] = (
                frame_name(t.header.frame_id),
                np.array([tr.x, tr.y, tr.z], dtype=float),
                rotation_matrix(t.transform.rotation),
            )

    def _in_root(self, frame: str) -> tuple[str, np.ndarray, np.ndarray] | None:
        """(root, position, axes) of ``frame`` in the root of its tree (None for a cycle)."""
        position, axes = np.zeros(3), np.eye(3)
        seen: set[str] = set()
        while frame in self._parent:
            if frame in seen:
                return None
            seen.add(frame)
            parent, translation, rotation = self._parent[frame]
            position = rotation @ position + translation
            axes = rotation @ axes
            frame = parent
        return frame, position, axes

    def in_frame(self, frame: str, reference: str) -> tuple[np.ndarray, np.ndarray] | None:
        """(position (3,), axes (3, 3)) of ``frame`` in ``reference``, or None if the static
        tree does not connect them (in either direction)."""
        found, ref = self._in_root(frame_name(frame)), self._in_root(frame_name(reference))
        if found is None or ref is None or found[0] != ref[0]:
            return None
        _, position, axes = found
        _, ref_position, ref_axes = ref
        return ref_axes.T @ (position - ref_position), ref_axes.T @ axes

    def in_base(self, frame: str) -> tuple[np.ndarray, np.ndarray] | None:
        """(position (3,), axes (3, 3)) of ``frame`` in base_link, or None if the static
        tree does not connect them."""
        return self.in_frame(frame, BASE_FRAME)

    def mount(self, frame: str) -> tuple[float, float, float] | None:
        """(x, y, yaw) of ``frame`` in base_link, yaw the heading of its x axis."""
        found = self.in_base(frame)
        if found is None:
            return None
        position, axes = found
        return float(position[0]), float(position[1]), math.atan2(axes[1, 0], axes[0, 0])
