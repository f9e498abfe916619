"""The engine and the planner wired together, as the virtual clock drives them.

Used by replay (sensor records from a log) and by the simulator's closed loop (records as
they are produced): the paper's shared memory (Fig. 6) is the published population, which
the planner reads at its own rate, and the planner's newest command. The engine is the fly
engine or, with ``stereo = "sgbm"``, the conventional SGBM baseline: same interface, same
planner, same outputs.

The collaborators, one job each: :mod:`~flylog.replay.engines` (which engine),
:mod:`~flylog.replay.pose_tracker` (the pose at each image, heading-corrected),
:class:`Publication` (what ticks see), :mod:`~flylog.replay.obstacle_cache` (the obstacle
rule's answers), :mod:`~flylog.replay.planner_jobs` (ticks and snapshots, encoded) and
:mod:`~flylog.replay.worker` (their queue and the writing).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from flylog.fly.engine import GenerationStats
from flylog.fly.population import Population
from flylog.geometry import Pose2D, StereoRig
from flylog.planner import Command, HarmonicPlanner
from flylog.replay.config import ReplayConfig
from flylog.replay.engines import StereoEngine, photometric_evaluations, stereo_engine
from flylog.replay.obstacle_cache import Candidates
from flylog.replay.overlay import best_valid_flies
from flylog.replay.planner_jobs import (
    PlannerJobs,
    Published,
    SnapshotInputs,
    TickInputs,
    path_poses,
)
from flylog.replay.pose_tracker import KEYFRAME_FLIES, ODOM_HISTORY, PoseTracker, pose_at
from flylog.replay.worker import MAX_PENDING_JOBS, OutputQueue, Write
from flylog.sensors import OdomReading, SonarReading, StereoPair

# What other modules import from here.
__all__ = [
    "KEYFRAME_FLIES",
    "MAX_PENDING_JOBS",
    "ODOM_HISTORY",
    "PLANNER_TICK",
    "SNAPSHOT_TICK",
    "FlyPipeline",
    "Publication",
    "StereoEngine",
    "Write",
    "best_valid_flies",
    "path_poses",
    "pose_at",
    "stereo_engine",
]

PLANNER_TICK = "planner"
SNAPSHOT_TICK = "snapshot"


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


class FlyPipeline:
    """Implements :class:`flylog.replay.clock.Pipeline` over a stereo engine (the FlyEngine or
    the SgbmEngine, :func:`stereo_engine`) and a HarmonicPlanner.

    ``write(topic, t_ns, message)`` receives every output message; ``on_row`` one row of the
    per-step table per planner tick. ``write_tf`` is off in the closed loop, where the
    simulator writes odom → base_link itself.

    With ``planner_thread``, the planner's work (each tick, and each snapshot: the flies,
    the potential and the path), the encoding of every output and its writing run on a
    worker thread while the engine goes on (replay: the planner does not feed back into the
    engine); ``write`` and ``on_row`` are then called on that thread only. Inputs are taken
    at the virtual time of the tick, the worker runs the jobs in order, and all outputs are
    written in the order they are asked for, so the output is identical message for
    message; at most ``MAX_PENDING_JOBS`` wait. :attr:`command` is then the newest command
    *written*: the closed loop, which needs each command at once, runs without the thread.
    Call :meth:`flush` when the clock has finished, and :meth:`close` in any case.
    """

    def __init__(
        self,
        config: ReplayConfig,
        rig: StereoRig,
        start: Pose2D,
        goal: tuple[float, float],
        write: Write,
        *,
        write_tf: bool = True,
        on_row: Callable[[dict[str, Any]], None] | None = None,
        planner_thread: bool = False,
        planner: bool = True,
    ) -> None:
        self.config = config
        self.rig = rig
        self.engine = stereo_engine(config, rig)
        # centred between start and goal, so both fit whenever they are extent apart at most
        centre = ((start.x + goal[0]) / 2.0, (start.y + goal[1]) / 2.0)
        self.planner = HarmonicPlanner.centred_on(config.planner, centre, goal)
        self._poses = PoseTracker(config.heading, rig, start, config.engine.similarity)
        self.published = Publication(self.engine, start)
        self._candidates = Candidates(config.obstacles)
        self._jobs = PlannerJobs(
            config,
            rig,
            self.planner,
            write_tf=write_tf,
            rows=on_row is not None,
            planner_outputs=planner,
        )
        self._queue = OutputQueue(write, on_row, threaded=planner_thread)
        self._last_stats: GenerationStats | None = None
        self._pair: StereoPair | None = None  # newest stereo pair delivered
        self._sonar: tuple[SonarReading, Pose2D] | None = None  # newest, and odometry then
        # Evaluations made outside the engine's generations (the heading's measurement, the
        # obstacle rule's distinctness), charged to the next generation.
        self._owed_evaluations = 0
        self._evaluations = 0
        # the photometric matching of each pair, in evaluations (flylog.fly.photometric)
        self._photometric_cost = photometric_evaluations(config, rig)
        self.snapshots = 0
        if planner and config.planner.warm_start_sweeps:
            self._queue.submit(self._jobs.warm_start)  # on the worker, while the engine starts

    @property
    def pose(self) -> Pose2D:
        """The robot's pose now: the newest odometry, heading-corrected."""
        return self._poses.odom.pose

    @property
    def command(self) -> Command:
        """The planner's newest command written."""
        return self._queue.command

    # --- the clock's Pipeline protocol (flylog.replay.clock says when each is called) -----

    def deliver(self, record: object) -> None:
        self.published.before_record()
        if isinstance(record, StereoPair):
            moved = self._poses.at_pair(record, lambda: self.engine.population)
            self._owed_evaluations += moved.evaluations
            if moved.motion is not None:
                self.engine.apply_motion(moved.motion)
            # the distinctness test scores flies on the images they were scored on
            self._pair = self.engine.set_images(record)
            self._owed_evaluations += self._photometric_cost
        elif isinstance(record, SonarReading):
            self.engine.set_sonar(record)
            self._sonar = (record, self._poses.odom.pose)
        elif isinstance(record, OdomReading):
            self._poses.add_odometry(record)
        else:
            msg = f"the pipeline cannot use a {type(record).__name__}"
            raise TypeError(msg)

    def generation(self, tick_before_publish: bool, /) -> tuple[int, int]:
        return self.run_generations(1, tick_before_publish)[0]

    def run_generations(self, count: int, tick_before_publish: bool, /) -> list[tuple[int, int]]:
        """``count`` generations in one call of the engine (:meth:`FlyEngine.steps`)."""
        self.published.before_generations(tick_before_publish)
        out = []
        for stats in self.engine.steps(count):
            evals = stats.evaluations + self._owed_evaluations
            self._owed_evaluations = 0
            self._evaluations += evals
            out.append((evals, self.config.generation_cost_ns(evals)))
            self._last_stats = stats
        return out

    def publish(self, t_ns: int) -> None:
        assert self._last_stats is not None
        pose = self._poses.at_images or self._poses.odom.pose
        self.published.publish(pose, self._last_stats, self._pair)

    def tick(self, name: str, t_ns: int) -> None:
        if name == PLANNER_TICK:
            inputs = TickInputs(
                t_ns, self._seen(), self._evaluations, self._poses.odom, self._sonar
            )
            self._queue.submit(self._jobs.tick, inputs)
        elif name == SNAPSHOT_TICK:
            self.snapshots += 1
            snapshot = SnapshotInputs(t_ns, self._seen(), self._poses.odom.pose)
            self._queue.submit(self._jobs.snapshot, snapshot)
        else:
            msg = f"unknown tick {name!r}"
            raise ValueError(msg)

    # --- the end of a run -----------------------------------------------------------------

    def flush(self) -> None:
        """Wait until the worker thread has written every output asked for."""
        self._queue.flush()

    def close(self) -> None:
        """Stop the planner's worker thread (after :meth:`flush`, or to abandon a run)."""
        self._queue.close()

    def _seen(self) -> Published:
        """The publication as a tick sees it now: the population an immutable copy the
        worker may read, with the obstacle rule's candidates (their distinctness test's
        evaluations charged to the next generation, once a publication)."""
        published = self.published
        pop = published.population()
        candidates, evaluations = self._candidates.of(pop, published.generation)
        self._owed_evaluations += evaluations
        return Published(
            pop,
            published.pose,
            published.image_stamp_ns,
            published.generation,
            published.pair,
            candidates,
        )
