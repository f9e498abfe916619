"""The fly engine: a persistent population evolved on the newest images, sonar and odometry.

Usable without any log: feed it :class:`~flylog.sensors.StereoPair`,
:class:`~flylog.sensors.SonarReading` and odometry increments, call :meth:`FlyEngine.step`.
One generation (paper §2): evaluate the flies whose images changed, fuse sonar, share,
select the best fraction, refill with offspring and immigrants, evaluate the newcomers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flylog.errors import FlylogError
from flylog.fly.config import Backend, EngineConfig
from flylog.fly.fitness import (
    INVALID_FITNESS,
    as_planes,
    fitness_numba,
    fitness_numpy,
    left_projections_numba,
    rig_constants,
)
from flylog.fly.fusion import moved_by_odometry, sonar_fused, sonar_immigrants
from flylog.fly.operators import (
    neighbour_counts_numba,
    neighbour_counts_numpy,
    offspring,
    shared_fitness,
    shared_fitness_numba,
    survivor_indices,
    survivor_indices_numba,
)
from flylog.fly.population import (
    Population,
    fitness_summary_numba,
    fitness_summary_numpy,
    random_flies,
    sharing_radius,
)
from flylog.geometry import Pose2D, StereoRig
from flylog.sensors import SonarReading, StereoPair


@dataclass(frozen=True, slots=True)
class GenerationStats:
    """What one generation did; ``evaluations`` lets replay charge virtual time."""

    generation: int
    evaluations: int
    image_stamp_ns: int
    survivors: int
    offspring: int
    immigrants: int
    sonar_immigrants: int
    valid_flies: int
    best_fitness: float
    median_fitness: float  # over valid flies; INVALID_FITNESS if none


class FlyEngine:
    """The fly algorithm over a stereo rig, with sonar and odometry fusion."""

    def __init__(self, config: EngineConfig, rig: StereoRig, rng: np.random.Generator) -> None:
        if rig.baseline <= 0:
            msg = f"the fly engine needs a stereo baseline > 0, got {rig.baseline} m"
            raise FlylogError(msg)
        self.config = config
        self.rig = rig
        self._rng = rng
        self._margin = config.window // 2
        self._radius = sharing_radius(rig.n_pixels, config.flies)
        self._pop = Population.fresh(self._random(config.flies))
        # The next generation is written into this one's arrays (no allocation per step).
        self._spare = Population.fresh(np.empty((config.flies, 3)))
        self._numba = config.backend is Backend.NUMBA
        self._rig_constants = rig_constants(rig)
        self._left: np.ndarray | None = None
        self._right: np.ndarray | None = None
        self._stamp_ns = -1
        self._sonar: SonarReading | None = None
        self._generation = 0

    # --- inputs -----------------------------------------------------------------------------

    def set_images(self, pair: StereoPair) -> None:
        """Work on this pair from now on; every fly's vision fitness becomes stale."""
        left, right = as_planes(pair.left), as_planes(pair.right)
        expected = (self.rig.height, self.rig.width)
        if left.shape != right.shape or left.shape[:2] != expected or left.shape[2] not in (1, 3):
            msg = (
                f"stereo pair at {pair.stamp_ns} ns: images {np.shape(pair.left)} and "
                f"{np.shape(pair.right)} do not match the rig's {expected} (grey or RGB)"
            )
            raise FlylogError(msg)
        self._left, self._right, self._stamp_ns = left, right, pair.stamp_ns
        self._pop.stale[:] = True

    def set_sonar(self, reading: SonarReading) -> None:
        """Use this sonar reading (in base_link) for fusion until the next one."""
        self._sonar = reading

    def apply_motion(self, increment: Pose2D) -> None:
        """Proprioception: move every fly by the inverse of the robot's motion ``increment``
        (``relative(prev_odom, new_odom)``). Does nothing when proprioception is off."""
        if not self.config.proprioception:
            return
        self._pop.xyz = moved_by_odometry(self._pop.xyz, increment)
        self._pop.stale[:] = True

    # --- outputs ----------------------------------------------------------------------------

    @property
    def population(self) -> Population:
        """A read-only snapshot of the population, valid at any time."""
        return self._pop.copy(readonly=True)

    @property
    def sharing_radius(self) -> float:
        return self._radius

    @property
    def generation(self) -> int:
        return self._generation

    # --- one generation ---------------------------------------------------------------------

    def step(self) -> GenerationStats:
        """One generation on the newest data."""
        if self._left is None:
            msg = "the fly engine has no images yet: call set_images() before step()"
            raise FlylogError(msg)
        cfg = self.config
        evaluations = self._evaluate_stale()
        pop = self._pop
        pop.fitness = self._fused(pop.vision, pop.xyz)
        ranked = pop.fitness
        if cfg.sharing and cfg.sharing_coefficient > 0:
            ranked = self._shared(pop)
        select = survivor_indices_numba if self._numba else survivor_indices
        keep = select(ranked, cfg.survivors)
        n_new = cfg.flies - len(keep)
        n_immigrants = cfg.immigrants
        from_sonar = self._sonar_immigrants(n_immigrants)
        uniform = self._random(n_immigrants - len(from_sonar))
        children = offspring(
            self._rng,
            pop.xyz[keep],
            n_new - n_immigrants,
            self.rig,
            rate2=cfg.crossover2_rate if cfg.crossover2 else 0.0,
            rate3=cfg.crossover3_rate if cfg.crossover3 else 0.0,
            sigma_px=cfg.mutation_scale * self._radius,
            sigma_disparity_px=cfg.disparity_mutation_scale * self._radius,
            d_min=cfg.d_min,
            d_max=cfg.d_max,
            use_numba=self._numba,
        )
        newcomers = np.concatenate([children, from_sonar, uniform])
        self._pop = pop.survivors_then(keep, newcomers, out=self._spare)
        self._spare = pop
        new = slice(len(keep), None)
        evaluations += self._evaluate(np.arange(len(keep), cfg.flies))
        self._pop.fitness[new] = self._fused(self._pop.vision[new], self._pop.xyz[new])
        self._generation += 1
        summary = fitness_summary_numba if self._numba else fitness_summary_numpy
        best, valid, median = summary(self._pop.fitness)
        return GenerationStats(
            generation=self._generation,
            evaluations=evaluations,
            image_stamp_ns=self._stamp_ns,
            survivors=len(keep),
            offspring=len(children),
            immigrants=n_immigrants,
            sonar_immigrants=len(from_sonar),
            valid_flies=int(valid),
            best_fitness=float(best),
            median_fitness=float(median),
        )

    # --- internals --------------------------------------------------------------------------

    def _random(self, n: int) -> np.ndarray:
        cfg = self.config
        return random_flies(
            self._rng, self.rig, n, d_min=cfg.d_min, d_max=cfg.d_max, margin=self._margin
        )

    def _evaluate_stale(self) -> int:
        return self._evaluate(np.flatnonzero(self._pop.stale))

    def _evaluate(self, index: np.ndarray) -> int:
        """Vision fitness of the flies ``index`` (all stale) on the newest images."""
        if len(index) == 0:
            return 0
        pop, cfg = self._pop, self.config
        if self._numba:
            fitness_numba(
                self._left, self._right, pop.xyz, self.rig, cfg.window, cfg.guard,
                index=index, out=pop.vision,
            )  # fmt: skip
        else:
            pop.vision[index] = fitness_numpy(
                self._left, self._right, pop.xyz[index], self.rig, cfg.window, cfg.guard
            )
        pop.stale[index] = False
        pop.stamp_ns[index] = self._stamp_ns
        return len(index)

    def _fused(self, vision: np.ndarray, xyz: np.ndarray) -> np.ndarray:
        cfg = self.config
        if not cfg.sonar_fitness or self._sonar is None or cfg.sonar_bonus == 0:
            return vision.copy()
        return sonar_fused(
            vision,
            xyz,
            self._sonar,
            bonus=cfg.sonar_bonus,
            tolerance=cfg.sonar_tolerance,
            use_numba=self._numba,
        )

    def _shared(self, pop: Population) -> np.ndarray:
        """The fitness after 2-D sharing in the left image (what selection ranks)."""
        valid = pop.fitness > INVALID_FITNESS
        k = self.config.sharing_coefficient
        if self._numba:
            u_left, v = left_projections_numba(pop.xyz, self._rig_constants)
            counts = neighbour_counts_numba(u_left, v, valid, self._radius)
            return shared_fitness_numba(pop.fitness, counts, k)
        u_left, _, v, _ = self.rig.project(pop.xyz)
        counts = neighbour_counts_numpy(u_left, v, valid, self._radius)
        return shared_fitness(pop.fitness, counts, k)

    def _sonar_immigrants(self, n_immigrants: int) -> np.ndarray:
        cfg = self.config
        if not cfg.sonar_immigration or self._sonar is None:
            return np.empty((0, 3))
        n = round(cfg.sonar_immigration_fraction * n_immigrants)
        return sonar_immigrants(
            self._rng, self._sonar, n, self.rig, tolerance=cfg.sonar_tolerance, margin=self._margin
        )
