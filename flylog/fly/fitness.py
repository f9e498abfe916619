"""The fly's fitness: gradient over the dissimilarity of its two projections (paper §2.1.1).

``fitness = G / (D + guard·n·C)`` over the n = w×w neighbourhood and C channels, where D is
the similarity measure's dissimilarity (:mod:`flylog.fly.measures`: the paper's zero-mean SSD
``Σ_c (Σd² − (Σd)²/n)``, d = L − R, by default) and ``G = sqrt(|Sobel|)``, the square root
of the Sobel gradient norm of the left image at the left projection (summed over channels
under the norm). With :attr:`Gradient.HORIZONTAL` the norm is of gx alone (``gy_weight`` 0 in
the kernels): ``G = sqrt((Σ_c gx_c²)^½)``, equal to the paper's G wherever gy = 0 (a vertical
edge) and 0 on a horizontal edge, along which a horizontal disparity cannot be measured.

Projections are rounded to the nearest pixel (``floor(u + 0.5)``); with sub-pixel sampling
the right window is interpolated at the exact right projection instead
(:func:`flylog.fly.fitness_terms.subpixel_column`). Only the w×w pixels around each
projection are read (and one pixel column more on the right when interpolated): no
whole-image pre-processing. A fly behind
the cameras or whose neighbourhood leaves either image scores :data:`INVALID_FITNESS`,
below every valid fitness (which is ≥ 0).

Two implementations with bit-identical results: :func:`fitness_numba` (parallel over flies,
integer arithmetic on uint8 pixels, a window row at a time in AVX2 vectors written as LLVM IR)
and :func:`fitness_numpy` (a short gather reference).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from flylog.fly.bundles import Images
from flylog.fly.config import Gradient, Similarity
from flylog.fly.fitness_reference import fitness_numpy as fitness_numpy
from flylog.fly.fitness_terms import INVALID_FITNESS as INVALID_FITNESS
from flylog.fly.fitness_terms import as_planes as as_planes
from flylog.fly.fitness_terms import gy_weight as gy_weight
from flylog.fly.fitness_terms import sobel_norm2, subpixel_column, windows_into
from flylog.fly.fitness_vector import HALF, LANES, MAX_CHANNELS, lane_masks, prefetch
from flylog.fly.measure import (
    Measure,
    dissimilarity,
    has_vector,
    lane_sums,
    scratch_rows,
    sums_count,
    vector_sums,
)
from flylog.fly.measures import measure_of
from flylog.geometry import StereoRig
from flylog.geometry.kernels import (
    CX,
    CX_RIGHT,
    CY,
    FOCAL,
    LEFT,
    LEVEL,
    RIGHT,
    optical,
    project,
    row_clamped,
    seen_at_row,
)
from flylog.geometry.poses import Pose2D
from flylog.geometry.rolling import STILL, is_still, row_motion


def rig_constants(rig: StereoRig) -> np.ndarray:
    """The rig as the float64 array the kernels take (:mod:`flylog.geometry.kernels`)."""
    return rig.constants()


@numba.njit(cache=True, nogil=True)
def left_projections_numba(xyz, k):  # pragma: no cover - compiled
    """(u_left, v) of every fly, the same numbers as ``StereoRig.project`` (``k`` from
    :func:`rig_constants`)."""
    n = xyz.shape[0]
    u = np.empty(n)
    v = np.empty(n)
    for i in range(n):
        u[i], _, v[i], _ = project(k, xyz[i, 0], xyz[i, 1], xyz[i, 2])
    return u, v


# Flies go in blocks, in three passes: project all (and prefetch their window rows), then the
# integer window terms, then the float fitness. Each pass's iterations are independent, so the
# CPU overlaps one fly's long chain (divisions, loads, reductions, square roots) with the
# next's; scored fly by fly, that chain is most of the time.
_BLOCK = 64
# The window rows of the fly this many places ahead are prefetched: random flies' rows mostly
# miss L2, and a fly's wait then overlaps the work on the flies before it.
_AHEAD = 4


@numba.njit(cache=True, nogil=True)
def _prefetch_window(lflat, rflat, bl, br, stride, window, lanes, extra):  # pragma: no cover
    """Prefetch the bytes a vector window reads from bl (left) and br (right, ``extra`` bytes
    more a row); bl < 0: none."""
    if bl < 0:
        return
    for _ in range(window):
        prefetch(lflat, bl)
        prefetch(lflat, bl + lanes - 1)
        prefetch(rflat, br)
        prefetch(rflat, br + lanes - 1 + extra)
        bl += stride
        br += stride


# error_model="numpy": no zero test per division (a fly behind the cameras divides by a depth
# ≤ 0 and is discarded), so the projection and the last pass are vectorised loops.
@numba.njit(cache=True, nogil=True, error_model="numpy")
def _fitness_range(im, measure, xyz, index, start, stop, masks, out):  # pragma: no cover
    """Fitness of flies index[start:stop] on the pair ``im`` (:class:`Images`) by ``measure``
    (a :class:`~flylog.fly.measure.Measure`: numba compiles this once per measure), ``masks``
    from :func:`lane_masks` with the pair's gy weight."""
    channels, k, window, subpixel = im.channels, im.k, im.window, im.subpixel
    height = im.lrows.shape[0]
    stride = im.lrows.shape[1]
    width = stride // channels
    size = im.lrows.size
    h = window // 2
    n = window * window
    ncols = window * channels
    denominator_guard = im.guard * n * channels
    lflat = im.lrows.reshape(size)
    rflat = im.rrows.reshape(size)
    lanes = HALF if ncols <= HALF else LANES
    vector = ncols <= LANES and channels <= MAX_CHANNELS and has_vector(measure)
    reach = (window - 1) * stride + lanes  # bytes a vector window reads from its first
    across = channels if subpixel else 0  # the interpolated right rows read this much more
    # Per fly of the block: first offsets of its left and right windows (−1: invalid fly),
    # then the measure's window sums and the Sobel norm².
    first_l = np.empty(_BLOCK, dtype=np.int64)
    first_r = np.empty(_BLOCK, dtype=np.int64)
    count = sums_count(measure)
    sums = np.empty((count, _BLOCK), dtype=np.int64)
    grads = np.empty(_BLOCK, dtype=np.int64)
    # the projections of the block's flies: depth, u left, u right, v
    proj = np.empty((4, _BLOCK))
    fitness = np.empty(_BLOCK)
    scratch = np.empty((scratch_rows(measure), ncols), dtype=np.int32)  # the lane loop's
    frac = np.zeros(_BLOCK, dtype=np.int64)  # sub-pixel: the right window's weight
    bs = max(ncols, LANES)  # sub-pixel: the copied windows' row length
    lbuf = np.zeros(window * bs, dtype=np.uint8)
    rbuf = np.zeros(window * bs, dtype=np.uint8)
    focal, cx, cy, cx_right = k[FOCAL], k[CX], k[CY], k[CX_RIGHT]
    lx, ly, lz, ry = k[LEFT], k[LEFT + 1], k[LEFT + 2], k[RIGHT + 1]
    level = k[LEVEL] != 0.0
    rm, rolling, rows = im.row_motion, im.rolling, float(height)
    for block in range(start, stop, _BLOCK):
        m = min(_BLOCK, stop - block)
        # A level rig: the numbers of the general loop without the rotation's zeros and ones
        # (one thread, 1.00x the level-only kernel's rate against 0.94-0.98x for the general
        # loop on the same flies, tests/benchmarks/bench_fly.py). A rolling shutter: each fly
        # first seen from the robot at the time of the row it projects on at the stamp
        # (flylog.geometry.rolling); a still readout keeps the stamp's arithmetic untouched.
        if rolling and level:
            for t in range(m):
                i = index[block + t]
                x, y, z = xyz[i, 0], xyz[i, 1], xyz[i, 2]
                depth = x - lx
                safe = depth if depth > 1e-9 else 1e-9
                x, y = seen_at_row(rm, row_clamped(cy - focal * (z - lz) / safe, rows), x, y)
                depth = x - lx
                proj[0, t] = depth
                proj[1, t] = cx - focal * (y - ly) / depth
                proj[2, t] = cx_right - focal * (y - ry) / depth
                proj[3, t] = cy - focal * (z - lz) / depth
        elif rolling:
            for t in range(m):
                i = index[block + t]
                x, y, z = xyz[i, 0], xyz[i, 1], xyz[i, 2]
                x, y = seen_at_row(rm, row_clamped(project(k, x, y, z)[2], rows), x, y)
                a, b, depth, ar = optical(k, x, y, z)
                proj[0, t] = depth
                proj[1, t] = cx + focal * a / depth
                proj[2, t] = cx_right + focal * ar / depth
                proj[3, t] = cy + focal * b / depth
        elif level:
            for t in range(m):  # no branch: vectorised, four flies a division
                i = index[block + t]
                depth = xyz[i, 0] - lx
                proj[0, t] = depth
                proj[1, t] = cx - focal * (xyz[i, 1] - ly) / depth
                proj[2, t] = cx_right - focal * (xyz[i, 1] - ry) / depth
                proj[3, t] = cy - focal * (xyz[i, 2] - lz) / depth
        else:
            for t in range(m):
                i = index[block + t]
                a, b, depth, ar = optical(k, xyz[i, 0], xyz[i, 1], xyz[i, 2])
                proj[0, t] = depth
                proj[1, t] = cx + focal * a / depth
                proj[2, t] = cx_right + focal * ar / depth
                proj[3, t] = cy + focal * b / depth
        for t in range(m):
            ul = math.floor(proj[1, t] + 0.5)
            ur = math.floor(proj[2, t] + 0.5)
            vv = math.floor(proj[3, t] + 0.5)
            last = ur  # the right window's last column is last + h
            if subpixel:
                ur, frac[t] = subpixel_column(proj[1, t], proj[2, t])
                last = ur + 1
            inside = h <= vv <= height - 1 - h and h <= ul <= width - 1 - h
            if not (proj[0, t] > 0.0 and inside and h <= ur and last <= width - 1 - h):
                first_l[t] = -1
                continue
            row, cl, cr = int(vv), int(ul), int(ur)
            bl = (row - h) * stride + (cl - h) * channels
            br = (row - h) * stride + (cr - h) * channels
            first_l[t] = bl
            first_r[t] = br
        for t in range(min(_AHEAD, m)):
            _prefetch_window(lflat, rflat, first_l[t], first_r[t], stride, window, lanes, across)
        for t in range(m):
            if t + _AHEAD < m:
                ahead = t + _AHEAD
                _prefetch_window(
                    lflat, rflat, first_l[ahead], first_r[ahead], stride, window, lanes, across
                )
            bl = first_l[t]
            br = first_r[t]
            if bl < 0:
                continue
            q = frac[t]
            if vector and max(bl, br + across) + reach <= size:
                # the right rows interpolated as they are loaded when sub-pixel
                terms = vector_sums(
                    measure,
                    lflat,
                    rflat,
                    bl,
                    br,
                    stride,
                    window,
                    masks,
                    lanes == LANES,
                    subpixel,
                    q,
                    across,
                )
                for j in range(count):
                    sums[j, t] = terms[j]
                grads[t] = terms[count]
                continue
            src_l, src_r, step = lflat, rflat, stride
            if subpixel:  # the lane loop: both windows copied, the right one interpolated
                windows_into(lflat, rflat, bl, br, stride, window, channels, q, lbuf, rbuf, bs)
                src_l, src_r, step, bl, br = lbuf, rbuf, bs, 0, 0
            terms = lane_sums(measure, src_l, src_r, bl, br, step, window, channels, scratch)
            for j in range(count):
                sums[j, t] = terms[j]
            centre = bl + h * step + h * channels
            grads[t] = sobel_norm2(src_l, centre, step, channels, im.gy_weight)
        for t in range(m):  # no branch: vectorised (an invalid fly's terms are stale)
            unlike = dissimilarity(measure, sums[:, t], n, channels)
            fitness[t] = math.sqrt(math.sqrt(float(grads[t]))) / (unlike + denominator_guard)
        for t in range(m):
            out[index[block + t]] = fitness[t] if first_l[t] >= 0 else INVALID_FITNESS


