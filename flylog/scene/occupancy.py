"""Whether a robot's footprint can drive from a scene's start to its goal, and how far.

The world is sampled on a square grid (``cell`` metres): a cell is free for the robot when
its centre lies at least ``radius`` (the robot's radius plus a margin) from every obstacle
footprint, the exact distance of :func:`~flylog.scene.footprints.distance_to_footprints`.
The shortest path over the free cells, 8-connected, each move as long as it is (one cell
or its diagonal), is Dijkstra's; its length is at most 8 % (the octile metric's worst
case against the straight line) longer than the shortest collision-free curve on the same
cells. A goal no free cell connects to the start is unreachable for that footprint: the
generated ``dead-end`` worlds are checked this way.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np

from flylog.scene.footprints import Footprints, distance_to_footprints

_MOVES = tuple(
    (di, dj, math.hypot(di, dj)) for di in (-1, 0, 1) for dj in (-1, 0, 1) if (di, dj) != (0, 0)
)


@dataclass(frozen=True)
class ClearanceGrid:
    """Distance from every cell centre to the nearest footprint, on a square grid."""

    origin: tuple[float, float]  # (x, y) of cell [0, 0]'s corner; rows along +y
    cell: float  # m
    distance: np.ndarray  # (H, W) m, 0 inside a footprint

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        return (
            math.floor((y - self.origin[1]) / self.cell),
            math.floor((x - self.origin[0]) / self.cell),
        )

    def centres(self, cells: np.ndarray) -> np.ndarray:
        """(K, 2) x, y of the centres of ``cells`` (K, 2) row, col."""
        c = np.asarray(cells, dtype=float)
        return np.stack(
            [
                self.origin[0] + (c[:, 1] + 0.5) * self.cell,
                self.origin[1] + (c[:, 0] + 0.5) * self.cell,
            ],
            axis=1,
        )


def clearance_grid(
    fp: Footprints, bounds: tuple[float, float, float, float], cell: float
) -> ClearanceGrid:
    """The distances on the cells covering ``bounds`` (xmin, ymin, xmax, ymax)."""
    x0, y0, x1, y1 = bounds
    cols = max(1, math.ceil((x1 - x0) / cell))
    rows = max(1, math.ceil((y1 - y0) / cell))
    xs = x0 + (np.arange(cols) + 0.5) * cell
    ys = y0 + (np.arange(rows) + 0.5) * cell
    gx, gy = np.meshgrid(xs, ys)
    d = distance_to_footprints(fp, np.stack([gx.ravel(), gy.ravel()], axis=1))
    return ClearanceGrid((x0, y0), cell, d.reshape(rows, cols))


@dataclass(frozen=True)
class PathCheck:
    """The shortest path for a footprint from start to goal, if there is one."""

    reachable: bool
    length: float  # m along the grid path (inf when unreachable)
    path: np.ndarray  # (K, 2) cell centres from start to goal ((0, 2) when unreachable)
    narrowest_gap: float  # m: the widest path's bottleneck (widest_gap; inf: no path)


def shortest_path(
    grid: ClearanceGrid, start: tuple[float, float], goal: tuple[float, float], radius: float
) -> PathCheck:
    """Dijkstra over the cells at least ``radius`` from every footprint (8-connected)."""
    free = grid.distance >= radius
    h, w = free.shape
    s, g = grid.cell_of(*start), grid.cell_of(*goal)
    inside = all(0 <= c[0] < h and 0 <= c[1] < w for c in (s, g))
    if not inside or not free[s] or not free[g]:
        return _unreachable()
    best = np.full((h, w), np.inf)
    came = np.full((h, w), -1, dtype=np.int64)
    best[s] = 0.0
    queue: list[tuple[float, int, int]] = [(0.0, *s)]
    while queue:
        d, i, j = heapq.heappop(queue)
        if (i, j) == g:
            break
        if d > best[i, j]:
            continue
        for di, dj, step in _MOVES:
            ti, tj = i + di, j + dj
            if not (0 <= ti < h and 0 <= tj < w) or not free[ti, tj]:
                continue
            # a diagonal move passes between its two side cells: both must be free
            if di and dj and not (free[i, tj] and free[ti, j]):
                continue
            nd = d + step
            if nd < best[ti, tj]:
                best[ti, tj] = nd
                came[ti, tj] = i * w + j
                heapq.heappush(queue, (nd, ti, tj))
    if not np.isfinite(best[g]):
        return _unreachable()
    cells = [g]
    while cells[-1] != s:
        flat = int(came[cells[-1]])
        cells.append((flat // w, flat % w))
    order = np.array(cells[::-1])
    gap = widest_gap(grid, start, goal)
    return PathCheck(True, float(best[g]) * grid.cell, grid.centres(order), gap)


def widest_gap(grid: ClearanceGrid, start: tuple[float, float], goal: tuple[float, float]) -> float:
    """Twice the largest clearance r for which some path of cells at least r from every
    footprint joins start and goal (the bottleneck of the widest path, 8-connected): the
    narrowest gap the way must pass. 0 when start or goal is inside an obstacle."""
    d = grid.distance
    h, w = d.shape
    s, g = grid.cell_of(*start), grid.cell_of(*goal)
    best = np.full((h, w), -1.0)
    best[s] = d[s]
    queue: list[tuple[float, int, int]] = [(-float(d[s]), *s)]
    while queue:
        neg, i, j = heapq.heappop(queue)
        if (i, j) == g:
            return 2.0 * -neg
        if -neg < best[i, j]:
            continue
        for di, dj, _ in _MOVES:
            ti, tj = i + di, j + dj
            if not (0 <= ti < h and 0 <= tj < w):
                continue
            width = min(-neg, float(d[ti, tj]))
            if width > best[ti, tj]:
                best[ti, tj] = width
                heapq.heappush(queue, (-width, ti, tj))
    return 0.0


def _unreachable() -> PathCheck:
    return PathCheck(False, math.inf, np.zeros((0, 2)), math.inf)
