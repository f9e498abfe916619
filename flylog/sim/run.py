"""The simulate loop: drive the robot through a scene and record every sensor as MCAP.

Each sensor keeps its own rate (cameras ``camera.frame_rate``, sonars ``sonar.rate``,
odometry ``odometry.rate``). Between two sensor events both poses advance with the command
in force (trajectory noise drawn per odometry step); the driver is asked for a new command
at every odometry step, from the odometric pose (what the robot knows). The cameras and the
sonars see the world from the TRUE pose. The odometric pose is initialised with the true
start pose, so the ``odom`` frame coincides with the scene's world frame at t = 0; the true
pose is written only under ``/truth/``.
"""

from __future__ import annotations

import dataclasses
import heapq
import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Protocol

import numpy as np

from flylog.budget import DEFAULT_LIMITS, Estimate, Limits, simulation_estimate
from flylog.config import to_mapping
from flylog.geometry import Pose2D
from flylog.geometry.poses import yaw_quaternion
from flylog.io import contract, encode
from flylog.io.collisions import Role, check_outputs
from flylog.io.decode import yaw_of
from flylog.io.shutter import shutter_metadata
from flylog.io.writer import LogConfig, LogWriter
from flylog.scene.load import Scene
from flylog.sensors import OdomReading, SonarReading, StereoPair
from flylog.sim.camera_defects import CameraDefects, check_exposure, check_readout
from flylog.sim.drive import Driver, PlanDriver
from flylog.sim.kinematics import RobotPoses, advance_poses
from flylog.sim.scene_view import scene_shapes

# Static transforms and the scene are re-sent at this period, so a viewer that seeks into
# the middle of a log still finds them.
_STATIC_PERIOD_NS = 1_000_000_000
DEFAULT_DURATION = 20.0


Write = Callable[[str, int, object], None]


class ClosedLoopDriver(Driver, Protocol):
    """A driver that also consumes the sensor records and writes its own output topics."""

    @property
    def finished(self) -> bool:
        """True once the driver is done (goal reached, goal unreachable, or stuck for its
        timeout): the simulation ends there."""

    @property
    def status(self) -> str:
        """The driver's status for the summary ('goal_reached', 'unreachable', 'stuck',
        'driving')."""

    @property
    def ending(self) -> str:
        """Why the run ends: 'goal_reached', 'unreachable', 'stuck' or 'duration'."""

    def observe(self, record: object) -> None:
        """A sensor record was just produced."""

    def finish(self, end_ns: int) -> dict[str, str]:
        """Flush at the end of the log; return the metadata to store (REPLAY_METADATA)."""


@dataclass(frozen=True)
class SimulationOptions:
    duration: float | None = None  # s; None: the scene's duration, else DEFAULT_DURATION
    seed: int = 0
    resolution: tuple[int, int] | None = None  # (width, height) overriding the scene's
    frame_rate: float | None = None  # Hz overriding the scene's
    log: LogConfig = LogConfig()
    limits: Limits = DEFAULT_LIMITS  # the job is refused before it starts if over them
    # StereoRig fields overriding the scene's camera after the resolution (tilt, roll, pan,
    # principal_point, doffs: pixels of the final resolution)
    camera: tuple[tuple[str, object], ...] = ()
    # The camera model replacing the scene's [camera_defects] table (None: the scene's)
    camera_defects: CameraDefects | None = None


@dataclass(frozen=True)
class SimulationSummary:
    path: Path
    duration: float
    frames: int
    messages: int
    bytes: int
    wall_seconds: float
    goal_distance: float  # true distance to the goal at the end (m)
    status: str | None = None  # closed loop: the planner's status at the end
    ending: str | None = None  # closed loop: goal_reached, unreachable, stuck or duration


def effective_scene(scene: Scene, options: SimulationOptions) -> Scene:
    """The scene with the command-line overrides (resolution, frame rate, camera) applied."""
    rig = scene.spec.camera
    if options.resolution is not None:
        rig = rig.resized(*options.resolution)
    if options.frame_rate is not None:
        rig = dataclasses.replace(rig, frame_rate=options.frame_rate)
    if options.camera:
        rig = dataclasses.replace(rig, **dict(options.camera))  # type: ignore[arg-type]
    spec = dataclasses.replace(scene.spec, camera=rig)
    if options.camera_defects is not None:
        spec = dataclasses.replace(spec, camera_defects=options.camera_defects)
    check_exposure(spec.camera_defects, rig.frame_rate, source=scene.source)
    check_readout(spec.camera_defects, rig.height, rig.frame_rate, source=scene.source)
    return dataclasses.replace(scene, spec=spec)


def simulation_duration(scene: Scene, options: SimulationOptions) -> float:
    if options.duration is not None:
        return options.duration
    return scene.spec.duration if scene.spec.duration is not None else DEFAULT_DURATION


