"""Scores of one fly snapshot against the true view of the left camera.

Definitions (``MetricsConfig`` holds every threshold):

- *Obstacle flies* are the flies the planner takes for obstacles: the run's own
  ``flylog.fly.obstacles.ObstacleFlies`` rule (fitness above a quantile of the positive
  fitnesses, z above a ground margin, at least a minimum age), stored in its metadata.
- A fly is *in view* if it lies in front of the left camera and its rounded left
  projection falls inside the image. Only flies in view can be checked against the
  rendered truth; the others are counted apart (``outside_view``).
- The *true view* is the left camera's depth and obstacle ids, rendered by the simulator
  on a grid of k×k pixel blocks (k the largest divisor of the image's width and height
  leaving the grid at least ``truth_width`` wide; 640×480: k = 4): each block holds what
  the ray through its centre sees (the camera's own rig at 1/k of its resolution and focal
  length: 1/k² of the rays). A pixel *sees* its block's surface (id), its true depth D
  interpolated in 1/D between block centres that see that surface (exact on planes);
  within a block of a boundary between surfaces, a fly whose depth is within τ of the
  other side's is judged against that side (``view_at``). k = 1 is the per-pixel view.
- A fly in view is *on a surface* if ``|d − D| ≤ τ·D``, with d its depth along the left
  optical axis and D the true depth at its rounded left projection (never on the sky);
  *on an obstacle* if it is on a surface and that pixel sees an obstacle (id ≥ 0), which
  then is the obstacle it lies on.
- precision = obstacle flies on a surface / obstacle flies in view.
- recall = covered cells / visible-obstacle cells, the left image being split in square
  cells of ``cell_px`` pixels (the last row and column may be partial): a cell is a
  visible-obstacle cell if more than ``cell_obstacle_share`` of its pixels see an
  obstacle, covered if an obstacle fly on an obstacle projects into it.
- F = 2PR / (P + R). Depth error: ``|d − D| / D`` of the obstacle flies in view whose
  pixel sees a surface (not the sky); summaries take its median.
- Nearest obstacle: the 2-D distance from the robot (base_link origin) to the nearest
  obstacle fly (detected) and to the nearest obstacle pixel of the true view (visible).

``flylog.metrics.snapshots`` computes the same scores for many snapshots at once; this
module, one snapshot at a time, is its reference.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from flylog.geometry import StereoRig
from flylog.metrics.config import MetricsConfig


class FlyScore(NamedTuple):
    """Counts of one snapshot; ratios are properties (NaN where undefined)."""

    flies: int
    obstacle_flies: int
    in_view: int
    on_surface: int
    on_obstacle: int
    visible_cells: int
    covered_cells: int
    depth_errors: np.ndarray  # relative depth errors of the obstacle flies in view
    flies_on: np.ndarray  # (n_obstacles,) obstacle flies on each obstacle
    visible_pixels: np.ndarray  # (n_obstacles,) pixels of the true view on each obstacle
    nearest_detected: float  # m; inf without obstacle flies
    nearest_visible: float  # m; inf without a visible obstacle

    @property
    def outside_view(self) -> int:
        return self.obstacle_flies - self.in_view

    @property
    def precision(self) -> float:
        return ratio(self.on_surface, self.in_view)

    @property
    def recall(self) -> float:
        return ratio(self.covered_cells, self.visible_cells)

    @property
    def f_score(self) -> float:
        return f_score(self.precision, self.recall)


def ratio(num: float, den: float) -> float:
    return float(num) / float(den) if den > 0 else float("nan")


def f_score(precision: float, recall: float) -> float:
    """2PR / (P + R); 0 if both are 0, NaN if either is undefined."""
    if np.isnan(precision) or np.isnan(recall):
        return float("nan")
    total = precision + recall
    return 2.0 * precision * recall / total if total > 0 else 0.0


def cell_counts(mask: np.ndarray, cell: int, block: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """(true pixels, pixels) of each ``cell``×``cell`` pixel cell of a mask given on a grid
    of ``block``×``block`` pixel blocks ((H/block, W/block); a block counts its pixels as
    true or false together), partial cells at the bottom and right included: two
    (ceil(H/cell), ceil(W/cell)) int64 arrays."""
    mask = np.asarray(mask, dtype=np.int64)
    if cell % block:  # cells cut through blocks: count on the full pixel grid
        mask = mask.repeat(block, axis=0).repeat(block, axis=1)
        block = 1
    h, w = mask.shape
    step = cell // block
    rows, cols = np.arange(0, h, step), np.arange(0, w, step)
    hits = np.add.reduceat(np.add.reduceat(mask, rows, axis=0), cols, axis=1)
    pixels = np.outer(np.diff(np.append(rows, h)), np.diff(np.append(cols, w)))
    return hits * block * block, pixels * block * block


def nearest_visible_distance(
    depth: np.ndarray, ids: np.ndarray, rig: StereoRig, block: int = 1
) -> float:
    """2-D distance (m) from base_link's origin to the nearest obstacle pixel of the view
    (``depth``, ``ids`` on a grid of ``block``-pixel blocks of the rig's image).

    Along one image column base_link's (x, y) grows linearly with depth, so the nearest
    obstacle point of a column is its obstacle pixel of least depth."""
    masked = np.where(ids >= 0, depth, np.inf).min(axis=0)
    seen = np.isfinite(masked)
    if not seen.any():
        return float("inf")
    d = masked[seen].astype(float)
    u = np.flatnonzero(seen) * block + (block - 1) / 2.0  # the block's centre column
    x = rig.mount_x + d
    y = rig.baseline / 2.0 - (u - rig.cx) * d / rig.focal_px
    return float(np.hypot(x, y).min())


def _inverse_bilinear(
    inverse: np.ndarray, i: np.ndarray, j: np.ndarray, fy: np.ndarray, fx: np.ndarray
) -> np.ndarray:
    """1/D interpolated (or extrapolated) bilinearly between block centres (i..i+1, j..j+1)
    at offsets (fy, fx) from centre (i, j), in block units; ``inverse`` is the view's 1/D."""
    top = (1 - fx) * inverse[i, j] + fx * inverse[i, j + 1]
    bottom = (1 - fx) * inverse[i + 1, j] + fx * inverse[i + 1, j + 1]
    return (1 - fy) * top + fy * bottom


def relative_depth_error(d: np.ndarray, true_d: np.ndarray) -> np.ndarray:
    """|d − D| / D, inf where D is not finite (the sky)."""
    with np.errstate(invalid="ignore"):
        return np.where(np.isfinite(true_d), np.abs(d - true_d) / true_d, np.inf)


def view_at(
    depth: np.ndarray,
    ids: np.ndarray,
    iu: np.ndarray,
    iv: np.ndarray,
    d: np.ndarray,
    tau: float,
    block: int = 1,
) -> tuple[np.ndarray, np.ndarray]:
    """(true depth D, id) that flies at depths ``d`` projecting to full-image pixels (``iu``,
    ``iv``) are judged against, from a view given in ``block``-pixel blocks.

    Within one surface (2×2 block centres all seeing the same obstacle, or all the ground)
    D is interpolated between block centres bilinearly in 1/D, which is exact on a plane (a
    face, a top, the ground: 1/D is affine in the pixel coordinates there). A pixel whose
    2×2 surrounding centres see one surface sees it. A pixel near a boundary (they do not)
    sees its own block's surface, its D extrapolated (by at most 1.5 blocks) from the
    nearest 2×2 window holding its block that sees one surface (else the block's own
    value); but it may as well see the other side: a fly whose depth is within ``tau`` of
    another surface of the 3×3 neighbouring windows is judged against the one it matches
    best. With ``block`` = 1, the pixel's own values."""
    own_i, own_j = iv // block, iu // block
    true_d = depth[own_i, own_j].astype(float)
    hit = ids[own_i, own_j]
    rows, cols = depth.shape
    if block == 1 or rows < 2 or cols < 2:
        return true_d, hit
    # Pixel positions in block-centre units, and the 2×2 window of centres around them.
    y, x = (iv - (block - 1) / 2.0) / block, (iu - (block - 1) / 2.0) / block
    i0 = np.clip(np.floor(y).astype(np.int64), 0, rows - 2)
    j0 = np.clip(np.floor(x).astype(np.int64), 0, cols - 2)
    # one[i, j]: the centres of blocks (i..i+1, j..j+1) all see one obstacle, or the ground.
    first = ids[:-1, :-1]
    one = (first >= -1) & (ids[:-1, 1:] == first) & (ids[1:, :-1] == first)
    one &= ids[1:, 1:] == first
    with np.errstate(divide="ignore"):
        inverse = 1.0 / depth.astype(float)
    inv = _inverse_bilinear(inverse, i0, j0, y - i0, x - j0)
    inside = one[i0, j0] & (inv > 0)
    true_d[inside] = 1.0 / inv[inside]
    near = np.flatnonzero(~inside)
    if len(near) == 0:
        return true_d, hit
    # The 3×3 windows around each pixel near a boundary, all at once: (9, pixels) arrays
    # over the distinct pixels (flies crowd on a few), then (9, flies).
    pixels, fly_pixel = np.unique(iv[near] * depth.shape[1] * block + iu[near], return_inverse=True)
    first_fly = np.zeros(len(pixels), dtype=np.int64)
    first_fly[fly_pixel] = near
    pi, pj, py, px = i0[first_fly], j0[first_fly], y[first_fly], x[first_fly]
    oi, oj = own_i[first_fly], own_j[first_fly]
    di, dj = np.repeat([-1, 0, 1], 3)[:, None], np.tile([-1, 0, 1], 3)[:, None]
    i = np.clip(pi[None, :] + di, 0, rows - 2)
    j = np.clip(pj[None, :] + dj, 0, cols - 2)
    inv = _inverse_bilinear(inverse, i, j, py - i, px - j)
    usable = one[i, j] & (inv > 0)
    candidate = 1.0 / np.where(usable, inv, 1.0)
    # The own surface: the usable window holding the own block nearest the pixel's own.
    holds_own = (i <= oi) & (oi <= i + 1) & (j <= oj) & (oj <= j + 1)
    rank = np.where(usable & holds_own, np.abs(di) + np.abs(dj), 9)
    own = np.argmin(rank, axis=0)
    p = np.arange(len(pixels))
    has_own = (rank[own, p] < 9)[fly_pixel]
    true_d[near[has_own]] = candidate[own, p][fly_pixel][has_own]
    # A fly matching another side within tau is judged against the side it matches best.
    err = np.where(
        usable[:, fly_pixel], relative_depth_error(d[near], candidate[:, fly_pixel]), np.inf
    )
    best = np.argmin(err, axis=0)
    n = np.arange(len(near))
    matched = (err[best, n] <= tau) & (err[best, n] < relative_depth_error(d[near], true_d[near]))
    window_ids = ids[i, j][:, fly_pixel]
    true_d[near[matched]] = candidate[:, fly_pixel][best, n][matched]
    hit[near[matched]] = window_ids[best, n][matched]
    return true_d, hit


def score_flies(
    xyz: np.ndarray,
    depth: np.ndarray,
    ids: np.ndarray,
    rig: StereoRig,
    n_obstacles: int,
    config: MetricsConfig,
    *,
    flies: int | None = None,
    block: int = 1,
) -> FlyScore:
    """Score the obstacle flies ``xyz`` (M, 3) (base_link) against the true left view
    (``depth``, ``ids`` rendered from the true pose at the snapshot's time, on a grid of
    ``block``×``block`` pixel blocks of ``rig``'s image: (height/block, width/block))."""
    xyz = np.asarray(xyz, dtype=float).reshape(-1, 3)
    if depth.shape != (rig.height // block, rig.width // block) or depth.shape != ids.shape:
        msg = (
            f"true view of shape {depth.shape} (ids {ids.shape}) for a {rig.width}x"
            f"{rig.height} rig in blocks of {block} px"
        )
        raise ValueError(msg)
    h, w = rig.height, rig.width
    u, _, v, d = rig.project(xyz)
    iu, iv = np.rint(u), np.rint(v)
    in_view = (d > 0) & (iu >= 0) & (iu < w) & (iv >= 0) & (iv < h)
    iu, iv, d = iu[in_view].astype(np.int64), iv[in_view].astype(np.int64), d[in_view]
    true_d, hit = view_at(depth, ids, iu, iv, d, config.tau, block)
    seen = np.isfinite(true_d)
    err = np.abs(d - true_d)
    on_surface = seen & (err <= config.tau * true_d)
    on_obstacle = on_surface & (hit >= 0)

    obstacle_px = ids >= 0
    hits, pixels = cell_counts(obstacle_px, config.cell_px, block)
    visible_cells = hits > config.cell_obstacle_share * pixels
    covered = np.zeros_like(visible_cells)
    covered[iv[on_obstacle] // config.cell_px, iu[on_obstacle] // config.cell_px] = True
    covered &= visible_cells

    flies_on = np.bincount(hit[on_obstacle].astype(np.int64), minlength=n_obstacles)
    visible_pixels = (
        block * block * np.bincount(ids[obstacle_px].astype(np.int64), minlength=n_obstacles)
    )
    nearest = float(np.hypot(xyz[:, 0], xyz[:, 1]).min()) if len(xyz) else float("inf")
    return FlyScore(
        flies=len(xyz) if flies is None else int(flies),
        obstacle_flies=len(xyz),
        in_view=int(in_view.sum()),
        on_surface=int(on_surface.sum()),
        on_obstacle=int(on_obstacle.sum()),
        visible_cells=int(visible_cells.sum()),
        covered_cells=int(covered.sum()),
        depth_errors=err[seen] / true_d[seen],
        flies_on=flies_on[:n_obstacles],
        visible_pixels=visible_pixels[:n_obstacles],
        nearest_detected=nearest,
        nearest_visible=nearest_visible_distance(depth, ids, rig, block),
    )