# The parallel kernel splits the flies into this many chunks. No reduction crosses flies, so
# results do not depend on the split or the thread count.
_CHUNKS = 64
# Below this many evaluations one thread is faster: a parallel region costs more than the
# work, and much more when other processes compete for the cores.
PARALLEL_MIN_EVALUATIONS = 20_000


@numba.njit(cache=True, nogil=True, parallel=True)
def _fitness_parallel(im, measure, xyz, index, out):  # pragma: no cover - compiled
    m = index.shape[0]
    masks = lane_masks(im.window, im.channels, im.gy_weight)
    for chunk in numba.prange(_CHUNKS):
        start, stop = chunk * m // _CHUNKS, (chunk + 1) * m // _CHUNKS
        _fitness_range(im, measure, xyz, index, start, stop, masks, out)


@numba.njit(cache=True, nogil=True)
def fitness_serial(im, measure, xyz, index, out):  # pragma: no cover - compiled
    """The fitness of the flies ``index`` of ``xyz`` on the pair ``im`` (:class:`Images`) by
    ``measure``, into ``out``, on one thread: for kernels that score flies as part of a
    larger compiled call."""
    masks = lane_masks(im.window, im.channels, im.gy_weight)
    _fitness_range(im, measure, xyz, index, 0, index.shape[0], masks, out)


