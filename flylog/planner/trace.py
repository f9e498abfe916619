"""The planned path, compiled: gradient descent on the potential's gradient fields.

:func:`flylog.planner.steering.descend` is the reference (plain Python over callables, the
same arithmetic); replay traces a path at every snapshot, where the Python loop cost
milliseconds per path.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from flylog.planner.grid import GridGeometry
from flylog.planner.steering import FLAT_GRADIENT, PathEnd, PlannedPath

# The kernel's end codes, in PathEnd's order.
_ENDS = (PathEnd.GOAL, PathEnd.MAX_STEPS, PathEnd.FLAT, PathEnd.LEFT_GRID, PathEnd.OBSTACLE)
_GOAL, _MAX_STEPS, _FLAT, _LEFT_GRID, _OBSTACLE = range(5)


@numba.njit(cache=True, nogil=True)
def _bilinear(field, ox, oy, cell, n, x, y):  # pragma: no cover - compiled
    """As :func:`flylog.planner.grid.bilinear`: clamped to the outermost cell centres."""
    cx = min(max((x - ox) / cell - 0.5, 0.0), n - 1.0)
    cy = min(max((y - oy) / cell - 0.5, 0.0), n - 1.0)
    j0 = min(int(cx), n - 2)
    i0 = min(int(cy), n - 2)
    fy, fx = cy - i0, cx - j0
    f00, f01 = field[i0, j0], field[i0, j0 + 1]
    f10, f11 = field[i0 + 1, j0], field[i0 + 1, j0 + 1]
    return (1 - fy) * ((1 - fx) * f00 + fx * f01) + fy * ((1 - fx) * f10 + fx * f11)


@numba.njit(cache=True, nogil=True)
def _blocked(obstacles, ox, oy, cell, n, x, y):  # pragma: no cover - compiled
    """-1 off the grid, 1 in an obstacle cell, 0 in a free one (GridGeometry's rules)."""
    size = n * cell
    if not (ox <= x < ox + size and oy <= y < oy + size):
        return -1
    j = min(max(math.floor((x - ox) / cell), 0), n - 1)
    i = min(max(math.floor((y - oy) / cell), 0), n - 1)
    return 1 if obstacles[i, j] else 0


@numba.njit(cache=True, nogil=True)
def _descend_kernel(
    gx_field, gy_field, obstacles, ox, oy, cell, x, y, goal_x, goal_y, step, max_steps, tol
):  # pragma: no cover - compiled
    n = obstacles.shape[0]
    pts = np.empty((max_steps + 2, 2))
    pts[0, 0], pts[0, 1] = x, y
    k = 1
    escaping = _blocked(obstacles, ox, oy, cell, n, x, y) == 1
    end = _MAX_STEPS
    for _ in range(max_steps):
        if math.hypot(x - goal_x, y - goal_y) <= tol:
            pts[k, 0], pts[k, 1] = goal_x, goal_y
            k += 1
            end = _GOAL
            break
        gx = _bilinear(gx_field, ox, oy, cell, n, x, y)
        gy = _bilinear(gy_field, ox, oy, cell, n, x, y)
        norm = math.hypot(gx, gy)
        if norm <= FLAT_GRADIENT:
            end = _FLAT
            break
        x, y = x - step * gx / norm, y - step * gy / norm
        state = _blocked(obstacles, ox, oy, cell, n, x, y)
        if state == -1:
            end = _LEFT_GRID
            break
        pts[k, 0], pts[k, 1] = x, y
        k += 1
        if state == 1 and not escaping:
            end = _OBSTACLE
            break
        escaping = escaping and state == 1
    return pts[:k].copy(), end


def descend_on_grid(
    gradient: tuple[np.ndarray, np.ndarray],
    obstacles: np.ndarray,
    geometry: GridGeometry,
    start_xy: tuple[float, float],
    goal_xy: tuple[float, float],
    *,
    step: float,
    max_steps: int,
    goal_tolerance: float,
) -> PlannedPath:
    """:func:`~flylog.planner.steering.descend` over the gradient fields ``gradient``
    ((dU/dx, dU/dy) at the cell centres) and the obstacle cells, with the same rules and
    bounds."""
    ox, oy = geometry.origin
    gx, gy = gradient
    points, end = _descend_kernel(
        np.ascontiguousarray(gx, dtype=np.float64),
        np.ascontiguousarray(gy, dtype=np.float64),
        np.ascontiguousarray(obstacles, dtype=np.bool_),
        float(ox),
        float(oy),
        float(geometry.cell_size),
        float(start_xy[0]),
        float(start_xy[1]),
        float(goal_xy[0]),
        float(goal_xy[1]),
        float(step),
        int(max_steps),
        float(goal_tolerance),
    )
    return PlannedPath(points, _ENDS[end])
