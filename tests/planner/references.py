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


def box_sum(counts: np.ndarray, half_width: int) -> np.ndarray:
    """Sum of ``counts`` over the (2r+1) x (2r+1) window around each cell (window clipped
    at the grid edges), through an integral image of the zero-padded counts (int64 for
    integer counts, float64 for weights)."""
    dtype = np.int64 if np.issubdtype(counts.dtype, np.integer) else np.float64
    if half_width <= 0:
        return counts.astype(dtype, copy=True)
    k = 2 * half_width + 1
    h, w = counts.shape
    integral = np.zeros((h + k, w + k), dtype=dtype)
    integral[1:, 1:] = np.pad(counts, half_width).cumsum(axis=0).cumsum(axis=1)
    return integral[k:, k:] - integral[:h, k:] - integral[k:, :w] + integral[:h, :w]


def dense_cells_numpy(
    counts: np.ndarray,
    cell_size: float,
    half_width: int,
    threshold: float,
    rows: slice = slice(None),
    cols: slice = slice(None),
) -> np.ndarray:
    """Reference of :func:`flylog.planner.obstacles.dense_cells`: (H, W) bool, cells holding
    at least one fly whose window density (flies per m² over the (2r+1)² window) reaches
    ``threshold``. Requiring a fly in the cell itself keeps the
    obstacle where the flies are (the window does not smear it); the window rejects
    isolated flies. With ``rows`` and ``cols`` (steps of 1), those cells only: the same
    values as ``dense_cells(counts, ...)[rows, cols]`` (the planner needs the cells in view
    range, a quarter of the grid)."""
    window_area = ((2 * half_width + 1) * cell_size) ** 2
    counts_in = counts[rows, cols]
    density = box_sum(around(counts, rows, cols, half_width), half_width) / window_area
    r = max(half_width, 0)
    density = density[r : r + counts_in.shape[0], r : r + counts_in.shape[1]]
    return (counts_in > 0) & (density >= threshold)


def around(counts: np.ndarray, rows: slice, cols: slice, margin: int) -> np.ndarray:
    """``counts[rows, cols]`` and ``margin`` more cells on every side, zeros off the grid
    (as box_sum pads the whole grid)."""
    margin = max(margin, 0)
    h, w = counts.shape
    r0, r1, _ = rows.indices(h)
    c0, c1, _ = cols.indices(w)
    out = np.zeros((max(r1 - r0, 0) + 2 * margin, max(c1 - c0, 0) + 2 * margin), counts.dtype)
    a0, a1 = max(r0 - margin, 0), min(r1 + margin, h)
    b0, b1 = max(c0 - margin, 0), min(c1 + margin, w)
    if a0 < a1 and b0 < b1:
        out[a0 - r0 + margin : a1 - r0 + margin, b0 - c0 + margin : b1 - c0 + margin] = counts[
            a0:a1, b0:b1
        ]
    return out


def seen_free_numpy(
    in_view: np.ndarray,
    detected: np.ndarray,
    rng: np.ndarray,
    bearing: np.ndarray,
    half_fov: float,
    cell_size: float,
    view_range: float,
) -> np.ndarray:
    """Reference of :func:`flylog.planner.obstacles.seen_free`: (H, W) bool, cells in view,
    not detected, and nearer than the first detected obstacle in their bearing (cells in an
    obstacle's shadow are not seen, so are not free).

    Bearings are binned at the angle one cell subtends at the view range; each bin's shadow
    starts at the nearest detection in it or its two neighbours, less one cell (the
    detection's own extent)."""
    width = max(cell_size / max(view_range, cell_size), 1e-6)
    n_bins = max(1, math.ceil(2.0 * half_fov / width))
    bins = np.clip(((bearing + half_fov) / width).astype(np.int64), 0, n_bins - 1)
    nearest = np.full(n_bins + 2, np.inf)
    hits = detected & in_view
    np.minimum.at(nearest, bins[hits] + 1, rng[hits])
    # an obstacle cell spans a little more than its bin: its neighbours share its shadow
    shadow = np.minimum(np.minimum(nearest[:-2], nearest[1:-1]), nearest[2:])
    return in_view & ~detected & (rng < shadow[bins] - cell_size)
