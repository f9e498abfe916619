"""Who decides the robot's velocity: the :class:`Driver` protocol and the scene's own plan.

A driver sees only the time and the odometric pose (what the robot knows), never the truth.
The closed-loop fly engine + planner implement the same protocol.
"""

from __future__ import annotations

import bisect
import math
from typing import Protocol

from flylog.geometry import Pose2D
from flylog.geometry.poses import wrap_angle
from flylog.scene.load import Scene
from flylog.scene.spec import DriveConfig


class Driver(Protocol):
    def command(self, t: float, odom_pose: Pose2D) -> tuple[float, float]:
        """(v m/s, w rad/s) to hold from time t (s) on, given the odometric pose."""
        ...


class PlanDriver:
    """Follows a scene's ``[drive]`` plan: timed commands, or waypoints with a controller.

    The waypoint controller turns towards the current waypoint at ``heading_gain`` × heading
    error (capped at ``max_turn_rate_deg``), drives at ``max_speed`` scaled by the cosine of
    the heading error (not at all when facing away) and, on the last waypoint, slows so as to
    stop on it. A waypoint within ``tolerance`` counts as reached; after the last, it stops.
    """

    def __init__(self, drive: DriveConfig, goal: tuple[float, float]) -> None:
        self.drive = drive
        self._times = [c.t_start for c in drive.commands]
        self._waypoints = list(drive.waypoints) if drive.waypoints else [tuple(goal)]
        self._next = 0  # index of the waypoint being tracked

    @classmethod
    def from_scene(cls, scene: Scene) -> PlanDriver:
        return cls(scene.spec.drive, scene.spec.robot.goal)

    @property
    def finished(self) -> bool:
        """True once every waypoint has been reached (never for timed commands)."""
        return not self.drive.commands and self._next >= len(self._waypoints)

    @property
    def waypoint_index(self) -> int:
        return self._next

    def command(self, t: float, odom_pose: Pose2D) -> tuple[float, float]:
        if self.drive.commands:
            i = bisect.bisect_right(self._times, t) - 1
            if i < 0:
                return 0.0, 0.0
            c = self.drive.commands[i]
            return c.v, math.radians(c.w_deg)
        return self._track(odom_pose)

    def _track(self, pose: Pose2D) -> tuple[float, float]:
        d = self.drive
        while self._next < len(self._waypoints):
            wx, wy = self._waypoints[self._next]
            if math.hypot(wx - pose.x, wy - pose.y) > d.tolerance:
                break
            self._next += 1
        if self._next >= len(self._waypoints):
            return 0.0, 0.0
        wx, wy = self._waypoints[self._next]
        dist = math.hypot(wx - pose.x, wy - pose.y)
        error = wrap_angle(math.atan2(wy - pose.y, wx - pose.x) - pose.theta)
        w_max = math.radians(d.max_turn_rate_deg)
        w = max(-w_max, min(w_max, d.heading_gain * error))
        v = d.max_speed * max(0.0, math.cos(error))
        if self._next == len(self._waypoints) - 1:
            # Slow down over the last metre so as not to overshoot the final waypoint.
            v = min(v, d.max_speed * dist)
        return v, w
