"""Settings of the visual heading correction (:mod:`flylog.fly.heading`), apart from its
compiled scan so that reading a configuration loads no kernel."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flylog.config import param
from flylog.errors import ConfigError
from flylog.geometry import Pose2D


@dataclass(frozen=True)
class HeadingConfig:
    """Visual heading correction of the odometry (replay and closed loop)."""

    enabled: bool = param(
        True,
        help="measure the odometry's turn error since a keyframe with the flies and correct the "
        "robot's pose by it (false: odometry alone, as in the paper)",
    )
    flies: int = param(1000, help="the fittest flies compared with a keyframe", min=1)
    min_flies: int = param(
        100, help="fewer valid flies than this: no measurement for that frame", min=1
    )
    span_px: float = param(
        3.0,
        help="the extra yaw scanned, ± this many pixels at the image centre (the odometry's "
        "turn error over a keyframe's span, turning 20° on the spot at 0.5 rad/s, is 0.75 px "
        "sd at 320×240)",
        unit="px",
        min=0.0,
    )
    keyframe_distance: float = param(
        0.2,
        help="a measurement compares the pair at hand with the keyframe (the pair the last "
        "measurement was due at) once the robot has driven this far since: measured against a "
        "keyframe, the errors of successive measurements do not add up frame after frame (one "
        "frame apart they add up to as much as the odometry's own error driving straight)",
        unit="m",
        min=0.0,
    )
    keyframe_turn_deg: float = param(
        20.0,
        help="... or turned this much since the keyframe (the view must still overlap)",
        unit="deg",
        min=0.0,
        max=90.0,
    )
    keyframe_frames: int = param(
        15, help="... or this many pairs have come since the keyframe", min=1
    )
    min_turn_deg: float = param(
        2.0,
        help="no measurement (the next keyframe follows) when the robot turned less than "
        "this since the keyframe: driving straight 0.2 m at 320×240 the odometry's turn error "
        "(0.26 px sd) is hardly larger than a measurement's (0.14 px), whose bias (+0.02 px) "
        "adds up; turning, the odometry's error grows with the turn (0.5 px curving, 0.6-1.3 "
        "px on the spot) and a measurement's does not",
        unit="deg",
        min=0.0,
        max=90.0,
    )
    step_px: float = param(0.25, help="step of the scan", unit="px", min=0.01)
    window: int = param(7, help="side of the compared patches (odd)", unit="px", min=3, max=31)
    guard: float = param(
        1.0, help="added to the zero-mean SSD per pixel and channel", unit="grey level²", min=1e-6
    )
    max_parallax_px: float = param(
        0.2,
        help="flies whose column in the later pair moves more than this when their disparity "
        "is off by disparity_error_px are not compared: driving, a near fly's image motion "
        "off the image centre is mostly parallax, and its depth error reads as yaw "
        "(turning on the spot the cameras move 0.1 m·Δθ: 0.15 px for every fly at 20°, "
        "0 = compare every fly)",
        unit="px",
        min=0.0,
    )
    disparity_error_px: float = param(
        0.5, help="the flies' disparity error assumed by max_parallax_px", unit="px", min=0.0
    )
    measurement_sd_px: float = param(
        0.15,
        help="spread of one measurement against the keyframe (measured on closed-loop "
        "corridor and clutter runs at 320×240, 1000 flies: 0.04-0.11 px turning 11-38° on "
        "the spot, 0.13-0.25 px driving 0.2-0.3 m)",
        unit="px",
        min=1e-6,
    )
    gate: float = param(
        3.0,
        help="a measurement farther from the odometry than this many sd of their difference "
        "is dropped (an outlier: flies off their surfaces, an occlusion, repeated texture)",
        min=0.0,
    )
    odometry_rate: float = param(
        50.0,
        help="odometry steps per second, each with its own turn-rate error (the simulator's "
        "odometry.rate)",
        unit="Hz",
        min=0.1,
    )
    odometry_turn_noise: float = param(
        0.05,
        help="sd of the odometry's turn-rate error as a fraction of the turn rate (the "
        "simulator's odometry.angular_noise)",
        min=0.0,
    )
    odometry_turn_noise_floor_deg: float = param(
        0.5,
        help="sd of the odometry's turn-rate error whenever the robot moves (the simulator's "
        "odometry.angular_noise_floor_deg)",
        unit="deg/s",
        min=0.0,
    )

    def __post_init__(self) -> None:
        if self.window % 2 == 0:
            msg = f"heading.window must be odd, got {self.window}"
            raise ConfigError(msg)

    @property
    def scan_size(self) -> int:
        """How many extra yaws the scan scores: ± span_px in step_px steps, and 0."""
        return 2 * math.floor(self.span_px / self.step_px + 1e-9) + 1

    def offsets(self, focal_px: float) -> np.ndarray:
        """The extra yaws scanned (rad), symmetric about 0."""
        half = self.scan_size // 2
        return np.arange(-half, half + 1) * self.step_px / focal_px

    def odometry_variance(self, increment: Pose2D, seconds: float) -> float:
        """Variance (rad²) of the odometry's heading error accrued over ``increment`` taking
        ``seconds``: each odometry step's turn rate is off by floor + fraction·|rate|
        (sd); 0 for a robot that did not move."""
        if seconds <= 0.0 or (increment.x == 0.0 and increment.y == 0.0 and increment.theta == 0.0):
            return 0.0
        rate = abs(increment.theta) / seconds
        sd = math.radians(self.odometry_turn_noise_floor_deg) + self.odometry_turn_noise * rate
        return seconds * sd * sd / self.odometry_rate

    def evaluations(self, flies: int) -> int:
        """What a measurement by ``flies`` flies costs, in fitness evaluations: a fitness
        evaluation compares two patches, the scan compares two pairs (left, right) per fly
        and extra yaw."""
        return 2 * flies * self.scan_size

    def due(self, since: Pose2D, pairs: int) -> bool:
        """Whether to measure now, ``pairs`` pairs and the motion ``since`` after the
        keyframe."""
        return (
            math.hypot(since.x, since.y) >= self.keyframe_distance
            or abs(since.theta) >= math.radians(self.keyframe_turn_deg)
            or pairs >= self.keyframe_frames
        )

    @property
    def max_evaluations(self) -> int:
        """The most a measurement costs (0 when switched off)."""
        return self.evaluations(self.flies) if self.enabled else 0
