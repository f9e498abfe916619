"""The similarity measures, each one definition (:class:`~flylog.fly.measure.Measure`): its
window sums and its finishing step. :data:`MEASURES` maps the configuration's
:class:`~flylog.fly.config.Similarity` to them; every user (fitness kernel and reference,
scouts, distinctness, heading) takes a measure from there.

Three kinds of window sums serve the five measures, with n = w×w pixels and C channels, all in
integers on uint8 images (the compiled kernel and the numpy reference get the same integers,
then the same float steps):

- the differences' (:data:`DIFFERENCE`): with d = L − R, Σd² over every pixel and channel
  and Σ_c (Σd_c)², whose ``(n·Σd² − Σ_c (Σd_c)²) / n`` is Σ_c ZSSD_c, the zero-mean SSD
  (each patch loses its own mean per channel: an offset between the cameras is removed);
- the correlation's (:data:`CORRELATION`): per channel ``cov_c = n·Σlr − Σl·Σr``,
  ``vl_c = n·Σl² − (Σl)²``, ``vr_c = n·Σr² − (Σr)²``, summed over channels. ZNCC pooled
  over channels is ``Σ_c cov_c / sqrt(Σ_c vl_c · Σ_c vr_c)`` (0 when either patch is flat):
  unchanged when the right image is ``a·R + b`` for any gain a > 0 and offsets b per
  channel;
- the absolute differences' (:data:`ABSOLUTE`): Σ|d| over every pixel and channel, by the
  lane loop alone (no vector form: every window takes the scalar loop).

The finishing steps:

- zssd: Σ_c ZSSD_c (paper §2.1.1);
- zncc: ``NCC_SCALE·n·C·(1 − ZNCC)``: 1 − ZNCC in grey level² per pixel and channel,
  2·s²·(1 − ZNCC) being the zero-mean SSD of two patches of contrast s, here s = 4.
  Measured s = 2, 4, 8, 32, 128 (docs/engine.md): 4 gives the best real-pair share and the
  corridor's F-score within 0.006 of the best;
- gain_zssd: the gain-compensated zero-mean SSD, the left patch the reference and the right
  one's deviations scaled to its contrast, ``Σ‖(L − μL) − g·(R − μR)‖²`` with g = σL/σR
  (pooled over channels), which is ``2·(vl/n)·(1 − ZNCC)``: unchanged by a gain a > 0 and
  offsets of the right image, and, as the zero-mean SSD, small for a low-contrast left
  patch whatever it is compared with. A flat right patch (ZNCC 0) scores ``2·vl/n``, the
  value of an uncorrelated one;
- contrast_zncc: 1 − ZNCC weighed by the left patch's contrast σL = sqrt(vl/(n²·C)) grey
  levels (per pixel and channel), ``2·s·σL·n·C·(1 − ZNCC) = CONTRAST_SCALE·sqrt(C·vl)·(1 −
  ZNCC)``, s = 4: the geometric mean of zncc's ``2·s²`` and gain_zssd's ``2·σL²`` weights,
  so zncc's at σL = s. Unchanged by a gain and offsets of the right image as both; under
  noise of sd σ a right match scores ≈ 2·s·σ²/σL per pixel, a flat patch ≈ 2·s·σ at any
  depth, so texture wins over flat noise (gain_zssd scores both ≈ 2·σ²);
- sad: ``(Σ|d|)²/(n·C)``, the SSD of a uniform difference of the same mean |d|: the guard
  keeps its unit. Not zero-mean: an offset between the cameras counts.
"""

from __future__ import annotations

import numba
import numpy as np

from flylog.fly.config import Similarity
from flylog.fly.fitness_vector import ncc_terms_intrinsic, vector_variants, window_terms_intrinsic
from flylog.fly.measure import Measure, WindowSums

NCC_SCALE = 2.0 * 4.0 * 4.0
# contrast_zncc's 2·s (grey levels): its dissimilarity is 2·s·σL·(1 − ZNCC) per pixel and
# channel, zncc's at σL = s.
CONTRAST_SCALE = 2.0 * 4.0


# --- the differences' sums: (Σd², Σ_c (Σd_c)²) -----------------------------------------------


@numba.njit(cache=True, nogil=True)
def zssd_lanes(lflat, rflat, bl, br, stride, window, channels, scratch):  # pragma: no cover
    """(Σd², Σ_c (Σd_c)²) for any window and channel count: Σd and Σd² per (column, channel)
    lane in ``scratch`` (≥ 2, ≥ window·channels) int32, then by channel."""
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
    squares = np.int64(0)
    for c in range(channels):
        s1 = np.int64(0)
        for j in range(c, ncols, channels):
            s1 += col[j]
        squares += s1 * s1
    return sq, squares


@numba.njit(cache=True, nogil=True)
def zssd_patch_sums(a, b, channels):  # pragma: no cover - compiled
    """(Σd², Σ_c (Σd_c)²) of two float patches (n·C,), channel last."""
    s2 = 0.0
    squares = 0.0
    for ch in range(channels):
        s1 = 0.0
        for t in range(ch, a.shape[0], channels):
            d = a[t] - b[t]
            s1 += d
            s2 += d * d
        squares += s1 * s1
    return s2, squares


