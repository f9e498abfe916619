"""References for :mod:`flylog.fly.sorting` that only tests call: a stable LSD radix argsort
and Hoare quickselect (compiled, compared with numpy), against which the engine's
``select_radix`` and ``median_radix`` are checked."""

from __future__ import annotations

import numba
import numpy as np

_DIGIT_BITS = 8
_BINS = 1 << _DIGIT_BITS
_PASSES = 64 // _DIGIT_BITS


@numba.njit(cache=True, nogil=True)
def _ordered_keys(values):  # pragma: no cover - compiled
    """uint64 keys in the same order as the float64 ``values`` (no NaN; −0.0 equals 0.0)."""
    bits = (values + 0.0).view(np.uint64)  # + 0.0 turns −0.0 into 0.0
    keys = np.empty_like(bits)
    sign = np.uint64(1) << np.uint64(63)
    for i in range(bits.shape[0]):
        b = bits[i]
        keys[i] = ~b if b & sign else b | sign
    return keys


@numba.njit(cache=True, nogil=True)
def _stable_argsort_keys(keys):  # pragma: no cover - compiled
    """Indices that sort uint64 ``keys`` ascending, equal keys in index order."""
    n = keys.shape[0]
    if n == 0:
        return np.arange(0)
    counts = np.zeros((_PASSES, _BINS), dtype=np.int64)
    mask = np.uint64(_BINS - 1)
    for i in range(n):
        k = keys[i]
        for p in range(_PASSES):
            counts[p, (k >> np.uint64(p * _DIGIT_BITS)) & mask] += 1
    order = np.arange(n)
    spare = np.empty(n, dtype=np.int64)
    start = np.empty(_BINS, dtype=np.int64)
    for p in range(_PASSES):
        shift = np.uint64(p * _DIGIT_BITS)
        if counts[p, (keys[0] >> shift) & mask] == n:
            continue  # every key has this digit: the pass would not move anything
        total = 0
        for d in range(_BINS):
            start[d] = total
            total += counts[p, d]
        for t in range(n):
            i = order[t]
            d = (keys[i] >> shift) & mask
            spare[start[d]] = i
            start[d] += 1
        order, spare = spare, order
    return order


@numba.njit(cache=True, nogil=True)
def stable_argsort_numba(values):  # pragma: no cover - compiled
    """Indices that sort float64 ``values`` ascending, equal values in index order: the same
    as ``np.argsort(values, kind="stable")`` for values without NaN."""
    return _stable_argsort_keys(_ordered_keys(values))


@numba.njit(cache=True, nogil=True)
def select_in_place(a, k):  # pragma: no cover - compiled
    """The ``k``-th smallest of ``a`` (0-based), which is left reordered so that
    ``a[:k] <= a[k] <= a[k + 1:]`` (Hoare quickselect, median-of-three pivot; O(n))."""
    lo, hi = 0, a.shape[0] - 1
    while lo < hi:
        x, y, z = a[lo], a[(lo + hi) // 2], a[hi]
        # the median of the three: a pivot that is neither extreme of the range
        pivot = max(min(x, y), min(max(x, y), z))
        i, j = lo, hi
        while i <= j:
            while a[i] < pivot:
                i += 1
            while a[j] > pivot:
                j -= 1
            if i <= j:
                a[i], a[j] = a[j], a[i]
                i += 1
                j -= 1
        # now a[lo:j + 1] <= pivot, a[i:hi + 1] >= pivot and anything between equals it
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            return a[k]
    return a[k]


@numba.njit(cache=True, nogil=True)
def median_in_place(work):  # pragma: no cover - compiled
    """``np.median`` of a non-empty float64 array without NaN, which is left reordered."""
    n = work.shape[0]
    upper = select_in_place(work, n // 2)
    if n % 2:
        return upper
    lower = work[0]
    for i in range(1, n // 2):
        lower = max(lower, work[i])
    return (lower + upper) / 2.0


@numba.njit(cache=True, nogil=True)
def median_numba(values):  # pragma: no cover - compiled
    """``np.median`` of a non-empty float64 array without NaN (same value; O(n))."""
    return median_in_place(values.copy())


@numba.njit(cache=True, nogil=True)
def smallest_stable_numba(values, keep):  # pragma: no cover - compiled
    """The first ``keep`` of ``np.argsort(values, kind="stable")`` (float64, no NaN): the cut
    is found by selection, so only the ``keep`` taken values are sorted."""
    n = values.shape[0]
    if keep >= n:
        return stable_argsort_numba(values)
    if keep <= 0:
        return np.empty(0, dtype=np.int64)
    keys = _ordered_keys(values)
    cut = select_in_place(keys.copy(), keep - 1)
    below = 0
    for i in range(n):
        if keys[i] < cut:
            below += 1
    ties = keep - below  # equal to the cut: the lowest indices are taken
    taken = np.empty(keep, dtype=np.int64)
    t = 0
    for i in range(n):
        if keys[i] < cut or (keys[i] == cut and ties > 0):
            if keys[i] == cut:
                ties -= 1
            taken[t] = i
            t += 1
    return taken[_stable_argsort_keys(keys[taken])]
