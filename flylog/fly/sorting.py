"""Selection and medians for the engine's compiled kernels.

numba's own ``np.partition`` and ``np.median`` cost about 12 s of compilation on first use;
these compile in well under a second. A generation needs a median of ~5000 values and the
selection cut, both O(n) radix selections that never reorder their input (the compiled
quickselect and stable argsort they are checked against live in ``tests/fly``).
"""

from __future__ import annotations

import numba
import numpy as np

_RADIX_BITS = 8
_RADIX_BINS = 1 << _RADIX_BITS
# Below this many candidates a radix pass costs more than sorting them.
_FEW = 16
# Digit histograms a pass fills in turn (the loop below is written for four). On the engine's
# own fitness (5000 flies, 400 generations, thread CPU time, medians, same run): the selection
# cut 0.78× the time of one histogram (9.4 against 12.1 µs), sharing's median 0.92× (8.6
# against 9.3 µs); on 5000 lognormal values 0.60× (8.2 against 13.7 µs).
_HISTOGRAMS = 4


@numba.njit(cache=True, nogil=True)
def select_radix(values, k, keys):  # pragma: no cover - compiled
    """The ``k``-th smallest of float64 ``values`` (0-based; no NaN; −0.0 comes back as 0.0):
    the value a quickselect gives, without reordering ``values``. ``keys`` (≥ N)
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
    # Four histograms, one per key of every four: keys close in value share a digit, and
    # one histogram's increments of the same bin wait for each other through memory.
    counts = np.empty((_HISTOGRAMS, _RADIX_BINS), dtype=np.int64)
    mask = np.uint64(_RADIX_BINS - 1)
    m = n
    shift = max(top + 1 - _RADIX_BITS, 0)
    while m > _FEW and spread != zero:
        s = np.uint64(shift)
        counts[:] = 0
        for i in range(0, m - m % _HISTOGRAMS, _HISTOGRAMS):
            counts[0, (keys[i] >> s) & mask] += 1
            counts[1, (keys[i + 1] >> s) & mask] += 1
            counts[2, (keys[i + 2] >> s) & mask] += 1
            counts[3, (keys[i + 3] >> s) & mask] += 1
        for i in range(m - m % _HISTOGRAMS, m):
            counts[0, (keys[i] >> s) & mask] += 1
        d = 0
        c = counts[0, 0] + counts[1, 0] + counts[2, 0] + counts[3, 0]
        while k >= c:
            k -= c
            d += 1
            c = counts[0, d] + counts[1, d] + counts[2, d] + counts[3, d]
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
