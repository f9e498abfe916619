"""What one update of obstacle flies says about each cell: how much fly weight lies in it,
and how much looks through it.

A stereo fly's depth error grows as Z² / (f·B) (one pixel of disparity at depth Z, focal
f in pixels, baseline B): at 320×240 with the bundled rig (f·B = 30 px·m) 0.08 m at
1.5 m, 0.53 m at 4 m. A fly counts as ``min(1, depth_error_full / error)`` of a fly, so
far, coarse flies need many more of their kind to make a cell dense than near, sharp ones.

The line of sight from the cameras to a fly crosses cells that the cameras saw through:
the fly would be hidden if one of them held an obstacle. Every cell on the segment from
the robot to the fly's depth less its depth error and one cell (the fly may lie that much
nearer) receives the fly's weight as *seen-through* evidence. A cell that more weight looks
through than lies in is free this update, however many coarse flies blurred into it.

:func:`seen_through` is compiled; :func:`seen_through_numpy` in ``tests/planner`` is its
reference (same samples, same sums).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from flylog.planner.grid import GridGeometry


def depth_weights(
    ranges: np.ndarray, focal_baseline: float, full_weight_error: float
) -> np.ndarray:
    """(M,) float64: each fly's weight, 1 where its depth error ``ranges² / focal_baseline``
    is at most ``full_weight_error`` (m), ``full_weight_error / error`` beyond."""
    error = np.asarray(ranges, dtype=np.float64) ** 2 / focal_baseline
    return np.minimum(1.0, full_weight_error / np.maximum(error, 1e-12))


def depth_errors(ranges: np.ndarray, focal_baseline: float) -> np.ndarray:
    """(M,) float64: the depth spanned by one pixel of disparity at each range (m)."""
    return np.asarray(ranges, dtype=np.float64) ** 2 / focal_baseline


def weighted_counts(
    geometry: GridGeometry, points_xy: np.ndarray, weights: np.ndarray
) -> np.ndarray:
    """(H, W) float64: the sum of ``weights`` of the points (N, 2+) in each cell."""
    rows, cols, inside = geometry.cells_of(np.asarray(points_xy, dtype=np.float64))
    flat = rows[inside] * geometry.cells + cols[inside]
    sums = np.bincount(flat, weights=weights[inside], minlength=geometry.cells * geometry.cells)
    return sums.reshape(geometry.shape)


def ray_stops(ranges: np.ndarray, errors: np.ndarray, cell_size: float) -> np.ndarray:
    """(M,) how far along each line of sight the cells are seen through: the fly's range
    less its depth error and one cell (negative: not at all)."""
    return np.asarray(ranges, dtype=np.float64) - errors - cell_size


def seen_through(
    geometry: GridGeometry,
    origin_xy: tuple[float, float],
    points_xy: np.ndarray,
    stops: np.ndarray,
    weights: np.ndarray,
) -> np.ndarray:
    """(H, W) float64: for every cell, the total weight of the lines of sight that cross it.

    Each line runs from ``origin_xy`` towards its point, sampled every half cell from the
    origin out to ``stops`` (m); a cell receives a line's weight once, however many of its
    samples fall in it."""
    pts = np.ascontiguousarray(np.asarray(points_xy, dtype=np.float64)[:, :2])
    return _seen_through_kernel(
        float(geometry.origin[0]),
        float(geometry.origin[1]),
        float(geometry.cell_size),
        int(geometry.cells),
        float(origin_xy[0]),
        float(origin_xy[1]),
        pts,
        np.ascontiguousarray(stops, dtype=np.float64),
        np.ascontiguousarray(weights, dtype=np.float64),
    )


@numba.njit(cache=True, nogil=True)
def _seen_through_kernel(ox, oy, cell, n, x0, y0, pts, stops, weights):  # pragma: no cover
    out = np.zeros((n, n))
    step = 0.5 * cell
    for k in range(pts.shape[0]):
        stop = stops[k]
        if stop < 0.0:
            continue
        dx, dy = pts[k, 0] - x0, pts[k, 1] - y0
        length = math.hypot(dx, dy)
        if length <= 0.0:
            continue
        ux, uy = dx / length, dy / length
        samples = math.floor(stop / step) + 1
        last = -1
        for s in range(samples):
            x = x0 + s * step * ux
            y = y0 + s * step * uy
            j = math.floor((x - ox) / cell)
            i = math.floor((y - oy) / cell)
            if i < 0 or i >= n or j < 0 or j >= n:
                break
            flat = i * n + j
            if flat != last:
                out[i, j] += weights[k]
                last = flat
    return out


def full_weight_range(
    focal_baseline: float | None, full_weight_depth_error: float, view_range: float
) -> float:
    """The range (m) up to which a fly counts fully, where one pixel of disparity spans
    ``full_weight_depth_error``: sqrt(error × f·B) (2.1 m at 320×240 with the bundled rig,
    f·B = 30 px·m), at most ``view_range``; ``view_range`` without ``focal_baseline``."""
    if focal_baseline is None or full_weight_depth_error <= 0.0:
        return float(view_range)
    return min(math.sqrt(full_weight_depth_error * float(focal_baseline)), float(view_range))
