"""2-D sharing's neighbour counts: for each fly, how many others project within R of it in
the left image (paper §2.1.2), every generation, so they are counted in a compiled grid; the
O(N²) numpy reference is what tests compare the kernels to."""

from __future__ import annotations

import numba
import numpy as np

from flylog.fly.fitness import INVALID_FITNESS
from flylog.geometry.kernels import project


def neighbour_counts_numpy(
    u: np.ndarray, v: np.ndarray, valid: np.ndarray, radius: float
) -> np.ndarray:
    """Reference: for each valid fly, how many other valid flies project within ``radius``
    px of it in the left image (O(N²); invalid flies count 0)."""
    du = u[:, None] - u[None, :]
    dv = v[:, None] - v[None, :]
    near = (du * du + dv * dv <= radius * radius) & valid[:, None] & valid[None, :]
    np.fill_diagonal(near, False)
    return near.sum(axis=1).astype(np.int64)


# The grid never has more cells than this many per valid fly, plus a few (its cells grow
# instead), so its buffer is O(N) whatever the spread of the points.
_CELLS_PER_FLY = 8
_MIN_CELLS = 16


def grid_buffer_size(n: int) -> int:
    """Length of the integer scratch ``grid`` the counting kernels need for ``n`` flies."""
    return _CELLS_PER_FLY * n + _MIN_CELLS + 1


@numba.njit(cache=True, nogil=True)
def _grid_counts(puv, pidx, m, radius, grid, ints, suv, counts):  # pragma: no cover - compiled
    """Adds to ``counts[pidx[t]]`` the neighbours of the ``m`` valid flies at ``puv[t]``.

    The flies are sorted by the cell of a grid whose cells are at least R wide (a stable
    counting sort, rows then columns), with an empty column of padding on the left, two on the
    right and an empty row below. Two flies within R are then in the same or adjacent cells,
    and the flies a fly still has to test (each pair once) are two contiguous runs of the
    sorted flies: the rest of its cell and the next cell of its row, then the three cells
    below, walked as one loop. Their bounds are cell starts: no search (a sweep that searches
    them spends most of its time in loop exits mispredicted on fresh flies every
    generation). ``ints`` is (4, ≥ m) integer scratch, ``suv`` (≥ m, 2) float64."""
    cell, order, near, sorted_cell = ints[0], ints[1], ints[2], ints[3]
    umin, vmin, umax, vmax = np.inf, np.inf, -np.inf, -np.inf
    for t in range(m):
        umin, umax = min(umin, puv[t, 0]), max(umax, puv[t, 0])
        vmin, vmax = min(vmin, puv[t, 1]), max(vmax, puv[t, 1])
    w, h = umax - umin, vmax - vmin
    limit = _CELLS_PER_FLY * m + _MIN_CELLS
    # A hair above R: two points R apart can never land two cells apart through rounding.
    side = max(radius * (1.0 + 1e-6), 1e-300)
    while True:
        inv = 1.0 / side
        if w * inv < limit and h * inv < limit:
            n_cols, n_rows = int(w * inv) + 1, int(h * inv) + 1
            if (n_cols + 3) * (n_rows + 1) <= limit:
                break
        side *= 2.0
    stride = n_cols + 3
    n_cells = stride * (n_rows + 1)
    starts = grid[: n_cells + 1]
    starts[:] = 0
    for t in range(m):
        q = int((puv[t, 1] - vmin) * inv) * stride + int((puv[t, 0] - umin) * inv) + 1
        cell[t] = q
        starts[q] += 1
    total = 0
    for q in range(n_cells + 1):
        total += starts[q]
        starts[q] = total  # the end of cell q, for now
    for t in range(m - 1, -1, -1):  # backwards, so stable; each end becomes its cell's start
        q = cell[t]
        at = starts[q] - 1
        starts[q] = at
        order[at] = t
    for s in range(m):
        t = order[s]
        suv[s, 0] = puv[t, 0]
        suv[s, 1] = puv[t, 1]
        sorted_cell[s] = cell[t]
        near[s] = 0
    r2 = radius * radius
    for s in range(m):
        q = sorted_cell[s]
        ua, va = suv[s, 0], suv[s, 1]
        found = 0
        # flies s+1 … (end of the next cell), then lo … hi: one loop, one exit
        same = starts[q + 2] - (s + 1)
        lo, hi = starts[q + stride - 1], starts[q + stride + 2]
        jump = lo - (s + 1) - same
        for j in range(same + hi - lo):
            t = s + 1 + j + (j >= same) * jump
            du = ua - suv[t, 0]
            dv = va - suv[t, 1]
            hit = du * du + dv * dv <= r2
            found += hit
            near[t] += hit
        near[s] += found
    for s in range(m):
        counts[pidx[order[s]]] += near[s]


