"""The fitness kernel's scalar window terms (:mod:`flylog.fly.fitness`): the Sobel norm², the
zero-mean SSD and the zero-mean normalised cross-correlation's sums, on an image read as a
flat (H·W·C) uint8 array, for any window and channel count. All integer arithmetic: the
compiled kernel and the numpy reference get the same integers, then the same float steps.

ZNCC, pooled over channels (each channel loses its own mean): with n = w×w and, per channel,
``cov_c = n·Σlr − Σl·Σr``, ``vl_c = n·Σl² − (Σl)²``, ``vr_c = n·Σr² − (Σr)²``,
``ZNCC = Σ_c cov_c / sqrt(Σ_c vl_c · Σ_c vr_c)`` (0 when either patch is flat). It does not
change when the right image is ``a·R + b`` for any gain a > 0 and offsets b per channel.
The fitness built on it (``NCC_SCALE``) is in :mod:`flylog.fly.fitness`.

The gain-compensated zero-mean SSD reuses those sums: the left patch the reference, the
right one's deviations scaled to its contrast, ``Σ‖(L − μL) − g·(R − μR)‖²`` with
``g = σL/σR`` (pooled over channels) is ``2·(vl/n)·(1 − ZNCC)``: unchanged by a gain a > 0
and offsets of the right image, and, as the zero-mean SSD, small for a low-contrast left
patch whatever it is compared with. A flat right patch (ZNCC 0) scores ``2·vl/n``, the
value of an uncorrelated one.

contrast_zncc weighs 1 − ZNCC by the left patch's contrast σL = sqrt(vl/(n²·C)) grey levels
(per pixel and channel), ``2·s·σL·n·C·(1 − ZNCC) = CONTRAST_SCALE·sqrt(C·vl)·(1 − ZNCC)``,
s = 4: the geometric mean of zncc's ``2·s²`` and the gain-compensated SSD's ``2·σL²``
weights, so zncc's at σL = s. Unchanged by a gain and offsets of the right image as both;
under noise of sd σ a right match scores ≈ 2·s·σ²/σL per pixel, a flat patch ≈ 2·s·σ at any
depth, so texture wins over flat noise (the gain-compensated SSD scores both ≈ 2·σ²).

The compiled kernels of :mod:`flylog.fly.fitness` read GY_BIT and NCC_BIT as compile-time
constants; numba's cache of those kernels does not see a change here.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from flylog.fly.config import Gradient, Similarity

INVALID_FITNESS = -1.0
# ZNCC's fitness, G / (n·C·(guard + NCC_SCALE·(1 − ZNCC))): 1 − ZNCC in grey level² per pixel
# and channel, 2·s²·(1 − ZNCC) being the zero-mean SSD of two patches of contrast s, here s = 4.
# Measured s = 2, 4, 8, 32, 128 (docs/engine.md): 4 gives the best real-pair share and the
# corridor's F-score within 0.006 of the best.
NCC_SCALE = 2.0 * 4.0 * 4.0
# Sub-pixel sampling: the right window is interpolated between two columns with weights in
# 1/FRACTION steps (fixed point, rounded: (w0·a + w1·b + FRACTION/2) >> FRACTION_BITS).
FRACTION_BITS = 8
FRACTION = 1 << FRACTION_BITS

# Bits of the ``measure`` integer the compiled kernels take (measure_code).
GY_BIT = 1  # the Sobel norm² includes gy²
NCC_BIT = 2  # the kernels sum ZNCC's terms (cov, vl, vr; else ZSSD's)
SUBPIXEL_BIT = 4  # the right window is sampled at the exact right projection
GAIN_BIT = 8  # with NCC_BIT: the gain-compensated zero-mean SSD from those sums (else ZNCC)
CONTRAST_BIT = 16  # with NCC_BIT: 1 − ZNCC weighted by the left patch's contrast
# contrast_zncc's 2·s (grey levels): its dissimilarity is 2·s·σL·(1 − ZNCC) per pixel and
# channel, zncc's at σL = s.
CONTRAST_SCALE = 2.0 * 4.0


def gy_weight(gradient: Gradient) -> int:
    """The weight of gy² in the Sobel norm² the kernels compute: 1 for the paper's norm, 0 for
    the horizontal derivative alone (``gradient`` a :class:`Gradient` or its value)."""
    return 1 if Gradient(gradient) is Gradient.NORM else 0


def measure_code(
    gradient: Gradient, similarity: Similarity = Similarity.ZSSD, subpixel: bool = False
) -> int:
    """The ``measure`` integer the compiled kernels take: :data:`GY_BIT` for the paper's
    Sobel norm, :data:`NCC_BIT` for ZNCC, with :data:`GAIN_BIT` too for the gain-compensated
    zero-mean SSD, :data:`SUBPIXEL_BIT` for sub-pixel sampling."""
    return gy_weight(gradient) * GY_BIT + similarity_bits(similarity) + SUBPIXEL_BIT * subpixel


def similarity_bits(similarity: Similarity) -> int:
    """The bits of :func:`measure_code` that choose the dissimilarity."""
    kind = Similarity(similarity)
    if kind is Similarity.ZNCC:
        return NCC_BIT
    if kind is Similarity.GAIN_ZSSD:
        return NCC_BIT | GAIN_BIT
    if kind is Similarity.CONTRAST_ZNCC:
        return NCC_BIT | CONTRAST_BIT
    return 0


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
def windows_into(lflat, rflat, bl, br, stride, window, channels, q, lbuf, rbuf,
                 bs):  # fmt: skip  # pragma: no cover - compiled
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


@numba.njit(cache=True, nogil=True)
def zssd_lanes(lflat, rflat, bl, br, stride, window, channels, scratch):  # pragma: no cover
    """n·Σ_c ZSSD_c = n·Σd² − Σ_c (Σd)², for any window and channel count: Σd and Σd² per
    (column, channel) lane in ``scratch`` (≥ 2, ≥ window·channels) int32, then by channel."""
    ncols = window * channels
    col, sqv = scratch[0], scratch[1]
    for j in range(ncols):
        col[j] = 0
        sqv[j] = 0
    # Unsigned offsets: no negative-index wraparound test per byte, so the lane loop vectorises.
    ul, ur, ustride = np.uint64(bl), np.uint64(br), np.uint64(stride)
    for _ in range(window):
        for j in range(ncols):
            d = np.int32(lflat[ul + np.uint64(j)]) - np.int32(rflat[ur + np.uint64(j)])
            col[j] += d
            sqv[j] += d * d
        ul += ustride
        ur += ustride
    sq = np.int64(0)
    for j in range(ncols):
        sq += sqv[j]
    total = np.int64(window * window) * sq
    for c in range(channels):
        s1 = np.int64(0)
        for j in range(c, ncols, channels):
            s1 += col[j]
        total -= s1 * s1
    return total


@numba.njit(cache=True, nogil=True)
def ncc_lanes(lflat, rflat, bl, br, stride, window, channels, scratch):  # pragma: no cover
    """(Σ_c cov_c, Σ_c vl_c, Σ_c vr_c) of the module docstring: Σl, Σr, Σl², Σr², Σlr per
    (column, channel) lane in ``scratch`` (≥ 5, ≥ window·channels) int32, then by channel."""
    ncols = window * channels
    sl, sr, ql, qr, x = scratch[0], scratch[1], scratch[2], scratch[3], scratch[4]
    for j in range(ncols):
        sl[j] = 0
        sr[j] = 0
        ql[j] = 0
        qr[j] = 0
        x[j] = 0
    ul, ur, ustride = np.uint64(bl), np.uint64(br), np.uint64(stride)
    for _ in range(window):
        for j in range(ncols):
            a = np.int32(lflat[ul + np.uint64(j)])
            b = np.int32(rflat[ur + np.uint64(j)])
            sl[j] += a
            sr[j] += b
            ql[j] += a * a
            qr[j] += b * b
            x[j] += a * b
        ul += ustride
        ur += ustride
    n = np.int64(window * window)
    cov = np.int64(0)
    vl = np.int64(0)
    vr = np.int64(0)
    for c in range(channels):
        a1 = np.int64(0)
        b1 = np.int64(0)
        a2 = np.int64(0)
        b2 = np.int64(0)
        ab = np.int64(0)
        for j in range(c, ncols, channels):
            a1 += sl[j]
            b1 += sr[j]
            a2 += ql[j]
            b2 += qr[j]
            ab += x[j]
        cov += n * ab - a1 * b1
        vl += n * a2 - a1 * a1
        vr += n * b2 - b1 * b1
    return cov, vl, vr


@numba.njit(cache=True, nogil=True, inline="always")
def zncc_of(cov, vl, vr):  # pragma: no cover - compiled
    """ZNCC from the integer sums (0 when either patch is flat)."""
    product = float(vl) * float(vr)
    return cov / np.sqrt(product) if product > 0.0 else 0.0


@numba.njit(cache=True, nogil=True, inline="always")
def ncc_unlike(cov, vl, vr, n, channels, measure):  # pragma: no cover - compiled
    """The dissimilarity from ZNCC's sums (integers or floats) of an n-pixel, C-channel
    window, for the ``measure`` of :func:`measure_code`: ``NCC_SCALE·n·C·(1 − ZNCC)``; with
    :data:`GAIN_BIT` the gain-compensated zero-mean SSD ``2·(vl/n)·(1 − ZNCC)``; with
    :data:`CONTRAST_BIT` ``CONTRAST_SCALE·sqrt(C·vl)·(1 − ZNCC)`` (module docstring).
    Same arithmetic as :func:`ncc_unlike_numpy`."""
    if measure & GAIN_BIT:
        return 2.0 * (float(vl) / n) * (1.0 - zncc_of(cov, vl, vr))
    if measure & CONTRAST_BIT:
        return CONTRAST_SCALE * np.sqrt(float(vl) * channels) * (1.0 - zncc_of(cov, vl, vr))
    return NCC_SCALE * n * channels * (1.0 - zncc_of(cov, vl, vr))


def ncc_unlike_numpy(cov, vl, vr, n: int, channels: int, measure: int) -> np.ndarray:
    """Reference: :func:`ncc_unlike` of arrays."""
    vl = np.asarray(vl).astype(np.float64)
    vr = np.asarray(vr).astype(np.float64)
    product = vl * vr
    with np.errstate(divide="ignore", invalid="ignore"):
        zncc = np.where(product > 0.0, cov / np.sqrt(product), 0.0)
    if measure & GAIN_BIT:
        return 2.0 * (vl / n) * (1.0 - zncc)
    if measure & CONTRAST_BIT:
        return CONTRAST_SCALE * np.sqrt(vl * channels) * (1.0 - zncc)
    return NCC_SCALE * n * channels * (1.0 - zncc)


def ncc_sums_numpy(patch_l: np.ndarray, patch_r: np.ndarray):
    """Reference: :func:`ncc_lanes`'s (cov, vl, vr) of (M, w, w, C) int64 patch pairs."""
    n = patch_l.shape[1] * patch_l.shape[2]
    a1, b1 = patch_l.sum(axis=(1, 2)), patch_r.sum(axis=(1, 2))
    a2, b2 = (patch_l * patch_l).sum(axis=(1, 2)), (patch_r * patch_r).sum(axis=(1, 2))
    ab = (patch_l * patch_r).sum(axis=(1, 2))
    cov = (n * ab - a1 * b1).sum(axis=1)
    vl = (n * a2 - a1 * a1).sum(axis=1)
    vr = (n * b2 - b1 * b1).sum(axis=1)
    return cov, vl, vr
