"""Stable ordering and medians for the engine's compiled kernels.

numba's own ``np.argsort(kind="mergesort")``, ``np.partition`` and ``np.median`` cost about
12 s of compilation on first use; this LSD radix sort compiles in well under a second, sorts a
few thousand floats in tens of microseconds and is stable (ties keep index order), which is
what deterministic selection needs.
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
def stable_argsort_numba(values):  # pragma: no cover - compiled
    """Indices that sort float64 ``values`` ascending, equal values in index order: the same
    as ``np.argsort(values, kind="stable")`` for values without NaN."""
    n = values.shape[0]
    if n == 0:
        return np.arange(0)
    keys = _ordered_keys(values)
    counts = np.zeros((_PASSES, _BINS), dtype=np.int64)
    mask = np.uint64(_BINS - 1)
    for i in range(n):
        k = keys[i]
        for p in range(_PASSES):
            counts[p, (k >> np.uint64(p * _DIGIT_BITS)) & mask] += 1
    order = np.arange(n)
    spare = np.empty(n, dtype=np.int64)
    for p in range(_PASSES):
        shift = np.uint64(p * _DIGIT_BITS)
        if counts[p, (keys[0] >> shift) & mask] == n:
            continue  # every key has this digit: the pass would not move anything
        start = np.empty(_BINS, dtype=np.int64)
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
def median_numba(values):  # pragma: no cover - compiled
    """``np.median`` of a non-empty float64 array without NaN (same value, bit for bit)."""
    n = values.shape[0]
    order = stable_argsort_numba(values)
    upper = values[order[n // 2]]
    if n % 2:
        return upper
    return (values[order[n // 2 - 1]] + upper) / 2.0
