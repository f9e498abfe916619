"""The tables of a scene file as typed, frozen configs (the format is in ``flylog.scene.load``)."""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

from flylog.config import param
from flylog.errors import ConfigError
from flylog.geometry import StereoRig
from flylog.sensors import SonarConfig
from flylog.sim.camera_defects import CameraDefects
from flylog.sim.kinematics import OdometryConfig


class ObstacleKind(enum.Enum):
    BOX = "box"
    CYLINDER = "cylinder"
    WALL = "wall"


@dataclass(frozen=True)
class TextureConfig:
    """Procedural value-noise texture: a base colour modulated by a few octaves of noise."""

    color: tuple[float, float, float] = param((0.7, 0.5, 0.3), help="base colour, RGB in [0, 1]")
    feature_size: float = param(
        0.04, help="size of the finest texture features", unit="m", min=0.001, max=10.0
    )
    contrast: float = param(0.6, help="modulation depth of the noise", min=0.0, max=1.0)

    def __post_init__(self) -> None:
        if not all(0.0 <= c <= 1.0 for c in self.color):
            msg = f"texture color must have components in [0, 1], got {list(self.color)}"
            raise ConfigError(msg)


@dataclass(frozen=True)
class GroundConfig:
    """The flat, textured ground plane z = 0."""

    texture: TextureConfig = param(
        TextureConfig(color=(0.45, 0.42, 0.38), feature_size=0.05, contrast=0.5),
        help="texture of the ground",
    )


@dataclass(frozen=True)
class LightingConfig:
    """A directional light for Lambertian shading, plus ambient light and the sky.

    The sky's texture is a function of the viewing direction only (it is at infinity), so
    both cameras see it at zero disparity, as a real sky; a plain sky would meet the far
    ground in a horizontal edge that matches equally well at every depth.
    """

    azimuth_deg: float = param(30.0, help="direction the light comes from (world)", unit="deg")
    elevation_deg: float = param(
        50.0, help="elevation of the light above the horizon", unit="deg", min=0.0, max=90.0
    )
    ambient: float = param(0.35, help="ambient fraction of the light", min=0.0, max=1.0)
    sky_color: tuple[float, float, float] = param(
        (0.62, 0.75, 0.92), help="colour of the sky, RGB in [0, 1]"
    )
    sky_feature_deg: float = param(
        2.0, help="angular size of the sky's (cloud) texture", unit="deg", min=0.01
    )
    sky_contrast: float = param(0.3, help="contrast of the sky's texture (0: plain)", min=0, max=1)

    def light_vector(self) -> tuple[float, float, float]:
        """Unit vector pointing towards the light (world)."""
        az, el = math.radians(self.azimuth_deg), math.radians(self.elevation_deg)
        return (math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el))


@dataclass(frozen=True)
class ObstacleConfig:
    """One obstacle: a vertical extrusion of a rectangle (box, wall) or a disc (cylinder)."""

    kind: ObstacleKind  # required: it decides which of the fields below apply
    center: tuple[float, float] | None = param(
        None, help="box/cylinder: centre of the footprint (world)", unit="m"
    )
    size: tuple[float, float] | None = param(
        None, help="box: length along its yaw and width across", unit="m"
    )
    yaw_deg: float = param(0.0, help="box: rotation of the footprint", unit="deg")
    radius: float | None = param(None, help="cylinder: radius", unit="m", min=0.001)
    start: tuple[float, float] | None = param(None, help="wall: first endpoint", unit="m")
    end: tuple[float, float] | None = param(None, help="wall: second endpoint", unit="m")
    thickness: float = param(0.1, help="wall: thickness", unit="m", min=0.001)
    height: float = param(1.0, help="height above the ground", unit="m", min=0.001)
    texture: TextureConfig = param(TextureConfig(), help="surface texture")
    sonar_absorbing: bool = param(False, help="visible to the cameras but never seen by sonar")
    low_texture: bool = param(False, help="nearly uniform surface (hard for stereo)")

    def __post_init__(self) -> None:
        needs = {
            ObstacleKind.BOX: ("center", "size"),
            ObstacleKind.CYLINDER: ("center", "radius"),
            ObstacleKind.WALL: ("start", "end"),
        }[self.kind]
        optional = ("center", "size", "radius", "start", "end")
        for name in optional:
            given = getattr(self, name) is not None
            if name in needs and not given:
                msg = f"a {self.kind.value} needs '{name}' (it takes {' and '.join(needs)})"
                raise ConfigError(msg)
            if name not in needs and given:
                msg = f"a {self.kind.value} takes {' and '.join(needs)}, not '{name}'"
                raise ConfigError(msg)
        if self.size is not None and min(self.size) <= 0.0:
            msg = f"'size' must be positive, got {list(self.size)}"
            raise ConfigError(msg)
        if self.start is not None and self.start == self.end:
            msg = "a wall's 'start' and 'end' must differ"
            raise ConfigError(msg)