def images_of(
    left: np.ndarray,
    right: np.ndarray,
    rig: StereoRig,
    window: int,
    guard: float,
    *,
    gradient: Gradient = Gradient.NORM,
    subpixel: bool = False,
    stamp_ns: int = -1,
    readout: Pose2D = STILL,
) -> Images:
    """The pair as the kernels take it: (H, W·C) uint8 rows of (H, W) or (H, W, C) images;
    ``readout``: the robot's motion over the images' readout (:mod:`flylog.geometry.rolling`)."""
    left, right = as_planes(left), as_planes(right)
    height, width, channels = left.shape
    return Images(
        lrows=left.reshape(height, width * channels),
        rrows=right.reshape(height, width * channels),
        channels=channels,
        k=rig_constants(rig),
        window=window,
        guard=float(guard),
        gy_weight=gy_weight(gradient),
        subpixel=bool(subpixel),
        stamp=stamp_ns,
        row_motion=row_motion(readout, height),
        rolling=not is_still(readout),
    )


def fitness_into(
    im: Images,
    measure: Measure,
    xyz: np.ndarray,
    index: np.ndarray,
    out: np.ndarray,
    parallel_min: int = PARALLEL_MIN_EVALUATIONS,
) -> None:
    """:func:`fitness_numba` without the argument conversions, for a caller (the engine) that
    keeps them: C-contiguous float64 ``xyz``, int64 ``index``; in parallel over flies when
    there are at least ``parallel_min``."""
    kernel = _fitness_parallel if len(index) >= parallel_min else fitness_serial
    kernel(im, measure, xyz, index, out)


def fitness_numba(
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
    index: np.ndarray | None = None,
    out: np.ndarray | None = None,
    parallel_min: int = PARALLEL_MIN_EVALUATIONS,
) -> np.ndarray:
    """The fitness of the flies ``index`` of ``xyz`` (all if None), written into ``out``;
    each fly projected at its row's time under the rolling shutter's ``readout``.

    Runs in parallel over flies when there are at least ``parallel_min`` to evaluate.
    """
    xyz = np.ascontiguousarray(xyz, dtype=np.float64)
    if out is None:
        out = np.full(len(xyz), INVALID_FITNESS)
    if index is None:
        index = np.arange(len(xyz), dtype=np.int64)
    im = images_of(
        left, right, rig, window, guard, gradient=gradient, subpixel=subpixel, readout=readout
    )
    index = np.asarray(index, dtype=np.int64)
    fitness_into(im, measure_of(similarity), xyz, index, out, parallel_min)
    return out
