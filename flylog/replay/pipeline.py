"""The engine and the planner wired together, as the virtual clock drives them.

Used by replay (sensor records from a log) and by the simulator's closed loop (records as
they are produced): the paper's shared memory (Fig. 6) is the published population, which
the planner reads at its own rate, and the planner's newest command. The engine is the fly
engine or, with ``stereo = "sgbm"``, the conventional SGBM baseline: same interface, same
planner, same outputs.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from flylog.fly.engine import FlyEngine, GenerationStats
from flylog.fly.fusion import moved_by_odometry
from flylog.fly.heading import fused_yaw, measure_yaw
from flylog.fly.population import Population
from flylog.geometry import Pose2D, StereoRig, compose, inverse, relative, transform_points_2d
from flylog.geometry.poses import wrap_angle
from flylog.io import contract, encode
from flylog.io.readahead import lower_thread_priority
from flylog.planner import Command, HarmonicPlanner, Status
from flylog.planner.obstacles import sonar_arc_points
from flylog.replay.config import ReplayConfig, Stereo
from flylog.sensors import OdomReading, SonarReading, StereoPair

Write = Callable[[str, int, Any], None]

PLANNER_TICK = "planner"
SNAPSHOT_TICK = "snapshot"


@dataclass(frozen=True)
class _TickInputs:
    """What a planner tick at ``t_ns`` sees, captured at that virtual time."""

    t_ns: int
    population: Population | None  # the newest published (an immutable copy)
    published_pose: Pose2D  # odometry the population is expressed at
    image_stamp_ns: int  # stamp of the images it was scored on (-1: none yet)
    generation: int
    evaluations: int
    odom: OdomReading  # the newest odometry delivered
    pair: StereoPair | None  # the images the population was scored on (None: none yet)
    candidates: np.ndarray | None  # the flies whose distinctness the rule reads (or None)
    sonar: tuple[SonarReading, Pose2D] | None  # the newest sonar reading, and odometry then


@dataclass(frozen=True)
class _Outputs:
    """What one piece of the pipeline's work writes: messages, and for a planner tick its
    command and its row of the per-step table."""

    messages: list[tuple[str, int, Any]]
    command: Command | None = None
    row: dict[str, Any] | None = None


# Planner jobs that may wait for the worker thread before the engine waits for them.
MAX_PENDING_JOBS = 8


class StereoEngine(Protocol):
    """What the pipeline needs of an engine (FlyEngine and SgbmEngine implement it)."""

    def set_images(self, pair: StereoPair) -> None: ...

    def set_sonar(self, reading: SonarReading) -> None: ...

    def apply_motion(self, increment: Pose2D) -> None: ...

    def step(self) -> GenerationStats: ...

    def steps(self, count: int) -> list[GenerationStats]: ...

    @property
    def population(self) -> Population: ...


def stereo_engine(config: ReplayConfig, rig: StereoRig) -> StereoEngine:
    """The engine ``config.stereo`` names; SGBM samples as many points as there are flies."""
    if config.stereo is Stereo.SGBM:
        from flylog.baseline.sgbm import SgbmEngine  # OpenCV only when asked for

        return SgbmEngine(config.sgbm, rig, points=config.engine.flies)
    return FlyEngine(config.engine, rig, np.random.default_rng(config.seed))


ODOM_HISTORY = 16  # odometry readings kept to find the pose at an image's stamp


def pose_at(readings: deque[OdomReading], stamp_ns: int) -> Pose2D:
    """The odometric pose at ``stamp_ns``: linear between the two readings around it (the
    heading along the shorter way); past the newest reading, the newest two's motion carried
    on for at most one interval between them (records come in stamp order: an image is
    delivered before the reading after it, up to an odometry period later, 10 mrad of turn
    at 0.5 rad/s); before the oldest kept, the oldest."""
    newest = readings[-1]
    if stamp_ns >= newest.stamp_ns:
        if len(readings) < 2 or stamp_ns == newest.stamp_ns:
            return newest.pose
        previous = readings[-2]
        span = newest.stamp_ns - previous.stamp_ns
        if span <= 0:
            return newest.pose
        return _along(
            previous.pose, newest.pose, 1.0 + min(stamp_ns - newest.stamp_ns, span) / span
        )
    later = newest
    for earlier in reversed(readings):
        if earlier.stamp_ns <= stamp_ns:
            if later.stamp_ns == earlier.stamp_ns:
                return earlier.pose
            a = (stamp_ns - earlier.stamp_ns) / (later.stamp_ns - earlier.stamp_ns)
            return _along(earlier.pose, later.pose, a)
        later = earlier
    return later.pose


def _along(p: Pose2D, q: Pose2D, a: float) -> Pose2D:
    """The pose a fraction ``a`` of the way from p to q (a > 1: beyond q), position and
    heading (the shorter way) linear."""
    turn = wrap_angle(q.theta - p.theta)
    return Pose2D(p.x + a * (q.x - p.x), p.y + a * (q.y - p.y), wrap_angle(p.theta + a * turn))


KEYFRAME_FLIES = 3  # flies kept with a keyframe, per one compared (some leave the view)


@dataclass
class _Keyframe:
    """The pair the next heading measurement compares with: its flies (base_link there), the
    robot's pose there, and what came since (pairs, the odometry's heading variance)."""

    pair: StereoPair
    xyz: np.ndarray
    pose: Pose2D
    pairs: int = 0
    variance: float = 0.0


class FlyPipeline:
    """Implements :class:`flylog.replay.clock.Pipeline` over a stereo engine (the FlyEngine or
    the SgbmEngine, :func:`stereo_engine`) and a HarmonicPlanner.

    ``write(topic, t_ns, message)`` receives every output message; ``on_row`` one row of the
    per-step table per planner tick. ``write_tf`` is off in the closed loop, where the
    simulator already writes odom → base_link.

    With ``planner_thread``, the planner's work (each tick, and each snapshot: the flies,
    the potential and the path), the encoding of every output and its writing run on a
    worker thread while the engine goes on (replay: the planner does not feed back into the
    engine); ``write`` and ``on_row`` are then called on that thread only. Inputs are taken
    at the virtual time of the tick, the worker runs the jobs in order, and all outputs are
    written in the order they were asked for, so the output is identical message for
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
    ) -> None:
        self.config = config
        self.rig = rig
        self._mapping_range = config.planner.mapping_range(rig.focal_px, rig.baseline)
        self.engine = stereo_engine(config, rig)
        # centred between start and goal, so both fit whenever they are extent apart at most
        centre = ((start.x + goal[0]) / 2.0, (start.y + goal[1]) / 2.0)
        self.planner = HarmonicPlanner.centred_on(config.planner, centre, goal)
        self._write = write
        self._write_tf = write_tf
        self._on_row = on_row
        self._odom = OdomReading(0, start)  # newest odometry delivered (heading-corrected)
        # the last readings as delivered, to find the odometry at an image's stamp (16 at
        # 50 Hz: 0.3 s, more than --sync's delay of one frame period)
        self._odom_history: deque[OdomReading] = deque([self._odom], maxlen=ODOM_HISTORY)
        # the visual heading's correction (config.heading): the robot's pose is this ⊕ the
        # odometry's (None: none yet, the odometry's pose as it is)
        self._correction: Pose2D | None = None
        self._keyframe: _Keyframe | None = None  # what the next heading measurement uses
        # (corrected) odometry at the stamp of the images the population is scored on: the
        # flies are expressed in base_link there (the pose published with them)
        self._engine_pose: Pose2D | None = None
        self._last_stats: GenerationStats | None = None
        # what ticks see: the newest population published, and where the robot was then
        self._published: Population | None = None
        # Publishing does not copy the population: ticks copy it when they read it, and so do
        # a delivered record and a generation that a tick may follow before the next publish
        # (the clock says): a copy per generation cost 4 % of the replay's main thread.
        self._published_live = False  # what was published is the engine's population, now
        self._published_gone = False  # ... and a generation has moved it on: none may read
        self._published_pose = start
        self._published_image_ns = -1
        self._published_generation = 0
        self._pair: StereoPair | None = None  # newest stereo pair delivered
        self._sonar: tuple[SonarReading, Pose2D] | None = None  # newest, and odometry then
        self._published_pair: StereoPair | None = None  # ... when the population was published
        self._evidence: tuple[int, np.ndarray, np.ndarray | None] | None = None  # _obstacles
        # Distinctness is measured once a published population, on the worker, for the
        # candidates found here (_published_candidates); its fitness evaluations are charged
        # to the next generation.
        self._candidates: tuple[int, np.ndarray] | None = None  # (generation, mask)
        self._owed_evaluations = 0
        self._evaluations = 0
        self.command = Command(0.0, 0.0, Status.DRIVING)
        self.snapshots = 0
        # the worker runs nicer than the engine's thread (see flylog.io.readahead)
        self._worker = (
            ThreadPoolExecutor(1, "flylog-planner", initializer=lower_thread_priority)
            if planner_thread
            else None
        )
        self._pending: deque[Future[None]] = deque()  # the worker's jobs, in the order asked for
        if config.planner.warm_start_sweeps:
            self._submit(self._warm_start)  # on the worker, while the engine starts

    def _warm_start(self) -> _Outputs:
        """Relax the obstacle-free field before the first tick (planner.warm_start_sweeps)."""
        cfg = self.config.planner
        self.planner.relax_until(cfg.relax_tolerance, cfg.warm_start_sweeps, chunk=100)
        return _Outputs([])

    # --- the clock's Pipeline protocol -----------------------------------------------------

    def deliver(self, record: object) -> None:
        # records change the engine's population (odometry moves the flies), which ticks
        # until the next publish must not see: copy what was published first
        if self._published_live:
            self._published_population()
        if isinstance(record, StereoPair):
            # Proprioception at each new pair, by the odometry between the two pairs' stamps:
            # the flies are scored on the pair's images, so they must be expressed where the
            # robot was when those were taken. Moved to the newest odometry instead, they were
            # scored (and bred) up to a frame period (and, --sync, two) off their images'
            # pose: 20-30 mrad of rotation at 0.5 rad/s, in the published cloud too.
            odometry = pose_at(self._odom_history, record.stamp_ns)
            pose = self._corrected(odometry)
            if self._engine_pose is not None:
                pose = self._heading_measured(record, odometry, pose)
                self.engine.apply_motion(relative(self._engine_pose, pose))
            self._engine_pose = pose
            self.engine.set_images(record)
            self._pair = record
        elif isinstance(record, SonarReading):
            self.engine.set_sonar(record)
            self._sonar = (record, self._odom.pose)
        elif isinstance(record, OdomReading):
            self._odom_history.append(record)
            self._odom = OdomReading(record.stamp_ns, self._corrected(record.pose))
        else:
            msg = f"the pipeline cannot use a {type(record).__name__}"
            raise TypeError(msg)

    @property
    def pose(self) -> Pose2D:
        """The robot's pose now: the newest odometry, heading-corrected."""
        return self._odom.pose

    def _corrected(self, odometry: Pose2D) -> Pose2D:
        """The robot's pose for an odometric pose: the heading's correction ⊕ it."""
        return odometry if self._correction is None else compose(self._correction, odometry)

    def _heading_measured(self, pair: StereoPair, odometry: Pose2D, pose: Pose2D) -> Pose2D:
        """The robot's pose at ``pair`` (``pose``, from ``odometry`` there), its heading
        corrected, when a measurement is due and the robot turned since the keyframe, by the
        flies' measurement of the turn since the keyframe fused with the odometry's
        (config.heading); the correction then applies to all odometry. The pair that was due,
        with the flies fitted to it, is the next keyframe."""
        cfg, previous = self.config.heading, self._pair
        assert self._engine_pose is not None
        if not cfg.enabled or previous is None:
            return pose
        if self._keyframe is None:
            pop = self.engine.population
            fittest = np.argsort(-pop.fitness, kind="stable")
            fittest = fittest[pop.fitness[fittest] > 0][: KEYFRAME_FLIES * cfg.flies]
            self._keyframe = _Keyframe(previous, pop.xyz[fittest], self._engine_pose)
        key = self._keyframe
        key.pairs += 1
        key.variance += cfg.odometry_variance(
            relative(self._engine_pose, pose), (pair.stamp_ns - previous.stamp_ns) / 1e9
        )
        since = relative(key.pose, pose)
        if key.variance == 0.0 or not cfg.due(since, key.pairs):
            return pose
        self._keyframe = None
        if abs(since.theta) < math.radians(cfg.min_turn_deg):
            return pose
        measured = measure_yaw(
            (key.pair.left, key.pair.right), (pair.left, pair.right), key.xyz, since,
            self.rig, cfg,
        )  # fmt: skip
        self._owed_evaluations += cfg.evaluations(measured.flies)
        if measured.yaw is None:
            return pose
        sd = cfg.measurement_sd_px / self.rig.focal_px
        turn = fused_yaw(measured.yaw, key.variance, sd, cfg.gate)
        pose = Pose2D(pose.x, pose.y, wrap_angle(pose.theta + turn))
        self._correction = compose(pose, inverse(odometry))
        newest = self._odom_history[-1]
        self._odom = OdomReading(newest.stamp_ns, self._corrected(newest.pose))
        return pose

    def generation(self, keep_published: bool = True) -> tuple[int, int]:
        return self.run_generations(1, keep_published)[0]

    def run_generations(self, count: int, keep_published: bool = False) -> list[tuple[int, int]]:
        """``count`` generations, as ``count`` calls of :meth:`generation` make them, in one
        call of the engine (:meth:`FlyEngine.steps`)."""
        if keep_published:
            self._published_population()
        elif self._published_live:
            self._published_live, self._published_gone = False, True
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
        self._published_live, self._published_gone = True, False
        self._published_pose = self._engine_pose or self._odom.pose
        self._published_image_ns = self._last_stats.image_stamp_ns
        self._published_generation = self._last_stats.generation
        self._published_pair = self._pair

    def _published_population(self) -> Population | None:
        """The newest population published (an immutable copy), as ticks see it."""
        if self._published_gone:
            msg = "a tick read a published population that a generation has moved on"
            raise RuntimeError(msg)
        if self._published_live:
            self._published = self.engine.population
            self._published_live = False
        return self._published

    def tick(self, name: str, t_ns: int) -> None:
        if name == PLANNER_TICK:
            self._planner_tick(t_ns)
        elif name == SNAPSHOT_TICK:
            self._snapshot(t_ns)
        else:
            msg = f"unknown tick {name!r}"
            raise ValueError(msg)

    # --- planner ---------------------------------------------------------------------------

    def _planner_tick(self, t_ns: int) -> None:
        pop = self._published_population()
        tick = _TickInputs(
            t_ns,
            pop,
            self._published_pose,
            self._published_image_ns,
            self._published_generation,
            self._evaluations,
            self._odom,
            self._published_pair,
            self._published_candidates(pop),
            self._sonar,
        )
        self._submit(self._run_tick, tick)

    def flush(self) -> None:
        """Wait until the worker thread has written every output asked for."""
        while self._pending:
            self._pending.popleft().result()

    def close(self) -> None:
        """Stop the planner's worker thread (after :meth:`flush`, or to abandon a run)."""
        if self._worker is not None:
            self._worker.shutdown(wait=True, cancel_futures=True)
            self._worker = None
            self._pending.clear()

    def _submit(self, job: Callable[..., _Outputs], *args: Any) -> None:
        """Run ``job`` (work the engine does not wait for) and write its outputs: on the
        worker, which runs the jobs in the order asked for and writes each one's outputs as
        it ends (so the engine's thread neither encodes nor writes them), or at once without
        one. A job's error is raised here, at a later call, or by :meth:`flush`."""
        if self._worker is None:
            self._emit(job(*args))
            return
        self._pending.append(self._worker.submit(self._run_and_emit, job, args))
        while self._pending and (self._pending[0].done() or len(self._pending) > MAX_PENDING_JOBS):
            self._pending.popleft().result()

    def _run_and_emit(self, job: Callable[..., _Outputs], args: tuple[Any, ...]) -> None:
        self._emit(job(*args))

    def _emit(self, outputs: _Outputs) -> None:
        for topic, t_ns, message in outputs.messages:
            self._write(topic, t_ns, message)
        if outputs.command is not None:
            self.command = outputs.command
        if outputs.row is not None and self._on_row is not None:
            self._on_row(outputs.row)

    def _run_tick(self, tick: _TickInputs) -> _Outputs:
        """The planner's work at one tick: obstacles in, relaxation, command, table row."""
        pop = tick.population
        if pop is None:
            obstacles = np.empty((0, 3))
        else:
            mask, _ = self._obstacles(pop, tick.pair, tick.generation, tick.candidates)
            obstacles = pop.xyz[mask]
            in_odom = transform_points_2d(tick.published_pose, obstacles[:, :2])
            self.planner.update_obstacles(
                in_odom,
                tick.published_pose,
                self.rig.half_fov,
                view_range=self._mapping_range,
                sonar_xy=self._echoes(tick),
                focal_baseline=self.rig.focal_px * self.rig.baseline,
            )
        change = self.planner.relax()
        pose, t_ns = tick.odom.pose, tick.t_ns
        command = self.planner.command(pose, t_ns / 1e9)
        status = contract.CommandStatus(command.status.value)
        message = encode.command(command.linear, command.angular, status, t_ns)
        messages = [(contract.PLANNER_COMMAND, t_ns, message)]
        if self._on_row is None:
            return _Outputs(messages, command)
        valid = pop.fitness[pop.fitness > 0] if pop is not None else np.empty(0)
        row = {
            "t": t_ns / 1e9,
            "generation": tick.generation,
            "evaluations": tick.evaluations,
            "valid_flies": len(valid),
            "obstacle_flies": len(obstacles),
            "best_fitness": float(valid.max()) if len(valid) else math.nan,
            "median_fitness": float(np.median(valid)) if len(valid) else math.nan,
            "image_latency": (t_ns - tick.image_stamp_ns) / 1e9
            if tick.image_stamp_ns >= 0
            else math.nan,
            "odom_latency": (t_ns - tick.odom.stamp_ns) / 1e9,
            "x": pose.x,
            "y": pose.y,
            "theta": pose.theta,
            "linear": command.linear,
            "angular": command.angular,
            "status": status.value,
            "potential_change": change,
        }
        return _Outputs(messages, command, row)

    def _echoes(self, tick: _TickInputs) -> np.ndarray | None:
        """The newest sonar reading's near echoes (planner.sonar_range) as arc points in
        odom, for the planner (None: none)."""
        reach = self.config.planner.sonar_range
        if tick.sonar is None or reach <= 0.0:
            return None
        reading, pose = tick.sonar
        arcs = sonar_arc_points(reading, reach, 0.5 * self.config.planner.cell_size)
        return transform_points_2d(pose, arcs) if len(arcs) else None

    # --- snapshots -------------------------------------------------------------------------

    def _snapshot(self, t_ns: int) -> None:
        self.snapshots += 1
        pop = self._published_population()  # immutable: the worker may read it
        published = (
            self._published_pose,
            self._published_pair,
            self._published_generation,
            self._published_candidates(pop),
        )
        self._submit(self._snapshot_outputs, t_ns, pop, *published, self._odom.pose)

    def _snapshot_outputs(
        self,
        t_ns: int,
        pop: Population | None,
        published_pose: Pose2D,
        pair: StereoPair | None,
        generation: int,
        candidates: np.ndarray | None,
        robot_pose: Pose2D,
    ) -> _Outputs:
        """A snapshot's messages: the flies (with each fly's distinctness when the obstacle
        rule reads it) in base_link at ``robot_pose`` (the newest odometry), their overlay
        and odom → base_link there (when a population was published), then the planner's
        potential and path."""
        messages: list[tuple[str, int, Any]] = []
        if pop is not None:
            distinct = None
            if candidates is not None:
                distinct = self._obstacles(pop, pair, generation, candidates)[1]
            uv, colours = self._overlay(pop)  # on the images the flies were scored on
            # The flies are expressed where the robot was when their images were taken; the
            # cloud goes out in base_link at the snapshot's time, like every message (the
            # metrics render the truth there).
            xyz = pop.xyz
            if published_pose != robot_pose:
                xyz = moved_by_odometry(xyz, relative(published_pose, robot_pose))
            cloud = encode.point_cloud(
                xyz, pop.fitness, t_ns, contract.BASE_FRAME, pop.age, distinct=distinct
            )
            messages += [
                (contract.FLIES, t_ns, cloud),
                (contract.FLIES_OVERLAY, t_ns, encode.image_annotations(uv, colours, t_ns)),
            ]
            if self._write_tf:
                transform = encode.odom_transform(robot_pose)
                messages.append((contract.TF, t_ns, encode.frame_transforms([transform], t_ns)))
        return _Outputs(messages + self._planner_snapshot(t_ns, robot_pose).messages)

    def _published_candidates(self, pop: Population | None) -> np.ndarray | None:
        """The flies of ``pop`` (the published population) whose distinctness the rule
        reads (None when it reads none), found once a publication; the fitness evaluations
        measuring them will cost are charged to the next generation then."""
        rule = self.config.obstacles
        if pop is None or not rule.uses_distinctness:
            return None
        if self._candidates is None or self._candidates[0] != self._published_generation:
            candidates = rule.candidates(pop.xyz, pop.fitness, pop.age)
            self._candidates = (self._published_generation, candidates)
            self._owed_evaluations += rule.distinct_evaluations(candidates)
        return self._candidates[1]

    def _obstacles(
        self,
        pop: Population,
        pair: StereoPair | None,
        generation: int,
        candidates: np.ndarray | None,
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """The obstacle rule's mask of the population published at ``generation``, and the
        distinctness of its ``candidates`` (None when the rule reads none), measured once a
        publication: planner ticks and snapshots of the same population share it (both run
        in order on the worker thread, or both on the caller's)."""
        if self._evidence is not None and self._evidence[0] == generation:
            return self._evidence[1], self._evidence[2]
        rule = self.config.obstacles
        if candidates is None:
            mask, distinct = rule.mask(pop.xyz, pop.fitness, pop.age), None
        else:
            distinct = rule.distinct_of(pop.xyz, candidates, pair, self.rig, self.config.engine)
            mask = rule.keep(candidates, distinct)
        self._evidence = (generation, mask, distinct)
        return mask, distinct

    def _planner_snapshot(self, t_ns: int, robot_pose: Pose2D) -> _Outputs:
        """The potential and the path the robot would follow from ``robot_pose``, now."""
        ox, oy = self.planner.origin
        grid = encode.grid(
            self.planner.potential, Pose2D(ox, oy, 0.0), self.planner.cell_size, t_ns,
            contract.ODOM_FRAME,
        )  # fmt: skip
        path = encode.poses_in_frame(
            path_poses(self.planner.path(robot_pose)), t_ns, contract.ODOM_FRAME
        )
        return _Outputs(
            [(contract.PLANNER_POTENTIAL, t_ns, grid), (contract.PLANNER_PATH, t_ns, path)]
        )

    def _overlay(self, pop: Population) -> tuple[np.ndarray, np.ndarray]:
        """The best ``overlay_flies`` valid flies projected on the left image, coloured from
        red (lowest shown fitness) to green (best)."""
        best = best_valid_flies(pop.fitness, self.config.overlay_flies)
        k = len(best)
        if k == 0:
            return np.empty((0, 2)), np.empty((0, 4))
        u_left, _, v, _ = self.rig.project(pop.xyz[best])
        f = pop.fitness[best]
        span = f.max() - f.min()
        a = (f - f.min()) / span if span > 0 else np.ones(k)
        colours = np.stack([1.0 - a, a, np.zeros(k), np.ones(k)], axis=1)
        return np.stack([u_left, v], axis=1), colours


def best_valid_flies(fitness: np.ndarray, k: int) -> np.ndarray:
    """Indices of the ``k`` fittest flies of positive fitness, by increasing fitness: the last
    ``k`` of ``np.argsort(fitness[valid], kind="stable")`` (equal fitnesses by index, the
    highest indices kept at the cut), found by a partition and a sort of those ``k`` only,
    5× faster than sorting all the valid flies at each snapshot."""
    valid = np.flatnonzero(fitness > 0)
    f = fitness[valid]
    k = min(k, len(f))
    if k == 0:
        return valid[:0]
    if k < len(f):
        cut = np.partition(f, len(f) - k)[len(f) - k]  # the k-th largest fitness
        above = np.flatnonzero(f > cut)
        at_cut = np.flatnonzero(f == cut)
        chosen = np.sort(np.concatenate([above, at_cut[len(at_cut) - (k - len(above)) :]]))
    else:
        chosen = np.arange(len(f))
    return valid[chosen[np.argsort(f[chosen], kind="stable")]]


def path_poses(points: np.ndarray) -> np.ndarray:
    """(K, 2) path points → (K, 3) poses heading along the path (the last keeps the previous
    heading)."""
    if len(points) == 0:
        return np.empty((0, 3))
    d = np.diff(points, axis=0)
    heading = np.arctan2(d[:, 1], d[:, 0]) if len(d) else np.zeros(0)
    heading = np.append(heading, heading[-1] if len(heading) else 0.0)
    return np.column_stack([points, heading])
