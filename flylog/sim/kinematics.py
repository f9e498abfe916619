"""Unicycle kinematics and simulated odometry (paper §3.3).

The odometric pose integrates the commanded motion exactly: it is what the algorithm may
use. The true pose integrates the command plus Gaussian "trajectory noise" (wheel slip,
rough ground): only the renderer, the sonar and the metrics see it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flylog.config import param
from flylog.geometry import Pose2D
from flylog.geometry.poses import wrap_angle


@dataclass(frozen=True)
class OdometryConfig:
    """Odometry rate and the trajectory noise added to the commanded motion.

    The noise is drawn once per odometry step (1/rate seconds) and applied to the commanded
    velocities of that step: the standard deviation is ``floor + fraction · |command|``.
    A robot that is told to stand still does not drift.
    """

    rate: float = param(50.0, help="odometry steps per second", unit="Hz", min=0.1, max=10000.0)
    linear_noise: float = param(
        0.05, help="linear speed noise, as a fraction of the commanded speed", min=0.0
    )
    angular_noise: float = param(
        0.05, help="turn rate noise, as a fraction of the commanded turn rate", min=0.0
    )
    linear_noise_floor: float = param(
        0.0, help="linear speed noise added whenever the robot moves", unit="m/s", min=0.0
    )
    angular_noise_floor_deg: float = param(
        0.5, help="turn rate noise added whenever the robot moves", unit="deg/s", min=0.0
    )

    @property
    def dt(self) -> float:
        return 1.0 / self.rate


@dataclass(frozen=True, slots=True)
class RobotPoses:
    """Where the robot believes it is (odometry) and where it really is (truth)."""

    odom: Pose2D
    true: Pose2D


def integrate_unicycle(pose: Pose2D, v: float, w: float, dt: float) -> Pose2D:
    """The pose after driving at constant (v m/s, w rad/s) for dt seconds: an exact arc."""
    th = pose.theta
    if abs(w * dt) < 1e-12:
        return Pose2D(pose.x + v * dt * math.cos(th), pose.y + v * dt * math.sin(th), th)
    th1 = th + w * dt
    r = v / w
    return Pose2D(
        pose.x + r * (math.sin(th1) - math.sin(th)),
        pose.y - r * (math.cos(th1) - math.cos(th)),
        wrap_angle(th1),
    )


def noisy_command(
    v: float, w: float, config: OdometryConfig, rng: np.random.Generator
) -> tuple[float, float]:
    """The velocities the robot really executes for one odometry step of command (v, w).

    Always draws two normals (also for a zero command) so that the random stream does not
    depend on what was commanded.
    """
    e_v, e_w = rng.standard_normal(2)
    if v == 0.0 and w == 0.0:
        return 0.0, 0.0
    sd_v = config.linear_noise_floor + config.linear_noise * abs(v)
    sd_w = math.radians(config.angular_noise_floor_deg) + config.angular_noise * abs(w)
    return v + sd_v * float(e_v), w + sd_w * float(e_w)


def advance_poses(
    poses: RobotPoses,
    v: float,
    w: float,
    dt: float,
    config: OdometryConfig,
    rng: np.random.Generator,
) -> RobotPoses:
    """Advance both poses by a command held for ``dt`` seconds.

    ``dt`` is split into odometry steps of at most 1/rate seconds; each step draws its own
    trajectory noise. The odometric pose integrates the command exactly.
    """
    n = max(1, math.ceil(dt * config.rate - 1e-9))
    step = dt / n
    odom, true = poses.odom, poses.true
    for _ in range(n):
        odom = integrate_unicycle(odom, v, w, step)
        tv, tw = noisy_command(v, w, config, rng)
        true = integrate_unicycle(true, tv, tw, step)
    return RobotPoses(odom, true)
