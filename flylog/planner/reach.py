"""Whether the goal can be reached in the map: the free cells 4-connected to the goal cell.

The harmonic field has its only minimum at the goal, but in a region walled off from the
goal every boundary value is 1 (or more, inside obstacles) and U tends to 1 all over it:
its gradient vanishes and the descent ends FLAT, so the planner asks the map directly.

:func:`reachable_from` is a compiled breadth-first fill; ``tests/planner`` holds its numpy
reference (repeated 4-neighbour dilation to a fixed point).
"""

from __future__ import annotations

import numba
import numpy as np


def reachable_from(free: np.ndarray, seed: tuple[int, int]) -> np.ndarray:
    """(H, W) bool: the cells of ``free`` 4-connected to ``seed`` (the seed counts as free)."""
    mask = np.ascontiguousarray(free, dtype=np.bool_)
    return _fill_kernel(mask, int(seed[0]), int(seed[1]))


def any_within(region: np.ndarray, cell: tuple[int, int], radius: int) -> bool:
    """Whether ``region`` holds a cell within the (2r+1)² square around ``cell``."""
    h, w = region.shape
    i, j = cell
    r = max(int(radius), 0)
    block = region[max(i - r, 0) : min(i + r + 1, h), max(j - r, 0) : min(j + r + 1, w)]
    return bool(block.any())


@numba.njit(cache=True, nogil=True)
def _fill_kernel(free, si, sj):  # pragma: no cover - compiled
    h, w = free.shape
    out = np.zeros((h, w), dtype=np.bool_)
    if not (0 <= si < h and 0 <= sj < w):
        return out
    queue = np.empty(h * w, dtype=np.int64)
    out[si, sj] = True
    queue[0] = si * w + sj
    head, tail = 0, 1
    while head < tail:
        flat = queue[head]
        head += 1
        i, j = flat // w, flat % w
        for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            ti, tj = i + di, j + dj
            if 0 <= ti < h and 0 <= tj < w and free[ti, tj] and not out[ti, tj]:
                out[ti, tj] = True
                queue[tail] = ti * w + tj
                tail += 1
    return out