@numba.njit(cache=True, nogil=True)
def neighbour_counts_into(u, v, valid, radius, grid, ints, uv, counts):  # pragma: no cover
    """Same counts as :func:`neighbour_counts_numpy`, written into ``counts``, by a grid of
    R-cells (:func:`_grid_counts`). ``grid`` is integer scratch of :func:`grid_buffer_size`,
    ``ints`` (5, ≥ N) integer (int32 or int64; int32 for N < 2³¹ / 8) and ``uv`` (2, ≥ N, 2)
    float64 scratch."""
    m = 0
    for i in range(u.shape[0]):
        counts[i] = 0
        if valid[i]:
            uv[0, m, 0] = u[i]
            uv[0, m, 1] = v[i]
            ints[0, m] = i
            m += 1
    if m > 0:
        _grid_counts(uv[0], ints[0], m, radius, grid, ints[1:], uv[1], counts)


@numba.njit(cache=True, nogil=True)
def fly_neighbour_counts_into(xyz, k, fitness, radius, grid, ints, uv, counts):  # pragma: no cover
    """The same counts for the flies themselves: valid = fitness > INVALID_FITNESS, (u, v)
    their left projections (``StereoRig.project``'s numbers, ``k`` from
    :func:`~flylog.fly.fitness.rig_constants`); scratch as for :func:`neighbour_counts_into`."""
    m = 0
    for i in range(xyz.shape[0]):
        counts[i] = 0
        if fitness[i] > INVALID_FITNESS:
            u, _, v, _ = project(k, xyz[i, 0], xyz[i, 1], xyz[i, 2])
            uv[0, m, 0] = u
            uv[0, m, 1] = v
            ints[0, m] = i
            m += 1
    if m > 0:
        _grid_counts(uv[0], ints[0], m, radius, grid, ints[1:], uv[1], counts)


# The counter's integer scratch: int32 halves the grid and index arrays a generation walks
# (~10 µs of ~110 at 5000 flies); indices and cells stay below 2³¹ up to 250 M flies.
_SCRATCH = np.int32


class NeighbourCounter:
    """The counting kernels with their scratch kept between calls (the engine counts every
    generation)."""

    def __init__(self) -> None:
        self._n = -1
        self.grid = np.empty(0, dtype=_SCRATCH)
        self.ints = np.empty((5, 0), dtype=_SCRATCH)
        self.uv = np.empty((2, 0, 2))
        self.counts = np.empty(0, dtype=np.int64)  # for kernels that leave their counts here

    def scratch(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(grid, ints, uv) for ``n`` flies (and ``counts``), reallocated only when ``n``
        changes."""
        if n != self._n:
            self._n = n
            self.grid = np.empty(grid_buffer_size(n), dtype=_SCRATCH)
            self.ints = np.empty((5, n), dtype=_SCRATCH)
            self.uv = np.empty((2, n, 2))
            self.counts = np.empty(n, dtype=np.int64)
        return self.grid, self.ints, self.uv

    def __call__(
        self, u: np.ndarray, v: np.ndarray, valid: np.ndarray, radius: float
    ) -> np.ndarray:
        """(N,) int64 neighbour counts (a new array)."""
        counts = np.empty(len(u), dtype=np.int64)
        neighbour_counts_into(u, v, valid, float(radius), *self.scratch(len(u)), counts)
        return counts