@dataclass(frozen=True)
class ClutterConfig:
    """Obstacles placed at random from the scene's seed (deterministic)."""

    count: int = param(20, help="number of obstacles to place", min=0, max=10000)
    area: tuple[float, float, float, float] = param(
        (0.0, -5.0, 10.0, 5.0), help="region xmin, ymin, xmax, ymax of the centres", unit="m"
    )
    size_range: tuple[float, float] = param(
        (0.2, 0.8), help="footprint size (box sides, cylinder diameter)", unit="m"
    )
    height_range: tuple[float, float] = param((0.3, 1.5), help="heights", unit="m")
    cylinder_fraction: float = param(0.4, help="fraction of cylinders", min=0.0, max=1.0)
    clear_radius: float = param(
        1.0, help="no obstacle closer than this to the start and goal", unit="m", min=0.0
    )
    min_gap: float = param(0.3, help="minimum free space between obstacles", unit="m", min=0.0)
    feature_size: float = param(
        0.04, help="texture feature size of the placed obstacles", unit="m", min=0.001
    )
    contrast: float = param(0.6, help="texture contrast of the placed obstacles", min=0, max=1)

    def __post_init__(self) -> None:
        x0, y0, x1, y1 = self.area
        if not (x0 < x1 and y0 < y1):
            msg = f"'area' must be xmin, ymin, xmax, ymax with min < max, got {list(self.area)}"
            raise ConfigError(msg)
        for name in ("size_range", "height_range"):
            lo, hi = getattr(self, name)
            if not 0.0 < lo <= hi:
                msg = f"'{name}' must be 0 < min <= max, got {[lo, hi]}"
                raise ConfigError(msg)


@dataclass(frozen=True)
class RobotConfig:
    """Where the robot starts and where it should go."""

    start: tuple[float, float, float] = param(
        (0.0, 0.0, 0.0), help="start pose x, y (m) and heading (deg)"
    )
    goal: tuple[float, float] = param((10.0, 0.0), help="goal position x, y", unit="m")
    radius: float = param(
        0.3, help="radius of the robot's footprint (collisions)", unit="m", min=0.0
    )


@dataclass(frozen=True)
class VelocityCommand:
    """From ``t_start`` on (until the next command), drive at (v, w)."""

    t_start: float  # required: a command without a time means nothing
    v: float = param(0.0, help="linear speed", unit="m/s")
    w_deg: float = param(0.0, help="turn rate, counter-clockwise", unit="deg/s")


@dataclass(frozen=True)
class DriveConfig:
    """The driving plan: timed velocity commands, or waypoints tracked by a controller.

    With neither, the robot drives to ``robot.goal`` as a single waypoint.
    """

    waypoints: tuple[tuple[float, float], ...] = param(
        (), help="positions to reach in order (the goal is not implied)", unit="m"
    )
    commands: tuple[VelocityCommand, ...] = param((), help="timed velocity commands")
    max_speed: float = param(0.5, help="waypoint mode: top speed", unit="m/s", min=0.0)
    max_turn_rate_deg: float = param(
        45.0, help="waypoint mode: top turn rate", unit="deg/s", min=0.0
    )
    heading_gain: float = param(
        2.0, help="waypoint mode: turn rate per radian of heading error", unit="1/s", min=0.0
    )
    tolerance: float = param(
        0.15, help="waypoint mode: a waypoint is reached within this distance", unit="m", min=0.01
    )

    def __post_init__(self) -> None:
        if self.waypoints and self.commands:
            msg = "give either 'waypoints' or 'commands', not both"
            raise ConfigError(msg)
        times = [c.t_start for c in self.commands]
        if times != sorted(times):
            msg = f"'commands' must be in increasing t_start, got {times}"
            raise ConfigError(msg)


@dataclass(frozen=True)
class GeneratedConfig:
    """What ``flylog scene generate`` measured on a world it wrote (checked on a grid of
    the robot's footprint, :mod:`flylog.scene.occupancy`)."""

    family: str  # required: passages, clutter or dead-end
    seed: int = param(0, help="seed the world was generated from", min=0)
    reachable: bool = param(True, help="whether a collision-free path to the goal exists")
    optimal_path_m: float | None = param(
        None, help="length of the shortest collision-free path (absent: unreachable)", unit="m"
    )
    narrowest_gap_m: float | None = param(
        None, help="twice the smallest clearance along that path", unit="m"
    )
    difficulty: float = param(0.0, help="the family's difficulty parameter", min=0.0, max=1.0)
    check_radius: float = param(
        0.35, help="footprint radius the path was checked for (robot and margin)", unit="m"
    )


@dataclass(frozen=True)
class SceneSpec:
    """A whole scene file."""

    name: str  # required
    duration: float | None = param(None, help="default simulated duration", unit="s", min=0.0)
    seed: int = param(0, help="seed of the random placement (clutter)", min=0)
    ground: GroundConfig = param(GroundConfig(), help="the ground plane")
    lighting: LightingConfig = param(LightingConfig(), help="light and sky")
    obstacles: tuple[ObstacleConfig, ...] = param((), help="the obstacles")
    clutter: ClutterConfig | None = param(None, help="randomly placed obstacles")
    robot: RobotConfig = param(RobotConfig(), help="start and goal")
    camera: StereoRig = param(StereoRig(), help="the stereo rig")
    camera_defects: CameraDefects = param(
        CameraDefects(),
        help="the cameras' exposure, gain, response, noise, vignetting and blur (absent: "
        "ideal cameras)",
    )
    sonar: SonarConfig = param(SonarConfig(), help="the sonar ring")
    odometry: OdometryConfig = param(OdometryConfig(), help="odometry and trajectory noise")
    drive: DriveConfig = param(DriveConfig(), help="the driving plan")
    generated: GeneratedConfig | None = param(
        None, help="written by `flylog scene generate`: the world's family and checks"
    )
