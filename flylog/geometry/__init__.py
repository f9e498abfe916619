"""Frames, poses and the stereo rig. The conventions here are the project's, once.

Frames (ROS REP 103):
- ``odom`` / world: x east-ish, y left, z up. The robot moves in the plane z = 0.
- ``base_link``: the robot; x forward, y left, z up. Flies live here.
- ``camera_left`` / ``camera_right``: optical frames; x right, y down, z forward (depth).
  Rectified: one orientation for both (the mount's pan, tilt and roll applied to the level
  orientation, axes along base_link x), the right optical centre ``baseline`` along the
  left camera's x axis, the pair's midpoint at (mount_x, mount_y, mount_height). A level
  rig's left camera sits at (mount_x, mount_y + baseline/2, mount_height).
- Pixels: (u, v) with u to the right and v down; pixel centres at integer coordinates. The
  left principal point is (cx, cy), the right one (cx + doffs, cy): disparity uL − uR is
  f·B/Z − doffs.
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