def simulation_budget(scene: Scene, options: SimulationOptions) -> Estimate:
    """The output size and peak memory of simulating ``scene`` with ``options``."""
    spec = effective_scene(scene, options).spec
    return simulation_estimate(
        spec.camera,
        simulation_duration(scene, options),
        sonar_rate=spec.sonar.rate,
        odometry_rate=spec.odometry.rate,
    )


def _schedule(rate: float, end_ns: int) -> list[int]:
    period = 1e9 / rate
    return [round(k * period) for k in range(math.floor(end_ns / period + 1e-9) + 1)]


def simulate(
    scene: Scene,
    output: Path,
    options: SimulationOptions,
    *,
    make_driver: Callable[[Scene, Write], ClosedLoopDriver] | None = None,
    on_frame: Callable[[int, int], None] | None = None,
) -> SimulationSummary:
    """Simulate ``scene`` and write the log atomically to ``output``.

    The scene's driving plan drives the robot unless ``make_driver(scene, write)`` builds a
    closed-loop driver: it then receives every sensor record as it is produced, writes its
    outputs into the same log, and ends the simulation when it has finished (goal reached,
    or stuck for its timeout); the summary then carries its status and why the run ended.
    ``on_frame(done, total)`` reports progress in stereo frames.
    """
    from flylog.sim.camera import CameraModel, band_rows, frame_bands, shutter_bands
    from flylog.sim.render import Renderer
    from flylog.sim.sonar import sonar_ranges

    t_wall = time.perf_counter()
    scene_file = [Role(Path(scene.source), "the scene", "scene")] if scene.source else []
    check_outputs(scene_file, [Role(Path(output), "the log", "output")])
    simulation_budget(scene, options).check(options.limits)
    scene = effective_scene(scene, options)
    spec = scene.spec
    rig, sonar_cfg, odo_cfg = spec.camera, spec.sonar, spec.odometry
    duration = simulation_duration(scene, options)
    end_ns = round(duration * 1e9)
    trajectory_rng, sonar_rng = (
        np.random.default_rng(s) for s in np.random.SeedSequence(options.seed).spawn(2)
    )
    renderer = Renderer(scene, rig)
    defects = spec.camera_defects
    camera = (
        None
        if defects.ideal
        else CameraModel(defects, rig, seed=options.seed, period_s=1.0 / rig.frame_rate)
    )
    # a realistic camera's rolling shutter: row v exposed at the frame's stamp + v periods
    row_period_s = 0.0 if camera is None else defects.row_period_us * 1e-6
    mounts = sonar_cfg.mounts()
    statics = encode.static_transforms(rig, sonar_cfg)
    shapes = scene_shapes(scene)

    # Event queue of (time, order, kind): at equal times odometry first, then sonar, camera.
    events: list[tuple[int, int, str]] = []
    for order, (kind, rate) in enumerate(
        (("odom", odo_cfg.rate), ("sonar", sonar_cfg.rate), ("camera", rig.frame_rate))
    ):
        events.extend((t, order, kind) for t in _schedule(rate, end_ns))
    events.extend((t, -1, "static") for t in range(0, end_ns + 1, _STATIC_PERIOD_NS))
    heapq.heapify(events)
    total_frames = sum(1 for e in events if e[2] == "camera")

    poses = RobotPoses(scene.start_pose, scene.start_pose)
    series = _PoseSeries()
    command = (0.0, 0.0)
    now_ns = 0
    frames = messages = 0
    with LogWriter.from_config(output, options.log) as log:
        log.attach("scene.toml", scene.text.encode(), "application/toml")
        log.add_metadata(contract.SIMULATION_METADATA, _metadata(scene, options, duration))
        if row_period_s > 0.0:
            log.add_metadata(
                contract.SHUTTER_METADATA, shutter_metadata(defects.row_period_us * 1000.0)
            )

        def write(topic: str, t_ns: int, message: object) -> None:
            nonlocal messages
            log.write(topic, t_ns, message)
            messages += 1

        closed: ClosedLoopDriver | None = None
        driver: Driver = PlanDriver(spec.drive, goal=scene.goal)
        if make_driver is not None:
            driver = closed = make_driver(scene, write)

        while events:
            t_ns, _, kind = heapq.heappop(events)
            if t_ns > now_ns:
                poses = advance_poses(
                    poses, *command, (t_ns - now_ns) / 1e9, odo_cfg, trajectory_rng
                )
                now_ns = t_ns
            if kind == "static":
                write(contract.TF, t_ns, encode.frame_transforms(statics, t_ns))
                write(
                    contract.TRUTH_SCENE,
                    t_ns,
                    encode.scene_update(shapes, t_ns, contract.ODOM_FRAME),
                )
            elif kind == "odom":
                odom = OdomReading(t_ns, poses.odom)
                write(contract.ODOM, t_ns, encode.pose_in_frame(poses.odom, t_ns, "odom"))
                write(
                    contract.TF,
                    t_ns,
                    encode.frame_transforms([encode.odom_transform(poses.odom)], t_ns),
                )
                write(
                    contract.TRUTH_POSE,
                    t_ns,
                    encode.pose_in_frame(poses.true, t_ns, contract.ODOM_FRAME),
                )
                series.add(t_ns, poses)
                if closed is not None:
                    closed.observe(odom)
                command = driver.command(t_ns / 1e9, poses.odom)
                if closed is not None and closed.finished:
                    break  # goal reached, or stuck for the timeout: the log ends here
            elif kind == "sonar":
                ranges = sonar_ranges(scene, sonar_cfg, poses.true, sonar_rng)
                reading = SonarReading(
                    t_ns, ranges, mounts, math.radians(sonar_cfg.cone_deg), sonar_cfg.max_range
                )
                write(
                    contract.SONAR,
                    t_ns,
                    encode.sonar_ranges(reading, min_range=sonar_cfg.min_range),
                )
                if closed is not None:
                    closed.observe(reading)
            else:
                if camera is None:
                    pair = renderer.render(poses.true)
                    left, right = pair.left, pair.right
                else:
                    bands = shutter_bands(
                        rig.height, row_period_s, band_rows(rig, *command, row_period_s)
                    )
                    renders = [
                        renderer.render_bands(b)
                        for b in frame_bands(poses.true, *command, defects, bands)
                    ]
                    left, right = camera.pair(frames, [(r.left, r.right) for r in renders])
                for side, image in (("left", left), ("right", right)):
                    frame = contract.CAMERA_FRAMES[side]
                    write(contract.IMAGE_TOPICS[side], t_ns, encode.raw_image(image, t_ns, frame))
                    write(
                        contract.CALIBRATION_TOPICS[side],
                        t_ns,
                        encode.camera_calibration(rig, side, t_ns),
                    )
                if closed is not None:
                    closed.observe(StereoPair(t_ns, left, right))
                frames += 1
                if on_frame is not None:
                    on_frame(frames, total_frames)
        status = ending = None
        if closed is not None:
            status, ending = closed.status, closed.ending
            log.add_metadata(contract.REPLAY_METADATA, closed.finish(now_ns))
        log.add_metadata(contract.TRAJECTORIES_METADATA, series.metadata())
    gx, gy = scene.goal
    return SimulationSummary(
        path=output,
        duration=now_ns / 1e9,
        frames=frames,
        messages=messages,
        bytes=output.stat().st_size,
        wall_seconds=time.perf_counter() - t_wall,
        goal_distance=math.hypot(poses.true.x - gx, poses.true.y - gy),
        status=status,
        ending=ending,
    )


