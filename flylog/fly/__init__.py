"""flylog.fly: the fly algorithm (evolutionary stereovision with sonar and odometry fusion).

Usable as a library without any log::

    engine = FlyEngine(EngineConfig(), StereoRig(), np.random.default_rng(0))
    engine.set_images(pair)
    stats = engine.step()
    points = obstacle_points(engine, quantile=0.5, ground_margin=0.05)
"""

from flylog.fly.config import Backend, EngineConfig, Gradient
from flylog.fly.engine import FlyEngine, GenerationStats
from flylog.fly.fitness import INVALID_FITNESS, fitness_numba, fitness_numpy
from flylog.fly.obstacles import ObstacleFlies, obstacle_mask, obstacle_points
from flylog.fly.population import Population, random_flies, sharing_radius

__all__ = [
    "INVALID_FITNESS",
    "Backend",
    "EngineConfig",
    "FlyEngine",
    "GenerationStats",
    "Gradient",
    "ObstacleFlies",
    "Population",
    "fitness_numba",
    "fitness_numpy",
    "obstacle_mask",
    "obstacle_points",
    "random_flies",
    "sharing_radius",
]
