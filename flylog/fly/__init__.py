"""flylog.fly: the fly algorithm (evolutionary stereovision with sonar and odometry fusion).

Usable as a library without any log::

    engine = FlyEngine(EngineConfig(), StereoRig(), np.random.default_rng(0))
    engine.set_images(pair)
    stats = engine.step()
    points = obstacle_points(engine, quantile=0.5, ground_margin=0.05)

The names below are imported on first use (PEP 562): ``flylog.fly.obstacles`` or
``flylog.fly.config`` alone (what the metrics and the planner's configuration read) need
not import the engine and its compiled kernels.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from flylog.lazy import lazy_names

if TYPE_CHECKING:
    from flylog.fly.config import Backend, EngineConfig, Gradient, Similarity
    from flylog.fly.engine import FlyEngine
    from flylog.fly.fitness import INVALID_FITNESS, fitness_numba, fitness_numpy
    from flylog.fly.obstacles import ObstacleFlies, obstacle_mask, obstacle_points
    from flylog.fly.operators import random_flies
    from flylog.fly.population import Population, sharing_radius
    from flylog.fly.stats import GenerationStats

# public name → the submodule defining it
_WHERE = {
    "Backend": "config",
    "EngineConfig": "config",
    "Gradient": "config",
    "Similarity": "config",
    "FlyEngine": "engine",
    "GenerationStats": "stats",
    "INVALID_FITNESS": "fitness",
    "fitness_numba": "fitness",
    "fitness_numpy": "fitness",
    "ObstacleFlies": "obstacles",
    "obstacle_mask": "obstacles",
    "obstacle_points": "obstacles",
    "Population": "population",
    "random_flies": "operators",
    "sharing_radius": "population",
}

__all__ = [
    "INVALID_FITNESS",
    "Backend",
    "EngineConfig",
    "FlyEngine",
    "GenerationStats",
    "Gradient",
    "ObstacleFlies",
    "Population",
    "Similarity",
    "fitness_numba",
    "fitness_numpy",
    "obstacle_mask",
    "obstacle_points",
    "random_flies",
    "sharing_radius",
]


__getattr__, __dir__ = lazy_names(__name__, _WHERE)
