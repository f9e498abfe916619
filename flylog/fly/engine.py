"""The fly engine: a persistent population evolved on the newest images, sonar and odometry.

Usable without any log: feed it :class:`~flylog.sensors.StereoPair`,
:class:`~flylog.sensors.SonarReading` and odometry increments, call :meth:`FlyEngine.step`.
One generation (paper §2): evaluate the flies whose images changed, fuse sonar, share,
select the best fraction, refill with offspring and immigrants, evaluate the newcomers.
"""

from __future__ import annotations

import math

import numpy as np

from flylog.errors import FlylogError
from flylog.fly.bundles import Breeding, Flies, Fusion, Images, Scratch, Selection
from flylog.fly.bundles import Scouting as ScoutBundle
from flylog.fly.config import Backend, EngineConfig
from flylog.fly.fitness import (
    INVALID_FITNESS,
    PARALLEL_MIN_EVALUATIONS,
    as_planes,
    fitness_into,
    fitness_numpy,
    measure_code,
    rig_constants,
)
from flylog.fly.fusion import (
    arc_constants,
    fired_arcs,
    fired_sonars,
    move_by_odometry,
    moved_by_odometry,
    score_into,
    sonar_fused,
    sonar_immigrants,
)
from flylog.fly.generation import generations_kernel
from flylog.fly.neighbours import NeighbourCounter, neighbour_counts_numpy
from flylog.fly.operators import newcomer_constants, newcomers_numpy, random_flies
from flylog.fly.population import Population, sharing_radius
from flylog.fly.scouts import Scouting
from flylog.fly.selection import shared_fitness, survivor_indices
from flylog.fly.stats import GenerationStats
from flylog.geometry import Pose2D, StereoRig
from flylog.sensors import SonarReading, StereoPair

# Sonar immigrants: candidates are drawn n at a time, at most this many times.
_SONAR_TRIES = 8


