"""The planner's side of the pipeline, run as jobs of :class:`~flylog.replay.worker.OutputQueue`:
a planner tick (obstacles in, relaxation, command, table row) and the planner's part of a
snapshot (the potential, the path and the obstacle map, encoded as the log's messages; the
flies' part is :mod:`flylog.replay.fly_snapshot`'s).

Each job reads only what it is given, captured at its virtual time, and the planner, which
no other job touches: the jobs may run on a worker thread while the engine goes on."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from flylog.geometry import Pose2D, StereoRig, transform_points_2d
from flylog.io import contract, encode
from flylog.io.tables import Column, table_row
from flylog.planner import HarmonicPlanner
from flylog.planner.obstacles import sonar_arc_points
from flylog.planner.sonar_free import free_cones
from flylog.replay.config import ReplayConfig
from flylog.replay.obstacle_cache import Evidence
from flylog.replay.publication import Published
from flylog.replay.worker import Outputs
from flylog.sensors import OdomReading, SonarReading

# pyarrow type names: pyarrow is imported with the first row (flylog.io.tables)
_F, _I, _S = "float64", "int64", "string"

# RUN.parquet: one row per planner tick (the README's table is made from this).
STEP_COLUMNS = (
    Column("t_s", _F, "s", "log time of the planner tick"),
    Column("generation", _I, "", "generations (sgbm: frames matched) behind what the planner saw"),
    Column("evaluations", _I, "", "fitness evaluations so far (sgbm: the distinctness test's)"),
    Column("valid_flies", _I, "", "flies inside both images, with positive fitness (sgbm: points)"),
    Column("obstacle_flies", _I, "", "flies taken for obstacles (the [obstacles] rule)"),
    Column("best_fitness", _F, "", "best fitness of the population the planner saw"),
    Column("median_fitness", _F, "", "median fitness of its valid flies"),
    Column(
        "image_latency_s", _F, "s", "tick time − stamp of the images those flies were scored on"
    ),
    Column("odom_latency_s", _F, "s", "tick time − stamp of the newest odometry"),
    Column("x_m", _F, "m", "odometric position x"),
    Column("y_m", _F, "m", "odometric position y"),
    Column("theta_rad", _F, "rad", "odometric heading"),
    Column("linear_m_s", _F, "m/s", "commanded linear velocity"),
    Column("angular_rad_s", _F, "rad/s", "commanded angular velocity"),
    Column("status", _S, "", "planner status: driving, goal_reached, stuck or unreachable"),
    Column("potential_change", _F, "", "largest change of the tick's last SOR sweep"),
)


@dataclass(frozen=True)
class TickInputs:
    """What a planner tick at ``t_ns`` sees, captured at that virtual time."""

    t_ns: int
    published: Published
    evaluations: int  # fitness evaluations so far
    odom: OdomReading  # the newest odometry delivered
    sonar: tuple[SonarReading, Pose2D] | None  # the newest sonar reading, and odometry then


class PlannerJobs:
    """The planner's work for the pipeline; ``rows`` makes each tick's row of the per-step
    table. ``evidence`` is the obstacle rule's answers, shared with the flies' snapshots."""

    def __init__(
        self,
        config: ReplayConfig,
        rig: StereoRig,
        planner: HarmonicPlanner,
        evidence: Evidence,
        *,
        rows: bool,
    ) -> None:
        self.config = config
        self.rig = rig
        self.planner = planner
        self._rows = rows
        self._mapping_range = config.planner.mapping_range(rig.focal_px, rig.baseline)
        self._evidence = evidence

    def warm_start(self) -> Outputs:
        """Relax the obstacle-free field before the first tick (planner.warm_start_sweeps, at
        the grid's optimal over-relaxation: planner.warm_start_omega)."""
        cfg = self.config.planner
        self.planner.relax_until(
            cfg.relax_tolerance, cfg.warm_start_sweeps, chunk=100, omega=cfg.warm_start_omega
        )
        return Outputs([])

    def tick(self, tick: TickInputs) -> Outputs:
        """The planner's work at one tick: obstacles in, relaxation, command, table row."""
        seen = tick.published
        pop = seen.population
        if pop is None:
            obstacles = np.empty((0, 3))
        else:
            mask, _ = self._evidence.of(pop, seen.pair, seen.generation, seen.candidates)
            obstacles = pop.xyz[mask]
            in_odom = transform_points_2d(seen.pose, obstacles[:, :2])
            self.planner.update_obstacles(
                in_odom,
                seen.pose,
                self.rig.half_fov,
                view_range=self._mapping_range,
                sonar_xy=self._echoes(tick.sonar),
                focal_baseline=self.rig.focal_px * self.rig.baseline,
                sonar_cones=self._free_cones(tick.sonar),
            )
        change = self.planner.relax()
        pose, t_ns = tick.odom.pose, tick.t_ns
        command = self.planner.command(pose, t_ns / 1e9)
        status = contract.CommandStatus(command.status.value)
        message = encode.command(command.linear, command.angular, status, t_ns)
        messages: list[tuple[str, int, Any]] = [(contract.PLANNER_COMMAND, t_ns, message)]
        if not self._rows:
            return Outputs(messages, command)
        valid = pop.fitness[pop.fitness > 0] if pop is not None else np.empty(0)
        values = {
            "t_s": t_ns / 1e9,
            "generation": seen.generation,
            "evaluations": tick.evaluations,
            "valid_flies": len(valid),
            "obstacle_flies": len(obstacles),
            "best_fitness": float(valid.max()) if len(valid) else math.nan,
            "median_fitness": float(np.median(valid)) if len(valid) else math.nan,
            "image_latency_s": (t_ns - seen.image_stamp_ns) / 1e9
            if seen.image_stamp_ns >= 0
            else math.nan,
            "odom_latency_s": (t_ns - tick.odom.stamp_ns) / 1e9,
            "x_m": pose.x,
            "y_m": pose.y,
            "theta_rad": pose.theta,
            "linear_m_s": command.linear,
            "angular_rad_s": command.angular,
            "status": status.value,
            "potential_change": change,
        }
        return Outputs(messages, command, table_row(STEP_COLUMNS, values))

    def _echoes(self, sonar: tuple[SonarReading, Pose2D] | None) -> np.ndarray | None:
        """The sonar reading's near echoes (planner.sonar_range) as arc points in odom, for
        the planner (None: none)."""
        reach = self.config.planner.sonar_range
        if sonar is None or reach <= 0.0:
            return None
        reading, pose = sonar
        arcs = sonar_arc_points(reading, reach, 0.5 * self.config.planner.cell_size)
        return transform_points_2d(pose, arcs) if len(arcs) else None

    def _free_cones(
        self, sonar: tuple[SonarReading, Pose2D] | None
    ) -> tuple[np.ndarray, float] | None:
        """The sonar reading's free cones in odom and their half opening angle, for the
        planner (None: no reading, or planner.sonar_clears off)."""
        cfg = self.config.planner
        if sonar is None or not cfg.sonar_clears:
            return None
        reading, pose = sonar
        return free_cones(reading, pose, cfg.sonar_free_margin), reading.half_cone

    def snapshot(self, t_ns: int, robot_pose: Pose2D) -> list[tuple[str, int, Any]]:
        """The planner's part of a snapshot: the potential, the path the robot would follow
        from ``robot_pose`` and the obstacle map, now."""
        ox, oy = self.planner.origin
        grid = encode.grid(
            self.planner.potential,
            Pose2D(ox, oy, 0.0),
            self.planner.cell_size,
            t_ns,
            contract.ODOM_FRAME,
        )
        path = encode.poses_in_frame(
            path_poses(self.planner.path(robot_pose)), t_ns, contract.ODOM_FRAME
        )
        occupancy = encode.occupancy_grid(
            self.planner.detected_mask,
            self.planner.obstacle_mask,
            Pose2D(ox, oy, 0.0),
            self.planner.cell_size,
            t_ns,
            contract.ODOM_FRAME,
        )
        return [
            (contract.PLANNER_POTENTIAL, t_ns, grid),
            (contract.PLANNER_PATH, t_ns, path),
            (contract.PLANNER_MAP, t_ns, occupancy),
        ]


def path_poses(points: np.ndarray) -> np.ndarray:
    """(K, 2) path points → (K, 3) poses heading along the path (the last keeps the previous
    heading)."""
    if len(points) == 0:
        return np.empty((0, 3))
    d = np.diff(points, axis=0)
    heading = np.arctan2(d[:, 1], d[:, 0]) if len(d) else np.zeros(0)
    heading = np.append(heading, heading[-1] if len(heading) else 0.0)
    return np.column_stack([points, heading])
