"""The fitness's numpy reference (:mod:`flylog.fly.fitness`): whole patches gathered, the
compiled kernels' integer arithmetic (the measure's sums, :mod:`flylog.fly.measures`), then
the same float steps. The numpy backend runs it."""

from __future__ import annotations

import numpy as np

from flylog.fly.config import Gradient, Similarity
from flylog.fly.fitness_terms import (
    FRACTION,
    FRACTION_BITS,
    INVALID_FITNESS,
    as_planes,
    gy_weight,
    subpixel_columns_numpy,
)
from flylog.fly.measures import measure_of
from flylog.geometry import Pose2D, StereoRig
from flylog.geometry.rolling import STILL, at_rows, is_still, row_motion


def fitness_numpy(
    left: np.ndarray,
    right: np.ndarray,
    xyz: np.ndarray,
    rig: StereoRig,
    window: int,
    guard: float,
    *,
    gradient: Gradient = Gradient.NORM,
    similarity: Similarity = Similarity.ZSSD,
    subpixel: bool = False,
    readout: Pose2D = STILL,
) -> np.ndarray:
    """Reference: the fitness of every fly of ``xyz`` (N, 3), by gathering whole patches;
    ``subpixel``: the right patch interpolated at the exact right projection; ``readout``:
    the rolling shutter's motion, each fly projected at its row's time
    (:func:`~flylog.geometry.rolling.at_rows`)."""
    left, right = as_planes(left), as_planes(right)
    height, width, channels = left.shape
    h = window // 2
    n = window * window
    xyz = np.asarray(xyz, dtype=np.float64)
    if not is_still(readout):
        xyz = at_rows(xyz, rig, row_motion(readout, height))
    u_left, u_right, v, depth = rig.project(xyz)
    ul, ur, vv = (np.floor(a + 0.5) for a in (u_left, u_right, v))
    q = np.zeros(len(ur), dtype=np.int64)
    if subpixel:
        ur, q = subpixel_columns_numpy(u_left, u_right)
    valid = (depth > 0) & (vv >= h) & (vv <= height - 1 - h)
    for u in (ul, ur + (1 if subpixel else 0)):
        valid &= (u >= h) & (u <= width - 1 - h)
    valid &= ur >= h
    out = np.full(len(depth), INVALID_FITNESS)
    rows, ul_i, ur_i = (a[valid].astype(np.intp) for a in (vv, ul, ur))
    off = np.arange(-h, h + 1)
    r = rows[:, None, None] + off[None, :, None]
    patch_l = left[r, ul_i[:, None, None] + off[None, None, :]].astype(np.int64)
    patch_r = right[r, ur_i[:, None, None] + off[None, None, :]].astype(np.int64)
    if subpixel:
        nxt = right[r, ur_i[:, None, None] + off[None, None, :] + 1].astype(np.int64)
        w = q[valid][:, None, None, None]
        patch_r = ((FRACTION - w) * patch_r + w * nxt + FRACTION // 2) >> FRACTION_BITS
    c = patch_l[:, h - 1 : h + 2, h - 1 : h + 2]  # the 3×3 around the left projection
    gx = (c[:, :, 2] - c[:, :, 0]) * np.array([1, 2, 1])[None, :, None]
    gy = (c[:, 2, :] - c[:, 0, :]) * np.array([1, 2, 1])[None, :, None]
    grad2 = (gx.sum(axis=1) ** 2 + gy_weight(gradient) * gy.sum(axis=1) ** 2).sum(axis=1)
    g = np.sqrt(np.sqrt(grad2.astype(np.float64)))
    measure = measure_of(similarity)
    rows = (len(patch_l), n * channels)  # the patches as rows of n·C, channel last
    sums = measure.sums.numpy(patch_l.reshape(rows), patch_r.reshape(rows), channels)
    out[valid] = g / (measure.finish_numpy(sums, n, channels) + guard * n * channels)
    return out
