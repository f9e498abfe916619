"""Plain-numpy references of the planner's compiled map kernels (tests only)."""

from __future__ import annotations

import math

import numpy as np

from flylog.planner.grid import GridGeometry


def seen_through_numpy(
    geometry: GridGeometry,
    origin_xy: tuple[float, float],
    points_xy: np.ndarray,
    stops: np.ndarray,
    weights: np.ndarray,
) -> np.ndarray:
    """Reference of :func:`flylog.planner.evidence.seen_through`: every line's samples at
    once, cut at the first sample off the grid, one weight per run of samples in a cell."""
    n, cell = geometry.cells, geometry.cell_size
    ox, oy = geometry.origin
    x0, y0 = origin_xy
    step = 0.5 * cell
    out = np.zeros(geometry.shape)
    for (px, py), stop, w in zip(np.asarray(points_xy)[:, :2], stops, weights, strict=True):
        length = math.hypot(px - x0, py - y0)
        if stop < 0.0 or length <= 0.0:
            continue
        ux, uy = (px - x0) / length, (py - y0) / length
        s = np.arange(math.floor(stop / step) + 1, dtype=np.float64)
        j = np.floor((x0 + s * step * ux - ox) / cell).astype(np.int64)
        i = np.floor((y0 + s * step * uy - oy) / cell).astype(np.int64)
        off = (i < 0) | (i >= n) | (j < 0) | (j >= n)
        if off.any():
            first = int(np.argmax(off))
            i, j = i[:first], j[:first]
        flat = i * n + j
        runs = np.ones(len(flat), dtype=bool)
        runs[1:] = flat[1:] != flat[:-1]
        np.add.at(out, (i[runs], j[runs]), w)
    return out


def reachable_from_numpy(free: np.ndarray, seed: tuple[int, int]) -> np.ndarray:
    """Reference of :func:`flylog.planner.reach.reachable_from`: grow the seed by its four
    neighbours within ``free`` until nothing changes."""
    out = np.zeros(free.shape, dtype=bool)
    h, w = free.shape
    if not (0 <= seed[0] < h and 0 <= seed[1] < w):
        return out
    out[seed] = True
    while True:
        grown = out.copy()
        grown[1:, :] |= out[:-1, :]
        grown[:-1, :] |= out[1:, :]
        grown[:, 1:] |= out[:, :-1]
        grown[:, :-1] |= out[:, 1:]
        grown &= free
        grown[seed] = True
        if np.array_equal(grown, out):
            return out
        out = grown


def cone_cells_numpy(
    geometry: GridGeometry,
    cones: np.ndarray,
    half_cone: float,
    rows: slice = slice(None),
    cols: slice = slice(None),
) -> np.ndarray:
    """Reference of :func:`flylog.planner.sonar_free.cone_cells`: each cone over the whole
    window at once, the same arithmetic."""
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
        inside = along * math.sin(half_cone) - across * math.cos(half_cone) >= 0.5 * c
        out |= inside & (along > 0.0) & (np.hypot(dx, dy) <= reach)
    return out
