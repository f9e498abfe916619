"""The measures' window sums and the Sobel (:mod:`flylog.fly.measures`,
:mod:`flylog.fly.fitness`), on LLVM vectors written out by hand: numba widens int16 and int32
arithmetic to int64, which keeps a plain lane loop 4 lanes wide with its accumulators in
memory. Each window row is read as 16 or 32 bytes, widened to int16 lanes, one lane per
(column, channel) byte; d = L − R is masked to the window's lanes;
Σd is kept per lane in int16 (|Σd| ≤ 32·255) and Σd² in int32 lane pairs (vpmaddwd), in
registers across rows. The sums by channel and the Sobel's gx, gy by channel are dot products of
lane vectors with 0/±1/2 masks; their 16 pair-sum vectors are then reduced together by a
transposing add tree. Sub-pixel sampling interpolates each right row as it is loaded, from
two unaligned loads one pixel apart (:class:`_Window`), with no copy of the window. A window
that needs more than 32 lanes (wider than 10 pixels in colour), more than MAX_CHANNELS
channels, or whose reads would run past the end of the image takes the measure's lane loop
and the scalar Sobel (:mod:`flylog.fly.fitness_terms`) instead; both paths give the same
integers. A measure's sums take their four intrinsics from :func:`vector_variants`.
"""

from __future__ import annotations

import numba
import numpy as np
from llvmlite import binding as llvm
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from flylog.fly.fitness_terms import FRACTION_BITS
from flylog.fly.measure import VectorSums

