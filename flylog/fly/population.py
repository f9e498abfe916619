"""The fly population as a structure of arrays, its compiled selection into the next
generation's arrays, and the sharing radius (uniform sampling of new flies:
:func:`flylog.fly.operators.random_flies`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from flylog.fly.bundles import Flies, Selection
from flylog.fly.fitness_terms import INVALID_FITNESS
from flylog.fly.neighbours import NeighbourCounter, fly_neighbour_counts_into
from flylog.fly.selection import shared_fitness_into, survivors_cut


@dataclass
class Population:
    """N flies in base_link. Row i of every array describes fly i.

    ``vision`` is the image-only fitness, valid for the image pair of ``stamp_ns`` unless
    ``stale``; ``fitness`` is the fused one (vision × sonar bonus), what selection (before
    sharing), obstacle extraction and the logs use. Both are :data:`INVALID_FITNESS` for a fly
    outside either image or behind the cameras, and for a fly not evaluated yet.
    """

    xyz: np.ndarray  # (N, 3) float64, metres
    fitness: np.ndarray  # (N,) float64
    vision: np.ndarray  # (N,) float64
    stale: np.ndarray  # (N,) bool: vision must be recomputed
    stamp_ns: np.ndarray  # (N,) int64: stamp of the images vision was computed on, -1 = never
    age: np.ndarray  # (N,) int32: generations survived

    @classmethod
    def fresh(cls, xyz: np.ndarray) -> Population:
        """New, not yet evaluated flies at ``xyz``."""
        n = len(xyz)
        return cls(
            xyz=np.ascontiguousarray(xyz, dtype=np.float64),
            fitness=np.full(n, INVALID_FITNESS),
            vision=np.full(n, INVALID_FITNESS),
            stale=np.ones(n, dtype=bool),
            stamp_ns=np.full(n, -1, dtype=np.int64),
            age=np.zeros(n, dtype=np.int32),
        )

    def __len__(self) -> int:
        return len(self.xyz)

    def copy(self, *, readonly: bool = False) -> Population:
        """A deep copy (optionally with read-only arrays, for handing out snapshots)."""
        out = Population(
            *(np.array(a, copy=True) for a in (self.xyz, self.fitness, self.vision)),
            *(np.array(a, copy=True) for a in (self.stale, self.stamp_ns, self.age)),
        )
        if readonly:
            for a in (out.xyz, out.fitness, out.vision, out.stale, out.stamp_ns, out.age):
                a.flags.writeable = False
        return out

    def survivors_then(
        self, keep: np.ndarray, newcomers: np.ndarray, *, out: Population | None = None
    ) -> Population:
        """The flies ``keep`` (one generation older), followed by fresh flies ``newcomers``;
        written into ``out`` (same size, not ``self``) when given, to reuse its arrays."""
        n = len(keep) + len(newcomers)
        if out is None or len(out) != n or out is self:
            out = Population.fresh(np.empty((n, 3)))
        k = len(keep)
        for name in ("xyz", "fitness", "vision", "stale", "stamp_ns", "age"):
            np.take(getattr(self, name), keep, axis=0, out=getattr(out, name)[:k])
        out.age[:k] += 1
        out.xyz[k:] = newcomers
        out.fitness[k:] = INVALID_FITNESS
        out.vision[k:] = INVALID_FITNESS
        out.stale[k:] = True
        out.stamp_ns[k:] = -1
        out.age[k:] = 0
        return out

    def flies(self) -> Flies:
        """The arrays as the compiled kernels take them (:class:`~flylog.fly.bundles.Flies`)."""
        return Flies(self.xyz, self.fitness, self.vision, self.stale, self.stamp_ns, self.age)

    def select_into(
        self,
        out: Population,
        keep: int,
        counts: np.ndarray | None,
        coefficient: float,
        work: np.ndarray,
    ) -> int:
        """Compiled selection and gather in one pass: the ``keep`` flies
        :func:`~flylog.fly.selection.survivor_indices` takes on the shared fitness
        (:func:`~flylog.fly.selection.shared_fitness` with ``counts``; the fitness itself when
        ``counts`` is None), in index order, one generation older, then fresh flies whose
        ``xyz`` the caller writes. ``work`` is (2N,) float64 scratch. Returns ``keep``."""
        self._check_select(out, work)
        share = counts is not None
        if counts is None:
            counts = np.empty(0, dtype=np.int64)
        return _select_kernel(
            counts, float(coefficient), share, keep, work, self.flies(), out.flies()
        )

    def select_sharing_into(
        self,
        out: Population,
        keep: int,
        coefficient: float,
        work: np.ndarray,
        consts: np.ndarray,
        radius: float,
        counter: NeighbourCounter,
    ) -> int:
        """:meth:`select_into` with the counts sharing needs worked out in the same call: each
        valid fly's neighbours within ``radius`` px in the left image
        (:func:`~flylog.fly.neighbours.fly_neighbour_counts_into`, ``consts`` from
        :func:`~flylog.fly.fitness.rig_constants`, scratch from ``counter``; the counts are
        left in ``counter.counts``)."""
        self._check_select(out, work)
        grid, ints, floats = counter.scratch(len(self))
        selection = Selection(
            survivors=keep,
            sharing=True,
            coefficient=float(coefficient),
            work=work,
            radius=float(radius),
            grid=grid,
            ints=ints,
            floats=floats,
            counts=counter.counts,
        )
        return select_into_kernel(selection, consts, self.flies(), out.flies())

    def _check_select(self, out: Population, work: np.ndarray) -> None:
        if len(out) != len(self) or out is self or len(work) < 2 * len(self):
            msg = "select_into needs another population of the same size and 2N scratch"
            raise ValueError(msg)


@numba.njit(cache=True, nogil=True)
def _select_kernel(counts, coefficient, share, keep, work, a, b):  # pragma: no cover
    """:meth:`Population.select_into`: shared fitness, the selection cut, then one gather
    from the flies ``a`` into ``b`` (:class:`~flylog.fly.bundles.Flies`)."""
    n = a.fitness.shape[0]
    score = work[:n]
    if share:
        shared_fitness_into(a.fitness, counts, coefficient, work[n:], score)
    else:
        score[:] = a.fitness
    return _cut_and_gather(score, keep, work, a, b)


@numba.njit(cache=True, nogil=True)
def select_into_kernel(se, k, a, b):  # pragma: no cover - compiled
    """For compiled callers: the selection ``se`` (:class:`~flylog.fly.bundles.Selection`)
    from the flies ``a`` into ``b``: with sharing, each valid fly's neighbours within
    ``se.radius`` px in the left image first (``k``: the rig's constants; the counts are left
    in ``se.counts``), as :meth:`Population.select_sharing_into`; without, on the fitness
    itself (``se.counts`` not read). Returns how many flies were kept."""
    n = a.fitness.shape[0]
    score = se.work[:n]
    if se.sharing:
        fly_neighbour_counts_into(
            a.xyz, k, a.fitness, se.radius, se.grid, se.ints, se.floats, se.counts
        )
        shared_fitness_into(a.fitness, se.counts, se.coefficient, se.work[n:], score)
    else:
        score[:] = a.fitness
    return _cut_and_gather(score, se.survivors, se.work, a, b)


@numba.njit(cache=True, nogil=True)
def _cut_and_gather(score, keep, work, a, b):  # pragma: no cover - compiled
    """The selection cut on ``score`` (``work[n:]`` is scratch), then one gather from the flies
    ``a`` into ``b``: the taken flies one generation older, the rest of ``b`` fresh (xyz left
    to the caller)."""
    n = a.fitness.shape[0]
    everyone = keep >= n
    cut, ties = np.inf, 0
    if 0 < keep < n:
        cut, ties = survivors_cut(score, keep, work[n:])
    # Every fly is written at the next free row, which moves on only if the fly is taken: no
    # branch on the scores (they are fresh every generation, so it would mispredict half the
    # time); the rows after the taken ones are overwritten below and by the caller.
    t = 0
    for i in range(n):
        s = score[i]
        tie = s == cut
        take = everyone | (s > cut) | (tie & (ties > 0))
        ties -= tie & take
        b.xyz[t, 0], b.xyz[t, 1], b.xyz[t, 2] = a.xyz[i, 0], a.xyz[i, 1], a.xyz[i, 2]
        b.fitness[t] = a.fitness[i]
        b.vision[t] = a.vision[i]
        b.stale[t] = a.stale[i]
        b.stamp_ns[t] = a.stamp_ns[i]
        b.age[t] = a.age[i] + 1
        t += take
    for r in range(t, n):
        b.fitness[r] = INVALID_FITNESS
        b.vision[r] = INVALID_FITNESS
        b.stale[r] = True
        b.stamp_ns[r] = -1
        b.age[r] = 0
    return t


def fitness_summary(fitness: np.ndarray) -> tuple[float, int, float]:
    """(best, number valid, median of the valid) fitness; the median is INVALID_FITNESS
    when no fly is valid."""
    valid = fitness[fitness > INVALID_FITNESS]
    median = float(np.median(valid)) if len(valid) else INVALID_FITNESS
    return float(fitness.max()), len(valid), median


def sharing_radius(n_pixels: int, n_flies: int) -> float:
    """R = ½(√(N_pixels / N_flies) − 1) px (paper §2.1.2), never negative."""
    return max(0.0, 0.5 * (math.sqrt(n_pixels / n_flies) - 1.0))