def zssd_sums_numpy(a: np.ndarray, b: np.ndarray, channels: int) -> tuple[np.ndarray, ...]:
    """Reference: :func:`zssd_patch_sums` of (M, n·C) patch pairs, its additions in its order."""
    size = a.shape[1]
    zero = np.zeros(a.shape[0], dtype=np.result_type(a.dtype, b.dtype))
    s2, squares = zero.copy(), zero.copy()
    for ch in range(channels):
        s1 = zero.copy()
        for t in range(ch, size, channels):
            d = a[:, t] - b[:, t]
            s1 += d
            s2 += d * d
        squares += s1 * s1
    return s2, squares


DIFFERENCE = WindowSums(
    name="difference",
    count=2,
    lanes=zssd_lanes,
    scratch_rows=2,
    patches=zssd_patch_sums,
    numpy=zssd_sums_numpy,
    vector=vector_variants(window_terms_intrinsic),
)


# --- the correlation's sums: (Σ_c cov_c, Σ_c vl_c, Σ_c vr_c) ---------------------------------


@numba.njit(cache=True, nogil=True)
def ncc_lanes(lflat, rflat, bl, br, stride, window, channels, scratch):  # pragma: no cover
    """(Σ_c cov_c, Σ_c vl_c, Σ_c vr_c): Σl, Σr, Σl², Σr², Σlr per (column, channel) lane in
    ``scratch`` (≥ 5, ≥ window·channels) int32, then by channel."""
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


@numba.njit(cache=True, nogil=True)
def ncc_patch_sums(a, b, channels):  # pragma: no cover - compiled
    """(Σ_c cov_c, Σ_c vl_c, Σ_c vr_c) of two float patches (n·C,), channel last."""
    n = a.shape[0] // channels
    cov = 0.0
    vl = 0.0
    vr = 0.0
    for ch in range(channels):
        sa = 0.0
        sb = 0.0
        saa = 0.0
        sbb = 0.0
        sab = 0.0
        for t in range(ch, a.shape[0], channels):
            x = a[t]
            y = b[t]
            sa += x
            sb += y
            saa += x * x
            sbb += y * y
            sab += x * y
        cov += n * sab - sa * sb
        vl += n * saa - sa * sa
        vr += n * sbb - sb * sb
    return cov, vl, vr


def ncc_sums_numpy(a: np.ndarray, b: np.ndarray, channels: int) -> tuple[np.ndarray, ...]:
    """Reference: :func:`ncc_patch_sums` of (M, n·C) patch pairs, its additions in its order."""
    size = a.shape[1]
    n = size // channels
    zero = np.zeros(a.shape[0], dtype=np.result_type(a.dtype, b.dtype))
    cov, vl, vr = zero.copy(), zero.copy(), zero.copy()
    for ch in range(channels):
        sa, sb, saa, sbb, sab = (zero.copy() for _ in range(5))
        for t in range(ch, size, channels):
            x, y = a[:, t], b[:, t]
            sa += x
            sb += y
            saa += x * x
            sbb += y * y
            sab += x * y
        cov += n * sab - sa * sb
        vl += n * saa - sa * sa
        vr += n * sbb - sb * sb
    return cov, vl, vr


CORRELATION = WindowSums(
    name="correlation",
    count=3,
    lanes=ncc_lanes,
    scratch_rows=5,
    patches=ncc_patch_sums,
    numpy=ncc_sums_numpy,
    vector=vector_variants(ncc_terms_intrinsic),
)


@numba.njit(cache=True, nogil=True, inline="always")
def zncc_of(cov, vl, vr):  # pragma: no cover - compiled
    """ZNCC from the correlation's sums (0 when either patch is flat)."""
    product = float(vl) * float(vr)
    return cov / np.sqrt(product) if product > 0.0 else 0.0


def zncc_numpy(cov, vl, vr) -> np.ndarray:
    """Reference: :func:`zncc_of` of arrays."""
    product = np.asarray(vl).astype(np.float64) * np.asarray(vr).astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(product > 0.0, cov / np.sqrt(product), 0.0)


# --- sum of absolute differences: (Σ|d|,) ------------------------------------------------------


@numba.njit(cache=True, nogil=True)
def sad_lanes(lflat, rflat, bl, br, stride, window, channels, scratch):  # pragma: no cover
    """(Σ|d|,) over the window's pixels and channels: |d| summed per (column, channel) lane in
    ``scratch`` (≥ 1, ≥ window·channels) int32, then over the lanes."""
    ncols = window * channels
    col = scratch[0]
    for j in range(ncols):
        col[j] = 0
    ul, ur, ustride = np.uint64(bl), np.uint64(br), np.uint64(stride)
    for _ in range(window):
        for j in range(ncols):
            d = np.int32(lflat[ul + np.uint64(j)]) - np.int32(rflat[ur + np.uint64(j)])
            col[j] += abs(d)
        ul += ustride
        ur += ustride
    total = np.int64(0)
    for j in range(ncols):
        total += col[j]
    return (total,)


