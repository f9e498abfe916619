"""The engine and the planner wired together, as the virtual clock drives them.

Used by replay (sensor records from a log) and by the simulator's closed loop (records as
they are produced): the paper's shared memory (Fig. 6) is the published population, which
the planner reads at its own rate, and the planner's newest command. The engine is the fly
engine or, with ``stereo = "sgbm"``, the conventional SGBM baseline: same interface, same
planner, same outputs.

The collaborators, one job each: :mod:`~flylog.replay.engines` (which engine),
:mod:`~flylog.replay.pose_tracker` (the pose at each image, heading-corrected),
:mod:`~flylog.replay.publication` (what ticks see), :mod:`~flylog.replay.obstacle_cache`
(the obstacle rule's answers), :mod:`~flylog.replay.planner_jobs` (ticks and the planner's
part of snapshots), :mod:`~flylog.replay.fly_snapshot` (the flies' part), and
:mod:`~flylog.replay.worker` (their queue and the writing).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

from flylog.fly.engine import GenerationStats
from flylog.geometry import Pose2D, StereoRig
from flylog.planner import Command, HarmonicPlanner
from flylog.replay.config import ReplayConfig
from flylog.replay.engines import StereoEngine, photometric_evaluations, stereo_engine
from flylog.replay.fly_snapshot import FlySnapshots, SnapshotInputs
from flylog.replay.obstacle_cache import Candidates, Evidence
from flylog.replay.overlay import best_valid_flies
from flylog.replay.planner_jobs import PlannerJobs, TickInputs, path_poses
from flylog.replay.pose_tracker import KEYFRAME_FLIES, ODOM_HISTORY, PoseTracker, pose_at
from flylog.replay.publication import Publication, Published
from flylog.replay.worker import MAX_PENDING_JOBS, OutputQueue, Outputs, Write
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


class FlyPipeline:
    """Implements :class:`flylog.replay.clock.Pipeline` over a stereo engine (the FlyEngine or
    the SgbmEngine, :func:`stereo_engine`) and a HarmonicPlanner.

    ``write(topic, t_ns, message)`` receives every output message; ``on_row`` one row of the
    per-step table per planner tick. ``row_period_ns``: the cameras' rolling shutter
    (``ReplayInputs.row_period_ns``, 0: global); each pair is given to the engine with the
    robot's motion over its readout (:meth:`PoseTracker.readout`). ``write_tf`` is off in
    the closed loop, where the simulator writes odom → base_link itself.

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
        row_period_ns: float = 0.0,
    ) -> None:
        self.config = config
        self.rig = rig
        # a rolling shutter's readout, the whole image's (0: a global shutter): each pair
        # carries the robot's motion over it, and the flies are scored at their rows' times
        self._readout_ns = round(rig.height * row_period_ns)
        self.engine = stereo_engine(config, rig)
        # centred between start and goal, so both fit whenever they are extent apart at most
        centre = ((start.x + goal[0]) / 2.0, (start.y + goal[1]) / 2.0)
        self.planner = HarmonicPlanner.centred_on(config.planner, centre, goal)
        self._poses = PoseTracker(config.heading, rig, start, config.engine.similarity)
        self.published = Publication(self.engine, start)
        self._candidates = Candidates(config.obstacles)
        evidence = Evidence(config.obstacles, rig, config.engine)
        self._jobs = PlannerJobs(config, rig, self.planner, evidence, rows=on_row is not None)
        self._flies = FlySnapshots(
            rig, evidence, overlay_flies=config.overlay_flies, write_tf=write_tf
        )
        self._planner_outputs = planner
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
            if self._readout_ns > 0:
                readout = self._poses.readout(record.stamp_ns, self._readout_ns)
                record = dataclasses.replace(record, readout=readout)
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
            # the flies and odom → base_link where the robot is at the snapshot's stamp: the
            # newest odometry is up to a reading period older (at 0.5 rad/s on `turn` with
            # realistic cameras, fly precision 0.733 at the newest reading, 0.905 at the stamp)
            snapshot = SnapshotInputs(t_ns, self._seen(), self._poses.at(t_ns))
            self._queue.submit(self._snapshot, snapshot)
        else:
            msg = f"unknown tick {name!r}"
            raise ValueError(msg)

    def _snapshot(self, snap: SnapshotInputs) -> Outputs:
        """A snapshot's messages (a job of the queue): the flies', then the planner's
        (without ``planner``, the flies' only)."""
        messages = self._flies.snapshot(snap)
        if self._planner_outputs:
            messages += self._jobs.snapshot(snap.t_ns, snap.robot_pose)
        return Outputs(messages)

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
