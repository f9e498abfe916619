"""Closed loop (paper Fig. 6): the fly engine and the planner drive the simulated robot.

The same pipeline and virtual clock as replay, fed with the records as the simulator
produces them; the command is the planner's newest. Implements the simulator's Driver
protocol plus ``observe`` (records in), ``finish`` (flush at the end) and ``finished``.
"""

from __future__ import annotations

import json

from flylog.config import to_mapping
from flylog.geometry import Pose2D, StereoRig
from flylog.planner import Status
from flylog.replay.clock import VirtualClock
from flylog.replay.config import ReplayConfig
from flylog.replay.pipeline import FlyPipeline, Write
from flylog.replay.run import clock_config


class PlannerDriver:
    def __init__(
        self,
        config: ReplayConfig,
        rig: StereoRig,
        start: Pose2D,
        goal: tuple[float, float],
        write: Write,
    ) -> None:
        self.config = config
        # the simulator writes odom → base_link itself
        self.pipeline = FlyPipeline(config, rig, start, goal, write, write_tf=False)
        self.clock = VirtualClock(self.pipeline, clock_config(config, round(1e9 / rig.frame_rate)))

    def observe(self, record: object) -> None:
        self.clock.feed(record)

    def command(self, t: float, odom_pose: Pose2D) -> tuple[float, float]:
        # Records stamped t may still come (the simulator asks right after odometry at t):
        # compute only up to just before t.
        self.clock.advance_to(round(t * 1e9) - 1)
        cmd = self.pipeline.command
        if cmd.status is Status.GOAL_REACHED:
            return 0.0, 0.0
        return cmd.linear, cmd.angular

    @property
    def finished(self) -> bool:
        return self.pipeline.command.status is Status.GOAL_REACHED

    def finish(self, end_ns: int) -> dict[str, str]:
        """Run the clock to the end; the metadata to store, as replay stores it."""
        stats = self.clock.finish(end_ns)
        return {
            "config": json.dumps(to_mapping(self.config)),
            "generations": str(stats.generations),
            "evaluations": str(stats.evaluations),
            "frames": str(stats.frames),
            "closed_loop": "true",
        }
