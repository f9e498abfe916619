"""From the potential's gradient to unicycle velocity commands, a status and a path."""

from __future__ import annotations

import enum
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from flylog.geometry import Pose2D
from flylog.geometry.poses import wrap_angle
from flylog.planner.recovery import Recovery

# Below this gradient norm (potential units per metre) the descent direction is noise.
FLAT_GRADIENT = 1e-12


class Status(enum.Enum):
    """What the planner says about the robot's progress."""

    DRIVING = "driving"
    GOAL_REACHED = "goal_reached"
    STUCK = "stuck"
    UNREACHABLE = "unreachable"  # the map walls the goal off, and the recoveries did not open it


@dataclass(frozen=True, slots=True)
class Command:
    """Unicycle velocities for the robot and the planner's status."""

    linear: float  # m/s, forward
    angular: float  # rad/s, counter-clockwise
    status: Status
    recovery: Recovery = Recovery.NONE  # the recovery these velocities come from


class PathEnd(enum.Enum):
    """Which bound stopped a gradient-descent path."""

    GOAL = "goal"  # came within the goal tolerance
    MAX_STEPS = "max_steps"  # ran out of steps
    FLAT = "flat"  # the gradient vanished (unconverged or saddle)
    LEFT_GRID = "left_grid"  # stepped off the grid
    OBSTACLE = "obstacle"  # stepped into an obstacle cell


@dataclass(frozen=True, slots=True)
class PlannedPath:
    """The path the robot would follow now: (K, 2) points in odom, from the robot on."""

    points: np.ndarray
    end: PathEnd


def unicycle_command(
    pose: Pose2D,
    direction_xy: tuple[float, float],
    *,
    max_linear: float,
    max_angular: float,
    heading_gain: float,
    turn_in_place: float = math.pi / 2,
) -> tuple[float, float]:
    """(linear, angular) turning the robot towards ``direction_xy`` (any length): a
    proportional, saturated turn, and a forward speed that falls from ``max_linear`` (facing
    the direction) to zero at a heading error of ``turn_in_place`` radians, as
    ``(cos(error) - cos(turn_in_place)) / (1 - cos(turn_in_place))``; beyond it the robot
    turns in place. The default (pi/2) gives ``max_linear·cos(error)``. Turning in place
    before driving keeps the robot on the descent line instead of swinging wide of it."""
    dx, dy = direction_xy
    if math.hypot(dx, dy) <= FLAT_GRADIENT:
        return 0.0, 0.0
    error = wrap_angle(math.atan2(dy, dx) - pose.theta)
    angular = min(max(heading_gain * error, -max_angular), max_angular)
    floor = math.cos(min(max(turn_in_place, 1e-6), math.pi))
    linear = max_linear * max(0.0, (math.cos(error) - floor) / (1.0 - floor))
    return linear, angular


@dataclass
class SmoothedDirection:
    """A direction low-passed in time: each update moves the unit vector held towards the
    new direction by ``1 − exp(−dt / time_constant)`` and renormalises (a time constant of 0
    passes every direction through). Where the harmonic field is nearly flat, −∇U at the
    robot swings with every obstacle cell that appears or clears nearby; steering after
    each swing turns the robot back and forth, and the odometry's heading noise grows with
    every radian turned."""

    time_constant: float
    _unit: tuple[float, float] | None = None
    _t: float = 0.0

    def update(self, direction: tuple[float, float], t: float) -> tuple[float, float]:
        """The smoothed direction (unit length, or ``direction`` itself if it is flat or
        smoothing is off) after ``direction`` at time ``t`` (s)."""
        norm = math.hypot(*direction)
        if self.time_constant <= 0.0 or norm <= FLAT_GRADIENT:
            return direction
        new = (direction[0] / norm, direction[1] / norm)
        if self._unit is None:
            self._unit, self._t = new, t
            return new
        a = 1.0 - math.exp(-max(0.0, t - self._t) / self.time_constant)
        x = self._unit[0] + a * (new[0] - self._unit[0])
        y = self._unit[1] + a * (new[1] - self._unit[1])
        n = math.hypot(x, y)
        self._t = t
        if n > FLAT_GRADIENT:  # exactly opposite halves cancel: keep the old direction
            self._unit = (x / n, y / n)
        return self._unit


def speed_factor(distance: float, slowdown: float, floor: float = 0.0) -> float:
    """The share of the full forward speed at ``distance`` from what slows the robot down:
    ``distance / slowdown`` clamped to [floor, 1] (1 when ``slowdown`` is 0: no slow-down)."""
    if slowdown <= 0.0:
        return 1.0
    return min(1.0, max(floor, distance / slowdown))


@dataclass
class ProgressMonitor:
    """STUCK when the best distance to the goal has not improved by ``progress`` metres for
    ``stuck_time`` seconds. Euclidean distance can grow on a detour, so ``stuck_time``
    should exceed the longest detour the scene needs."""

    stuck_time: float
    progress: float
    best_distance: float = math.inf
    best_time: float | None = None

    def update(self, distance: float, t: float) -> bool:
        """Record the distance at time t; whether the robot is stuck now."""
        if self.best_time is None or distance <= self.best_distance - self.progress:
            self.best_distance = distance
            self.best_time = t
            return False
        return t - self.best_time >= self.stuck_time

    def reset(self) -> None:
        self.best_distance = math.inf
        self.best_time = None


def descend(
    start_xy: tuple[float, float],
    goal_xy: tuple[float, float],
    gradient: Callable[[float, float], tuple[float, float]],
    blocked: Callable[[float, float], bool | None],
    *,
    step: float,
    max_steps: int,
    goal_tolerance: float,
) -> PlannedPath:
    """Follow −∇U from ``start_xy`` in steps of ``step`` metres (normalised gradient), at most
    ``max_steps`` steps. ``blocked(x, y)`` is None off the grid, True in an obstacle cell.
    The path ends with the goal itself when it comes within ``goal_tolerance``. A path that
    starts inside an obstacle cell (an obstacle seen within the robot radius) may leave it;
    it ends when it enters one from free space."""
    x, y = start_xy
    escaping = bool(blocked(x, y))
    pts = [(x, y)]
    end = PathEnd.MAX_STEPS
    gx_goal, gy_goal = goal_xy
    for _ in range(max_steps):
        if math.hypot(x - gx_goal, y - gy_goal) <= goal_tolerance:
            pts.append((gx_goal, gy_goal))
            end = PathEnd.GOAL
            break
        gx, gy = gradient(x, y)
        norm = math.hypot(gx, gy)
        if norm <= FLAT_GRADIENT:
            end = PathEnd.FLAT
            break
        x, y = x - step * gx / norm, y - step * gy / norm
        state = blocked(x, y)
        if state is None:
            end = PathEnd.LEFT_GRID
            break
        pts.append((x, y))
        if state and not escaping:
            end = PathEnd.OBSTACLE
            break
        escaping = escaping and state
    return PlannedPath(np.asarray(pts, dtype=np.float64).reshape(-1, 2), end)
