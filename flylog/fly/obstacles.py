"""Obstacle points from the flies: what the planner and the metrics read."""

from __future__ import annotations

import numpy as np

from flylog.fly.engine import FlyEngine
from flylog.fly.population import Population


def obstacle_mask(
    xyz: np.ndarray,
    fitness: np.ndarray,
    *,
    min_fitness: float | None = None,
    quantile: float | None = None,
    ground_margin: float = 0.05,
) -> np.ndarray:
    """(N,) bool: the flies taken for obstacles, from the arrays a population (or a ``/flies``
    point cloud) holds: valid (fitness > 0), fitness above a threshold, and z above the
    ground by more than ``ground_margin`` m.

    Give exactly one threshold: ``min_fitness`` (absolute, in fitness units, which depend on
    the images' contrast) or ``quantile`` in [0, 1) of the positive fitnesses (scale-free:
    ``quantile=0.5`` keeps the better half of the valid flies).
    """
    if (min_fitness is None) == (quantile is None):
        msg = "give exactly one of min_fitness or quantile"
        raise ValueError(msg)
    if quantile is not None and not 0.0 <= quantile < 1.0:
        msg = f"quantile must be in [0, 1), got {quantile}"
        raise ValueError(msg)
    fitness = np.asarray(fitness)
    xyz = np.asarray(xyz)
    if xyz.shape != (len(fitness), 3):
        msg = f"xyz must be ({len(fitness)}, 3) like fitness, got {xyz.shape}"
        raise ValueError(msg)
    positive = fitness > 0
    if not positive.any():
        return np.zeros(len(fitness), dtype=bool)
    if quantile is not None:
        threshold = float(np.quantile(fitness[positive], quantile))
    else:
        threshold = float(min_fitness)  # type: ignore[arg-type]
    return positive & (fitness > threshold) & (xyz[:, 2] > ground_margin)


def obstacle_points(
    source: FlyEngine | Population,
    *,
    min_fitness: float | None = None,
    quantile: float | None = None,
    ground_margin: float = 0.05,
) -> np.ndarray:
    """(M, 3) positions (base_link) of the flies :func:`obstacle_mask` keeps."""
    pop = source.population if isinstance(source, FlyEngine) else source
    keep = obstacle_mask(
        pop.xyz, pop.fitness, min_fitness=min_fitness, quantile=quantile,
        ground_margin=ground_margin,
    )  # fmt: skip
    return pop.xyz[keep].copy()