# Marks the fused fitness as computed before the flies last moved (so: for every fly again).
_MOVED = object()


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
        self._measure = measure_code(config.gradient, config.similarity, config.subpixel)
        self._counter = NeighbourCounter()
        self._all = np.arange(config.flies, dtype=np.int64)
        self._none = self._all[:0]
        self._newcomers = self._all[config.survivors :]
        self._work = np.empty(2 * config.flies)  # selection's scratch
        self._newcomer_k = newcomer_constants(rig, config.d_min, config.d_max, self._margin)
        # what step() needs of the (frozen) configuration, worked out once
        self._survivors = config.survivors
        self._n_immigrants = config.immigrants
        self._sharing = config.sharing and config.sharing_coefficient > 0
        self._breed = self._breeding()
        self._left: np.ndarray | None = None
        self._right: np.ndarray | None = None
        no_rows = np.empty((0, 0), dtype=np.uint8)
        self._rows: tuple[np.ndarray, np.ndarray, int] = (no_rows, no_rows, 0)  # set_images
        self._stamp_ns = -1
        self._sonar: SonarReading | None = None
        self._sonars = np.empty((0, 5))  # fired_sonars(self._sonar)
        self._no_sonars = self._sonars
        self._cos_half_cone = 1.0
        self._arcs = np.empty((0, 4))  # fired_arcs(self._sonar)
        self._arc_k = arc_constants(rig, self._margin)
        # The reading every fly's fitness was fused with (None: fitness = vision); a fly's
        # fitness is recomputed only when its vision is, unless the reading changes.
        self._fused_with: SonarReading | object | None = None  # _MOVED after a motion
        self._generation = 0
        self._scouts = Scouting(config, rig, self._margin)  # see step()
        # what _step_numba needs, worked out once
        self._fuse_sonar = config.sonar_fitness and config.sonar_bonus != 0
        self._sonar_share = (
            round(config.sonar_immigration_fraction * config.immigrants)
            if config.sonar_immigration
            else 0
        )
        self._guard = float(config.guard)
        self._stale_index = np.empty(config.flies, dtype=np.int64)
        row_scratch = np.empty((3, max(config.flies, rig.height + 2)), dtype=np.int64)
        self._scratch = Scratch(self._stale_index, self._all, self._newcomers, row_scratch)

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
        height, width, channels = left.shape  # the compiled kernels read (H, W·C) rows
        self._rows = (
            left.reshape(height, width * channels),
            right.reshape(height, width * channels),
            channels,
        )
        self._pop.stale[:] = True
        self._scouts.new_images()

    def set_sonar(self, reading: SonarReading) -> None:
        """Use this sonar reading (in base_link) for fusion until the next one."""
        self._sonar = reading
        self._sonars = fired_sonars(reading)
        self._cos_half_cone = math.cos(reading.half_cone)
        self._arcs = fired_arcs(reading)

    def apply_motion(self, increment: Pose2D) -> None:
        """Proprioception: move every fly by the inverse of the robot's motion ``increment``
        (``relative(prev_odom, new_odom)``). Does nothing when proprioception is off.

        A moved fly is the same point of the world, and its vision fitness was measured on
        images taken before the motion: it stays valid until those images are replaced
        (scoring the moved fly on the same old images would mix two poses). Only the sonar
        term, which depends on where the fly is now relative to the cones, is recomputed."""
        self._scouts.turned(increment.theta)  # scouting reads the turn, proprioception or not
        if not self.config.proprioception:
            return
        if self._numba:
            move_by_odometry(self._pop.xyz, increment)
        else:
            self._pop.xyz = moved_by_odometry(self._pop.xyz, increment)
        self._fused_with = _MOVED

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
        if self._numba:
            return self._step_numba()
        cfg = self.config
        pop = self._pop
        # after a step every fly is evaluated; new images make them all stale
        if pop.stale.all():
            stale = self._all
        else:
            stale = np.flatnonzero(pop.stale) if pop.stale.any() else self._none
        evaluations = self._score(stale)
        nxt = self._spare
        n_immigrants = self._n_immigrants
        # random numbers in this order: sonar arcs, uniform immigrants, breeding
        counts = self._neighbour_counts(pop) if self._sharing else None
        ranked = pop.fitness if counts is None else shared_fitness(
            pop.fitness, counts, cfg.sharing_coefficient
        )  # fmt: skip
        keep = survivor_indices(ranked, self._survivors)
        k = len(keep)
        n_children = cfg.flies - k - n_immigrants
        from_sonar = self._sonar_immigrants(n_immigrants)
        n_sonar = len(from_sonar)
        rate2, rate3, sigma_px, sigma_d = self._breed
        children, uniform = newcomers_numpy(
            self._rng, pop.xyz[keep], n_children, n_immigrants - len(from_sonar), self.rig,
            rate2=rate2, rate3=rate3, sigma_px=sigma_px, sigma_disparity_px=sigma_d,
            d_min=cfg.d_min, d_max=cfg.d_max, margin=self._margin,
        )  # fmt: skip
        pop.survivors_then(keep, np.concatenate([children, from_sonar, uniform]), out=nxt)
        # Scouting immigrants (flylog.fly.scouts): while turning, the last uniform immigrants
        # move to where new content enters the view; their candidates' evaluations are
        # charged here, the chosen flies are scored with the other newcomers.
        assert self._left is not None and self._right is not None  # set by the first pair
        evaluations += self._scouts.place(
            self._rng, nxt.xyz, n_immigrants, n_sonar, self._left, self._right
        )
        self._pop, self._spare = nxt, pop
        evaluations += self._score(self._newcomers)
        self._generation += 1
        return GenerationStats(
            generation=self._generation,
            evaluations=evaluations,
            image_stamp_ns=self._stamp_ns,
            survivors=k,
            offspring=n_children,
            immigrants=n_immigrants,
            sonar_immigrants=n_sonar,
        )

    def steps(self, count: int) -> list[GenerationStats]:
        """``count`` generations on the newest data, as ``count`` calls of :meth:`step` make
        them (same population, same statistics), in one compiled call with the numba
        backend (:func:`~flylog.fly.generation.generations_kernel`). For a caller that
        gives the engine nothing and reads nothing between them (replay, between two
        ticks)."""
        if count < 1:
            return []
        if self._left is None or not self._numba:
            return [self.step() for _ in range(count)]
        return self._steps_numba(count)

    # --- internals --------------------------------------------------------------------------

    def _step_numba(self) -> GenerationStats:
        return self._steps_numba(1)[0]

    def _steps_numba(self, count: int) -> list[GenerationStats]:
        """:meth:`steps` in one compiled call (:func:`~flylog.fly.generation.generations_kernel`:
        the same kernels, in the same order, as the numpy path's steps), after the parallel
        fitness kernel when enough flies are stale to make it pay."""
        cfg, pop, nxt = self.config, self._pop, self._spare
        reading = self._sonar if self._fuse_sonar else None
        fuse_all = reading is not self._fused_with
        self._fused_with = reading
        sonars = self._no_sonars if reading is None else self._sonars
        left, right, channels = self._rows
        evaluations = 0
        if cfg.flies >= PARALLEL_MIN_EVALUATIONS and pop.stale.any():
            stale = np.flatnonzero(pop.stale)
            evaluations = len(stale)
            if evaluations >= PARALLEL_MIN_EVALUATIONS:
                fitness_into(
                    left, right, channels, pop.xyz, stale, self._rig_constants, cfg.window,
                    float(cfg.guard), self._measure, pop.vision,
                )  # fmt: skip
                pop.stale[stale] = False
                pop.stamp_ns[stale] = self._stamp_ns
                if not fuse_all:  # the kernel fuses only the flies it scores: these too
                    self._fuse(stale, sonars)
            else:
                evaluations = 0
        n_immigrants = self._n_immigrants
        n_sonar = 0 if self._sonar is None else self._sonar_share
        made = np.empty((count, 4), dtype=np.int64)
        images = Images(left, right, channels, self._rig_constants, cfg.window, self._guard,
                        self._measure, self._stamp_ns)  # fmt: skip
        fusion = Fusion(sonars, float(self._cos_half_cone), float(cfg.sonar_tolerance),
                        float(cfg.sonar_bonus))  # fmt: skip
        breeding = Breeding(*self._breed, self._newcomer_k, self._arcs, self._half_cone,
                            self._arc_k, _SONAR_TRIES, n_sonar, n_immigrants)  # fmt: skip
        fraction, c0, c1, in_right, depths, scout_k, *scratch = self._scouts.kernel_args(
            n_immigrants
        )
        scouting = ScoutBundle(float(fraction), float(c0), float(c1), bool(in_right),
                               int(depths), scout_k, *scratch)  # fmt: skip
        generations_kernel(
            count, made, self._rng, images, Flies(*pop.arrays()), Flies(*nxt.arrays()),
            fuse_all, fusion, self._selection(), breeding, scouting, self._scratch,
        )  # fmt: skip
        if count % 2:
            self._pop, self._spare = nxt, pop
        made[0, 0] += evaluations
        first = self._generation + 1
        self._generation += count
        return [
            GenerationStats(
                generation=first + g,
                evaluations=int(e),
                image_stamp_ns=self._stamp_ns,
                survivors=int(kept),
                offspring=int(children),
                immigrants=n_immigrants,
                sonar_immigrants=int(found),
            )
            for g, (e, kept, children, found) in enumerate(made.tolist())
        ]

    def _selection(self) -> Selection:
        cfg = self.config
        grid, ints, uv = self._counter.scratch(cfg.flies)
        return Selection(self._survivors, self._sharing, float(cfg.sharing_coefficient), self._work,
                         self._radius, grid, ints, uv, self._counter.counts)  # fmt: skip

    def _fuse(self, index: np.ndarray, sonars: np.ndarray) -> None:
        """The fused fitness of the flies ``index`` from their vision fitness."""
        pop, cfg = self._pop, self.config
        left, right, channels = self._rows
        score_into(
            left, right, channels, pop.xyz, self._none, self._rig_constants, cfg.window,
            float(cfg.guard), self._stamp_ns, pop.vision, pop.stale, pop.stamp_ns, sonars,
            self._cos_half_cone, cfg.sonar_tolerance, cfg.sonar_bonus, index, pop.fitness,
            self._measure,
        )  # fmt: skip

    def _random(self, n: int) -> np.ndarray:
        cfg = self.config
        return random_flies(
            self._rng, self.rig, n, d_min=cfg.d_min, d_max=cfg.d_max, margin=self._margin
        )

    def _breeding(self) -> tuple[float, float, float, float]:
        """(rate2, rate3, σ_px, σ_disparity) of this configuration."""
        cfg = self.config
        return (
            cfg.crossover2_rate if cfg.crossover2 else 0.0,
            cfg.crossover3_rate if cfg.crossover3 else 0.0,
            cfg.mutation_scale * self._radius,
            cfg.disparity_mutation_scale * self._radius,
        )

    def _score(self, index: np.ndarray) -> int:
        """The numpy path's scoring: vision fitness of the flies ``index`` (all stale) on the
        newest images, then the fused fitness of those (of every fly if the reading changed
        or the flies moved). Returns how many were evaluated."""
        reading = self._sonar if self._fuse_sonar else None
        fuse = index
        if reading is not self._fused_with:
            fuse, self._fused_with = self._all, reading
        self._score_numpy(index, fuse, reading)
        return len(index)

    def _score_numpy(
        self, index: np.ndarray, fuse: np.ndarray, reading: SonarReading | None
    ) -> None:
        pop, cfg = self._pop, self.config
        assert self._left is not None and self._right is not None
        if len(index):
            pop.vision[index] = fitness_numpy(
                self._left, self._right, pop.xyz[index], self.rig, cfg.window, cfg.guard,
                gradient=cfg.gradient, similarity=cfg.similarity, subpixel=cfg.subpixel,
            )  # fmt: skip
            pop.stale[index] = False
            pop.stamp_ns[index] = self._stamp_ns
        if len(fuse) == 0:
            return
        if reading is None or len(self._sonars) == 0:
            pop.fitness[fuse] = pop.vision[fuse]
        else:
            pop.fitness[fuse] = sonar_fused(
                pop.vision[fuse], pop.xyz[fuse], reading, bonus=cfg.sonar_bonus,
                tolerance=cfg.sonar_tolerance, use_numba=False,
            )  # fmt: skip

    def _neighbour_counts(self, pop: Population) -> np.ndarray:
        """The numpy path's neighbour counts: each valid fly's neighbours within R in the left
        image (the compiled path counts them in :meth:`Population.select_sharing_into`)."""
        u_left, _, v, _ = self.rig.project(pop.xyz)
        return neighbour_counts_numpy(u_left, v, pop.fitness > INVALID_FITNESS, self._radius)

    @property
    def _half_cone(self) -> float:
        return 0.0 if self._sonar is None else float(self._sonar.half_cone)

    def _n_sonar(self, n_immigrants: int) -> int:
        """How many of the immigrants to place on sonar arcs (0 when that is off)."""
        cfg = self.config
        if not cfg.sonar_immigration or self._sonar is None:
            return 0
        return round(cfg.sonar_immigration_fraction * n_immigrants)

    def _sonar_immigrants(self, n_immigrants: int) -> np.ndarray:
        """The numpy path's sonar immigrants (the compiled one draws them with the rest)."""
        n = self._n_sonar(n_immigrants)
        if n == 0:
            return np.empty((0, 3))
        assert self._sonar is not None
        return sonar_immigrants(
            self._rng, self._sonar, n, self.rig, tolerance=self.config.sonar_tolerance,
            margin=self._margin, tries=_SONAR_TRIES,
        )  # fmt: skip
