"""What the planner does when the map cuts the robot off from the goal.

No descent reaches the goal from a region that the map walls off (see
:mod:`flylog.planner.reach`): the field is flat there. Once the cut has lasted
``cut_off_time``, the planner tries, in order and each once: turning on the spot through
``look_around_deg`` (the cameras see the cells round the robot, and cells seen free are
cleared); forgetting the remembered cells far from the latest evidence
(``stale_keep_distance``); backing up ``backup_distance`` (a robot pressed against an
obstacle sees it nearer than the engine's depth range). If the goal is still cut off,
the status is UNREACHABLE: with unknown cells counted as free, no frontier of the robot's
free space leads to the goal (docs/navigation.md states the rule and its limit).
Whenever the goal becomes reachable the sequence ends and the robot steers along the
field again.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

from flylog.geometry import Pose2D
from flylog.geometry.poses import wrap_angle
from flylog.planner.config import PlannerConfig


class Recovery(enum.Enum):
    """Which recovery the planner is in (NONE: the goal is reachable, or the cut is new)."""

    NONE = "none"
    LOOK_AROUND = "look_around"
    CLEAR_STALE = "clear_stale"
    BACK_UP = "back_up"
    EXHAUSTED = "exhausted"  # every recovery tried: the status is UNREACHABLE


@dataclass(frozen=True, slots=True)
class RecoverySettings:
    cut_off_time: float  # s the goal must stay cut off before the first recovery
    look_around: float  # rad turned on the spot
    turn_rate: float  # rad/s
    backup_distance: float  # m
    backup_speed: float  # m/s

    @classmethod
    def of(cls, config: PlannerConfig) -> RecoverySettings:
        """The planner configuration's recovery settings (turns at max_angular_speed)."""
        return cls(
            cut_off_time=config.cut_off_time,
            look_around=math.radians(config.look_around_deg),
            turn_rate=config.max_angular_speed,
            backup_distance=config.backup_distance,
            backup_speed=config.backup_speed,
        )


@dataclass
class RecoverySequence:
    """The recoveries' state; :meth:`step` says which one is in force at each tick."""

    settings: RecoverySettings
    phase: Recovery = Recovery.NONE
    _cut_since: float | None = None
    _phase_since: float = 0.0
    _turned: float = 0.0
    _last_theta: float = 0.0
    _from: Pose2D | None = None

    def step(self, cut_off: bool, t: float, pose: Pose2D) -> Recovery:
        """The recovery in force at time ``t`` (s), given whether the goal is cut off now."""
        s = self.settings
        if not cut_off:
            self.phase, self._cut_since = Recovery.NONE, None
            return self.phase
        if self.phase is Recovery.NONE:
            if self._cut_since is None:
                self._cut_since = t
            if t - self._cut_since < s.cut_off_time:
                return self.phase
            self._enter(Recovery.LOOK_AROUND, t, pose)
        if self.phase is Recovery.LOOK_AROUND:
            self._turned += abs(wrap_angle(pose.theta - self._last_theta))
            self._last_theta = pose.theta
            # bounded in time too: a robot that cannot turn (wedged) must not turn for ever
            limit = 2.0 * s.look_around / max(s.turn_rate, 1e-9)
            if self._turned >= s.look_around or t - self._phase_since >= limit:
                self._enter(Recovery.CLEAR_STALE, t, pose)
        elif self.phase is Recovery.CLEAR_STALE:
            self._enter(Recovery.BACK_UP, t, pose)
        elif self.phase is Recovery.BACK_UP:
            assert self._from is not None
            moved = math.hypot(pose.x - self._from.x, pose.y - self._from.y)
            limit = 2.0 * s.backup_distance / max(s.backup_speed, 1e-9)
            if moved >= s.backup_distance or t - self._phase_since >= limit:
                self._enter(Recovery.EXHAUSTED, t, pose)
        return self.phase

    def skip_backing_up(self, t: float, pose: Pose2D) -> None:
        """No room behind the robot: give the back-up up."""
        if self.phase is Recovery.BACK_UP:
            self._enter(Recovery.EXHAUSTED, t, pose)

    def command(self) -> tuple[float, float] | None:
        """(linear, angular) of the recovery in force; None: steer along the field."""
        s = self.settings
        if self.phase is Recovery.LOOK_AROUND:
            return (0.0, s.turn_rate)
        if self.phase is Recovery.BACK_UP:
            return (-s.backup_speed, 0.0)
        if self.phase in (Recovery.CLEAR_STALE, Recovery.EXHAUSTED):
            return (0.0, 0.0)
        return None

    def reset(self) -> None:
        self.phase, self._cut_since = Recovery.NONE, None

    def _enter(self, phase: Recovery, t: float, pose: Pose2D) -> None:
        self.phase, self._phase_since = phase, t
        self._turned, self._last_theta, self._from = 0.0, pose.theta, pose
