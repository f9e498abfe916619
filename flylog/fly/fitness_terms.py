"""The fitness kernel's scalar window terms (:mod:`flylog.fly.fitness`) that do not depend on
the similarity measure: the projection's sub-pixel column, a window pair's copy with the right
one interpolated, and the Sobel norm², on an image read as a flat (H·W·C) uint8 array, for any
window and channel count. All integer arithmetic: the compiled kernel and the numpy reference
get the same integers. The measures' own sums are in :mod:`flylog.fly.measures`.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from flylog.fly.config import Gradient

INVALID_FITNESS = -1.0
# Sub-pixel sampling: the right window is interpolated between two columns with weights in
# 1/FRACTION steps (fixed point, rounded: (w0·a + w1·b + FRACTION/2) >> FRACTION_BITS).
FRACTION_BITS = 8
FRACTION = 1 << FRACTION_BITS


def gy_weight(gradient: Gradient) -> int:
    """The weight of gy² in the Sobel norm² the kernels compute: 1 for the paper's norm, 0 for
    the horizontal derivative alone (``gradient`` a :class:`Gradient` or its value)."""
    return 1 if Gradient(gradient) is Gradient.NORM else 0


def as_planes(image: np.ndarray) -> np.ndarray:
    """(H, W) or (H, W, C) uint8 → (H, W, C) C-contiguous uint8 (a view when possible)."""
    image = np.asarray(image)
    if image.ndim == 2:
        image = image[:, :, None]
    return np.ascontiguousarray(image, dtype=np.uint8)


@numba.njit(cache=True, nogil=True, inline="always")
def subpixel_column(u_left, u_right):  # pragma: no cover - compiled
    """(x0, q): the right window's left column and weight of the next one, in 1/FRACTION, for
    a left projection rounded to its pixel: the right one moves by the same rounding, so the
    fly's disparity is kept exact. Same arithmetic as :func:`subpixel_columns_numpy`."""
    x = u_right + (math.floor(u_left + 0.5) - u_left)
    x0 = math.floor(x)
    q = math.floor((x - x0) * FRACTION + 0.5)
    if q >= FRACTION:
        return x0 + 1, 0
    return x0, q


def subpixel_columns_numpy(u_left: np.ndarray, u_right: np.ndarray):
    """Reference: :func:`subpixel_column` of arrays."""
    x = u_right + (np.floor(u_left + 0.5) - u_left)
    x0 = np.floor(x)
    q = np.floor((x - x0) * FRACTION + 0.5)
    over = q >= FRACTION
    return np.where(over, x0 + 1, x0), np.where(over, 0, q).astype(np.int64)


@numba.njit(cache=True, nogil=True)
def windows_into(
    lflat, rflat, bl, br, stride, window, channels, q, lbuf, rbuf, bs
):  # pragma: no cover - compiled
    """Copy the left window from bl, and the right one from br interpolated towards the next
    column with weight q/FRACTION, into rows of ``bs`` bytes of lbuf and rbuf."""
    ncols = window * channels
    w1 = np.int32(q)
    w0 = np.int32(FRACTION) - w1
    half = np.int32(FRACTION // 2)
    # Unsigned offsets: no negative-index wraparound test per byte, so the loops vectorise.
    lo, ro, bo = np.uint64(bl), np.uint64(br), np.uint64(0)
    across, ustride, ubs = np.uint64(channels), np.uint64(stride), np.uint64(bs)
    for _ in range(window):
        for j in range(ncols):
            lbuf[bo + np.uint64(j)] = lflat[lo + np.uint64(j)]
        for j in range(ncols):
            a = np.int32(rflat[ro + np.uint64(j)])
            b = np.int32(rflat[ro + np.uint64(j) + across])
            rbuf[bo + np.uint64(j)] = np.uint8((w0 * a + w1 * b + half) >> np.int32(FRACTION_BITS))
        lo += ustride
        ro += ustride
        bo += ubs


@numba.njit(cache=True, nogil=True, inline="always")
def _byte(flat, offset):  # pragma: no cover - compiled
    return np.int64(flat[offset])


@numba.njit(cache=True, nogil=True)
def sobel_norm2(flat, centre, stride, channels, gy_weight=1):  # pragma: no cover - compiled
    """Σ_c (gx² + gy_weight·gy²) of the 3×3 Sobel around the flat offset ``centre`` (channel
    0) of an image read as a flat (H·W·C) array (offsets unsigned: no wraparound test per
    read)."""
    grad2 = np.int64(0)
    across, down = np.uint64(channels), np.uint64(stride)
    for c in range(channels):
        m = np.uint64(centre + c)
        a, b = m - down, m + down  # above and below
        nw, n, ne = _byte(flat, a - across), _byte(flat, a), _byte(flat, a + across)
        w, e = _byte(flat, m - across), _byte(flat, m + across)
        sw, s, se = _byte(flat, b - across), _byte(flat, b), _byte(flat, b + across)
        gx = ne - nw + 2 * (e - w) + se - sw
        gy = sw - nw + 2 * (s - n) + se - ne
        grad2 += gx * gx + gy_weight * gy * gy
    return grad2