class _PoseSeries:
    """The /truth/pose and /odom series as written, for the TRAJECTORIES_METADATA record."""

    def __init__(self) -> None:
        self.t_ns: list[int] = []
        self.true: list[Pose2D] = []
        self.odom: list[Pose2D] = []

    def add(self, t_ns: int, poses: RobotPoses) -> None:
        self.t_ns.append(int(t_ns))
        self.true.append(poses.true)
        self.odom.append(poses.odom)

    def _json(self, poses: list[Pose2D]) -> str:
        return json.dumps(
            {
                "t_ns": self.t_ns,
                "x": [float(p.x) for p in poses],
                "y": [float(p.y) for p in poses],
                "theta": [_logged_heading(p.theta) for p in poses],
            },
            separators=(",", ":"),
        )

    def metadata(self) -> dict[str, str]:
        return {
            "version": contract.TRAJECTORIES_VERSION,
            "true": self._json(self.true),
            "odom": self._json(self.odom),
        }


def _logged_heading(theta: float) -> float:
    """The heading a reader decodes from the quaternion logged for ``theta`` (the same
    operations as reading the topic: both ways of reading a log agree bit for bit)."""
    x, y, z, w = yaw_quaternion(theta)
    return yaw_of(SimpleNamespace(x=x, y=y, z=z, w=w))


def _metadata(scene: Scene, options: SimulationOptions, duration: float) -> dict[str, str]:
    """What a run needs to be reproduced, and the mission (start, goal) replay needs."""
    return {
        "scene": scene.name,
        "scene_source": scene.source,
        "seed": str(options.seed),
        "duration": repr(duration),
        "camera": json.dumps(to_mapping(scene.spec.camera)),
        "camera_defects": json.dumps(to_mapping(scene.spec.camera_defects)),
        "sonar": json.dumps(to_mapping(scene.spec.sonar)),
        "start": json.dumps(list(scene.spec.robot.start)),
        "goal": json.dumps(list(scene.goal)),
    }
