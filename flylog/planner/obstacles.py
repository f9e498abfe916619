"""Obstacle cells from obstacle flies: density, the cameras' view, occlusion, inflation.

Pure functions over grids; :class:`~flylog.planner.planner.HarmonicPlanner` keeps the memory.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from flylog.geometry import Pose2D
from flylog.planner.grid import GridGeometry
from flylog.sensors import SonarReading


def fly_counts(geometry: GridGeometry, points_xy: np.ndarray) -> np.ndarray:
    """(H, W) int64: how many points (N, 2+) fall in each cell (points off the grid are
    dropped)."""
    pts = np.asarray(points_xy, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] < 2:
        msg = f"obstacle points must be (M, 2) or (M, 3), got shape {pts.shape}"
        raise ValueError(msg)
    rows, cols, inside = geometry.cells_of(pts)
    flat = rows[inside] * geometry.cells + cols[inside]
    counts = np.bincount(flat, minlength=geometry.cells * geometry.cells)
    return counts.reshape(geometry.shape)


def dense_cells(
    counts: np.ndarray,
    cell_size: float,
    half_width: int,
    threshold: float,
    rows: slice = slice(None),
    cols: slice = slice(None),
) -> np.ndarray:
    """(H, W) bool: cells holding at least one fly whose window density (flies per m² over
    the (2r+1)² window, clipped at the grid's edges) reaches ``threshold``. Requiring a fly
    in the cell itself keeps the obstacle where the flies are (the window does not smear
    it); the window rejects isolated flies. With ``rows`` and ``cols`` (steps of 1), those
    cells only: the same values as ``dense_cells(counts, ...)[rows, cols]`` (the planner
    needs the cells in view range, a quarter of the grid). ``counts``: integers or float64
    weights.

    The window sums come from an integral image of the cells in ``[rows, cols]`` and
    ``2r`` around them, zeros off the grid, summed down the columns and then along the rows
    (int64 for integer counts, float64 for weights). Compiled, without the GIL (the
    planner's worker runs it at every tick beside the engine): the numpy form of the same
    sums (``dense_cells_numpy`` in ``tests/planner``, bit-identical) took 0.4 ms a tick."""
    h, w = counts.shape
    r0, r1, _ = rows.indices(h)
    c0, c1, _ = cols.indices(w)
    integer = np.issubdtype(counts.dtype, np.integer) or counts.dtype == np.bool_
    source = np.ascontiguousarray(counts, dtype=np.int64 if integer else np.float64)
    window_area = ((2 * half_width + 1) * cell_size) ** 2
    return _dense_cells_kernel(
        source,
        r0,
        max(r1, r0),
        c0,
        max(c1, c0),
        max(half_width, 0),
        window_area,
        float(threshold),
    )


@numba.njit(cache=True, nogil=True)
def _dense_cells_kernel(counts, r0, r1, c0, c1, r, area, threshold):  # pragma: no cover
    h, w = counts.shape
    hi, wi = r1 - r0, c1 - c0
    out = np.zeros((hi, wi), dtype=np.bool_)
    if r == 0:
        for i in range(hi):
            for j in range(wi):
                v = counts[r0 + i, c0 + j]
                out[i, j] = v > 0 and v / area >= threshold
        return out
    # the cells of [rows, cols] and r around them (zeros off the grid), padded by r more:
    # integral[1 + p, 1 + q] sums the padded cells up to (p, q)
    big_h, big_w = hi + 2 * r, wi + 2 * r
    k = 2 * r + 1
    integral = np.zeros((big_h + k, big_w + k), dtype=counts.dtype)
    for p in range(big_h + 2 * r):
        gi = r0 - 2 * r + p
        row_in = r <= p < r + big_h and 0 <= gi < h
        for q in range(big_w + 2 * r):
            gj = c0 - 2 * r + q
            v = counts[gi, gj] if row_in and r <= q < r + big_w and 0 <= gj < w else 0
            integral[p + 1, q + 1] = integral[p, q + 1] + v
    for p in range(1, big_h + k):
        for q in range(1, big_w + k):
            integral[p, q] = integral[p, q - 1] + integral[p, q]
    for i in range(hi):
        y = i + r
        for j in range(wi):
            x = j + r
            total = (
                integral[y + k, x + k] - integral[y, x + k] - integral[y + k, x] + integral[y, x]
            )
            out[i, j] = counts[r0 + i, c0 + j] > 0 and total / area >= threshold
    return out


def sonar_arc_points(reading: SonarReading, max_range: float, spacing: float) -> np.ndarray:
    """(M, 2) base_link points along the arc of every sonar whose echo is nearer than
    ``max_range``: the echo came from somewhere on that arc (its range across the cone),
    ``spacing`` apart at most so every cell the arc crosses holds one."""
    fired = reading.fired & (reading.ranges <= max_range)
    if not fired.any():
        return np.empty((0, 2))
    mounts, ranges = reading.mounts[fired], reading.ranges[fired]
    half = reading.half_cone
    n = max(2, math.ceil(2.0 * half * float(ranges.max()) / spacing) + 1)
    angles = mounts[:, 2:3] + np.linspace(-half, half, n)[None, :]  # (k, n)
    x = mounts[:, 0:1] + ranges[:, None] * np.cos(angles)
    y = mounts[:, 1:2] + ranges[:, None] * np.sin(angles)
    return np.stack([x.ravel(), y.ravel()], axis=1)


def polar_of_cells(
    geometry: GridGeometry, pose: Pose2D, rows: slice = slice(None), cols: slice = slice(None)
) -> tuple[np.ndarray, np.ndarray]:
    """(range, bearing) of the cell centres in ``[rows, cols]`` from the robot; bearing
    relative to its heading, in [-pi, pi]."""
    ox, oy = geometry.origin
    centres = (np.arange(geometry.cells) + 0.5) * geometry.cell_size
    dx = (ox + centres[cols])[None, :] - pose.x
    dy = (oy + centres[rows])[:, None] - pose.y
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    # the centres in the robot's frame: the bearing needs no wrapping
    forward, left = c * dx + s * dy, c * dy - s * dx
    return np.hypot(dx, dy), np.arctan2(left, forward)


def view_mask(
    rng: np.ndarray, bearing: np.ndarray, half_fov: float, view_range: float
) -> np.ndarray:
    """(H, W) bool: cell centres inside the cameras' view sector."""
    return (rng <= view_range) & (np.abs(bearing) <= half_fov)


def seen_free(
    in_view: np.ndarray,
    detected: np.ndarray,
    rng: np.ndarray,
    bearing: np.ndarray,
    half_fov: float,
    cell_size: float,
    view_range: float,
) -> np.ndarray:
    """(H, W) bool: cells in view, not detected, and nearer than the first detected obstacle
    in their bearing (cells in an obstacle's shadow are not seen, so are not free).

    Bearings are binned at the angle one cell subtends at the view range; each bin's shadow
    starts at the nearest detection in it or its two neighbours, less one cell (the
    detection's own extent). Compiled, without the GIL (the planner's worker runs it at
    every tick beside the engine); ``seen_free_numpy`` in ``tests/planner`` is its
    reference (the same bins and minima)."""
    width = max(cell_size / max(view_range, cell_size), 1e-6)
    n_bins = max(1, math.ceil(2.0 * half_fov / width))
    return _seen_free_kernel(
        np.ascontiguousarray(in_view, dtype=np.bool_),
        np.ascontiguousarray(detected, dtype=np.bool_),
        np.ascontiguousarray(rng, dtype=np.float64),
        np.ascontiguousarray(bearing, dtype=np.float64),
        float(half_fov),
        float(width),
        n_bins,
        float(cell_size),
    )


@numba.njit(cache=True, nogil=True)
def _seen_free_kernel(
    in_view, detected, rng, bearing, half_fov, width, n_bins, cell
):  # pragma: no cover - compiled
    h, w = in_view.shape
    bins = np.empty((h, w), dtype=np.int64)
    nearest = np.full(n_bins + 2, np.inf)
    for i in range(h):
        for j in range(w):
            b = np.int64((bearing[i, j] + half_fov) / width)  # truncated, as astype does
            b = min(max(b, 0), n_bins - 1)
            bins[i, j] = b
            if detected[i, j] and in_view[i, j] and rng[i, j] < nearest[b + 1]:
                nearest[b + 1] = rng[i, j]
    # an obstacle cell spans a little more than its bin: its neighbours share its shadow
    shadow = np.empty(n_bins)
    for b in range(n_bins):
        shadow[b] = min(min(nearest[b], nearest[b + 1]), nearest[b + 2])
    out = np.zeros((h, w), dtype=np.bool_)
    for i in range(h):
        for j in range(w):
            out[i, j] = (
                in_view[i, j] and not detected[i, j] and rng[i, j] < shadow[bins[i, j]] - cell
            )
    return out


def disk_offsets(radius_cells: float) -> list[tuple[int, int]]:
    """(di, dj) of every cell whose centre lies within ``radius_cells`` of the origin."""
    r = math.floor(radius_cells + 1e-9)  # 0.3 / 0.1 is 2.999...: keep the 3-cell ring
    return [
        (di, dj)
        for di in range(-r, r + 1)
        for dj in range(-r, r + 1)
        if di * di + dj * dj <= radius_cells * radius_cells + 1e-9
    ]


def distance_within(mask: np.ndarray, radius_cells: float) -> np.ndarray:
    """(H, W) float64: distance (in cells, centre to centre) from each cell to the nearest
    set cell of ``mask``, where that is within ``radius_cells``; inf elsewhere.

    Compiled (:func:`distance_within_numpy` is the reference): the planner calls it every
    tick, and a stamp of the disk around each set cell costs far less than a pass over the
    whole grid per disk offset."""
    disk = disk_offsets(radius_cells)
    offsets = np.array(disk, dtype=np.int64).reshape(-1, 2)
    lengths = np.array([math.hypot(di, dj) for di, dj in disk], dtype=np.float64)
    return _distance_within_kernel(np.ascontiguousarray(mask, dtype=np.bool_), offsets, lengths)


@numba.njit(cache=True, nogil=True)
def _distance_within_kernel(mask, offsets, lengths):  # pragma: no cover - compiled
    h, w = mask.shape
    out = np.full((h, w), np.inf)
    for i in range(h):
        for j in range(w):
            if not mask[i, j]:
                continue
            for k in range(offsets.shape[0]):
                ti, tj = i + offsets[k, 0], j + offsets[k, 1]
                if 0 <= ti < h and 0 <= tj < w and lengths[k] < out[ti, tj]:
                    out[ti, tj] = lengths[k]
    return out


def distance_within_numpy(mask: np.ndarray, radius_cells: float) -> np.ndarray:
    """Reference of :func:`distance_within`: one whole-grid minimum per disk offset."""
    out = np.full(mask.shape, np.inf)
    h, w = mask.shape
    for di, dj in disk_offsets(radius_cells):
        # out[i + di, j + dj] = min(out, |(di, dj)|) where mask[i, j], over the overlap
        si0, si1 = max(0, -di), min(h, h - di)
        sj0, sj1 = max(0, -dj), min(w, w - dj)
        if si0 >= si1 or sj0 >= sj1:
            continue
        dst = out[si0 + di : si1 + di, sj0 + dj : sj1 + dj]
        src = mask[si0:si1, sj0:sj1]
        np.minimum(dst, np.where(src, math.hypot(di, dj), np.inf), out=dst)
    return out


def inflate(mask: np.ndarray, radius_cells: float) -> np.ndarray:
    """``mask`` dilated by a disk of ``radius_cells`` (a cell is set if any set cell's centre
    lies within the radius of its centre)."""
    return np.isfinite(distance_within(mask, radius_cells))


def skin(mask: np.ndarray) -> np.ndarray:
    """Cells of ``mask`` with a 4-neighbour outside it (cells off the grid count as inside)."""
    out = np.zeros_like(mask)
    out[1:, :] |= ~mask[:-1, :]
    out[:-1, :] |= ~mask[1:, :]
    out[:, 1:] |= ~mask[:, :-1]
    out[:, :-1] |= ~mask[:, 1:]
    return out & mask


def obstacle_values(distance: np.ndarray, radius_cells: float, rise: float) -> np.ndarray:
    """Dirichlet values of the inflated obstacle cells (where ``distance`` is finite).

    The skin (cells touching free space) is 1, as the paper's obstacles; deeper cells rise
    linearly towards 1 + ``rise`` at the detected cells, so a robot inside an inflated
    obstacle has a gradient out of it. Free space only touches the skin, the border (1) and
    the goal (0): it stays below 1 and its descent can end nowhere but at the goal."""
    obstacles = np.isfinite(distance)
    r = math.floor(radius_cells + 1e-9)
    d = np.minimum(distance, r + 1.0)  # no inf * 0 off the obstacles
    values = 1.0 + rise * (r + 1.0 - d) / (r + 1.0)
    values[skin(obstacles)] = 1.0
    return np.where(obstacles, values, 0.0)


def neighbour_factor(weight: np.ndarray) -> np.ndarray:
    """(H, W) float64: each cell's 1 / (total ``weight`` of its four neighbours), the SOR
    multiplier of a weighted mean of the neighbours (0.25 where every weight is 1; the
    outermost ring, never relaxed, gets 0.25).

    An obstacle cell of weight ``a`` that holds ``a`` times its Dirichlet value turns the
    neighbours' mean into the weighted mean: a = 1 is the paper's Dirichlet obstacle, a → 0
    a reflecting (Neumann) one, and in between a Robin boundary that lets the obstacle
    raise U in front of it by an amount that shrinks with a."""
    w = np.asarray(weight, dtype=np.float64)
    out = np.full(w.shape, 0.25)
    total = ((w[:-2, 1:-1] + w[2:, 1:-1]) + w[1:-1, :-2]) + w[1:-1, 2:]
    out[1:-1, 1:-1] = 1.0 / total
    return out
