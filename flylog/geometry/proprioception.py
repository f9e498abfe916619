"""Proprioception as an operator on points fixed in the world: where the robot sees them after
it moved by an odometry increment (the flies of the engine, SGBM's points, a snapshot's
flies brought to the planner's pose)."""

from __future__ import annotations

import math

import numba
import numpy as np

from flylog.geometry.poses import Pose2D, inverse, transform_points_2d


def moved_by_odometry(xyz: np.ndarray, increment: Pose2D) -> np.ndarray:
    """Proprioception as an operator: the flies, fixed in the world, seen from the robot
    after it moved by ``increment`` (the odometry increment ``relative(prev, new)``)."""
    return transform_points_2d(inverse(increment), xyz)


def move_by_odometry(xyz: np.ndarray, increment: Pose2D) -> None:
    """:func:`moved_by_odometry` in place, compiled (the same numbers: the same scalar cos and
    sin, the same operations in the same order), for C-contiguous float64 ``xyz`` (N, 3)."""
    pose = inverse(increment)
    _move_kernel(xyz, pose.x, pose.y, math.cos(pose.theta), math.sin(pose.theta))


@numba.njit(cache=True, nogil=True)
def _move_kernel(xyz, x, y, c, s):  # pragma: no cover - compiled
    """transform_points_2d's arithmetic, in place."""
    for i in range(xyz.shape[0]):
        px, py = xyz[i, 0], xyz[i, 1]
        xyz[i, 0] = x + c * px - s * py
        xyz[i, 1] = y + s * px + c * py
