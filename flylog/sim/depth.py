"""The renderer's depth path in plain numpy, for many poses at once: the left camera's true
depth and ids, bit for bit what the compiled kernel (``flylog.sim.render.Renderer.
render_depth``) writes. Ground truth for the metrics (one renderer, two implementations).

Why not the kernel itself: ``flylog metrics`` renders ~300 small views; loading any compiled
numba function costs ~0.2 s of numba start-up (more than rendering them), and the depth
path is simple enough to vectorise over whole batches of views.

The arithmetic is the kernel's, operation for operation (the same ray directions, footprint
hits from :func:`flylog.scene.footprints.ray_hits_numpy`, ``slope = (v - cy) / f``,
``hc / slope``, ``(hc - h) / slope``), so the depths and ids are equal, not close
(``tests/metrics/test_depth.py`` compares them exactly). Instead of testing every candidate
surface at every pixel, each footprint a column crosses covers a contiguous run of rows with
its side face and another with its top (the tests are monotonic down a column); the run ends
are found by evaluating the kernel's own tests on the few rows around their analytic
positions, and each column is then assembled from runs: the nearest footprint's run wins
(the kernel walks the footprints in order of entry depth and stops at the first surface).
Columns where footprints overlap along the ray (a farther face can be nearer than the top
of an earlier footprint) are rendered by :func:`depths_reference` instead.
"""

from __future__ import annotations

import math

import numpy as np

from flylog.geometry import StereoRig
from flylog.scene.footprints import Footprints, ray_hits_numpy
from flylog.sim.rotated import sample_truth, warps

# ids, as in flylog.sim.render
GROUND = -1
SKY = -2
# Rows evaluated around a run end's analytic position (which is off by far less than a row).
_WINDOW = 5


