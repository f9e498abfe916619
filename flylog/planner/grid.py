"""Where the planner grid lies in the odometric frame, and interpolation on it.

Orientation (also that of a foxglove Grid): the grid is axis-aligned with ``odom``.
Array index ``[row, col]``; row 0 is at the origin's y and rows grow along +y; columns grow
along +x. Cell ``[i, j]`` covers ``[ox + j*c, ox + (j+1)*c] x [oy + i*c, oy + (i+1)*c]`` and
its value belongs to the cell centre ``(ox + (j + 0.5)*c, oy + (i + 0.5)*c)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np


@dataclass(frozen=True, slots=True)
class GridGeometry:
    """A square grid of ``cells`` x ``cells`` cells of side ``cell_size`` with its corner at
    ``origin`` (x, y) in the odometric frame."""

    origin: tuple[float, float]
    cell_size: float
    cells: int

    @property
    def shape(self) -> tuple[int, int]:
        return (self.cells, self.cells)

    def contains(self, x: float, y: float) -> bool:
        """Whether (x, y) lies on the grid."""
        ox, oy = self.origin
        size = self.cells * self.cell_size
        return ox <= x < ox + size and oy <= y < oy + size

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """(row, col) of the cell holding (x, y), clamped to the grid."""
        ox, oy = self.origin
        j = min(max(math.floor((x - ox) / self.cell_size), 0), self.cells - 1)
        i = min(max(math.floor((y - oy) / self.cell_size), 0), self.cells - 1)
        return i, j

    def cells_of(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Rows, cols (int64) of points (N, 2+) and a mask of those on the grid."""
        ox, oy = self.origin
        col = np.floor((xy[:, 0] - ox) / self.cell_size)
        row = np.floor((xy[:, 1] - oy) / self.cell_size)
        inside = (col >= 0) & (col < self.cells) & (row >= 0) & (row < self.cells)
        inside &= np.isfinite(col) & np.isfinite(row)
        rows = np.where(inside, row, 0).astype(np.int64)
        cols = np.where(inside, col, 0).astype(np.int64)
        return rows, cols, inside

    def centre_of(self, i: int, j: int) -> tuple[float, float]:
        """(x, y) of the centre of cell (row i, col j)."""
        ox, oy = self.origin
        return (ox + (j + 0.5) * self.cell_size, oy + (i + 0.5) * self.cell_size)

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """(x, y) of every cell centre, each (H, W)."""
        ox, oy = self.origin
        c = (np.arange(self.cells) + 0.5) * self.cell_size
        x, y = np.meshgrid(ox + c, oy + c)
        return x, y


def centred_origin(centre_xy: tuple[float, float], extent: float) -> tuple[float, float]:
    """The corner of a grid of side ``extent`` centred on ``centre_xy``."""
    return (centre_xy[0] - extent / 2.0, centre_xy[1] - extent / 2.0)


def log_distance_guess(geometry: GridGeometry, goal: tuple[float, float]) -> np.ndarray:
    """A start of the relaxation close to the obstacle-free solution: log(1 + distance from
    the goal in cells), scaled to at most 1, so the robot has a descent direction from the
    first tick (the relaxation refines it)."""
    x, y = geometry.centres()
    guess = np.log1p(np.hypot(x - goal[0], y - goal[1]) / geometry.cell_size)
    return guess / guess.max()


def neighbour_mean(u: np.ndarray) -> np.ndarray:
    """(H, W): the mean of each cell's four neighbours (of those on the grid)."""
    total = np.zeros_like(u)
    count = np.zeros_like(u)
    total[1:, :] += u[:-1, :]
    count[1:, :] += 1
    total[:-1, :] += u[1:, :]
    count[:-1, :] += 1
    total[:, 1:] += u[:, :-1]
    count[:, 1:] += 1
    total[:, :-1] += u[:, 1:]
    count[:, :-1] += 1
    return total / count


def bilinear(field: np.ndarray, geometry: GridGeometry, x: float, y: float) -> float:
    """``field`` (H, W), sampled at cell centres, bilinearly interpolated at (x, y); clamped
    to the outermost cell centres."""
    i0, j0, fy, fx = _corner(geometry, x, y)
    f00 = field[i0, j0]
    f01 = field[i0, j0 + 1]
    f10 = field[i0 + 1, j0]
    f11 = field[i0 + 1, j0 + 1]
    return float((1 - fy) * ((1 - fx) * f00 + fx * f01) + fy * ((1 - fx) * f10 + fx * f11))


def gradient_field(u: np.ndarray, cell_size: float) -> tuple[np.ndarray, np.ndarray]:
    """(dU/dx, dU/dy) at every cell centre: central differences inside, one-sided at the
    edges (exact for a linear U); ``np.gradient(u, cell_size)``'s arithmetic, value for
    value, in a compiled loop that releases the GIL (the planner's worker computes it at
    each tick while the engine runs)."""
    if u.dtype != np.float64 or u.ndim != 2 or min(u.shape) < 2:
        msg = f"gradient_field needs a float64 grid of at least 2 x 2 cells, got {u.dtype}{u.shape}"
        raise ValueError(msg)
    gx, gy = np.empty(u.shape), np.empty(u.shape)
    _gradient_kernel(u, float(cell_size), gx, gy)
    return gx, gy


@numba.njit(cache=True, nogil=True)
def _gradient_kernel(u, dx, gx, gy):  # pragma: no cover - compiled
    """np.gradient's first-order edges and central interior, along both axes, into gx, gy."""
    h, w = u.shape
    twice = 2.0 * dx
    for i in range(h):
        for j in range(w):
            if i == 0:
                gy[i, j] = (u[1, j] - u[0, j]) / dx
            elif i == h - 1:
                gy[i, j] = (u[h - 1, j] - u[h - 2, j]) / dx
            else:
                gy[i, j] = (u[i + 1, j] - u[i - 1, j]) / twice
            if j == 0:
                gx[i, j] = (u[i, 1] - u[i, 0]) / dx
            elif j == w - 1:
                gx[i, j] = (u[i, w - 1] - u[i, w - 2]) / dx
            else:
                gx[i, j] = (u[i, j + 1] - u[i, j - 1]) / twice


def _corner(geometry: GridGeometry, x: float, y: float) -> tuple[int, int, float, float]:
    """Lower-left cell centre of the interpolation square holding (x, y), and fractions."""
    ox, oy = geometry.origin
    n = geometry.cells
    # continuous index with cell centres at integers
    cx = min(max((x - ox) / geometry.cell_size - 0.5, 0.0), n - 1.0)
    cy = min(max((y - oy) / geometry.cell_size - 0.5, 0.0), n - 1.0)
    j0 = min(int(cx), n - 2)
    i0 = min(int(cy), n - 2)
    return i0, j0, cy - i0, cx - j0
