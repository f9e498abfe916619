"""Free space from the sonar ring: a sonar reports the nearest surface inside its cone, so
the cone up to its echo (or up to its maximum range, without an echo) holds no obstacle
that reflects sound.

That is evidence the cameras' flies cannot give about themselves: a cluster of false
matches at a near, confident depth outweighs the lines of sight through it, but the sonar
looking through the same cells hears nothing there. A cell counts as sonar-free when its
centre lies inside the cone at least half a cell from the cone's edges, and at least
``margin`` nearer than the echo (the range noise and the cell's own extent).
"""

from __future__ import annotations

import math

import numpy as np

from flylog.geometry import Pose2D, transform_points_2d
from flylog.planner.grid import GridGeometry
from flylog.sensors import SonarReading


def free_cones(reading: SonarReading, pose: Pose2D, margin: float) -> np.ndarray:
    """(n, 4) every sonar's apex x, y and axis yaw in odom (``pose``: the odometry at the
    reading) and how far along it the cone is free: the echo's range less ``margin``, or
    the maximum range less ``margin`` without an echo (negative: nothing free)."""
    mounts = np.asarray(reading.mounts, dtype=np.float64)
    apex = transform_points_2d(pose, mounts[:, :2])
    reach = np.where(reading.fired, reading.ranges, reading.max_range) - margin
    return np.column_stack([apex, pose.theta + mounts[:, 2], reach])


def cone_cells(
    geometry: GridGeometry,
    cones: np.ndarray,
    half_cone: float,
    rows: slice = slice(None),
    cols: slice = slice(None),
) -> np.ndarray:
    """(h, w) bool over ``[rows, cols]``: cells inside a free cone of ``cones`` (n, 4) as
    :func:`free_cones` gives them, their centre at most the cone's free reach from its apex
    and at least half a cell inside both of its edges."""
    ox, oy = geometry.origin
    c = geometry.cell_size
    centres = (np.arange(geometry.cells) + 0.5) * c
    xs, ys = (ox + centres[cols])[None, :], (oy + centres[rows])[:, None]
    out = np.zeros((ys.shape[0], xs.shape[1]), dtype=bool)
    for x0, y0, yaw, reach in np.asarray(cones, dtype=np.float64).reshape(-1, 4):
        if not reach > 0.0:
            continue
        dx, dy = xs - x0, ys - y0
        cos_y, sin_y = math.cos(yaw), math.sin(yaw)
        along = cos_y * dx + sin_y * dy
        across = np.abs(cos_y * dy - sin_y * dx)
        # distance from the centre to the nearer edge ray: along·sin(h) − across·cos(h)
        inside = along * math.sin(half_cone) - across * math.cos(half_cone) >= 0.5 * c
        out |= inside & (along > 0.0) & (np.hypot(dx, dy) <= reach)
    return out