def _column_rays(rig: StereoRig, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Left camera origins (B,) x, (B,) y and world 2-D column directions (B, W, 2), as
    ``flylog.sim.render._camera_rays`` computes them (scalar cos/sin: the same bits)."""
    mx, my, _ = rig.camera_position("left")
    n = len(poses)
    ox, oy, cos, sin = np.empty(n), np.empty(n), np.empty((n, 1)), np.empty((n, 1))
    for b, (x, y, theta) in enumerate(poses.tolist()):
        c, s = math.cos(theta), math.sin(theta)
        ox[b], oy[b] = x + c * mx - s * my, y + s * mx + c * my
        cos[b], sin[b] = c, s
    lateral = -(np.arange(rig.width) - rig.cx) / rig.focal_px
    return ox, oy, np.stack([cos - sin * lateral, sin + cos * lateral], axis=2)


def _sorted_hits(
    fp: Footprints, rig: StereoRig, poses: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per column (B·W rows): the footprints it crosses in order of entry depth (stable),
    (t_in, t_out, index), padded with (inf, -inf, -1) to the most any column crosses."""
    ox, oy, dirs = _column_rays(rig, poses)
    w = rig.width
    t_in, t_out, _, _ = ray_hits_numpy(  # broadcasts over rays: arrays for its floats
        fp,
        np.repeat(ox, w)[:, None],  # type: ignore[arg-type]
        np.repeat(oy, w)[:, None],  # type: ignore[arg-type]
        dirs[..., 0].reshape(-1, 1),  # type: ignore[arg-type]
        dirs[..., 1].reshape(-1, 1),  # type: ignore[arg-type]
    )
    hit = t_out >= t_in
    t_in = np.where(hit, t_in, np.inf)
    most = int(hit.sum(axis=1).max(initial=0))
    order = np.argsort(t_in, axis=1, kind="stable")[:, :most]
    hit = np.take_along_axis(hit, order, 1)
    t_out = np.where(hit, np.take_along_axis(t_out, order, 1), -np.inf)
    return np.take_along_axis(t_in, order, 1), t_out, np.where(hit, order, -1)


def depths_reference(
    fp: Footprints, rig: StereoRig, poses: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Every candidate surface at every pixel, walked in the kernel's order: (B, H, W)
    float32 depth (m, inf = sky) and int16 ids. The plain reference of :func:`true_depths`."""
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    t_in, t_out, index = _sorted_hits(fp, rig, poses)
    depth, ids = _columns_reference(rig, fp, t_in, t_out, index)
    return _images(depth, ids, len(poses), rig)


def _columns_reference(
    rig: StereoRig, fp: Footprints, t_in: np.ndarray, t_out: np.ndarray, index: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(columns, H) depth (float64) and ids of the columns whose sorted hits are given."""
    hc = rig.mount_height
    slope = (np.arange(rig.height) - rig.cy) / rig.focal_px
    down = slope > 0.0
    with np.errstate(divide="ignore"):
        ground = np.where(down, hc / np.where(down, slope, 1.0), np.inf)
    n = len(t_in)
    best = np.broadcast_to(ground, (n, rig.height)).copy()
    ids = np.broadcast_to(np.where(down, GROUND, SKY).astype(np.int16), best.shape).copy()
    height = fp.height[np.maximum(index, 0)]
    with np.errstate(invalid="ignore", divide="ignore"):
        for i in range(t_in.shape[1]):
            t, h = t_in[:, i : i + 1], height[:, i : i + 1]
            k = index[:, i : i + 1].astype(np.int16)
            active = t < best  # the kernel stops at the first footprint entered beyond best
            z = hc - slope * t
            side = active & (t > 0.0) & (z >= 0.0) & (z <= h)
            best = np.where(side, t, best)
            ids = np.where(side, k, ids)
            t_top = (hc - h) / slope
            top = (
                active
                & ~side
                & down
                & (hc > h)
                & (t_top >= np.maximum(t, 0.0))
                & (t_top <= t_out[:, i : i + 1])
                & (t_top < best)
            )
            best = np.where(top, t_top, best)
            ids = np.where(top, k, ids)
    return best, ids


def _images(
    depth: np.ndarray, ids: np.ndarray, n: int, rig: StereoRig
) -> tuple[np.ndarray, np.ndarray]:
    """(B·W, H) columns → (B, H, W) images: depth as float32 (the kernel's output type)."""
    shape = (n, rig.width, rig.height)
    depth = depth.astype(np.float32).reshape(shape).transpose(0, 2, 1)
    return np.ascontiguousarray(depth), np.ascontiguousarray(ids.reshape(shape).transpose(0, 2, 1))


def _run_end(holds, estimate: np.ndarray, height: int) -> np.ndarray:
    """The first row at which ``holds(rows)`` (true down to some row, false below; an
    elementwise test of (N, k) rows) stops holding, knowing that row lies within a row of
    ``estimate`` (N,): the test is evaluated on the rows around it."""
    estimate = np.nan_to_num(estimate, nan=-_WINDOW, posinf=height + _WINDOW, neginf=-_WINDOW)
    start = np.clip(np.floor(estimate) - _WINDOW // 2, 0, height).astype(np.int64)
    rows = start[:, None] + np.arange(_WINDOW)
    inside = rows < height
    return start + (holds(np.minimum(rows, height - 1)) & inside).sum(axis=1)


def true_depths(fp: Footprints, rig: StereoRig, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The left camera's (B, H, W) float32 depth (m along the optical axis, inf = sky) and
    int16 ids (obstacle index, -1 ground, -2 sky) from each true robot pose (B, 3) (x, y,
    theta): equal to ``Renderer(scene, rig).render_depth(pose)`` for every pose. A rig that
    is not level is rendered through its left camera's level one, as the renderer does
    (:mod:`flylog.sim.rotated`)."""
    if rig.is_level:
        return _level_true_depths(fp, rig, poses)
    warp = warps(rig)[0]
    depth, ids = _level_true_depths(fp, warp.level, poses)
    return sample_truth(depth, ids, warp)


def _level_true_depths(
    fp: Footprints, rig: StereoRig, poses: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    n, height = len(poses), rig.height
    t_in, t_out, index = _sorted_hits(fp, rig, poses)
    hc, f, cy = rig.mount_height, rig.focal_px, rig.cy
    slope = (np.arange(height) - cy) / f
    horizon = int(np.count_nonzero(slope <= 0.0))  # rows below it see the ground
    columns, most = t_in.shape
    # Runs of rows [lo, hi) of each footprint's side face and top, in the kernel's order of
    # preference: side of the 1st footprint entered, its top, side of the 2nd, ...
    lo = np.zeros((columns, 2 * most), dtype=np.int64)
    hi = np.zeros((columns, 2 * most), dtype=np.int64)
    numerator = np.full((columns, 2 * most), np.nan)  # depth = numerator / slope (tops)
    constant = np.full((columns, 2 * most), np.nan)  # depth (sides)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        for i in range(most):
            t, t_exit = t_in[:, i], t_out[:, i]
            h = fp.height[np.maximum(index[:, i], 0)]
            c = hc - h

            def nearer_than_ground(rows, t=t):
                s = slope[rows]
                return (s <= 0.0) | (t[:, None] < hc / s)

            def above_top_edge(rows, t=t, h=h):
                return hc - slope[rows] * t[:, None] > h[:, None]

            def above_bottom_edge(rows, t=t):
                return (hc - slope[rows] * t[:, None] >= 0.0) & nearer_than_ground(rows)

            def top_beyond_entry(rows, c=c, t=t):
                s = slope[rows]
                return (s <= 0.0) | (c[:, None] / s >= np.maximum(t, 0.0)[:, None])

            def top_beyond_exit(rows, c=c, t_exit=t_exit):
                s = slope[rows]
                return (s <= 0.0) | (c[:, None] / s > t_exit[:, None])

            side = (t > 0.0) & np.isfinite(t)
            lo[:, 2 * i] = _run_end(above_top_edge, cy + f * c / t, height)
            hi[:, 2 * i] = np.where(side, _run_end(above_bottom_edge, cy + f * hc / t, height), 0)
            constant[:, 2 * i] = t
            top = np.isfinite(t) & (c > 0.0)
            lo[:, 2 * i + 1] = np.maximum(
                _run_end(top_beyond_exit, cy + f * c / t_exit, height), horizon
            )
            end = np.minimum(
                _run_end(top_beyond_entry, cy + f * c / np.maximum(t, 0.0), height),
                _run_end(nearer_than_ground, cy + f * hc / t, height),
            )
            hi[:, 2 * i + 1] = np.where(top, end, 0)
            numerator[:, 2 * i + 1] = c
        # The first footprint's run wins only if no later footprint starts before it ends.
        exits = np.maximum.accumulate(t_out, axis=1)
        overlap = (t_in[:, 1:] < exits[:, :-1]).any(axis=1) if most > 1 else np.zeros(columns, bool)

    # Each column in pieces between run ends; a piece belongs to the first run holding it.
    ends = np.concatenate(
        [
            np.zeros((columns, 1), np.int64),
            np.full((columns, 1), horizon),
            lo,
            hi,
            np.full((columns, 1), height),
        ],
        axis=1,
    )
    ends = np.sort(np.clip(ends, 0, height), axis=1)
    start = ends[:, :-1]
    owner = np.full(start.shape, -1)
    for r in range(2 * most - 1, -1, -1):
        holds = (lo[:, r : r + 1] <= start) & (start < hi[:, r : r + 1])
        owner = np.where(holds, r, owner)
    rows = np.arange(columns)[:, None]
    run = np.maximum(owner, 0)
    ground = start >= horizon
    piece_id = np.where(ground, GROUND, SKY)
    piece_num = np.full(start.shape, hc)
    piece_const = np.where(ground, np.nan, np.inf)
    if most:
        seen = owner >= 0
        piece_id = np.where(seen, index[rows, run // 2], piece_id)
        piece_num = np.where(seen, numerator[rows, run], piece_num)
        piece_const = np.where(seen, constant[rows, run], piece_const)
    lengths = np.diff(ends, axis=1).ravel()
    ids = np.repeat(piece_id.astype(np.int16).ravel(), lengths).reshape(columns, height)
    const = np.repeat(piece_const.ravel(), lengths).reshape(columns, height)
    num = np.repeat(piece_num.ravel(), lengths).reshape(columns, height)
    with np.errstate(invalid="ignore", divide="ignore"):
        depth = np.where(np.isnan(const), num / slope, const)
    if overlap.any():
        depth[overlap], ids[overlap] = _columns_reference(
            rig, fp, t_in[overlap], t_out[overlap], index[overlap]
        )
    return _images(depth, ids, n, rig)
