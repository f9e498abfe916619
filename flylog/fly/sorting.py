"""Stable ordering, selection and medians for the engine's compiled kernels.

numba's own ``np.argsort(kind="mergesort")``, ``np.partition`` and ``np.median`` cost about
12 s of compilation on first use; these compile in well under a second. The LSD radix sort is
stable (ties keep index order), which deterministic selection needs; medians and the
selection cut use an O(n) quickselect, since a generation needs two medians of ~5000 values
and only the best half of the flies in order.
"""

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


_RADIX_BITS = 8
_RADIX_BINS = 1 << _RADIX_BITS
# Below this many candidates a radix pass costs more than sorting them.
_FEW = 16


@numba.njit(cache=True, nogil=True)
def select_radix(values, k, keys):  # pragma: no cover - compiled
    """The ``k``-th smallest of float64 ``values`` (0-based; no NaN; −0.0 comes back as 0.0):
    the value :func:`select_in_place` gives, without reordering ``values``. ``keys`` (≥ N)
    uint64 is scratch.

    Most significant digit first over order-preserving integer keys: count the digits of
    the candidates, keep those with the digit the ``k``-th has. No loop here branches on the
    data, where quickselect's partition mispredicts about every other comparison on fresh
    fitness values (~3× slower in the engine, where every call sees new values)."""
    n = values.shape[0]
    bits = values.view(np.uint64)
    sign = np.uint64(1) << np.uint64(63)
    zero = np.uint64(0)
    common, differ = ~zero, zero  # bits every key has, bits some key has
    for i in range(n):
        b = bits[i] & ~sign if values[i] == 0.0 else bits[i]  # −0.0 is 0.0
        # negative: all bits flipped; positive: the sign bit set (so keys sort as values)
        key = b ^ ((zero - (b >> np.uint64(63))) | sign)
        keys[i] = key
        common &= key
        differ |= key
    # Start at the highest bit on which keys differ (fitness values share their sign and
    # most exponent bits: a pass on those would keep every candidate).
    top = 63
    spread = common ^ differ
    while top > 0 and not (spread >> np.uint64(top)) & np.uint64(1):
        top -= 1
    counts = np.empty(_RADIX_BINS, dtype=np.int64)
    mask = np.uint64(_RADIX_BINS - 1)
    m = n
    shift = max(top + 1 - _RADIX_BITS, 0)
    while m > _FEW and spread != zero:
        s = np.uint64(shift)
        counts[:] = 0
        for i in range(m):
            counts[(keys[i] >> s) & mask] += 1
        d = 0
        while k >= counts[d]:
            k -= counts[d]
            d += 1
        digit = np.uint64(d)
        t = 0
        for i in range(m):
            key = keys[i]
            keys[t] = key
            t += ((key >> s) & mask) == digit
        m = t
        if shift == 0:
            break
        shift = max(shift - _RADIX_BITS, 0)
    few = keys[:m]
    for i in range(1, m):  # insertion sort of the few left
        key = few[i]
        j = i - 1
        while j >= 0 and few[j] > key:
            few[j + 1] = few[j]
            j -= 1
        few[j + 1] = key
    key = few[k]
    b = key ^ sign if key & sign else ~key
    out = np.empty(1, dtype=np.uint64)
    out[0] = b
    return out.view(np.float64)[0]


@numba.njit(cache=True, nogil=True)
def median_radix(values, keys):  # pragma: no cover - compiled
    """``np.median`` of a non-empty float64 array without NaN (:func:`select_radix`; the
    array is not reordered, ``keys`` (≥ N) uint64 is scratch)."""
    n = values.shape[0]
    upper = select_radix(values, n // 2, keys)
    if n % 2:
        return upper
    # the (n/2 − 1)-th: upper again unless n/2 values lie below it, else the largest of those
    below, lower = 0, -np.inf
    for i in range(n):
        x = values[i]
        less = x < upper
        below += less
        lower = max(lower, x if less else -np.inf)
    if below < n // 2:
        lower = upper
    return (lower + upper) / 2.0
