"""The fitness kernel of the level-only rig (cameras at (mount_x, ±B/2, mount_height), axes
along base_link x, principal point shared), kept as the benchmark's reference: the kernel
that projects through a real camera's rig (:mod:`flylog.fly.fitness`) must be as fast.
Constants: (focal, cx, cy, b/2, mount x, mount height)."""

from __future__ import annotations

import math

import numba
import numpy as np

from flylog.fly.fitness import INVALID_FITNESS, _prefetch_window
from flylog.fly.fitness_terms import sobel_norm2 as _sobel_norm2
from flylog.fly.fitness_vector import HALF, LANES, MAX_CHANNELS, lane_masks
from flylog.fly.measures import DIFFERENCE, zssd_lanes
from flylog.geometry import StereoRig

assert DIFFERENCE.vector is not None
window_terms_16 = DIFFERENCE.vector.half
window_terms_32 = DIFFERENCE.vector.wide

# Flies go in blocks, in three passes: project all (and prefetch their window rows), then the
# integer window terms, then the float fitness. Each pass's iterations are independent, so the
# CPU overlaps one fly's long chain (divisions, loads, reductions, square roots) with the
# next's; done fly by fly, that chain was most of the time.
_BLOCK = 64
# The window rows of the fly this many places ahead are prefetched: random flies' rows mostly
# miss L2, and a fly's wait then overlaps the work on the flies before it.
_AHEAD = 4


# error_model="numpy": no zero test per division (a fly behind the cameras divides by a depth
# ≤ 0 and is discarded), so the projection and the last pass are vectorised loops.
@numba.njit(cache=True, nogil=True, error_model="numpy")
def _fitness_range(
    lrow, rrow, channels, xyz, index, start, stop, k, window, guard, gy_weight, masks, out
):  # pragma: no cover - compiled
    """Fitness of flies index[start:stop]; ``masks`` from :func:`lane_masks` with the same
    ``gy_weight``."""
    height = lrow.shape[0]
    stride = lrow.shape[1]
    width = stride // channels
    size = lrow.size
    h = window // 2
    n = window * window
    ncols = window * channels
    denominator_guard = guard * n * channels
    lflat = lrow.reshape(size)
    rflat = rrow.reshape(size)
    lanes = HALF if ncols <= HALF else LANES
    vector = ncols <= LANES and channels <= MAX_CHANNELS
    reach = (window - 1) * stride + lanes  # bytes a vector window reads from its first
    # Per fly of the block: first offsets of its left and right windows (−1: invalid fly),
    # then n·Σ_c ZSSD_c and the Sobel norm².
    first_l = np.empty(_BLOCK, dtype=np.int64)
    first_r = np.empty(_BLOCK, dtype=np.int64)
    totals = np.empty(_BLOCK, dtype=np.int64)
    grads = np.empty(_BLOCK, dtype=np.int64)
    # the projections of the block's flies: depth, u left, u right, v
    proj = np.empty((4, _BLOCK))
    fitness = np.empty(_BLOCK)
    scratch = np.empty((2, ncols), dtype=np.int32)  # for the windows of the lane loop
    focal, cx, cy, half_b, mount_x, mount_h = k[0], k[1], k[2], k[3], k[4], k[5]
    for block in range(start, stop, _BLOCK):
        m = min(_BLOCK, stop - block)
        for t in range(m):  # no branch: vectorised, four flies a division
            i = index[block + t]
            depth = xyz[i, 0] - mount_x
            proj[0, t] = depth
            proj[1, t] = cx - focal * (xyz[i, 1] - half_b) / depth
            proj[2, t] = cx - focal * (xyz[i, 1] + half_b) / depth
            proj[3, t] = cy - focal * (xyz[i, 2] - mount_h) / depth
        for t in range(m):
            ul = math.floor(proj[1, t] + 0.5)
            ur = math.floor(proj[2, t] + 0.5)
            vv = math.floor(proj[3, t] + 0.5)
            inside = h <= vv <= height - 1 - h and h <= ul <= width - 1 - h
            if not (proj[0, t] > 0.0 and inside and h <= ur <= width - 1 - h):
                first_l[t] = -1
                continue
            row, cl, cr = int(vv), int(ul), int(ur)
            bl = (row - h) * stride + (cl - h) * channels
            br = (row - h) * stride + (cr - h) * channels
            first_l[t] = bl
            first_r[t] = br
        for t in range(min(_AHEAD, m)):
            _prefetch_window(lflat, rflat, first_l[t], first_r[t], stride, window, lanes, 0)
        for t in range(m):
            if t + _AHEAD < m:
                ahead = t + _AHEAD
                _prefetch_window(
                    lflat, rflat, first_l[ahead], first_r[ahead], stride, window, lanes, 0
                )
            bl = first_l[t]
            br = first_r[t]
            if bl < 0:
                continue
            if vector and max(bl, br) + reach <= size:
                if lanes == HALF:
                    sq, squares, grad2 = window_terms_16(
                        lflat, rflat, bl, br, stride, window, masks
                    )
                else:
                    sq, squares, grad2 = window_terms_32(
                        lflat, rflat, bl, br, stride, window, masks
                    )
                totals[t] = n * sq - squares
                grads[t] = grad2
            else:
                sq, squares = zssd_lanes(lflat, rflat, bl, br, stride, window, channels, scratch)
                totals[t] = n * sq - squares
                centre = bl + h * stride + h * channels
                grads[t] = _sobel_norm2(lflat, centre, stride, channels, gy_weight)
        for t in range(m):  # no branch: vectorised (an invalid fly's terms are stale)
            zssd = totals[t] / n
            fitness[t] = math.sqrt(math.sqrt(float(grads[t]))) / (zssd + denominator_guard)
        for t in range(m):
            out[index[block + t]] = fitness[t] if first_l[t] >= 0 else INVALID_FITNESS


# The parallel kernel splits the flies into this many chunks. No reduction crosses flies, so
# results do not depend on the split or the thread count.
_CHUNKS = 64


@numba.njit(cache=True, nogil=True, parallel=True)
def _fitness_parallel(
    lrow, rrow, channels, xyz, index, k, window, guard, gy_weight, out
):  # pragma: no cover - compiled
    m = index.shape[0]
    masks = lane_masks(window, channels, gy_weight)
    for chunk in numba.prange(_CHUNKS):
        _fitness_range(
            lrow,
            rrow,
            channels,
            xyz,
            index,
            chunk * m // _CHUNKS,
            (chunk + 1) * m // _CHUNKS,
            k,
            window,
            guard,
            gy_weight,
            masks,
            out,
        )


@numba.njit(cache=True, nogil=True)
def _fitness_serial(
    lrow, rrow, channels, xyz, index, k, window, guard, gy_weight, out
):  # pragma: no cover - compiled
    masks = lane_masks(window, channels, gy_weight)
    _fitness_range(
        lrow,
        rrow,
        channels,
        xyz,
        index,
        0,
        index.shape[0],
        k,
        window,
        guard,
        gy_weight,
        masks,
        out,
    )


def level_constants(rig: StereoRig) -> np.ndarray:
    """The level kernel's constants of a level rig."""
    return np.array(
        [rig.focal_px, rig.cx, rig.cy, rig.baseline / 2.0, rig.mount_x, rig.mount_height]
    )


def level_fitness(left_rows, right_rows, channels, xyz, index, k, out, *, parallel):
    """7×7 fitness (guard 1, the paper's Sobel norm) of the flies ``index`` into ``out``."""
    kernel = _fitness_parallel if parallel else _fitness_serial
    kernel(left_rows, right_rows, channels, xyz, index, k, 7, 1.0, 1, out)
