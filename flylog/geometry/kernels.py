"""The stereo rig in compiled kernels: one float64 array and inline projection helpers.

Layout of :meth:`StereoRig.constants` (indices below): focal length, left cx, cy, right cx (cx +
doffs), the left and right optical centres in base_link, the base_link → optical rotation
row by row, and whether the rig is level (a kernel's fast path for it must give the same
numbers: with the level rotation's zeros and ones the general arithmetic reduces exactly to
the shortcut). Kernels that need more numbers append them after :data:`RIG_SIZE`.
The helpers compute what :meth:`StereoRig.project` and :meth:`StereoRig.backproject`
compute, operation for operation, so a kernel and its numpy reference agree bit for bit.

numba's on-disk cache of a kernel is keyed on its own file: it does not see an edit here (a
layout index, a helper), so after one, delete the caches (``make clean`` does).
"""

from __future__ import annotations

import numba

FOCAL, CX, CY, CX_RIGHT = 0, 1, 2, 3
LEFT = 4  # left optical centre x, y, z at 4, 5, 6
RIGHT = 7  # right optical centre x, y, z at 7, 8, 9
ROWS = 10  # base_link → optical rotation, row-major, at 10…18
LEVEL = 19  # 1.0 for a level rig (optical axes along base_link x), else 0.0
RIG_SIZE = 20


@numba.njit(cache=True, nogil=True, inline="always")
def optical(k, x, y, z):  # pragma: no cover - compiled
    """(a, b, depth, a_right): the point in the left optical frame (x right, y down, depth
    forward) and its x in the right one."""
    dx, dy, dz = x - k[4], y - k[5], z - k[6]
    depth = k[16] * dx + k[17] * dy + k[18] * dz
    a = k[10] * dx + k[11] * dy + k[12] * dz
    b = k[13] * dx + k[14] * dy + k[15] * dz
    ex, ey, ez = x - k[7], y - k[8], z - k[9]
    ar = k[10] * ex + k[11] * ey + k[12] * ez
    return a, b, depth, ar


@numba.njit(cache=True, nogil=True, inline="always")
def depth_of(k, x, y, z):  # pragma: no cover - compiled
    """Depth along the optical axis of a base_link point."""
    return k[16] * (x - k[4]) + k[17] * (y - k[5]) + k[18] * (z - k[6])


@numba.njit(cache=True, nogil=True, inline="always")
def row_of(k, x, y, z):  # pragma: no cover - compiled
    """v of a base_link point (unguarded division by its depth)."""
    dx, dy, dz = x - k[4], y - k[5], z - k[6]
    depth = k[16] * dx + k[17] * dy + k[18] * dz
    b = k[13] * dx + k[14] * dy + k[15] * dz
    return k[2] + k[0] * b / depth


@numba.njit(cache=True, nogil=True, inline="always")
def project(k, x, y, z):  # pragma: no cover - compiled
    """(u_left, u_right, v, depth) of a base_link point, as ``StereoRig.project`` (depth
    guarded at 1e-9 in the divisions)."""
    a, b, depth, ar = optical(k, x, y, z)
    safe = depth if depth > 1e-9 else 1e-9
    f = k[0]
    return k[1] + f * a / safe, k[3] + f * ar / safe, k[2] + f * b / safe, depth


@numba.njit(cache=True, nogil=True, inline="always")
def backproject(k, u, v, depth):  # pragma: no cover - compiled
    """The base_link point at left pixel (u, v) and ``depth``, as ``StereoRig.backproject``."""
    f = k[0]
    a = (u - k[1]) * depth / f
    b = (v - k[2]) * depth / f
    x = k[4] + (k[10] * a + k[13] * b + k[16] * depth)
    y = k[5] + (k[11] * a + k[14] * b + k[17] * depth)
    z = k[6] + (k[12] * a + k[15] * b + k[18] * depth)
    return x, y, z


# A rolling shutter in kernels (:mod:`flylog.geometry.rolling`): ``rm`` is the robot's motion
# per row (x, y, theta over the readout, divided by the image height); row v's motion is
# v · rm. A point's row is clamped to [0, height] (NaN: row 0) before it sets the motion.


@numba.njit(cache=True, nogil=True, inline="always")
def row_clamped(v, height):  # pragma: no cover - compiled
    """``v`` within [0, ``height``]; NaN gives 0."""
    if not v > 0.0:
        return 0.0
    return v if v < height else height


@numba.njit(cache=True, nogil=True, inline="always")
def seen_at_row(rm, v, x, y):  # pragma: no cover - compiled
    """(x, y) of a base_link point of the stamp as the robot sees it at row v's time: moved
    by the inverse of row v's motion, as ``moved_by_odometry``, the turn's cos and sin to
    second order (1 − a²/2, a)."""
    a = v * rm[2]
    c = 1.0 - 0.5 * a * a
    dx = x - v * rm[0]
    dy = y - v * rm[1]
    return c * dx + a * dy, c * dy - a * dx


@numba.njit(cache=True, nogil=True, inline="always")
def seen_at_stamp(rm, v, x, y):  # pragma: no cover - compiled
    """The inverse of :func:`seen_at_row` (to its order): (x, y) of a point seen at row v's
    time, in base_link at the stamp (row v's motion applied forward)."""
    a = v * rm[2]
    c = 1.0 - 0.5 * a * a
    return v * rm[0] + (c * x - a * y), v * rm[1] + (a * x + c * y)
