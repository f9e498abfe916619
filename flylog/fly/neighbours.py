"""2-D sharing's neighbour counts: for each fly, how many others project within R of it in
the left image (paper §2.1.2), every generation, so they are counted in a compiled grid; the
O(N²) numpy reference is what tests compare the kernels to."""

from __future__ import annotations

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from flylog.fly.fitness import INVALID_FITNESS
from flylog.geometry.kernels import project


def neighbour_counts_numpy(
    u: np.ndarray, v: np.ndarray, valid: np.ndarray, radius: float
) -> np.ndarray:
    """Reference: for each valid fly, how many other valid flies project within ``radius``
    px of it in the left image (O(N²); invalid flies count 0)."""
    du = u[:, None] - u[None, :]
    dv = v[:, None] - v[None, :]
    near = (du * du + dv * dv <= radius * radius) & valid[:, None] & valid[None, :]
    np.fill_diagonal(near, False)
    return near.sum(axis=1).astype(np.int64)


# The grid never has more cells than this many per valid fly, plus a few (its cells grow
# instead), so its buffer is O(N) whatever the spread of the points.
_CELLS_PER_FLY = 8
_MIN_CELLS = 16


@numba.njit(cache=True, nogil=True, inline="always")
def _padded(n):  # pragma: no cover - compiled
    """``n`` rounded up to a multiple of 4: the cells :func:`_running_sum` walks."""
    return (n + 3) // 4 * 4


def grid_buffer_size(n: int) -> int:
    """Length of the integer scratch ``grid`` the counting kernels need for ``n`` flies."""
    return int(_padded(_CELLS_PER_FLY * n + _MIN_CELLS + 1))


# Scratch rows past the last fly: the 4-lane tests read up to 8 flies past a run's start.
_PAD = 8
_LANES = 4
_F64x4 = ir.VectorType(ir.DoubleType(), _LANES)
_I32x4 = ir.VectorType(ir.IntType(32), _LANES)
_I64x4 = ir.VectorType(ir.IntType(64), _LANES)


def _splat(builder: ir.IRBuilder, value: ir.Value, vector: ir.VectorType) -> ir.Value:
    undef = ir.Constant(vector, ir.Undefined)
    first = builder.insert_element(undef, value, ir.Constant(ir.IntType(32), 0))
    return builder.shuffle_vector(first, undef, ir.Constant(_I32x4, [0] * _LANES))


@intrinsic
def _near_lanes(typingctx, su, sv, start, ua, va, r2, count):
    """A 4-bit mask: bit j set when j < ``count`` and (ua − su[start + j])² + (va −
    sv[start + j])² <= r2, the scalar test's operations in its order on one 4-lane vector
    (the same IEEE results). Reads su and sv at start … start + 3 whatever ``count``."""
    if su.dtype != types.float64 or sv.dtype != types.float64:
        return None  # a typing error: the lanes are read as float64

    def codegen(context, builder, signature, args):
        su_, sv_, start_, ua_, va_, r2_, count_ = args

        def lanes(array, array_type):
            data = context.make_array(array_type)(context, builder, array).data
            ptr = builder.bitcast(builder.gep(data, [start_]), _F64x4.as_pointer())
            return builder.load(ptr, align=8)

        du = builder.fsub(_splat(builder, ua_, _F64x4), lanes(su_, signature.args[0]))
        dv = builder.fsub(_splat(builder, va_, _F64x4), lanes(sv_, signature.args[1]))
        d2 = builder.fadd(builder.fmul(du, du), builder.fmul(dv, dv))
        near = builder.fcmp_ordered("<=", d2, _splat(builder, r2_, _F64x4))
        index = ir.Constant(_I64x4, list(range(_LANES)))
        count64 = builder.sext(count_, ir.IntType(64)) if count_.type.width < 64 else count_
        inside = builder.icmp_signed("<", index, _splat(builder, count64, _I64x4))
        bits = builder.bitcast(builder.and_(near, inside), ir.IntType(_LANES))
        return builder.zext(bits, ir.IntType(64))

    return types.int64(su, sv, start, ua, va, r2, count), codegen


@intrinsic
def _add_lanes(typingctx, near, start, mask):
    """near[start + j] += bit j of ``mask`` for j < 4, as one vector load, add and store of
    int32 lanes; returns the number of bits set."""
    if near.dtype != types.int32:
        return None

    def codegen(context, builder, signature, args):
        near_, start_, mask_ = args
        data = context.make_array(signature.args[0])(context, builder, near_).data
        ptr = builder.bitcast(builder.gep(data, [start_]), _I32x4.as_pointer())
        shifted = builder.lshr(
            _splat(builder, builder.trunc(mask_, ir.IntType(32)), _I32x4),
            ir.Constant(_I32x4, list(range(_LANES))),
        )
        bits = builder.and_(shifted, ir.Constant(_I32x4, [1] * _LANES))
        builder.store(builder.add(builder.load(ptr, align=4), bits), ptr, align=4)
        fnty = ir.FunctionType(ir.IntType(64), [ir.IntType(64)])
        popcount = cgutils.get_or_insert_function(builder.module, fnty, "llvm.ctpop.i64")
        return builder.call(popcount, [mask_])

    return types.int64(near, start, mask), codegen


