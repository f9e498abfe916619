"""Scores of one fly snapshot against the true view of the left camera.

Definitions (``MetricsConfig`` holds every threshold):

- *Obstacle flies* are the flies the planner takes for obstacles: the run's own
  ``flylog.fly.obstacles.ObstacleFlies`` rule (fitness above a quantile of the positive
  fitnesses, z above a ground margin, at least a minimum age), stored in its metadata.
- A fly is *in view* if it lies in front of the left camera and its rounded left
  projection falls inside the image. Only flies in view can be checked against the
  rendered truth; the others are counted apart (``outside_view``).
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


def cell_counts(mask: np.ndarray, cell: int) -> tuple[np.ndarray, np.ndarray]:
    """(true pixels, pixels) of each ``cell``×``cell`` block of a (H, W) mask, partial
    blocks at the bottom and right included: two (ceil(H/cell), ceil(W/cell)) arrays."""
    h, w = mask.shape
    rows, cols = -(-h // cell), -(-w // cell)
    padded = np.zeros((rows * cell, cols * cell), dtype=np.int32)
    ones = np.zeros_like(padded)
    padded[:h, :w] = mask
    ones[:h, :w] = 1
    shape = (rows, cell, cols, cell)
    return padded.reshape(shape).sum(axis=(1, 3)), ones.reshape(shape).sum(axis=(1, 3))


def nearest_visible_distance(depth: np.ndarray, ids: np.ndarray, rig: StereoRig) -> float:
    """2-D distance (m) from base_link's origin to the nearest obstacle pixel of the view.

    Along one image column base_link's (x, y) grows linearly with depth, so the nearest
    obstacle point of a column is its obstacle pixel of least depth."""
    masked = np.where(ids >= 0, depth, np.inf).min(axis=0)
    seen = np.isfinite(masked)
    if not seen.any():
        return float("inf")
    d = masked[seen].astype(float)
    u = np.flatnonzero(seen).astype(float)
    x = rig.mount_x + d
    y = rig.baseline / 2.0 - (u - rig.cx) * d / rig.focal_px
    return float(np.hypot(x, y).min())


def score_flies(
    xyz: np.ndarray,
    depth: np.ndarray,
    ids: np.ndarray,
    rig: StereoRig,
    n_obstacles: int,
    config: MetricsConfig,
    *,
    flies: int | None = None,
) -> FlyScore:
    """Score the obstacle flies ``xyz`` (M, 3) (base_link) against the true left view
    (``depth``, ``ids`` rendered from the true pose at the snapshot's time)."""
    xyz = np.asarray(xyz, dtype=float).reshape(-1, 3)
    h, w = depth.shape
    u, _, v, d = rig.project(xyz)
    iu, iv = np.rint(u), np.rint(v)
    in_view = (d > 0) & (iu >= 0) & (iu < w) & (iv >= 0) & (iv < h)
    iu, iv, d = iu[in_view].astype(np.int64), iv[in_view].astype(np.int64), d[in_view]
    true_d = depth[iv, iu].astype(float)
    hit = ids[iv, iu]
    seen = np.isfinite(true_d)
    err = np.abs(d - true_d)
    on_surface = seen & (err <= config.tau * true_d)
    on_obstacle = on_surface & (hit >= 0)

    obstacle_px = ids >= 0
    hits, pixels = cell_counts(obstacle_px, config.cell_px)
    visible_cells = hits > config.cell_obstacle_share * pixels
    covered = np.zeros_like(visible_cells)
    covered[iv[on_obstacle] // config.cell_px, iu[on_obstacle] // config.cell_px] = True
    covered &= visible_cells

    flies_on = np.bincount(hit[on_obstacle].astype(np.int64), minlength=n_obstacles)
    visible_pixels = np.bincount(ids[obstacle_px].astype(np.int64), minlength=n_obstacles)
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
        nearest_visible=nearest_visible_distance(depth, ids, rig),
    )
