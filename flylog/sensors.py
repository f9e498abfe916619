"""Sensor records shared by the simulator, the log reader and the engine.

These are what ``flylog.io`` decodes a log into and what the engine consumes, so the
engine never needs MCAP. Times are integer nanoseconds of log time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flylog.config import param
from flylog.geometry import Pose2D


@dataclass(frozen=True)
class SonarConfig:
    """A ring of sonars on the robot (the paper's six, 15° cones)."""

    angles_deg: tuple[float, ...] = param(
        (-50.0, -30.0, -10.0, 10.0, 30.0, 50.0),
        help="mounting directions, counter-clockwise from the robot's x axis",
        unit="deg",
    )
    cone_deg: float = param(15.0, help="full opening angle of each cone", unit="deg", min=0.5)
    max_range: float = param(3.0, help="maximum detection range", unit="m", min=0.05)
    min_range: float = param(0.05, help="minimum detection range", unit="m", min=0.0)
    noise_std: float = param(0.02, help="Gaussian range noise (standard deviation)", unit="m")
    mount_radius: float = param(0.2, help="distance of the transducers from base_link", unit="m")
    mount_height: float = param(0.3, help="height of the transducers", unit="m", min=0.0)
    rate: float = param(10.0, help="reading cycles per second", unit="Hz", min=0.1)

    def mounts(self) -> np.ndarray:
        """(n, 3): x, y, yaw of each transducer in base_link."""
        yaw = np.radians(np.asarray(self.angles_deg, dtype=float))
        r = self.mount_radius
        return np.stack([r * np.cos(yaw), r * np.sin(yaw), yaw], axis=1)


@dataclass(frozen=True, slots=True)
class StereoPair:
    """A rectified stereo pair: (H, W, 3) uint8 RGB (or (H, W) grey) each, and the robot's
    motion over the images' readout (a rolling shutter's: from the stamp, the exposure of
    row 0, to the stamp + height · row period, in base_link at the stamp; the replay sets it
    from the odometry, :mod:`flylog.geometry.rolling`). The default, no motion, puts every
    row at the stamp: a global shutter."""

    stamp_ns: int
    left: np.ndarray
    right: np.ndarray
    readout: Pose2D = Pose2D()


@dataclass(frozen=True, slots=True)
class SonarReading:
    """One reading cycle of the sonar ring. ``ranges`` is NaN where a sonar had no echo."""

    stamp_ns: int
    ranges: np.ndarray  # (n,) metres, NaN = no echo
    mounts: np.ndarray  # (n, 3) x, y, yaw in base_link
    cone_angle: float  # full opening angle, rad
    max_range: float  # metres

    @property
    def fired(self) -> np.ndarray:
        return ~np.isnan(self.ranges)

    @property
    def half_cone(self) -> float:
        return self.cone_angle / 2.0


@dataclass(frozen=True, slots=True)
class OdomReading:
    """The odometric pose (integrated commands) at a time; what the algorithm may use."""

    stamp_ns: int
    pose: Pose2D


def seconds_to_ns(t: float) -> int:
    return round(t * 1e9)


def ns_to_seconds(t_ns: int) -> float:
    return t_ns / 1e9


def degrees(a: float) -> float:
    return math.degrees(a)
