"""Scores of fly snapshots against the true view of the left camera.

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

A run is scored in batches of snapshots (:func:`score_snapshots`): one snapshot holds a few
hundred obstacle flies and a 160×120 view, so scoring it alone is some forty numpy calls on
small arrays, nearly all call overhead; the flies of a batch go through them together, each
carrying its snapshot's index into the stacked views. :func:`score_flies` and
:func:`view_at` are the one-snapshot forms.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from flylog.geometry import StereoRig
from flylog.metrics.config import MetricsConfig
from flylog.metrics.true_depth import relative_depth_error, view_at, views_at
from flylog.metrics.view import nearest_visible_rotated

# What other modules import from here.
__all__ = [
    "FlyScore",
    "cell_counts",
    "f_score",
    "nearest_visible_distance",
    "ratio",
    "relative_depth_error",
    "score_flies",
    "score_snapshots",
    "view_at",
    "views_at",
]


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


def _cell_counts(mask: np.ndarray, cell: int, block: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`cell_counts` of each of the stacked masks (S, h, w):
    (S, ch, cw) true pixels and (ch, cw) pixels."""
    mask = np.asarray(mask, dtype=bool)
    if cell % block:
        mask = mask.repeat(block, axis=1).repeat(block, axis=2)
        block = 1
    h, w = mask.shape[1:]
    step = cell // block
    if h % step == 0 and w % step == 0:  # whole cells: sums over a reshape, exact in int32
        # Rows of a cell first (whole image rows added: a long inner loop), then the few
        # columns of each cell: a third of the time of summing each cell's short rows first.
        rows = mask.reshape(len(mask), h // step, step, w).sum(axis=2, dtype=np.int32)
        hits = rows.reshape(len(mask), h // step, w // step, step).sum(axis=3, dtype=np.int64)
        pixels = np.full((h // step, w // step), step * step, dtype=np.int64)
    else:
        mask = mask.astype(np.int64)
        rows, cols = np.arange(0, h, step), np.arange(0, w, step)
        hits = np.add.reduceat(np.add.reduceat(mask, rows, axis=1), cols, axis=2)
        pixels = np.outer(np.diff(np.append(rows, h)), np.diff(np.append(cols, w)))
    return hits * block * block, pixels * block * block


def _per_snapshot(
    labels: tuple[np.ndarray, np.ndarray], snapshots: int, classes: int
) -> np.ndarray:
    """(snapshots, classes) counts of (snapshot, class) label pairs; classes ≥ ``classes``
    are dropped (ids beyond the obstacle count are not obstacles of the scene)."""
    s, c = labels
    width = max(classes, int(c.max()) + 1 if len(c) else 0)
    counts = np.bincount(s * width + c, minlength=snapshots * width)
    return counts.reshape(snapshots, width)[:, :classes]


def _pixels_per_obstacle(ids: np.ndarray, n_obstacles: int) -> np.ndarray:
    """(S, n_obstacles) blocks of each stacked view seeing each obstacle (ids beyond the
    count dropped; -1 ground and -2 sky not counted)."""
    count = len(ids)
    flat = ids.reshape(count, -1)
    low = min(int(flat.min()), 0) if flat.size else 0  # -2, the sky
    counts = np.zeros((count, n_obstacles), dtype=np.int64)
    # One bincount per view: its keys are the view's own ids, not ids offset by the view's
    # index (a third of the time: no int64 copy of the whole batch).
    for k in range(count):
        found = np.bincount(flat[k].astype(np.intp) - low, minlength=n_obstacles - low)
        counts[k] = found[-low : n_obstacles - low]
    return counts


def _nearest_visible(depth: np.ndarray, ids: np.ndarray, rig: StereoRig, block: int) -> np.ndarray:
    """:func:`nearest_visible_distance` of each stacked view."""
    if not rig.is_level:
        return nearest_visible_rotated(depth, ids, rig, block)
    masked = np.where(ids >= 0, depth, np.inf).min(axis=1)  # (S, columns)
    seen = np.isfinite(masked)
    d = masked.astype(float)
    u = np.arange(masked.shape[1]) * block + (block - 1) / 2.0
    x = rig.mount_x + d
    y = rig.baseline / 2.0 - (u - rig.cx) * d / rig.focal_px
    with np.errstate(invalid="ignore"):
        dist = np.where(seen, np.hypot(x, y), np.inf)
    return dist.min(axis=1) if dist.shape[1] else np.full(len(dist), np.inf)


def score_snapshots(
    xyzs: Sequence[np.ndarray],
    depth: np.ndarray,
    ids: np.ndarray,
    rig: StereoRig,
    n_obstacles: int,
    config: MetricsConfig,
    *,
    flies: Sequence[int] | None = None,
    block: int = 1,
) -> list[FlyScore]:
    """``score_flies(xyzs[k], depth[k], ids[k], rig, n_obstacles, config, flies=flies[k],
    block=block)`` for every snapshot k of the batch: the obstacle flies ``xyzs[k]`` (M, 3)
    against the stacked true views ``depth``, ``ids`` (S, height/block, width/block)."""
    count = len(xyzs)
    shape = (count, rig.height // block, rig.width // block)
    if depth.shape != shape or ids.shape != shape:
        msg = (
            f"true views of shape {depth.shape} (ids {ids.shape}) for {count} snapshots of a "
            f"{rig.width}x{rig.height} rig in blocks of {block} px"
        )
        raise ValueError(msg)
    if count == 0:
        return []
    xyz_of = [np.asarray(x, dtype=float).reshape(-1, 3) for x in xyzs]
    sizes = np.array([len(x) for x in xyz_of], dtype=np.int64)
    xyz = np.concatenate(xyz_of)
    snap = np.repeat(np.arange(count), sizes)
    h, w = rig.height, rig.width
    u, _, v, d = rig.project(xyz)
    iu, iv = np.rint(u), np.rint(v)
    in_view = (d > 0) & (iu >= 0) & (iu < w) & (iv >= 0) & (iv < h)
    iu, iv, d = iu[in_view].astype(np.int64), iv[in_view].astype(np.int64), d[in_view]
    s = snap[in_view]
    true_d, hit = views_at(depth, ids, s, iu, iv, d, config.tau, block)
    seen = np.isfinite(true_d)
    err = np.abs(d - true_d)
    on_surface = seen & (err <= config.tau * true_d)
    on_obstacle = on_surface & (hit >= 0)

    obstacle_px = ids >= 0
    hits, pixels = _cell_counts(obstacle_px, config.cell_px, block)
    visible_cells = hits > config.cell_obstacle_share * pixels
    covered = np.zeros_like(visible_cells)
    cell = config.cell_px
    covered[s[on_obstacle], iv[on_obstacle] // cell, iu[on_obstacle] // cell] = True
    covered &= visible_cells

    flies_on = _per_snapshot(
        (s[on_obstacle], hit[on_obstacle].astype(np.int64)), count, n_obstacles
    )
    visible_pixels = block * block * _pixels_per_obstacle(ids, n_obstacles)
    nearest = np.full(count, np.inf)
    np.minimum.at(nearest, snap, np.hypot(xyz[:, 0], xyz[:, 1]))
    nearest_visible = _nearest_visible(depth, ids, rig, block)
    in_view_n = np.bincount(s, minlength=count)
    on_surface_n = np.bincount(s[on_surface], minlength=count)
    on_obstacle_n = np.bincount(s[on_obstacle], minlength=count)
    visible_n = visible_cells.sum(axis=(1, 2))
    covered_n = covered.sum(axis=(1, 2))
    errors = err[seen] / true_d[seen]
    bounds = np.searchsorted(s[seen], np.arange(count + 1))
    return [
        FlyScore(
            flies=int(sizes[k]) if flies is None else int(flies[k]),
            obstacle_flies=int(sizes[k]),
            in_view=int(in_view_n[k]),
            on_surface=int(on_surface_n[k]),
            on_obstacle=int(on_obstacle_n[k]),
            visible_cells=int(visible_n[k]),
            covered_cells=int(covered_n[k]),
            depth_errors=errors[bounds[k] : bounds[k + 1]],
            flies_on=flies_on[k],
            visible_pixels=visible_pixels[k],
            nearest_detected=float(nearest[k]),
            nearest_visible=float(nearest_visible[k]),
        )
        for k in range(count)
    ]


# --- one snapshot ----------------------------------------------------------------------


def cell_counts(mask: np.ndarray, cell: int, block: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """(true pixels, pixels) of each ``cell``×``cell`` pixel cell of a mask given on a grid
    of ``block``×``block`` pixel blocks ((H/block, W/block); a block counts its pixels as
    true or false together), partial cells at the bottom and right included: two
    (ceil(H/cell), ceil(W/cell)) int64 arrays."""
    hits, pixels = _cell_counts(np.asarray(mask)[None], cell, block)
    return hits[0], pixels


def nearest_visible_distance(
    depth: np.ndarray, ids: np.ndarray, rig: StereoRig, block: int = 1
) -> float:
    """2-D distance (m) from base_link's origin to the nearest obstacle pixel of the view
    (``depth``, ``ids`` on a grid of ``block``-pixel blocks of the rig's image).

    Along one image column base_link's (x, y) grows linearly with depth, so the nearest
    obstacle point of a column is its obstacle pixel of least depth."""
    return float(_nearest_visible(depth[None], ids[None], rig, block)[0])


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
    return score_snapshots(
        [xyz],
        depth[None],
        ids[None],
        rig,
        n_obstacles,
        config,
        flies=None if flies is None else [flies],
        block=block,
    )[0]
