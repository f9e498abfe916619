"""What the fly engine holds between generations, shared by its two back-ends
(:mod:`flylog.fly.numpy_backend`, :mod:`flylog.fly.numba_backend`): the population (and the
arrays the next one is written into), the newest images and sonar reading, and the
configuration worked out once."""

from __future__ import annotations

import math

import numpy as np

from flylog.errors import FlylogError
from flylog.fly.bundles import Images
from flylog.fly.config import EngineConfig, Photometric
from flylog.fly.fitness import as_planes, images_of
from flylog.fly.fusion import fired_arcs, fired_sonars
from flylog.fly.measure import Measure
from flylog.fly.measures import measure_of
from flylog.fly.operators import random_flies
from flylog.fly.photometric import Matching, matched
from flylog.fly.population import Population, sharing_radius
from flylog.fly.scouts import Scouting
from flylog.geometry import StereoRig
from flylog.geometry.rolling import STILL
from flylog.sensors import SonarReading, StereoPair

# Sonar immigrants: candidates are drawn n at a time, at most this many times.
SONAR_TRIES = 8

# Marks the fused fitness as computed before the flies last moved (so: for every fly again).
MOVED = object()


class EngineState:
    """The engine's data: the population ``pop`` (and ``spare``, the arrays the next
    generation is written into), the newest pair and sonar reading, and what a generation
    needs of the (frozen) configuration."""

    def __init__(self, config: EngineConfig, rig: StereoRig, rng: np.random.Generator) -> None:
        if rig.baseline <= 0:
            msg = f"the fly engine needs a stereo baseline > 0, got {rig.baseline} m"
            raise FlylogError(msg)
        self.config = config
        self.rig = rig
        self.rng = rng
        self.margin = config.window // 2
        self.radius = sharing_radius(rig.n_pixels, config.flies)
        first = random_flies(
            rng, rig, config.flies, d_min=config.d_min, d_max=config.d_max, margin=self.margin
        )
        self.pop = Population.fresh(first)
        # The next generation is written into this one's arrays (no allocation per step).
        self.spare = Population.fresh(np.empty((config.flies, 3)))
        self.measure: Measure = measure_of(config.similarity)
        self.everyone = np.arange(config.flies, dtype=np.int64)
        self.newcomers = self.everyone[config.survivors :]
        self.survivors = config.survivors
        self.n_immigrants = config.immigrants
        self.sharing = config.sharing and config.sharing_coefficient > 0
        self.fuse_sonar = config.sonar_fitness and config.sonar_bonus != 0
        # (rate2, rate3, σ_px, σ_disparity) of this configuration
        self.breeding = (
            config.crossover2_rate if config.crossover2 else 0.0,
            config.crossover3_rate if config.crossover3 else 0.0,
            config.mutation_scale * self.radius,
            config.disparity_mutation_scale * self.radius,
        )
        self.left: np.ndarray | None = None
        self.matching: Matching | None = None  # the newest pair's photometric matching
        self.pair: StereoPair | None = None  # the newest pair as the flies are scored on it
        self.readout = STILL  # the newest pair's motion over its readout (a rolling shutter)
        self.right: np.ndarray | None = None
        self.images: Images | None = None  # the pair as the compiled kernels take it
        self.stamp_ns = -1
        self.sonar: SonarReading | None = None
        self.sonars = np.empty((0, 5))  # fired_sonars(self.sonar)
        self.cos_half_cone = 1.0
        self.arcs = np.empty((0, 4))  # fired_arcs(self.sonar)
        # The reading every fly's fitness was fused with (None: fitness = vision); a fly's
        # fitness is recomputed only when its vision is, unless the reading changes.
        self.fused_with: SonarReading | object | None = None  # MOVED after a motion
        self.generation = 0
        self.scouts = Scouting(config, rig, self.margin)

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
        if self.config.photometric is Photometric.MATCHED:
            ml, mr, self.matching = matched(_image(left), _image(right))
            left, right = as_planes(ml), as_planes(mr)
            pair = StereoPair(pair.stamp_ns, ml, mr, pair.readout)
        self.pair = pair
        cfg = self.config
        self.left, self.right, self.stamp_ns = left, right, pair.stamp_ns
        self.readout = pair.readout
        self.images = images_of(
            left,
            right,
            self.rig,
            cfg.window,
            cfg.guard,
            gradient=cfg.gradient,
            subpixel=cfg.subpixel,
            stamp_ns=pair.stamp_ns,
            readout=pair.readout,
        )
        self.pop.stale[:] = True
        self.scouts.new_images()

    def set_sonar(self, reading: SonarReading) -> None:
        """Use this sonar reading (in base_link) for fusion until the next one."""
        self.sonar = reading
        self.sonars = fired_sonars(reading)
        self.cos_half_cone = math.cos(reading.half_cone)
        self.arcs = fired_arcs(reading)

    def n_sonar(self) -> int:
        """How many of the immigrants to place on sonar arcs (0 when that is off)."""
        cfg = self.config
        if not cfg.sonar_immigration or self.sonar is None:
            return 0
        return round(cfg.sonar_immigration_fraction * self.n_immigrants)

    def swap(self) -> None:
        """The next generation, written into ``spare``, becomes the population."""
        self.pop, self.spare = self.spare, self.pop


def _image(planes: np.ndarray) -> np.ndarray:
    """(H, W, C) planes as an image: (H, W) for one channel."""
    return planes[:, :, 0] if planes.shape[2] == 1 else planes