HALF = 16  # int16 lanes per 256-bit vector
LANES = 2 * HALF
MAX_CHANNELS = 4
# Mask rows: the window's lanes (−1), then per channel: its lanes (1), gx (±1), gy (1, 2, 1).
_MASK_LANES, _MASK_SUM, _MASK_GX, _MASK_GY = 0, 1, 1 + MAX_CHANNELS, 1 + 2 * MAX_CHANNELS
_MASK_ROWS = 1 + 3 * MAX_CHANNELS
_I8, _I16, _I32, _I64 = ir.IntType(8), ir.IntType(16), ir.IntType(32), ir.IntType(64)
_BYTES = ir.VectorType(_I8, HALF)
_WORDS = ir.VectorType(_I16, HALF)
_PAIRS = ir.VectorType(_I32, HALF // 2)


def pair_sums_x86(builder: ir.IRBuilder, a: ir.Value, b: ir.Value) -> ir.Value:
    """a[2k]·b[2k] + a[2k+1]·b[2k+1] in int32: one AVX2 vpmaddwd."""
    fnty = ir.FunctionType(_PAIRS, [_WORDS, _WORDS])
    fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.x86.avx2.pmadd.wd")
    return builder.call(fn, [a, b])


def pair_sums_generic(builder: ir.IRBuilder, a: ir.Value, b: ir.Value) -> ir.Value:
    """The same sums for any target (the x86 backend does not always fold it to vpmaddwd)."""
    total = None
    for first in (0, 1):
        lanes = ir.Constant(_PAIRS, [2 * k + first for k in range(HALF // 2)])
        x = builder.sext(builder.shuffle_vector(a, a, lanes), _PAIRS)
        y = builder.sext(builder.shuffle_vector(b, b, lanes), _PAIRS)
        product = builder.mul(x, y)
        total = product if total is None else builder.add(total, product)
    return total


def rounded_high_x86(builder: ir.IRBuilder, a: ir.Value, b: ir.Value) -> ir.Value:
    """(a·b + 2¹⁴) >> 15 per int16 lane: one AVX2 vpmulhrsw."""
    fnty = ir.FunctionType(_WORDS, [_WORDS, _WORDS])
    fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.x86.avx2.pmul.hr.sw")
    return builder.call(fn, [a, b])


def rounded_high_generic(builder: ir.IRBuilder, a: ir.Value, b: ir.Value) -> ir.Value:
    """The same for any target."""
    wide = ir.VectorType(_I32, HALF)
    product = builder.mul(builder.sext(a, wide), builder.sext(b, wide))
    rounded = builder.add(product, ir.Constant(wide, [1 << 14] * HALF))
    return builder.trunc(builder.ashr(rounded, ir.Constant(wide, [15] * HALF)), _WORDS)


def _shuffle_add(builder: ir.IRBuilder, a: ir.Value, b: ir.Value, first, second) -> ir.Value:
    def pick(lanes):
        return builder.shuffle_vector(a, b, ir.Constant(_PAIRS, list(lanes)))

    return builder.add(pick(first), pick(second))


def _sums_of_eight(builder: ir.IRBuilder, v: list) -> ir.Value:
    """Eight <8 x i32> → one whose lanes are their sums, in the order v0 v2 v1 v3 v4 v6 v5 v7."""
    low, high = (0, 1, 2, 3, 8, 9, 10, 11), (4, 5, 6, 7, 12, 13, 14, 15)
    halves = [_shuffle_add(builder, v[k], v[k + 1], low, high) for k in range(0, 8, 2)]
    low, high = (0, 1, 8, 9, 4, 5, 12, 13), (2, 3, 10, 11, 6, 7, 14, 15)
    quarters = [_shuffle_add(builder, halves[k], halves[k + 1], low, high) for k in (0, 2)]
    even, odd = tuple(range(0, 16, 2)), tuple(range(1, 16, 2))
    return _shuffle_add(builder, quarters[0], quarters[1], even, odd)


def _reduce(builder: ir.IRBuilder, v: ir.Value, name: str, width: int) -> ir.Value:
    fnty = ir.FunctionType(v.type.element, [v.type])
    fn = cgutils.get_or_insert_function(builder.module, fnty, f"llvm.vector.reduce.add.{name}")
    total = builder.call(fn, [v])
    return total if width == 64 else builder.sext(total, _I64)


@intrinsic
def prefetch(typingctx, array, offset):
    """Ask the CPU to start loading the cache line holding byte ``offset`` of a C-contiguous
    array (a hint only: results do not depend on it)."""
    if not (isinstance(array, types.Array) and array.layout == "C"):
        return None

    def codegen(context, builder, signature, args):
        data = context.make_array(signature.args[0])(context, builder, args[0]).data
        ptr = builder.bitcast(builder.gep(data, [args[1]]), _I8.as_pointer())
        fnty = ir.FunctionType(ir.VoidType(), [_I8.as_pointer(), _I32, _I32, _I32])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.prefetch.p0")
        read, keep, data_cache = ir.Constant(_I32, 0), ir.Constant(_I32, 3), ir.Constant(_I32, 1)
        builder.call(fn, [ptr, read, keep, data_cache])
        return context.get_dummy_value()

    return types.none(array, offset), codegen


class _Window:
    """The code generator's view of one window pair: the images' and masks' pointers, the
    offsets and stride, and each window row's lanes as int16 vectors. With sub-pixel weights
    (q, across: the weight of the next column in 1/FRACTION, and its distance in bytes) the
    right row is interpolated as it is loaded, ((FRACTION − q)·a + q·b + FRACTION/2) >>
    FRACTION_BITS per lane, computed as a + (((b − a)·q·2⁷ + 2¹⁴) >> 15), one rounded high
    product (vpmulhrsw): the same integer, since 2⁷·q ≤ 32640 fits int16."""

    def __init__(self, context, builder, signature, args, subpixel: bool, pair_sums):
        self.builder = builder
        self.rounded_high = rounded_high_x86 if pair_sums is pair_sums_x86 else rounded_high_generic
        t, a = signature.args, args
        self.lptr = context.make_array(t[0])(context, builder, a[0]).data
        self.rptr = context.make_array(t[1])(context, builder, a[1]).data
        self.bl, self.br, self.stride, self.rows = a[2], a[3], a[4], a[5]
        self.mptr = builder.bitcast(
            context.make_array(t[6])(context, builder, a[6]).data, _WORDS.as_pointer()
        )
        self.weight = None
        if subpixel:
            q = builder.trunc(context.cast(builder, a[7], t[7], types.int64), _I16)
            self.across = context.cast(builder, a[8], t[8], types.int64)
            self.weight = self._splat(builder.shl(q, ir.Constant(_I16, 15 - FRACTION_BITS)))

    def _constant(self, value: int) -> ir.Constant:
        return ir.Constant(_WORDS, [value] * HALF)

    def _splat(self, value: ir.Value) -> ir.Value:
        b = self.builder
        one = b.insert_element(ir.Constant(_WORDS, ir.Undefined), value, ir.Constant(_I32, 0))
        return b.shuffle_vector(one, one, ir.Constant(ir.VectorType(_I32, HALF), [0] * HALF))

    def mask(self, row: int, half: int) -> ir.Value:
        ptr = self.builder.gep(self.mptr, [ir.Constant(_I64, 2 * row + half)])
        return self.builder.load(ptr, align=2)

    def words(self, data, offset, half: int) -> ir.Value:
        at = self.builder.add(offset, ir.Constant(_I64, half * HALF))
        ptr = self.builder.bitcast(self.builder.gep(data, [at]), _BYTES.as_pointer())
        return self.builder.zext(self.builder.load(ptr, align=1), _WORDS)

    def right_words(self, offset, half: int) -> ir.Value:
        a = self.words(self.rptr, offset, half)
        if self.weight is None:
            return a
        b = self.builder
        nxt = self.words(self.rptr, b.add(offset, self.across), half)
        return b.add(a, self.rounded_high(b, b.sub(nxt, a), self.weight))

    def rows_loop(self, body) -> None:
        """body(left offset, right offset) for each window row."""
        b = self.builder
        offsets = cgutils.alloca_once_value(b, self.bl), cgutils.alloca_once_value(b, self.br)
        with cgutils.for_range(b, self.rows):
            lo, ro = b.load(offsets[0]), b.load(offsets[1])
            body(lo, ro)
            b.store(b.add(lo, self.stride), offsets[0])
            b.store(b.add(ro, self.stride), offsets[1])

    def sobel(self, halves: int) -> tuple[list, list]:
        """The three left rows around the centre, summed down the columns (1, 2, 1) for gx
        and differenced (below − above) for gy."""
        b = self.builder
        centre = b.add(self.bl, b.mul(b.lshr(self.rows, ir.Constant(_I64, 1)), self.stride))
        above, below = b.sub(centre, self.stride), b.add(centre, self.stride)
        smooth, slope = [], []
        for h in range(halves):
            a, m, c = (self.words(self.lptr, at, h) for at in (above, centre, below))
            smooth.append(b.add(b.add(a, c), b.shl(m, self._constant(1))))
            slope.append(b.sub(c, a))
        return smooth, slope

    def dot(self, pair_sums, lanes: list, row: int) -> ir.Value:
        total = pair_sums(self.builder, lanes[0], self.mask(row, 0))
        for h in range(1, len(lanes)):
            total = self.builder.add(total, pair_sums(self.builder, lanes[h], self.mask(row, h)))
        return total


def _intrinsic(codegen, outputs: int, subpixel: bool):
    """An intrinsic (left, right, bl, br, stride, rows, masks[, q, across]) → ``outputs``
    int64s, on C-contiguous uint8 images: the sub-pixel form takes q and across."""

    def signature(left, right, masks, args):
        byte_arrays = all(
            isinstance(a, types.Array) and a.dtype == types.uint8 and a.layout == "C"
            for a in (left, right)
        )
        if not (byte_arrays and isinstance(masks, types.Array) and masks.layout == "C"):
            return None
        return types.UniTuple(types.int64, outputs)(*args), codegen

    if subpixel:

        @intrinsic
        def interpolated(typingctx, left, right, bl, br, stride, rows, masks, q, across):
            args = (left, right, bl, br, stride, rows, masks, q, across)
            return signature(left, right, masks, args)

        return interpolated

    @intrinsic
    def whole(typingctx, left, right, bl, br, stride, rows, masks):
        return signature(left, right, masks, (left, right, bl, br, stride, rows, masks))

    return whole


def window_terms_intrinsic(pair_sums, halves: int, subpixel: bool = False):
    """An intrinsic (left, right, bl, br, stride, rows, masks[, q, across]) → (Σd², Σ_c
    (Σd)_c², Sobel Σ_c gx² + gy²) over ``rows`` rows of ``halves``·16 bytes from flat offsets
    bl (left) and br (right), a row every ``stride`` bytes; the Sobel at the window's centre
    in the left image; ``masks`` (_MASK_ROWS, 2, 16) int16 from :func:`lane_masks`;
    ``subpixel``: the right rows interpolated (:class:`_Window`)."""

    def codegen(context, builder, signature, args):
        w = _Window(context, builder, signature, args, subpixel, pair_sums)
        lane_mask = [w.mask(_MASK_LANES, h) for h in range(halves)]
        s_acc = [cgutils.alloca_once_value(builder, ir.Constant(_WORDS, None)) for _ in lane_mask]
        q_acc = [cgutils.alloca_once_value(builder, ir.Constant(_PAIRS, None)) for _ in lane_mask]

        def row(lo, ro):
            for h in range(halves):
                left = w.words(w.lptr, lo, h)
                d = builder.and_(builder.sub(left, w.right_words(ro, h)), lane_mask[h])
                builder.store(builder.add(builder.load(s_acc[h]), d), s_acc[h])
                builder.store(
                    builder.add(builder.load(q_acc[h]), pair_sums(builder, d, d)), q_acc[h]
                )

        w.rows_loop(row)
        smooth, slope = w.sobel(halves)
        s = [builder.load(a) for a in s_acc]
        sums = [w.dot(pair_sums, s, _MASK_SUM + c) for c in range(MAX_CHANNELS)]
        gx = [w.dot(pair_sums, smooth, _MASK_GX + c) for c in range(MAX_CHANNELS)]
        gy = [w.dot(pair_sums, slope, _MASK_GY + c) for c in range(MAX_CHANNELS)]
        q = builder.load(q_acc[0])
        for a in q_acc[1:]:
            q = builder.add(q, builder.load(a))
        zero = ir.Constant(_PAIRS, None)
        first = _sums_of_eight(builder, sums + gx)  # lanes 0-3: Σd by channel, 4-7: gx
        second = _sums_of_eight(builder, [*gy, q, zero, zero, zero])  # 0-3: gy, lane 4: Σd²
        quad = ir.VectorType(_I32, 4)

        def lanes(v, start):
            return builder.shuffle_vector(v, v, ir.Constant(quad, list(range(start, start + 4))))

        by_channel = builder.sext(lanes(first, 0), ir.VectorType(_I64, 4))
        squares = _reduce(builder, builder.mul(by_channel, by_channel), "v4i64", 64)
        gx4, gy4 = lanes(first, 4), lanes(second, 0)
        grad2 = _reduce(
            builder, builder.add(builder.mul(gx4, gx4), builder.mul(gy4, gy4)), "v4i32", 32
        )
        sq = builder.sext(builder.extract_element(second, ir.Constant(_I32, 4)), _I64)
        return context.make_tuple(builder, signature.return_type, [sq, squares, grad2])

    return _intrinsic(codegen, 3, subpixel)


def target_has_avx2() -> bool:
    """AVX2 on the CPU numba compiles for (the host, unless NUMBA_CPU_NAME/FEATURES say else)."""
    if getattr(numba.config, "CPU_NAME", None) or getattr(numba.config, "CPU_FEATURES", None):
        return False
    return bool(llvm.get_host_cpu_features().get("avx2", False))


PAIR_SUMS = pair_sums_x86 if target_has_avx2() else pair_sums_generic


def vector_variants(factory) -> VectorSums:
    """The four intrinsics a measure's sums take from ``factory``
    (:func:`window_terms_intrinsic` or :func:`ncc_terms_intrinsic`): 16 and 32 lanes,
    whole-pixel and sub-pixel."""
    return VectorSums(
        half=factory(PAIR_SUMS, 1),
        wide=factory(PAIR_SUMS, 2),
        half_subpixel=factory(PAIR_SUMS, 1, subpixel=True),
        wide_subpixel=factory(PAIR_SUMS, 2, subpixel=True),
    )


@numba.njit(cache=True, nogil=True)
def lane_masks(window, channels, gy_weight=1):  # pragma: no cover - compiled
    """(_MASK_ROWS, 2, 16) int16 lane masks for a window and channel count (see _MASK_*); lane
    j is byte j of a window row: pixel j // channels, channel j % channels. ``gy_weight`` 0
    zeroes the gy masks, so the kernels' Sobel norm² is Σ_c gx² (the horizontal gradient)."""
    masks = np.zeros((_MASK_ROWS, 2, HALF), dtype=np.int16)
    if channels > MAX_CHANNELS or window * channels > LANES:
        return masks  # such windows take the lane loop
    for j in range(window * channels):
        masks[_MASK_LANES, j // HALF, j % HALF] = -1
        masks[_MASK_SUM + j % channels, j // HALF, j % HALF] = 1
    h = window // 2
    for c in range(channels):
        for pixel, gx, gy in ((h - 1, -1, 1), (h, 0, 2), (h + 1, 1, 1)):
            j = pixel * channels + c
            masks[_MASK_GX + c, j // HALF, j % HALF] = gx
            masks[_MASK_GY + c, j // HALF, j % HALF] = gy * gy_weight
    return masks


def ncc_terms_intrinsic(pair_sums, halves: int, subpixel: bool = False):
    """As :func:`window_terms_intrinsic`, for ZNCC: (left, right, bl, br, stride, rows,
    masks[, q, across]) → (n·Σlr − Σ_c Σl_c·Σr_c, n·Σl² − Σ_c (Σl_c)², n·Σr² − Σ_c (Σr_c)²,
    Sobel norm²) with n = rows² (:func:`flylog.fly.measures.ncc_lanes`'s three sums). Σl
    and Σr are kept per lane in int16, Σl², Σr², Σlr in int32 lane pairs: only Σl and Σr are
    needed by channel, the others over every lane."""

    def codegen(context, builder, signature, args):
        w = _Window(context, builder, signature, args, subpixel, pair_sums)

        def zeros(vector_type):
            return [
                cgutils.alloca_once_value(builder, ir.Constant(vector_type, None))
                for _ in range(halves)
            ]

        lane_mask = [w.mask(_MASK_LANES, h) for h in range(halves)]
        sl, sr = zeros(_WORDS), zeros(_WORDS)
        ql, qr, x = zeros(_PAIRS), zeros(_PAIRS), zeros(_PAIRS)

        def accumulate(acc, value):
            builder.store(builder.add(builder.load(acc), value), acc)

        def row(lo, ro):
            for h in range(halves):
                a = builder.and_(w.words(w.lptr, lo, h), lane_mask[h])
                b = builder.and_(w.right_words(ro, h), lane_mask[h])
                accumulate(sl[h], a)
                accumulate(sr[h], b)
                accumulate(ql[h], pair_sums(builder, a, a))
                accumulate(qr[h], pair_sums(builder, b, b))
                accumulate(x[h], pair_sums(builder, a, b))

        w.rows_loop(row)
        smooth, slope = w.sobel(halves)

        def total(accs):
            v = builder.load(accs[0])
            for a in accs[1:]:
                v = builder.add(v, builder.load(a))
            return _reduce(builder, v, "v8i32", 32)

        left_sums = [builder.load(a) for a in sl]
        right_sums = [builder.load(a) for a in sr]
        channel = range(MAX_CHANNELS)
        # lanes 0-3: Σl by channel, 4-7: Σr by channel, in the same channel order
        first = _sums_of_eight(
            builder,
            [w.dot(pair_sums, left_sums, _MASK_SUM + c) for c in channel]
            + [w.dot(pair_sums, right_sums, _MASK_SUM + c) for c in channel],
        )
        second = _sums_of_eight(  # lanes 0-3: gx, 4-7: gy
            builder,
            [w.dot(pair_sums, smooth, _MASK_GX + c) for c in channel]
            + [w.dot(pair_sums, slope, _MASK_GY + c) for c in channel],
        )
        quad = ir.VectorType(_I32, 4)

        def lanes(v, start):
            return builder.shuffle_vector(v, v, ir.Constant(quad, list(range(start, start + 4))))

        wide = ir.VectorType(_I64, 4)
        by_l, by_r = builder.sext(lanes(first, 0), wide), builder.sext(lanes(first, 4), wide)

        def reduce64(a, b):
            return _reduce(builder, builder.mul(a, b), "v4i64", 64)

        gx4, gy4 = lanes(second, 0), lanes(second, 4)
        grad2 = _reduce(
            builder, builder.add(builder.mul(gx4, gx4), builder.mul(gy4, gy4)), "v4i32", 32
        )
        n = builder.mul(w.rows, w.rows)
        cov = builder.sub(builder.mul(n, total(x)), reduce64(by_l, by_r))
        vl = builder.sub(builder.mul(n, total(ql)), reduce64(by_l, by_l))
        vr = builder.sub(builder.mul(n, total(qr)), reduce64(by_r, by_r))
        return context.make_tuple(builder, signature.return_type, [cov, vl, vr, grad2])

    return _intrinsic(codegen, 4, subpixel)
