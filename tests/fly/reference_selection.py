"""Array-returning forms of the compiled selection, sharing and neighbour-counting kernels,
for tests to compare with their numpy references (the engine calls the ``*_into`` kernels)."""

from __future__ import annotations

import numba
import numpy as np

from flylog.fly.neighbours import NeighbourCounter
from flylog.fly.selection import shared_fitness_into, survivors_cut


@numba.njit(cache=True, nogil=True)
def survivor_indices_numba(shared_fitness, keep):  # pragma: no cover - compiled
    """Same indices as :func:`~flylog.fly.selection.survivor_indices`."""
    n = shared_fitness.shape[0]
    if keep >= n:
        return np.arange(n)
    if keep <= 0:
        return np.empty(0, dtype=np.int64)
    cut, ties = survivors_cut(shared_fitness, keep, np.empty(n))
    out = np.empty(keep, dtype=np.int64)
    t = 0
    for i in range(n):
        s = shared_fitness[i]
        if s > cut or (s == cut and ties > 0):
            ties -= s == cut
            out[t] = i
            t += 1
    return out


@numba.njit(cache=True, nogil=True)
def shared_fitness_numba(fitness, counts, coefficient):  # pragma: no cover - compiled
    """Same values as :func:`~flylog.fly.selection.shared_fitness`."""
    out = np.empty_like(fitness)
    shared_fitness_into(fitness, counts, coefficient, np.empty_like(fitness), out)
    return out


def neighbour_counts_numba(
    u: np.ndarray, v: np.ndarray, valid: np.ndarray, radius: float
) -> np.ndarray:
    """Same counts as :func:`~flylog.fly.neighbours.neighbour_counts_numpy` (compiled grid,
    fresh buffers)."""
    return NeighbourCounter()(u, v, valid, radius)
