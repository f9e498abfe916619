"""Scene files: loading, checking, random placement, and the geometry query.

A scene file is TOML. Every table is optional except ``name``; every field has a default
(shown below) except those marked *required*. Lengths are metres, angles degrees, world
frame x forward at start (by convention), y left, z up. A wrong name, type or range raises
:class:`~flylog.errors.ConfigError` naming the file and the field (``obstacles[2].height``).

.. code-block:: toml

    name = "corridor"             # required
    duration = 20.0               # optional default simulated duration (s)
    seed = 0                      # seed of the random placement ([clutter])

    [ground.texture]              # the textured plane z = 0
    color = [0.45, 0.42, 0.38]    # RGB in [0, 1]
    feature_size = 0.05           # finest texture features (m); octaves at 1x, 2x, 4x
    contrast = 0.5                # 0 = plain colour, 1 = full modulation

    [lighting]                    # Lambertian shading
    azimuth_deg = 30.0            # the light comes from this direction (world) ...
    elevation_deg = 50.0          # ... and this elevation
    ambient = 0.35                # ambient fraction
    sky_color = [0.62, 0.75, 0.92]
    sky_feature_deg = 2.0         # the sky is textured by direction (zero disparity) ...
    sky_contrast = 0.3            # ... 0 gives a plain sky

    [[obstacles]]                 # one table per obstacle
    kind = "box"                  # required: "box" | "cylinder" | "wall"
    center = [4.0, 1.0]           # box, cylinder: footprint centre
    size = [0.6, 0.4]             # box: length (along yaw) and width
    yaw_deg = 20.0                # box: rotation
    height = 1.0
    texture = { color = [0.8, 0.3, 0.2], feature_size = 0.04, contrast = 0.6 }
    sonar_absorbing = false       # seen by the cameras, never by the sonar
    low_texture = false           # nearly uniform surface

    [[obstacles]]
    kind = "cylinder"
    center = [6.0, -1.0]
    radius = 0.3                  # cylinder only

    [[obstacles]]
    kind = "wall"
    start = [0.0, 1.5]            # wall: endpoints of its centre line ...
    end = [10.0, 1.5]
    thickness = 0.1               # ... and its thickness

    [clutter]                     # optional: obstacles placed from `seed`
    count = 20
    area = [0.0, -5.0, 10.0, 5.0] # xmin, ymin, xmax, ymax of the centres
    size_range = [0.2, 0.8]       # footprint size (box sides, cylinder diameter)
    height_range = [0.3, 1.5]
    cylinder_fraction = 0.4       # the rest are boxes with a random yaw and colour
    clear_radius = 1.0            # keep start and goal free
    min_gap = 0.3                 # free space between obstacles
    feature_size = 0.04
    contrast = 0.6

    [robot]
    start = [0.0, 0.0, 0.0]       # x, y, heading (deg)
    goal = [10.0, 0.0]
    radius = 0.3                  # footprint radius, for collisions

    [camera]                      # flylog.geometry.StereoRig
    width = 640
    height = 480
    focal_px = 500.0
    baseline = 0.12
    mount_height = 0.5
    mount_x = 0.1
    frame_rate = 15.0

    [camera_defects]              # flylog.sim.camera_defects.CameraDefects
    ideal = true                  # false: the camera model, every field at its typical value
    # right_gain_ratio = 1.1      # e.g. one defect changed from the typical camera's
    # read_noise_e = 2.5          # electrons rms

    [sonar]                       # flylog.sensors.SonarConfig
    angles_deg = [-50.0, -30.0, -10.0, 10.0, 30.0, 50.0]
    cone_deg = 15.0
    max_range = 3.0
    min_range = 0.05
    noise_std = 0.02
    mount_radius = 0.2
    mount_height = 0.3
    rate = 10.0

    [odometry]                    # flylog.sim.kinematics.OdometryConfig
    rate = 50.0                   # Hz; noise is drawn per step
    linear_noise = 0.05           # std = floor + fraction * |commanded|
    angular_noise = 0.05
    linear_noise_floor = 0.0      # m/s
    angular_noise_floor_deg = 0.5 # deg/s (only while moving)

    [drive]                       # either waypoints (tracked) ...
    waypoints = [[3.0, 0.0], [6.0, 1.0]]   # none and no commands: drive to robot.goal
    max_speed = 0.5               # m/s
    max_turn_rate_deg = 45.0      # deg/s
    heading_gain = 2.0            # turn rate per radian of heading error
    tolerance = 0.15              # m

    # ... or timed velocity commands, each held until the next (not both):
    # [[drive.commands]]
    # t_start = 0.0               # required
    # v = 0.0                     # m/s
    # w_deg = -15.0               # deg/s, counter-clockwise

A nested table replaces the defaults of the fields it gives, field by field, from the
defaults of its type (``[ground.texture]`` with only ``color`` takes the default
``feature_size`` of a texture, 0.04).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from flylog.config import from_mapping, problems_message, read_toml
from flylog.errors import ConfigError
from flylog.geometry import Pose2D
from flylog.io.inputs import read_input_bytes
from flylog.scene.footprints import Footprints, compile_footprints, distance_to_footprints
from flylog.scene.spec import (
    ClutterConfig,
    ObstacleConfig,
    ObstacleKind,
    SceneSpec,
    TextureConfig,
)

# Rejection sampling gives up after this many candidates per requested obstacle.
_CLUTTER_TRIES_PER_OBSTACLE = 200
# A point closer than this to a footprint is inside it (m).
_INSIDE = 1e-9


@dataclass(frozen=True)
class Scene:
    """A loaded scene: the checked file, every obstacle (clutter placed), and its text."""

    spec: SceneSpec
    obstacles: tuple[ObstacleConfig, ...]  # the file's obstacles, then the placed clutter
    source: str  # where it came from (a path, or a label)
    text: str  # the file's text, to attach to logs

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def start_pose(self) -> Pose2D:
        x, y, heading = self.spec.robot.start
        return Pose2D(x, y, math.radians(heading))

    @property
    def goal(self) -> tuple[float, float]:
        return self.spec.robot.goal

    @cached_property
    def footprints(self) -> Footprints:
        return compile_footprints(self.obstacles)


def parse_scene(text: str, source: str) -> Scene:
    """Parse and check a scene given as TOML text; ``source`` names it in error messages."""
    import tomllib

    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = f"{source}: not valid TOML ({exc})"
        raise ConfigError(msg) from None
    spec = from_mapping(SceneSpec, data, source=source)
    placed = place_clutter(spec, source=source) if spec.clutter is not None else ()
    scene = Scene(spec=spec, obstacles=spec.obstacles + placed, source=source, text=text)
    problems = placement_problems(scene)
    if problems:
        raise ConfigError(problems_message(source, problems))
    return scene


def _obstacle_name(scene: Scene, index: int) -> str:
    given = len(scene.spec.obstacles)
    return f"obstacles[{index}]" if index < given else f"clutter obstacle {index - given}"


def placement_problems(scene: Scene) -> list[str]:
    """What makes a scene impossible to drive: an obstacle over the robot at its start (its
    footprint within ``robot.radius`` of the start position), a goal inside an obstacle."""
    if not scene.obstacles:
        return []
    robot = scene.spec.robot
    points = np.array([robot.start[:2], robot.goal], dtype=float)
    clear = (max(robot.radius, _INSIDE), _INSIDE)  # distances are 0 inside a footprint
    if np.all(distance_to_footprints(scene.footprints, points) >= clear):
        return []  # the common case: one query over all obstacles
    problems = []
    for i, obstacle in enumerate(scene.obstacles):
        start, goal = distance_to_footprints(compile_footprints([obstacle]), points)
        name = _obstacle_name(scene, i)
        if start < clear[0]:
            problems.append(
                f"{name} lies over the robot's start {list(robot.start[:2])} (closer than "
                f"robot.radius = {robot.radius} m): move it or 'robot.start'"
            )
        if goal < clear[1]:
            problems.append(
                f"field 'robot.goal': {list(robot.goal)} is inside {name}: move the goal"
            )
    return problems


def load_scene(path: str | Path) -> Scene:
    """Load a scene file (see this module's docstring for the format)."""
    path = Path(path)
    read_toml(path)  # a missing, unreadable or malformed file: the messages of every config
    return parse_scene(read_input_bytes(path, "the scene file").decode("utf-8"), source=str(path))


def distance_to_obstacles(scene: Scene, xy: np.ndarray) -> np.ndarray:
    """(N,) 2-D distance from points (N, 2) to the nearest obstacle footprint (0 inside)."""
    return distance_to_footprints(scene.footprints, xy)


def place_clutter(spec: SceneSpec, *, source: str) -> tuple[ObstacleConfig, ...]:
    """The ``[clutter]`` obstacles, placed by rejection sampling from ``spec.seed``.

    Each candidate keeps ``clear_radius`` from start and goal and ``min_gap`` from every
    obstacle already there. Raises ConfigError if the area is too full for ``count``.
    """
    cl = spec.clutter
    assert isinstance(cl, ClutterConfig)
    rng = np.random.default_rng(spec.seed)
    x0, y0, x1, y1 = cl.area
    keep_clear = np.array([spec.robot.start[:2], spec.robot.goal], dtype=float)
    placed: list[ObstacleConfig] = []
    current = compile_footprints(spec.obstacles)
    for _ in range(cl.count * _CLUTTER_TRIES_PER_OBSTACLE):
        if len(placed) == cl.count:
            break
        candidate = _random_obstacle(rng, cl, (x0, y0, x1, y1))
        c = np.asarray(candidate.center)
        if candidate.radius is not None:
            bound = candidate.radius
        else:
            assert candidate.size is not None
            bound = math.hypot(*candidate.size) / 2.0
        if np.min(np.hypot(*(keep_clear - c).T)) < cl.clear_radius + bound:
            continue
        if len(current) and distance_to_footprints(current, c[None])[0] < bound + cl.min_gap:
            continue
        placed.append(candidate)
        current = compile_footprints([*spec.obstacles, *placed])
    if len(placed) < cl.count:
        msg = (
            f"{source}: field 'clutter.count': could place only {len(placed)} of {cl.count} "
            "obstacles; enlarge 'clutter.area' or lower 'count', 'size_range' or 'min_gap'"
        )
        raise ConfigError(msg)
    return tuple(placed)


def _random_obstacle(
    rng: np.random.Generator, cl: ClutterConfig, area: tuple[float, float, float, float]
) -> ObstacleConfig:
    x0, y0, x1, y1 = area
    center = (float(rng.uniform(x0, x1)), float(rng.uniform(y0, y1)))
    height = float(rng.uniform(*cl.height_range))
    red, green, blue = (float(c) for c in rng.uniform(0.2, 0.9, 3))
    color = (red, green, blue)
    texture = TextureConfig(color=color, feature_size=cl.feature_size, contrast=cl.contrast)
    if rng.uniform() < cl.cylinder_fraction:
        radius = float(rng.uniform(*cl.size_range)) / 2.0
        return ObstacleConfig(
            kind=ObstacleKind.CYLINDER,
            center=center,
            radius=radius,
            height=height,
            texture=texture,
        )
    size = (float(rng.uniform(*cl.size_range)), float(rng.uniform(*cl.size_range)))
    return ObstacleConfig(
        kind=ObstacleKind.BOX,
        center=center,
        size=size,
        yaw_deg=float(rng.uniform(0, 180)),
        height=height,
        texture=texture,
    )
