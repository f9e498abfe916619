"""The paper's shared memory (Fig. 6) on the engine's side: the newest population published,
and what a planner tick or a snapshot sees of it, captured at its virtual time."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flylog.fly.engine import GenerationStats
from flylog.fly.population import Population
from flylog.geometry import Pose2D
from flylog.replay.engines import StereoEngine
from flylog.sensors import StereoPair


@dataclass(frozen=True)
class Published:
    """The newest publication, as a tick or a snapshot sees it."""

    population: Population | None  # an immutable copy (None: none yet)
    pose: Pose2D  # odometry the population is expressed at
    image_stamp_ns: int  # stamp of the images it was scored on (-1: none yet)
    generation: int
    pair: StereoPair | None  # the images it was scored on (None: none yet)
    candidates: np.ndarray | None  # the flies whose distinctness the rule reads (or None)


class Publication:
    """The newest population published, and where and when it was computed: what ticks
    see.

    Publishing does not copy the population: it is copied when first read, and before
    anything changes it (a delivered record, a generation a tick may follow before the next
    publish): a copy per generation costs 4 % of the replay's main thread. A generation no
    tick can follow before the next publish drops it instead (the clock says which).
    """

    def __init__(self, engine: StereoEngine, start: Pose2D) -> None:
        self._engine = engine
        self._population: Population | None = None
        self._live = False  # what is published is the engine's population, as it is
        self._gone = False  # ... and a generation has moved it on: none may read it
        self.pose = start  # odometry the population is expressed at
        self.image_stamp_ns = -1  # stamp of the images it was scored on (-1: none yet)
        self.generation = 0
        self.pair: StereoPair | None = None  # the images it was scored on

    def publish(self, pose: Pose2D, stats: GenerationStats, pair: StereoPair | None) -> None:
        """The engine's population, as ``stats`` left it, becomes what ticks see."""
        self._live, self._gone = True, False
        self.pose = pose
        self.image_stamp_ns = stats.image_stamp_ns
        self.generation = stats.generation
        self.pair = pair

    def population(self) -> Population | None:
        """The newest population published (an immutable copy), as ticks see it."""
        if self._gone:
            msg = "a tick read a published population that a generation has moved on"
            raise RuntimeError(msg)
        if self._live:
            self._population = self._engine.population
            self._live = False
        return self._population

    def before_record(self) -> None:
        """A record is about to change the engine's population: copy what was published."""
        if self._live:
            self.population()

    def before_generations(self, tick_before_publish: bool) -> None:
        """Generations are about to change the engine's population: copy what was
        published if a tick may read it before the next publish, drop it if none can."""
        if tick_before_publish:
            self.population()
        elif self._live:
            self._live, self._gone = False, True
