"""SE(2) poses of a robot moving on the ground plane."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def wrap_angle(a: float) -> float:
    """The angle in (-pi, pi]."""
    return math.atan2(math.sin(a), math.cos(a))


@dataclass(frozen=True, slots=True)
class Pose2D:
    """A planar pose: position (m) and heading (rad, counter-clockwise from x)."""

    x: float = 0.0
    y: float = 0.0
    theta: float = 0.0

    def as_array(self) -> np.ndarray:
        return np.array([self.x, self.y, self.theta])


def compose(a: Pose2D, b: Pose2D) -> Pose2D:
    """a ⊕ b: the pose b, given in a's frame, expressed in a's parent frame."""
    c, s = math.cos(a.theta), math.sin(a.theta)
    return Pose2D(a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, wrap_angle(a.theta + b.theta))


def inverse(a: Pose2D) -> Pose2D:
    """The pose whose composition with ``a`` is the identity."""
    c, s = math.cos(a.theta), math.sin(a.theta)
    return Pose2D(-c * a.x - s * a.y, s * a.x - c * a.y, wrap_angle(-a.theta))


def relative(a: Pose2D, b: Pose2D) -> Pose2D:
    """⊖a ⊕ b: the motion from pose a to pose b, in a's frame (an odometry increment)."""
    return compose(inverse(a), b)


def transform_points_2d(pose: Pose2D, xy: np.ndarray) -> np.ndarray:
    """Points (N, 2+) given in the pose's frame, expressed in its parent frame (x, y only;
    further columns such as z are passed through)."""
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    out = np.array(xy, dtype=np.result_type(xy, np.float32), copy=True)
    x, y = xy[:, 0], xy[:, 1]
    out[:, 0] = pose.x + c * x - s * y
    out[:, 1] = pose.y + s * x + c * y
    return out


def yaw_quaternion(theta: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation by ``theta`` about z."""
    return (0.0, 0.0, math.sin(theta / 2.0), math.cos(theta / 2.0))