@numba.njit(cache=True, nogil=True)
def sad_patch_sums(a, b, channels):  # pragma: no cover - compiled
    """(Σ|d|,) of two float patches (n·C,), channel last."""
    total = 0.0
    for ch in range(channels):
        for t in range(ch, a.shape[0], channels):
            total += abs(a[t] - b[t])
    return (total,)


def sad_sums_numpy(a: np.ndarray, b: np.ndarray, channels: int) -> tuple[np.ndarray, ...]:
    """Reference: :func:`sad_patch_sums` of (M, n·C) patch pairs, its additions in its order."""
    total = np.zeros(a.shape[0], dtype=np.result_type(a.dtype, b.dtype))
    for ch in range(channels):
        for t in range(ch, a.shape[1], channels):
            total += np.abs(a[:, t] - b[:, t])
    return (total,)


ABSOLUTE = WindowSums(
    name="absolute",
    count=1,
    lanes=sad_lanes,
    scratch_rows=1,
    patches=sad_patch_sums,
    numpy=sad_sums_numpy,
)


@numba.njit(cache=True, nogil=True, inline="always")
def sad_finish(sums, n, channels):  # pragma: no cover - compiled
    """(Σ|d|)²/(n·C): the SSD of a uniform difference of SAD's mean |d| (grey level² summed
    over the window, the guard's unit)."""
    return float(sums[0]) * float(sums[0]) / (n * channels)


def sad_finish_numpy(sums, n: int, channels: int) -> np.ndarray:
    """Reference: :func:`sad_finish` of arrays."""
    total = np.asarray(sums[0]).astype(np.float64)
    return total * total / (n * channels)


# --- the measures: sums and finishing step ---------------------------------------------------


@numba.njit(cache=True, nogil=True, inline="always")
def zssd_finish(sums, n, channels):  # pragma: no cover - compiled
    """Σ_c ZSSD_c."""
    return (n * sums[0] - sums[1]) / n


def zssd_finish_numpy(sums, n: int, channels: int) -> np.ndarray:
    """Reference: :func:`zssd_finish` of arrays."""
    return (n * sums[0] - sums[1]) / n


@numba.njit(cache=True, nogil=True, inline="always")
def zncc_finish(sums, n, channels):  # pragma: no cover - compiled
    """NCC_SCALE·n·C·(1 − ZNCC)."""
    return NCC_SCALE * n * channels * (1.0 - zncc_of(sums[0], sums[1], sums[2]))


def zncc_finish_numpy(sums, n: int, channels: int) -> np.ndarray:
    """Reference: :func:`zncc_finish` of arrays."""
    return NCC_SCALE * n * channels * (1.0 - zncc_numpy(*sums))


@numba.njit(cache=True, nogil=True, inline="always")
def gain_zssd_finish(sums, n, channels):  # pragma: no cover - compiled
    """2·(vl/n)·(1 − ZNCC)."""
    return 2.0 * (float(sums[1]) / n) * (1.0 - zncc_of(sums[0], sums[1], sums[2]))


def gain_zssd_finish_numpy(sums, n: int, channels: int) -> np.ndarray:
    """Reference: :func:`gain_zssd_finish` of arrays."""
    vl = np.asarray(sums[1]).astype(np.float64)
    return 2.0 * (vl / n) * (1.0 - zncc_numpy(*sums))


@numba.njit(cache=True, nogil=True, inline="always")
def contrast_zncc_finish(sums, n, channels):  # pragma: no cover - compiled
    """CONTRAST_SCALE·sqrt(C·vl)·(1 − ZNCC)."""
    zncc = zncc_of(sums[0], sums[1], sums[2])
    return CONTRAST_SCALE * np.sqrt(float(sums[1]) * channels) * (1.0 - zncc)


def contrast_zncc_finish_numpy(sums, n: int, channels: int) -> np.ndarray:
    """Reference: :func:`contrast_zncc_finish` of arrays."""
    vl = np.asarray(sums[1]).astype(np.float64)
    return CONTRAST_SCALE * np.sqrt(vl * channels) * (1.0 - zncc_numpy(*sums))


ZSSD = Measure(Similarity.ZSSD, DIFFERENCE, zssd_finish, zssd_finish_numpy)
ZNCC = Measure(Similarity.ZNCC, CORRELATION, zncc_finish, zncc_finish_numpy)
GAIN_ZSSD = Measure(Similarity.GAIN_ZSSD, CORRELATION, gain_zssd_finish, gain_zssd_finish_numpy)
CONTRAST_ZNCC = Measure(
    Similarity.CONTRAST_ZNCC, CORRELATION, contrast_zncc_finish, contrast_zncc_finish_numpy
)
SAD = Measure(Similarity.SAD, ABSOLUTE, sad_finish, sad_finish_numpy)

MEASURES: dict[Similarity, Measure] = {
    m.similarity: m for m in (ZSSD, ZNCC, GAIN_ZSSD, CONTRAST_ZNCC, SAD)
}


def measure_of(similarity: Similarity | str) -> Measure:
    """The definition of a :class:`~flylog.fly.config.Similarity` (or its value)."""
    return MEASURES[Similarity(similarity)]
