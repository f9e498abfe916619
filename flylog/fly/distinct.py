"""Distinctness: is a fly's depth the only one its left pixel matches along the epipolar line?

A fly's fitness says its two projections look alike; it does not say that they look alike
*only* at that depth. Where the image varies little along the epipolar line (a horizontal
edge, a smooth stretch of sky or ground, a repeated texture), many depths along the fly's
ray score about as well, and the population settles at whichever it found first: a phantom
obstacle. The test here is the stereo matcher's uniqueness ratio (StereoSGBM's
``uniquenessRatio``) applied to one fly: its vision fitness divided by the best vision fitness
of the same left pixel at the disparities ``d + s`` for each shift ``s`` (px) of the list, the
right projection moved along the epipolar line and the left one kept. A value well above 1
means the match is a peak along the line; about 1 or below, that it is not evidence of a
surface at that depth.

With ``at_infinity``, one more rival: the same left pixel at disparity 0, the background at
infinity. The sky (and anything beyond ``d_max``) matches best there, a disparity no fly can
hold; along a row of a repeated or striped sky a fly settles on the best false match it can
reach, which may be a peak among its neighbours (shifts ±2, ±4 px) but never beats the true
match at infinity.

The fitness is :mod:`flylog.fly.fitness`'s (compiled kernel or numpy reference, bit-identical),
so distinctness costs ``1 + len(shifts)`` evaluations a fly (one more ``at_infinity``).

Under a rolling shutter (a pair's ``readout``, :mod:`flylog.geometry.rolling`) the fitness
reads a fly at its row's time: the rivals share the fly's left pixel *there*, so they are
made on the fly's ray at that time (the fly seen at its row's time, the rivals back-projected
from its pixel) and brought to the stamp by the row's motion, where the fitness takes them.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from flylog.fly.config import Gradient, Similarity
from flylog.fly.fitness import (
    INVALID_FITNESS,
    fitness_numba,
    fitness_numpy,
)
from flylog.geometry import Pose2D, StereoRig
from flylog.geometry.rolling import (
    STILL,
    is_still,
    row_motion,
    rows_clamped,
    seen_at_rows,
    seen_at_stamp,
)

# Distinctness of a fly no shift can be compared with (every shifted disparity ≤ 0 or off the
# image, or all of them score 0): its match has no rival on the line.
NO_RIVAL = math.inf

# The rival at infinity sits at this disparity f·B/Z (px): its right projection rounds to the
# column of the left one plus doffs (fitness reads whole pixels), unless it lies within this
# of a half pixel.
INFINITY_DISPARITY = 1e-9


def shifted_along_epipolar(
    xyz: np.ndarray, rig: StereoRig, shifts: tuple[int, ...], readout: Pose2D = STILL
) -> tuple[np.ndarray, np.ndarray]:
    """(S, N, 3) points with the left projection of ``xyz`` (N, 3) and the disparity d + s for
    each shift s (px), and (S, N) bool: whether that disparity is positive (a point in front
    of the cameras). Points whose shifted disparity is not positive are left at ``xyz``.
    With a moving ``readout``, the projection and the rivals are those at each fly's row
    time (:func:`_at_row_times`)."""
    xyz = np.asarray(xyz, dtype=np.float64)
    seen, rows, to_stamp = _at_row_times(xyz, rig, readout)
    u_left, u_right, v, depth = rig.project(seen)
    disparity = u_left - u_right + rig.doffs  # f·B/Z
    # every shift at once, (S, N): the same arithmetic element by element as one shift at a
    # time (the planner's worker measures this at every publication)
    d = disparity[None, :] + np.asarray(shifts, dtype=np.float64).reshape(-1, 1)
    valid = (d > 0) & (depth > 0)[None, :]
    safe = np.where(valid, d, 1.0)
    points = to_stamp(rig.backproject(u_left[None, :], v[None, :], rig.fb / safe), rows)
    return np.where(valid[:, :, None], points, xyz[None]), valid


def _at_row_times(
    xyz: np.ndarray, rig: StereoRig, readout: Pose2D
) -> tuple[np.ndarray, np.ndarray, Callable[[np.ndarray, np.ndarray], np.ndarray]]:
    """The flies as the fitness reads them under ``readout``: seen at their rows' times
    (:func:`~flylog.geometry.rolling.at_rows`), those rows, and the map of points seen at
    those times back to the stamp. A still readout: ``xyz`` itself and the identity."""
    if is_still(readout):
        return xyz, np.zeros(len(xyz)), lambda points, _rows: points
    rm = row_motion(readout, rig.height)
    rows = rows_clamped(rig.project(xyz)[2], rig.height)
    return seen_at_rows(xyz, rm, rows), rows, lambda points, r: seen_at_stamp(points, rm, r)


def at_infinity(
    xyz: np.ndarray, rig: StereoRig, readout: Pose2D = STILL
) -> tuple[np.ndarray, np.ndarray]:
    """(N, 3) points on the left rays of ``xyz`` (N, 3) at disparity ~0 (the background at
    infinity), and (N,) bool: whether the fly is in front of the cameras; the rays at each
    fly's row time under a moving ``readout``."""
    xyz = np.asarray(xyz, dtype=np.float64)
    seen, rows, to_stamp = _at_row_times(xyz, rig, readout)
    u_left, _, v, depth = rig.project(seen)
    far = rig.fb / INFINITY_DISPARITY
    valid = depth > 0
    points = to_stamp(rig.backproject(u_left, v, np.full(len(xyz), far)), rows)
    return np.where(valid[:, None], points, xyz), valid


def distinctness(
    left: np.ndarray,
    right: np.ndarray,
    xyz: np.ndarray,
    rig: StereoRig,
    window: int,
    guard: float,
    shifts: tuple[int, ...],
    *,
    gradient: Gradient = Gradient.NORM,
    similarity: Similarity = Similarity.ZSSD,
    subpixel: bool = False,
    use_numba: bool = True,
    infinity: bool = False,
    readout: Pose2D = STILL,
) -> np.ndarray:
    """(N,) float64: each fly's vision fitness over the best vision fitness of its left pixel
    at the disparities shifted by ``shifts`` (px), and with ``infinity`` at disparity 0 too
    (:func:`at_infinity`). 0 for a fly whose own fitness is not positive (invalid or no
    contrast), :data:`NO_RIVAL` for one with no valid rival. ``readout``: the pair's
    rolling-shutter motion (the fitness and the rivals at each fly's row time)."""
    if not shifts:
        msg = "distinctness needs at least one disparity shift"
        raise ValueError(msg)
    xyz = np.ascontiguousarray(xyz, dtype=np.float64)
    n = len(xyz)
    if n == 0:
        return np.empty(0)
    shifted, valid = shifted_along_epipolar(xyz, rig, shifts, readout)
    if infinity:
        far, in_front = at_infinity(xyz, rig, readout)
        shifted = np.concatenate([shifted, far[None]])
        valid = np.concatenate([valid, in_front[None]])
    points = np.concatenate([xyz[None], shifted]).reshape(-1, 3)
    fitness = fitness_numba if use_numba else fitness_numpy
    scores = fitness(
        left,
        right,
        points,
        rig,
        window,
        guard,
        gradient=gradient,
        similarity=similarity,
        subpixel=subpixel,
        readout=readout,
    )
    scores = scores.reshape(len(shifted) + 1, n)
    own = scores[0]
    rivals = np.where(valid, scores[1:], INVALID_FITNESS).max(axis=0)
    out = np.full(n, NO_RIVAL)
    compared = rivals > 0
    out[compared] = own[compared] / rivals[compared]
    out[own <= 0] = 0.0
    return out
