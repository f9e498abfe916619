"""Obstacle points from the flies: what the planner and the metrics read."""

from __future__ import annotations

import numpy as np

from flylog.fly.engine import FlyEngine
from flylog.fly.population import Population


def obstacle_points(
    source: FlyEngine | Population,
    *,
    min_fitness: float | None = None,
    quantile: float | None = None,
    ground_margin: float = 0.05,
) -> np.ndarray:
    """(M, 3) positions (base_link) of the flies taken for obstacles: valid (fitness > 0),
    fitness above a threshold, and z above the ground by more than ``ground_margin`` m.

    Give exactly one threshold: ``min_fitness`` (absolute, in fitness units, which depend on
    the images' contrast) or ``quantile`` in [0, 1) of the positive fitnesses (scale-free:
    ``quantile=0.5`` keeps the better half of the valid flies).
    """
    if (min_fitness is None) == (quantile is None):
        msg = "give exactly one of min_fitness or quantile"
        raise ValueError(msg)
    pop = source.population if isinstance(source, FlyEngine) else source
    positive = pop.fitness > 0
    if not positive.any():
        return np.empty((0, 3))
    if quantile is not None:
        if not 0.0 <= quantile < 1.0:
            msg = f"quantile must be in [0, 1), got {quantile}"
            raise ValueError(msg)
        threshold = float(np.quantile(pop.fitness[positive], quantile))
    else:
        threshold = float(min_fitness)  # type: ignore[arg-type]
    keep = positive & (pop.fitness > threshold) & (pop.xyz[:, 2] > ground_margin)
    return pop.xyz[keep].copy()
