"""The fitness kernel's scalar window terms (:mod:`flylog.fly.fitness`): the Sobel norm², the
zero-mean SSD and the zero-mean normalised cross-correlation's sums, on an image read as a
flat (H·W·C) uint8 array, for any window and channel count. All integer arithmetic: the
compiled kernel and the numpy reference get the same integers, then the same float steps.

ZNCC, pooled over channels (each channel loses its own mean): with n = w×w and, per channel,
``cov_c = n·Σlr − Σl·Σr``, ``vl_c = n·Σl² − (Σl)²``, ``vr_c = n·Σr² − (Σr)²``,
``ZNCC = Σ_c cov_c / sqrt(Σ_c vl_c · Σ_c vr_c)`` (0 when either patch is flat). It does not
change when the right image is ``a·R + b`` for any gain a > 0 and offsets b per channel.
The fitness built on it (``NCC_SCALE``) is in :mod:`flylog.fly.fitness`.

The compiled kernels of :mod:`flylog.fly.fitness` read GY_BIT and NCC_BIT as compile-time
constants; numba's cache of those kernels does not see a change here.
"""

from __future__ import annotations

import numba
import numpy as np

# Bits of the ``measure`` integer the compiled kernels take (measure_code in fitness.py).
GY_BIT = 1  # the Sobel norm² includes gy²
NCC_BIT = 2  # the similarity is ZNCC (else ZSSD)


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


def zncc_numpy(patch_l: np.ndarray, patch_r: np.ndarray) -> np.ndarray:
    """Reference: ZNCC of (M, w, w, C) int64 patch pairs, the compiled kernel's arithmetic."""
    n = patch_l.shape[1] * patch_l.shape[2]
    a1, b1 = patch_l.sum(axis=(1, 2)), patch_r.sum(axis=(1, 2))
    a2, b2 = (patch_l * patch_l).sum(axis=(1, 2)), (patch_r * patch_r).sum(axis=(1, 2))
    ab = (patch_l * patch_r).sum(axis=(1, 2))
    cov = (n * ab - a1 * b1).sum(axis=1)
    vl = (n * a2 - a1 * a1).sum(axis=1)
    vr = (n * b2 - b1 * b1).sum(axis=1)
    product = vl.astype(np.float64) * vr.astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        zncc = cov / np.sqrt(product)
    return np.where(product > 0.0, zncc, 0.0)
