"""Selection and sharing (paper §2.1.2): the elitist cut and the sharing penalty, each with
a plain numpy version and a compiled one giving the same numbers."""

from __future__ import annotations

import numba
import numpy as np

from flylog.fly.sorting import median_radix, select_radix


def survivor_indices(shared_fitness: np.ndarray, keep: int) -> np.ndarray:
    """Elitist, deterministic selection: the indices of the ``keep`` best flies, in index
    order; among equal flies at the cut the lowest indices stay. Index order, not best first:
    no sort is needed, and breeding picks parents uniformly, so their order does not matter."""
    n = len(shared_fitness)
    if keep >= n:
        return np.arange(n)
    if keep <= 0:
        return np.empty(0, dtype=np.int64)
    cut = np.partition(shared_fitness, n - keep)[n - keep]
    taken = shared_fitness > cut
    tied = np.flatnonzero(shared_fitness == cut)[: keep - int(np.count_nonzero(taken))]
    taken[tied] = True
    return np.flatnonzero(taken)


@numba.njit(cache=True, nogil=True)
def survivors_cut(score, keep, work):  # pragma: no cover - compiled
    """(cut, ties): the ``keep`` flies :func:`survivor_indices` takes are those with
    ``score > cut`` and the first ``ties`` with ``score == cut``; ``work`` (≥ N, contiguous)
    is scratch. Needs 0 < keep < N."""
    n = score.shape[0]
    cut = select_radix(score, n - keep, work[:n].view(np.uint64))
    above = 0
    for i in range(n):
        above += score[i] > cut
    return cut, keep - above


def shared_fitness(fitness: np.ndarray, counts: np.ndarray, coefficient: float) -> np.ndarray:
    """2-D sharing: fitness − K·n·f̃, with f̃ the median of the positive fitnesses, so that K
    is dimensionless whatever the images' contrast. Non-positive fitnesses are left alone."""
    positive = fitness > 0
    if not positive.any():
        return fitness.copy()
    scale = float(np.median(fitness[positive]))
    return np.where(positive, fitness - coefficient * scale * counts, fitness)


@numba.njit(cache=True, nogil=True)
def shared_fitness_into(fitness, counts, coefficient, work, out):  # pragma: no cover - compiled
    """:func:`shared_fitness` written into ``out`` (contiguous: also the median's scratch);
    ``work`` (≥ N) is scratch."""
    m = 0
    for i in range(fitness.shape[0]):
        work[m] = fitness[i]
        m += fitness[i] > 0
    if m == 0:
        out[:] = fitness
        return
    step = coefficient * median_radix(work[:m], out[:m].view(np.uint64))
    for i in range(fitness.shape[0]):
        out[i] = fitness[i] - step * counts[i] if fitness[i] > 0 else fitness[i]
