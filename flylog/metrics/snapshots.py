"""Scores of many fly snapshots at once: :func:`flylog.metrics.flies.score_flies` over a batch.

A snapshot holds a few hundred obstacle flies and its true view 160×120 blocks: one call of
``score_flies`` is some forty numpy operations on small arrays, ~1 ms of which nearly all
is call overhead, and a run has a snapshot every 0.2 s. Here the flies of all the batch's
snapshots go through the same operations together, each fly carrying its snapshot's index
into the stacked views. Every per-fly and per-pixel value is computed by the same floating-
point operations, in the same order, as ``score_flies`` / ``view_at`` (the reference,
which the tests compare this against), so the scores are identical, not merely close.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from flylog.geometry import StereoRig
from flylog.metrics.config import MetricsConfig
from flylog.metrics.flies import FlyScore, relative_depth_error


def _one_surface(ids: np.ndarray, s: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Whether the centres of blocks (i..i+1, j..j+1) of view ``s`` all see one obstacle,
    or all the ground."""
    first = ids[s, i, j]
    one = (first >= -1) & (ids[s, i, j + 1] == first) & (ids[s, i + 1, j] == first)
    one &= ids[s, i + 1, j + 1] == first
    return one


def _inverse_at(depth: np.ndarray, s: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore"):
        return 1.0 / depth[s, i, j].astype(float)


def _inverse_bilinear(
    depth: np.ndarray,
    s: np.ndarray,
    i: np.ndarray,
    j: np.ndarray,
    fy: np.ndarray,
    fx: np.ndarray,
) -> np.ndarray:
    """``flylog.metrics.flies._inverse_bilinear`` on view ``s`` of the stacked views."""
    top = (1 - fx) * _inverse_at(depth, s, i, j) + fx * _inverse_at(depth, s, i, j + 1)
    bottom = (1 - fx) * _inverse_at(depth, s, i + 1, j) + fx * _inverse_at(depth, s, i + 1, j + 1)
    return (1 - fy) * top + fy * bottom


def views_at(
    depth: np.ndarray,
    ids: np.ndarray,
    s: np.ndarray,
    iu: np.ndarray,
    iv: np.ndarray,
    d: np.ndarray,
    tau: float,
    block: int = 1,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`flylog.metrics.flies.view_at` for flies of several snapshots: fly k is judged
    against view ``s[k]`` of the stacked views ``depth``, ``ids`` (S, H/block, W/block)."""
    own_i, own_j = iv // block, iu // block
    true_d = depth[s, own_i, own_j].astype(float)
    hit = ids[s, own_i, own_j]
    rows, cols = depth.shape[1:]
    if block == 1 or rows < 2 or cols < 2:
        return true_d, hit
    y, x = (iv - (block - 1) / 2.0) / block, (iu - (block - 1) / 2.0) / block
    i0 = np.clip(np.floor(y).astype(np.int64), 0, rows - 2)
    j0 = np.clip(np.floor(x).astype(np.int64), 0, cols - 2)
    inv = _inverse_bilinear(depth, s, i0, j0, y - i0, x - j0)
    inside = _one_surface(ids, s, i0, j0) & (inv > 0)
    true_d[inside] = 1.0 / inv[inside]
    near = np.flatnonzero(~inside)
    if len(near) == 0:
        return true_d, hit
    # The 3×3 windows around each distinct (snapshot, pixel) near a boundary.
    width = cols * block
    key = (s[near] * (rows * block) + iv[near]) * width + iu[near]
    pixels, fly_pixel = np.unique(key, return_inverse=True)
    first_fly = np.zeros(len(pixels), dtype=np.int64)
    first_fly[fly_pixel] = near
    ps = s[first_fly][None, :]
    pi, pj, py, px = i0[first_fly], j0[first_fly], y[first_fly], x[first_fly]
    oi, oj = own_i[first_fly], own_j[first_fly]
    di, dj = np.repeat([-1, 0, 1], 3)[:, None], np.tile([-1, 0, 1], 3)[:, None]
    i = np.clip(pi[None, :] + di, 0, rows - 2)
    j = np.clip(pj[None, :] + dj, 0, cols - 2)
    inv = _inverse_bilinear(depth, ps, i, j, py - i, px - j)
    usable = _one_surface(ids, ps, i, j) & (inv > 0)
    candidate = 1.0 / np.where(usable, inv, 1.0)
    holds_own = (i <= oi) & (oi <= i + 1) & (j <= oj) & (oj <= j + 1)
    rank = np.where(usable & holds_own, np.abs(di) + np.abs(dj), 9)
    own = np.argmin(rank, axis=0)
    p = np.arange(len(pixels))
    has_own = (rank[own, p] < 9)[fly_pixel]
    true_d[near[has_own]] = candidate[own, p][fly_pixel][has_own]
    err = np.where(
        usable[:, fly_pixel], relative_depth_error(d[near], candidate[:, fly_pixel]), np.inf
    )
    best = np.argmin(err, axis=0)
    n = np.arange(len(near))
    matched = (err[best, n] <= tau) & (err[best, n] < relative_depth_error(d[near], true_d[near]))
    window_ids = ids[ps, i, j][:, fly_pixel]
    true_d[near[matched]] = candidate[:, fly_pixel][best, n][matched]
    hit[near[matched]] = window_ids[best, n][matched]
    return true_d, hit


def _cell_counts(mask: np.ndarray, cell: int, block: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`flylog.metrics.flies.cell_counts` of each of the stacked masks (S, h, w):
    (S, ch, cw) true pixels and (ch, cw) pixels."""
    mask = np.asarray(mask, dtype=bool)
    if cell % block:
        mask = mask.repeat(block, axis=1).repeat(block, axis=2)
        block = 1
    h, w = mask.shape[1:]
    step = cell // block
    if h % step == 0 and w % step == 0:  # whole cells: sums over a reshape, exact in int32
        cells = mask.reshape(len(mask), h // step, step, w // step, step)
        hits = cells.sum(axis=4, dtype=np.int32).sum(axis=2, dtype=np.int64)
        pixels = np.full((h // step, w // step), step * step, dtype=np.int64)
    else:
        mask = mask.astype(np.int64)
        rows, cols = np.arange(0, h, step), np.arange(0, w, step)
        hits = np.add.reduceat(np.add.reduceat(mask, rows, axis=1), cols, axis=2)
        pixels = np.outer(np.diff(np.append(rows, h)), np.diff(np.append(cols, w)))
    return hits * block * block, pixels * block * block


def _per_snapshot(labels: np.ndarray, snapshots: int, classes: int) -> np.ndarray:
    """(snapshots, classes) counts of (snapshot, class) label pairs; classes ≥ ``classes``
    are dropped (as ``score_flies`` drops ids beyond its obstacle count)."""
    s, c = labels
    width = max(classes, int(c.max()) + 1 if len(c) else 0)
    counts = np.bincount(s * width + c, minlength=snapshots * width)
    return counts.reshape(snapshots, width)[:, :classes]


def _pixels_per_obstacle(ids: np.ndarray, n_obstacles: int) -> np.ndarray:
    """(S, n_obstacles) blocks of each stacked view seeing each obstacle (ids beyond the
    count dropped; -1 ground and -2 sky not counted)."""
    count = len(ids)
    flat = np.maximum(ids.reshape(count, -1).astype(np.int64) + 2, 0)  # -2 sky: class 0
    width = max(n_obstacles + 2, int(flat.max()) + 1 if flat.size else 0)
    key = flat + (np.arange(count) * width)[:, None]
    counts = np.bincount(key.ravel(), minlength=count * width).reshape(count, width)
    return counts[:, 2 : n_obstacles + 2]


def _nearest_visible(depth: np.ndarray, ids: np.ndarray, rig: StereoRig, block: int) -> np.ndarray:
    """:func:`flylog.metrics.flies.nearest_visible_distance` of each stacked view."""
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
