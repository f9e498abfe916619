"""Frames, poses and the stereo rig. The conventions here are the project's, once.

Frames (ROS REP 103):
- ``odom`` / world: x east-ish, y left, z up. The robot moves in the plane z = 0.
- ``base_link``: the robot; x forward, y left, z up. Flies live here.
- ``camera_left`` / ``camera_right``: optical frames; x right, y down, z forward (depth).
  Both cameras look straight ahead (horizontal optical axes), rectified, same intrinsics;
  the left camera sits at base_link (mount_x, +baseline/2, mount_height), the right at
  (mount_x, -baseline/2, mount_height).
- Pixels: (u, v) with u to the right and v down; pixel centres at integer coordinates.
"""

from flylog.geometry.poses import (
    Pose2D,
    compose,
    inverse,
    relative,
    transform_points_2d,
    yaw_quaternion,
)
from flylog.geometry.stereo import OPTICAL_IN_BASE_QUAT, StereoRig

__all__ = [
    "OPTICAL_IN_BASE_QUAT",
    "Pose2D",
    "StereoRig",
    "compose",
    "inverse",
    "relative",
    "transform_points_2d",
    "yaw_quaternion",
]
