"""Closed loop (paper Fig. 6): the fly engine and the planner drive the simulated robot.

The same pipeline and virtual clock as replay, fed with the records as the simulator
produces them; the command is the planner's newest. Implements the simulator's Driver
protocol plus ``observe`` (records in), ``finish`` (flush at the end), ``finished`` and
``status``. The run is finished when the planner reports the goal reached or unreachable,
or once it has reported STUCK for ``planner.stuck_timeout`` seconds without a break.
"""

from __future__ import annotations

import json
from collections.abc import Callable

from flylog.config import to_mapping
from flylog.geometry import Pose2D, StereoRig
from flylog.planner import Status
from flylog.replay.clock import VirtualClock
from flylog.replay.config import ReplayConfig
from flylog.replay.pipeline import FlyPipeline, Write
from flylog.replay.run import clock_config
from flylog.scene.load import Scene

# statuses that end a run at once
_ENDS = (Status.GOAL_REACHED, Status.UNREACHABLE)


class PlannerDriver:
    def __init__(
        self,
        config: ReplayConfig,
        rig: StereoRig,
        start: Pose2D,
        goal: tuple[float, float],
        write: Write,
        *,
        row_period_ns: float = 0.0,
    ) -> None:
        self.config = config
        # the simulator writes odom → base_link itself
        self.pipeline = FlyPipeline(
            config, rig, start, goal, write, write_tf=False, row_period_ns=row_period_ns
        )
        self.clock = VirtualClock(self.pipeline, clock_config(config, rig))
        self._stuck_since: float | None = None  # s: when the planner's STUCK began
        self._t = 0.0

    def observe(self, record: object) -> None:
        self.clock.feed(record)

    def command(self, t: float, odom_pose: Pose2D) -> tuple[float, float]:
        # Records stamped t may still come (the simulator asks right after odometry at t):
        # compute only up to just before t.
        self.clock.advance_to(round(t * 1e9) - 1)
        cmd = self.pipeline.command
        self._t = t
        if cmd.status is not Status.STUCK:
            self._stuck_since = None
        elif self._stuck_since is None:
            self._stuck_since = t
        if cmd.status in _ENDS or self.finished:
            return 0.0, 0.0
        return cmd.linear, cmd.angular

    @property
    def stuck_for(self) -> float:
        """Seconds the planner has reported STUCK without a break (0 when it is not)."""
        return 0.0 if self._stuck_since is None else self._t - self._stuck_since

    @property
    def finished(self) -> bool:
        if self.pipeline.command.status in _ENDS:
            return True
        return self._stuck_since is not None and (
            self.stuck_for >= self.config.planner.stuck_timeout
        )

    @property
    def status(self) -> str:
        """How the run stands: the planner's status ('goal_reached', 'unreachable', 'stuck',
        'driving')."""
        return self.pipeline.command.status.value

    @property
    def ending(self) -> str:
        """Why the run ends (or would end now): 'goal_reached', 'unreachable', 'stuck' (STUCK
        for planner.stuck_timeout) or 'duration' (the simulation's time ran out)."""
        if self.pipeline.command.status in _ENDS:
            return self.pipeline.command.status.value
        return "stuck" if self.finished else "duration"

    def finish(self, end_ns: int) -> dict[str, str]:
        """Run the clock to the end; the metadata to store, as replay stores it (plus the
        planner's status and the run's ending when the simulation stopped)."""
        status, ending, stuck_for = self.status, self.ending, self.stuck_for
        stats = self.clock.finish(end_ns)
        return {
            "config": json.dumps(to_mapping(self.config)),
            "generations": str(stats.generations),
            "evaluations": str(stats.evaluations),
            "frames": str(stats.frames),
            "closed_loop": "true",
            "status": status,
            "ending": ending,
            "stuck_for": repr(stuck_for),
        }


def planner_driver(config: ReplayConfig) -> Callable[[Scene, Write], PlannerDriver]:
    """The ``make_driver`` that :func:`flylog.sim.run.simulate` takes for a closed loop: the
    engine and the planner, with ``config``, drive the robot from the scene's start pose to
    its goal, seeing through the scene's camera."""

    def make_driver(scene: Scene, write: Write) -> PlannerDriver:
        defects = scene.spec.camera_defects  # the simulator's rolling shutter, as it renders
        row_period_ns = 0.0 if defects.ideal else defects.row_period_us * 1000.0
        return PlannerDriver(
            config,
            scene.spec.camera,
            scene.start_pose,
            scene.goal,
            write,
            row_period_ns=row_period_ns,
        )

    return make_driver
