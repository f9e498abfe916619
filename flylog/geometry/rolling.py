"""A rolling shutter's rows in the robot's frame: where a point of base_link at an image's
stamp is when the row it falls on is exposed.

Row v of an image is exposed at the stamp + v · p (:mod:`flylog.io.shutter`); the robot moves
meanwhile. Its motion over the whole readout (stamp to stamp + height · p, an odometry
increment in base_link at the stamp) is the pair's ``readout``; row v's motion is the fraction
v / height of it: constant velocity over one readout (31.2 ms at 240 rows of 130 µs),
whose error under an angular acceleration α (the readout's motion is the chord between the
poses at its ends) is α·t·(T − t)/2, at most f·α·T²/8 in the image: 0.03 px per rad/s² at
T = 31.2 ms and f = 250 px, none while the robot turns at a constant rate.
A point P (base_link at the stamp) falling on row v is seen from the pose at that row's
time: P moved by the inverse of row v's motion (proprioception's
:func:`~flylog.geometry.proprioception.moved_by_odometry`), the turn's cos and sin to second
order (1 − a²/2 and a: their error a³/6 is below 1e-6 rad for the 16 mrad of a 31.2 ms
readout at 0.5 rad/s).
One correction step: v from P's own projection, then the moved point projected again.

These are the numpy forms of :func:`flylog.geometry.kernels.seen_at_row` and
:func:`~flylog.geometry.kernels.seen_at_stamp`, the same operations in the same order, so a
kernel and its reference agree bit for bit.
"""

from __future__ import annotations

import numpy as np

from flylog.geometry.poses import Pose2D
from flylog.geometry.stereo import StereoRig

# A readout with no motion: every row at the stamp (a global shutter, or a robot at rest).
STILL = Pose2D(0.0, 0.0, 0.0)


def row_motion(readout: Pose2D, height: int) -> np.ndarray:
    """(3,) float64: the motion per row (x, y, theta of ``readout`` over ``height`` rows)."""
    return np.array([readout.x, readout.y, readout.theta], dtype=np.float64) / float(height)


def is_still(readout: Pose2D) -> bool:
    """Whether ``readout`` moves nothing (then every row is at the stamp)."""
    return readout.x == 0.0 and readout.y == 0.0 and readout.theta == 0.0


def rows_clamped(v: np.ndarray, height: int) -> np.ndarray:
    """:func:`flylog.geometry.kernels.row_clamped` over an array."""
    return np.where(v > 0.0, np.minimum(v, float(height)), 0.0)


def seen_at_rows(xyz: np.ndarray, rm: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(N, 3): the points ``xyz`` (base_link at the stamp) seen from the robot at the times
    of rows ``v`` (N,), with ``rm`` from :func:`row_motion`."""
    a = v * rm[2]
    c = 1.0 - 0.5 * a * a
    dx = xyz[:, 0] - v * rm[0]
    dy = xyz[:, 1] - v * rm[1]
    return np.stack([c * dx + a * dy, c * dy - a * dx, xyz[:, 2]], axis=-1)


def seen_at_stamp(xyz: np.ndarray, rm: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The inverse of :func:`seen_at_rows` (to its order): points seen at the times of rows
    ``v``, in base_link at the stamp."""
    a = v * rm[2]
    c = 1.0 - 0.5 * a * a
    x, y = xyz[..., 0], xyz[..., 1]
    return np.stack([v * rm[0] + (c * x - a * y), v * rm[1] + (a * x + c * y), xyz[..., 2]], -1)


def at_rows(xyz: np.ndarray, rig: StereoRig, rm: np.ndarray) -> np.ndarray:
    """(N, 3): each point of ``xyz`` seen at the time of the row its projection falls on
    (one step: the row of its projection at the stamp, clamped to the image)."""
    xyz = np.asarray(xyz, dtype=np.float64)
    v = rows_clamped(rig.project(xyz)[2], rig.height)
    return seen_at_rows(xyz, rm, v)
