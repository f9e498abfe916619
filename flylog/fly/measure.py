"""What a similarity measure is, and how the compiled kernels take one.

A measure (:class:`Measure`) is one definition: the window sums it needs
(:class:`WindowSums`: integer sums over a window pair, in every form its users read them)
and its finishing step, from those sums to the dissimilarity the fitness divides by. Every
user takes the definition, not its parts: the fitness kernel (:mod:`flylog.fly.fitness`)
and its numpy reference (:mod:`flylog.fly.fitness_reference`), the scouts, distinctness
(through the fitness) and the visual heading (:mod:`flylog.fly.heading`, on float patches).
The definitions themselves, and the table from the configuration's
:class:`~flylog.fly.config.Similarity` to them, are in :mod:`flylog.fly.measures`.

Compiled kernels take a :class:`Measure` as an argument. numba types it by the measure's
name (:class:`MeasureType`), so it compiles each kernel once per measure it is called with,
and caches each (the type is a name: it pickles), and the calls below (:func:`lane_sums`,
:func:`vector_sums`, :func:`patch_sums`, :func:`dissimilarity`, …) are chosen while
compiling: the kernels hold no branch on the measure. Typing the argument in Python costs a
call 4–20 µs against 0.2–0.9 µs for a call without it (a loaded 2-core host); a namedtuple
field holding it would make numba type the whole tuple in Python, 160–230 µs a call, so
kernels take it as an argument of its own. numba's cache of a kernel does
not see a change in a measure's definition (clear ``__pycache__`` after editing one).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from numba import types
from numba.core.errors import TypingError
from numba.extending import (
    NativeValue,
    models,
    overload,
    register_model,
    typeof_impl,
    unbox,
)

from flylog.fly.config import Similarity


class VectorSums(NamedTuple):
    """A measure's window sums on LLVM vectors (:mod:`flylog.fly.fitness_vector`): each an
    intrinsic (left, right, bl, br, stride, rows, masks[, q, across]) → (*sums, Sobel
    norm²), for windows of 16 or 32 lanes, whole-pixel or sub-pixel."""

    half: Any
    wide: Any
    half_subpixel: Any
    wide_subpixel: Any


@dataclass(frozen=True, eq=False)
class WindowSums:
    """The integer sums a measure needs over a window pair (left window, right window of w×w
    pixels and C channels), in the forms its users take:

    - ``lanes``: compiled, (lflat, rflat, bl, br, stride, window, channels, scratch) →
      ``count`` int64 on images read as flat uint8 arrays from the offsets bl and br, a row
      every ``stride`` bytes; ``scratch`` is (``scratch_rows``, ≥ w·C) int32;
    - ``vector`` (or None): the same sums on LLVM vectors, with the Sobel norm²
      (:class:`VectorSums`); without them the fitness kernel runs ``lanes`` on every window;
    - ``patches``: compiled, (a, b, channels) → ``count`` float64 of two float patches
      (n·C,) laid out row by row, channel last (the heading's bilinear samples);
    - ``numpy``: (a, b, channels) → ``count`` arrays of (M, n·C) patch pairs, integer or
      float, with the additions in ``patches``' order (the float results are the same).
    """

    name: str
    count: int
    lanes: Any
    scratch_rows: int
    patches: Any
    numpy: Callable[[np.ndarray, np.ndarray, int], tuple[np.ndarray, ...]]
    vector: VectorSums | None = None


@dataclass(frozen=True, eq=False)
class Measure:
    """A similarity measure: its window ``sums`` and its finishing step, ``finish``
    (compiled, (sums, n, channels) → the dissimilarity, sums indexable: a tuple or an array
    column) and ``finish_numpy`` (the same over arrays of sums, the same float steps). The
    fitness is G / (dissimilarity + guard·n·C)."""

    similarity: Similarity
    sums: WindowSums
    finish: Any
    finish_numpy: Callable[..., np.ndarray]
    numba_type: MeasureType = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "numba_type", MeasureType(self.similarity.value))
        _BY_NAME[self.similarity.value] = self


_BY_NAME: dict[str, Measure] = {}


class MeasureType(types.Type):
    """numba's type of a :class:`Measure`: its name, nothing at run time."""

    def __init__(self, measure: str) -> None:
        self.measure = measure
        super().__init__(name=f"Measure({measure})")


register_model(MeasureType)(models.OpaqueModel)


@typeof_impl.register(Measure)
def _typeof_measure(value: Measure, context: object) -> MeasureType:
    return value.numba_type


@unbox(MeasureType)
def _unbox_measure(typ: MeasureType, obj: object, c: Any) -> NativeValue:
    return NativeValue(c.context.get_constant_null(typ))


def _measure(measure: Any) -> Measure:
    if not isinstance(measure, MeasureType):
        msg = f"expected a similarity measure, got {measure}"
        raise TypingError(msg)
    return _BY_NAME[measure.measure]


# The calls below are what a compiled kernel writes; numba replaces each by the measure's
# own function while compiling (their Python bodies never run).


def lane_sums(measure, lflat, rflat, bl, br, stride, window, channels, scratch):
    """The measure's window sums by its lane loop (:attr:`WindowSums.lanes`)."""
    raise NotImplementedError


def scratch_rows(measure):
    """The rows of int32 scratch :func:`lane_sums` needs."""
    raise NotImplementedError


def sums_count(measure):
    """How many window sums the measure has."""
    raise NotImplementedError


def has_vector(measure):
    """Whether the measure's sums have LLVM vector forms (:func:`vector_sums`)."""
    raise NotImplementedError


def vector_sums(measure, lflat, rflat, bl, br, stride, window, masks, wide, subpixel, q, across):
    """(*sums, Sobel norm²) on LLVM vectors: 32 lanes if ``wide`` else 16, the right rows
    interpolated with weight q if ``subpixel``; zeros for a measure without vector forms
    (a kernel calls it only when :func:`has_vector`)."""
    raise NotImplementedError


def patch_sums(measure, a, b, channels):
    """The measure's sums of two float patches (:attr:`WindowSums.patches`)."""
    raise NotImplementedError


def dissimilarity(measure, sums, n, channels):
    """The measure's finishing step (:attr:`Measure.finish`)."""
    raise NotImplementedError


_JIT: Any = {"cache": True, "nogil": True}  # the compiled callers cache the overloads


@overload(lane_sums, jit_options=_JIT)
def _lane_sums(measure, lflat, rflat, bl, br, stride, window, channels, scratch):
    lanes = _measure(measure).sums.lanes

    def impl(measure, lflat, rflat, bl, br, stride, window, channels, scratch):
        return lanes(lflat, rflat, bl, br, stride, window, channels, scratch)

    return impl


@overload(scratch_rows, jit_options=_JIT)
def _scratch_rows(measure):
    rows = _measure(measure).sums.scratch_rows
    return lambda measure: rows


@overload(sums_count, jit_options=_JIT)
def _sums_count(measure):
    count = _measure(measure).sums.count
    return lambda measure: count


@overload(has_vector, jit_options=_JIT)
def _has_vector(measure):
    vector = _measure(measure).sums.vector is not None
    return lambda measure: vector


@overload(vector_sums, jit_options=_JIT)
def _vector_sums(measure, lflat, rflat, bl, br, stride, window, masks, wide, subpixel, q, across):
    sums = _measure(measure).sums
    if sums.vector is None:
        zeros = (0,) * (sums.count + 1)

        def none(measure, lflat, rflat, bl, br, stride, window, masks, wide, subpixel, q, across):
            return zeros

        return none
    half, wide_, half_sub, wide_sub = sums.vector

    def impl(measure, lflat, rflat, bl, br, stride, window, masks, wide, subpixel, q, across):
        if subpixel:
            if wide:
                return wide_sub(lflat, rflat, bl, br, stride, window, masks, q, across)
            return half_sub(lflat, rflat, bl, br, stride, window, masks, q, across)
        if wide:
            return wide_(lflat, rflat, bl, br, stride, window, masks)
        return half(lflat, rflat, bl, br, stride, window, masks)

    return impl


@overload(patch_sums, jit_options=_JIT)
def _patch_sums(measure, a, b, channels):
    patches = _measure(measure).sums.patches

    def impl(measure, a, b, channels):
        return patches(a, b, channels)

    return impl


@overload(dissimilarity, jit_options=_JIT)
def _dissimilarity(measure, sums, n, channels):
    finish = _measure(measure).finish

    def impl(measure, sums, n, channels):
        return finish(sums, n, channels)

    return impl