@numba.njit(cache=True, nogil=True, inline="always")
def _running_sum(cells, n):  # pragma: no cover - compiled
    """``cells[:n]`` replaced by its running sum (``cells`` holds ``_padded(n)`` values, those
    past ``n`` zero), as four interleaved quarters, each from its own start: four independent
    chains of additions instead of one: 0.95× the counts' thread CPU time at 5000 flies and
    R = 3.4 px, where the grid has ~27 000 cells, 5.4 a fly."""
    quarter = _padded(n) // 4
    start1 = 0
    for q in range(quarter):
        start1 += cells[q]
    start2 = start1
    for q in range(quarter, 2 * quarter):
        start2 += cells[q]
    start3 = start2
    for q in range(2 * quarter, 3 * quarter):
        start3 += cells[q]
    c0, c1, c2, c3 = 0, start1, start2, start3
    for q in range(quarter):
        c0 += cells[q]
        cells[q] = c0
        c1 += cells[q + quarter]
        cells[q + quarter] = c1
        c2 += cells[q + 2 * quarter]
        cells[q + 2 * quarter] = c2
        c3 += cells[q + 3 * quarter]
        cells[q + 3 * quarter] = c3


@numba.njit(cache=True, nogil=True)
def _grid_counts(pu, pv, pidx, m, radius, grid, ints, su, sv, counts):  # pragma: no cover
    """Adds to ``counts[pidx[t]]`` the neighbours of the ``m`` valid flies at (pu[t], pv[t]).

    The flies are sorted by the cell of a grid whose cells are at least R wide (a stable
    counting sort, rows then columns), with an empty column of padding on the left, two on the
    right and an empty row below. Two flies within R are then in the same or adjacent cells,
    and the flies a fly still has to test (each pair once) are two contiguous runs of the
    sorted flies: the rest of its cell and the next cell of its row, then the three cells
    below. Their bounds are cell starts: no search. Each run is tested 4 flies at a time in
    vector lanes, masked to the run (the first 4 of the first run, the first 8 of the second,
    then a loop for the rest): a loop over each run's length exits at a different count for
    every fly, which the branch predictor misses on fresh flies every generation: with such
    loops the pair tests take 72 of the counts' ~120 µs at 5000 flies, with the lanes the
    counts take 0.64× that (docs/engine.md). ``ints`` is (4, ≥ m + 8) int32 scratch, ``su``
    and ``sv`` (≥ m + 8) float64."""
    cell, order, near, sorted_cell = ints[0], ints[1], ints[2], ints[3]
    umin, vmin, umax, vmax = np.inf, np.inf, -np.inf, -np.inf
    for t in range(m):
        umin, umax = min(umin, pu[t]), max(umax, pu[t])
        vmin, vmax = min(vmin, pv[t]), max(vmax, pv[t])
    w, h = umax - umin, vmax - vmin
    limit = _CELLS_PER_FLY * m + _MIN_CELLS
    # A hair above R: two points R apart can never land two cells apart through rounding.
    side = max(radius * (1.0 + 1e-6), 1e-300)
    while True:
        inv = 1.0 / side
        if w * inv < limit and h * inv < limit:
            n_cols, n_rows = int(w * inv) + 1, int(h * inv) + 1
            if (n_cols + 3) * (n_rows + 1) <= limit:
                break
        side *= 2.0
    stride = n_cols + 3
    n_cells = stride * (n_rows + 1)
    starts = grid[: n_cells + 1]
    grid[: _padded(n_cells + 1)] = 0
    for t in range(m):
        q = int((pv[t] - vmin) * inv) * stride + int((pu[t] - umin) * inv) + 1
        cell[t] = q
        starts[q] += 1
    _running_sum(grid, n_cells + 1)  # the end of cell q, for now
    for t in range(m - 1, -1, -1):  # backwards, so stable; each end becomes its cell's start
        q = cell[t]
        at = starts[q] - 1
        starts[q] = at
        order[at] = pidx[t]
        su[at] = pu[t]
        sv[at] = pv[t]
        sorted_cell[at] = q
    for s in range(m, m + _PAD):  # past the last fly: never within R, never counted
        su[s] = np.inf
        sv[s] = np.inf
    near[: m + _PAD] = 0
    r2 = radius * radius
    for s in range(m):
        q = sorted_cell[s]
        ua, va = su[s], sv[s]
        # flies a … (end of the next cell), then lo … hi
        a = s + 1
        same = starts[q + 2] - a
        lo, hi = starts[q + stride - 1], starts[q + stride + 2]
        below = hi - lo
        found = _add_lanes(near, a, _near_lanes(su, sv, a, ua, va, r2, same))
        found += _add_lanes(near, lo, _near_lanes(su, sv, lo, ua, va, r2, below))
        found += _add_lanes(near, lo + 4, _near_lanes(su, sv, lo + 4, ua, va, r2, below - 4))
        for t in range(a + 4, a + same):  # crowded cells only
            du = ua - su[t]
            dv = va - sv[t]
            hit = du * du + dv * dv <= r2
            found += hit
            near[t] += hit
        for t in range(lo + 8, hi):
            du = ua - su[t]
            dv = va - sv[t]
            hit = du * du + dv * dv <= r2
            found += hit
            near[t] += hit
        near[s] += found
    for s in range(m):
        counts[order[s]] += near[s]


@numba.njit(cache=True, nogil=True)
def neighbour_counts_into(u, v, valid, radius, grid, ints, floats, counts):  # pragma: no cover
    """Same counts as :func:`neighbour_counts_numpy`, written into ``counts``, by a grid of
    R-cells (:func:`_grid_counts`). ``grid`` is integer scratch of :func:`grid_buffer_size`,
    ``ints`` (5, ≥ N + 8) int32 and ``floats`` (4, ≥ N + 8) float64 scratch
    (:meth:`NeighbourCounter.scratch`)."""
    m = 0
    pu, pv = floats[0], floats[1]
    for i in range(u.shape[0]):
        counts[i] = 0
        if valid[i]:
            pu[m] = u[i]
            pv[m] = v[i]
            ints[0, m] = i
            m += 1
    if m > 0:
        _grid_counts(pu, pv, ints[0], m, radius, grid, ints[1:], floats[2], floats[3], counts)


@numba.njit(cache=True, nogil=True)
def fly_neighbour_counts_into(
    xyz, k, fitness, radius, grid, ints, floats, counts
):  # pragma: no cover
    """The same counts for the flies themselves: valid = fitness > INVALID_FITNESS, (u, v)
    their left projections (``StereoRig.project``'s numbers, ``k`` from
    :func:`~flylog.fly.fitness.rig_constants`); scratch as for :func:`neighbour_counts_into`."""
    m = 0
    pu, pv = floats[0], floats[1]
    for i in range(xyz.shape[0]):
        counts[i] = 0
        if fitness[i] > INVALID_FITNESS:
            u, _, v, _ = project(k, xyz[i, 0], xyz[i, 1], xyz[i, 2])
            pu[m] = u
            pv[m] = v
            ints[0, m] = i
            m += 1
    if m > 0:
        _grid_counts(pu, pv, ints[0], m, radius, grid, ints[1:], floats[2], floats[3], counts)


# The counter's integer scratch: int32 halves the grid and index arrays a generation walks
# (~10 µs of ~110 at 5000 flies), and the lanes' counts are int32; indices and cells stay
# below 2³¹ up to 250 M flies.
_SCRATCH = np.int32


class NeighbourCounter:
    """The counting kernels with their scratch kept between calls (the engine counts every
    generation)."""

    def __init__(self) -> None:
        self._n = -1
        self.grid = np.empty(0, dtype=_SCRATCH)
        self.ints = np.empty((5, _PAD), dtype=_SCRATCH)
        self.floats = np.empty((4, _PAD))
        self.counts = np.empty(0, dtype=np.int64)  # for kernels that leave their counts here

    def scratch(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(grid, ints, floats) for ``n`` flies (and ``counts``), reallocated only when ``n``
        changes."""
        if n != self._n:
            self._n = n
            self.grid = np.empty(grid_buffer_size(n), dtype=_SCRATCH)
            self.ints = np.empty((5, n + _PAD), dtype=_SCRATCH)
            self.floats = np.empty((4, n + _PAD))
            self.counts = np.empty(n, dtype=np.int64)
        return self.grid, self.ints, self.floats

    def __call__(
        self, u: np.ndarray, v: np.ndarray, valid: np.ndarray, radius: float
    ) -> np.ndarray:
        """(N,) int64 neighbour counts (a new array)."""
        counts = np.empty(len(u), dtype=np.int64)
        neighbour_counts_into(u, v, valid, float(radius), *self.scratch(len(u)), counts)
        return counts
