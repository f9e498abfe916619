"""The harmonic-function planner (paper §2.3): a grid over the odometric frame holding a
potential U with ∇²U = 0, relaxed a few sweeps at a time, and steering along −∇U.

Dirichlet cells: 1 on the border, 0 at the goal cell, and 1 on the skin of (inflated)
obstacles, rising inside them towards the detected cells (``escape_rise``, see
:func:`~flylog.planner.obstacles.obstacle_values`) so a robot inside one is steered out. The
grid keeps its values between ticks: obstacle changes only re-pin cells and the following
sweeps carry the change through, as the paper's continually iterated function does.

``obstacle_weight`` (1: the paper's form) is the weight an obstacle cell has in the mean of
its free neighbours: below 1, a Robin boundary under which 1 − U does not decay
exponentially along a channel, so a narrow passage to the goal is not outweighed by a wide
detour (docs/navigation.md gives the decay rates). The only minimum is still the goal.
The obstacle memory is :class:`~flylog.planner.map.ObstacleMap`; a goal the map cuts off
starts the recoveries of :mod:`flylog.planner.recovery`. With ``frontier_field``, while the
goal is not reachable through cells seen free, the frontier cells nearest the goal are the
field's sinks in its place (:mod:`flylog.planner.frontier`); when
those are cut off from the robot the recoveries run too, and once spent the next frontier
pulls (the goal is not said to be unreachable: it is not cut off).
"""

from __future__ import annotations

import math

import numpy as np

from flylog.errors import ConfigError
from flylog.geometry import Pose2D
from flylog.planner import obstacles as obs
from flylog.planner.config import PlannerConfig
from flylog.planner.frontier import nearest_cells, reachable_frontier
from flylog.planner.grid import (
    GridGeometry,
    bilinear,
    centred_origin,
    gradient_field,
    log_distance_guess,
    neighbour_mean,
)
from flylog.planner.map import ObstacleMap
from flylog.planner.reach import any_within, reachable_from
from flylog.planner.recovery import Recovery, RecoverySequence, RecoverySettings
from flylog.planner.relax import RelaxEnd, RelaxResult, sor_sweeps
from flylog.planner.steering import (
    Command,
    PathEnd,
    PlannedPath,
    ProgressMonitor,
    SmoothedDirection,
    Status,
    speed_factor,
    unicycle_command,
)
from flylog.planner.trace import descend_on_grid


class HarmonicPlanner:
    """A harmonic potential over a square grid in the odometric frame.

    ``origin`` is the grid's corner (x, y) in odom (a Pose2D's heading is ignored: the grid
    is axis-aligned with odom); :meth:`centred_on` builds one centred on a point. See
    :mod:`flylog.planner.grid` for the array orientation.
    """

    def __init__(
        self,
        config: PlannerConfig,
        origin: Pose2D | tuple[float, float],
        goal_xy: tuple[float, float],
    ) -> None:
        ox, oy = (origin.x, origin.y) if isinstance(origin, Pose2D) else origin
        self.config = config
        self.geometry = GridGeometry((float(ox), float(oy)), config.cell_size, config.cells)
        self.goal = (float(goal_xy[0]), float(goal_xy[1]))
        n = config.cells
        gi, gj = self.geometry.cell_of(*self.goal)
        if not self.geometry.contains(*self.goal) or not (0 < gi < n - 1 and 0 < gj < n - 1):
            msg = (
                f"goal {self.goal} lies outside the planner grid (corner {self.geometry.origin}, "
                f"side {n * config.cell_size:g} m, border cells excluded); "
                "increase planner.extent or move the grid"
            )
            raise ConfigError(msg)
        self._goal_cell = (gi, gj)
        self._border = np.zeros((n, n), dtype=bool)
        self._border[[0, -1], :] = True
        self._border[:, [0, -1]] = True
        self.map = ObstacleMap(config, self.geometry)
        x, y = self.geometry.centres()
        self._goal_distance = np.hypot(x - self.goal[0], y - self.goal[1])
        # frontier_field: the frontier cells that pull (None: the goal, or not yet computed)
        self._sinks: np.ndarray | None = None
        self._frontier_cut = False  # the sinks held are cut off from the robot
        self._release = False  # the recoveries for them are spent: take the next frontier
        self._for_frontier = False  # the recoveries in force began for a frontier cut off
        self._sink_cells = np.zeros((n, n), dtype=bool)  # the sinks pinned in the field
        self._fixed = np.zeros((n, n), dtype=bool)
        # the relaxed state: obstacle cells hold obstacle_weight × their value, so the
        # sweep's weighted mean needs no per-neighbour weights (see obs.neighbour_factor)
        self._u = log_distance_guess(self.geometry, self.goal)
        self._factor: np.ndarray | None = None  # None: the plain mean (obstacle_weight 1)
        self._weighted = np.zeros((n, n), dtype=bool)  # cells holding weight × value
        self._field_cache: np.ndarray | None = None
        self._apply_dirichlet()
        self._monitor = ProgressMonitor(config.stuck_time, config.stuck_progress)
        self._heading = SmoothedDirection(config.heading_smoothing)
        self._grad_cache: tuple[np.ndarray, np.ndarray] | None = None
        self._recoveries = RecoverySequence(RecoverySettings.of(config))
        self._reachable: tuple[int, np.ndarray] | None = None  # (map version, goal's region)

    @classmethod
    def centred_on(
        cls, config: PlannerConfig, centre_xy: tuple[float, float], goal_xy: tuple[float, float]
    ) -> HarmonicPlanner:
        """A planner whose grid is centred on ``centre_xy`` (e.g. the start)."""
        return cls(config, centred_origin(centre_xy, config.cells * config.cell_size), goal_xy)

    # ----------------------------------------------------------------- read-only views

    @property
    def origin(self) -> tuple[float, float]:
        """Corner (x, y) of cell [0, 0] in odom: the foxglove Grid's origin."""
        return self.geometry.origin

    @property
    def cell_size(self) -> float:
        return self.geometry.cell_size

    @property
    def potential(self) -> np.ndarray:
        """(H, W) float32 copy of U; row 0 at the origin's y, rows along +y, cols along +x."""
        return self._field().astype(np.float32)

    @property
    def obstacle_mask(self) -> np.ndarray:
        """(H, W) bool, read-only: inflated obstacle cells (Dirichlet >= 1, border excluded)."""
        view = self.map.obstacles.view()
        view.flags.writeable = False
        return view

    @property
    def detected_mask(self) -> np.ndarray:
        """(H, W) bool, read-only: remembered obstacle cells before inflation."""
        view = self.map.remembered.view()
        view.flags.writeable = False
        return view

    @property
    def recovery(self) -> Recovery:
        """The recovery in force (NONE while the goal is reachable in the map)."""
        return self._recoveries.phase

    # ----------------------------------------------------------------- obstacles

    def update_obstacles(
        self,
        points_odom_xy: np.ndarray,
        robot_pose: Pose2D,
        half_fov: float,
        view_range: float | None = None,
        sonar_xy: np.ndarray | None = None,
        focal_baseline: float | None = None,
        sonar_cones: tuple[np.ndarray, float] | None = None,
    ) -> int:
        """Fold the obstacle flies seen now (points (M, 2) or (M, 3) in odom) and the sonar
        echoes' arc points ``sonar_xy`` (M, 2) in odom into the map (:class:`~flylog.
        planner.map.ObstacleMap`'s rules; ``focal_baseline``, the rig's focal length in
        pixels times its baseline, weights the flies by their depth error and casts their
        lines of sight; ``sonar_cones``: the sonars' free cones and their half opening angle,
        :mod:`flylog.planner.sonar_free`). Returns how many inflated obstacle cells
        changed."""
        vr = self.config.view_range if view_range is None else float(view_range)
        version = self.map.version
        changed = self.map.update(
            points_odom_xy, robot_pose, half_fov, vr, sonar_xy, focal_baseline, sonar_cones
        )
        moved = self.config.frontier_field and self.update_frontier(robot_pose, apply=False)
        if self.map.version != version or moved:
            self._apply_dirichlet()
        return changed

    def update_frontier(self, robot_pose: Pose2D, *, apply: bool = True) -> bool:
        """With ``frontier_field``: recompute the frontier cells that pull, as seen from the
        robot (:mod:`flylog.planner.frontier`; :meth:`update_obstacles` does so at every
        update), and with ``apply`` re-pin the field; whether they changed. A robot inside
        an inflated obstacle looks from the free cells near it."""
        m, cfg = self.map, self.config
        cell = self.geometry.cell_of(robot_pose.x, robot_pose.y)
        obstacles = m.obstacles
        if obstacles[cell]:
            r = math.ceil(cfg.inflation_cells) + 1
            obstacles = obstacles.copy()
            i, j = cell
            obstacles[max(i - r, 0) : i + r + 1, max(j - r, 0) : j + r + 1] = False
        region, frontier = reachable_frontier(m.known, obstacles, cell)
        held, self._frontier_cut = self._sinks, False
        sinks = (
            None
            if region[self._goal_cell]
            else nearest_cells(frontier, self._goal_distance, cfg.frontier_band)
        )
        if sinks is not None and held is not None and not self._release:
            # the frontier nearest the goal cut off (a passage closed in the map, perhaps
            # by a phantom): keep pulling there while the recoveries try to open it
            still = held & ~m.known & ~obstacles
            if still.any() and not (still & frontier).any():
                new = float(self._goal_distance[sinks].min()) if sinks.any() else math.inf
                if new > float(self._goal_distance[still].min()) + cfg.frontier_band:
                    sinks, self._frontier_cut = still, True
        self._release = False
        same = (sinks is None and held is None) or (
            sinks is not None and held is not None and np.array_equal(sinks, held)
        )
        self._sinks = sinks
        if apply and not same:
            self._apply_dirichlet()
        return not same

    def clear_obstacles(self) -> None:
        """Forget every obstacle (the potential relaxes back over the freed cells)."""
        self.set_detected(np.zeros(self.geometry.shape, dtype=bool))

    def set_detected(self, detected: np.ndarray, known: np.ndarray | None = None) -> None:
        """Remember exactly the cells of ``detected`` (H, W) bool: a map of known geometry;
        ``known`` (H, W) bool, the cells that count as seen (None: every cell)."""
        self.map.clear()
        self.map.replace(detected, known)
        self._apply_dirichlet()

    def goal_cut_off(self, robot_pose: Pose2D) -> bool:
        """Whether no free cells connect the robot to the goal cell in the map (a robot
        inside an inflated obstacle asks for the free cells within the inflation of it)."""
        m = self.map
        if self._reachable is None or self._reachable[0] != m.version:
            self._reachable = (m.version, reachable_from(~m.obstacles, self._goal_cell))
        region = self._reachable[1]
        cell = self.geometry.cell_of(robot_pose.x, robot_pose.y)
        if not self.map.obstacles[cell]:
            return not bool(region[cell])
        return not any_within(region, cell, math.ceil(self.config.inflation_cells) + 1)

    # ----------------------------------------------------------------- relaxation

    def relax(self, sweeps: int | None = None, omega: float | None = None) -> float:
        """Run ``sweeps`` SOR sweeps (``omega``: planner.omega if None); return the largest
        change of the last sweep.

        By default (a planner tick): ``sweeps_per_tick`` sweeps, then more in chunks of as
        many while the last sweep still changed a cell by more than ``relax_tolerance``, up
        to ``max_sweeps_per_tick`` in all. Far from the goal, behind obstacles, U is within
        1e-5 of 1 and its gradient tiny: the transient of an obstacle update would steer
        the robot (it spins in place) unless the field is relaxed that far."""
        cfg = self.config
        n = cfg.sweeps_per_tick if sweeps is None else int(sweeps)
        if n < 0:
            msg = f"sweeps must be at least 0, got {n}"
            raise ValueError(msg)
        self._grad_cache = self._field_cache = None
        change = self._sweep(n, omega)
        if sweeps is not None:
            return change
        done = n
        while change > cfg.relax_tolerance and done < cfg.max_sweeps_per_tick:
            more = min(n, cfg.max_sweeps_per_tick - done)
            change = self._sweep(more, omega)
            done += more
        return change

    def relax_until(
        self, tolerance: float, max_sweeps: int, chunk: int = 10, omega: float | None = None
    ) -> RelaxResult:
        """Sweep in chunks until the last sweep's largest change is at most ``tolerance`` or
        ``max_sweeps`` are spent (for tests, warm starts and benchmarks; ticks use relax)."""
        done, change = 0, math.inf
        while done < max_sweeps:
            n = min(chunk, max_sweeps - done)
            change = self.relax(n, omega)
            done += n
            if change <= tolerance:
                return RelaxResult(done, change, RelaxEnd.CONVERGED)
        return RelaxResult(done, change, RelaxEnd.MAX_SWEEPS)

    # ----------------------------------------------------------------- steering

    def value(self, x: float, y: float) -> float:
        """U bilinearly interpolated at (x, y)."""
        return bilinear(self._field(), self.geometry, x, y)

    def gradient(self, x: float, y: float) -> tuple[float, float]:
        """∇U at (x, y): central-difference gradients at cell centres, bilinearly
        interpolated (continuous across cells; exact for a linear U)."""
        gx, gy = self._gradients()
        return (bilinear(gx, self.geometry, x, y), bilinear(gy, self.geometry, x, y))

    def command(self, robot_pose: Pose2D, t: float) -> Command:
        """Velocities towards :meth:`steering_direction` (−∇U at the robot, or the point
        ``lookahead`` down the descent path), and the status at time ``t`` (seconds).

        GOAL_REACHED (zero velocities) within the goal tolerance; within
        ``goal_approach_distance`` the robot steers straight at the goal point. The forward
        speed is scaled down near the goal (``goal_slowdown``) and near remembered obstacles
        (``obstacle_slowdown``, :meth:`clearance`). STUCK when the distance to the goal has
        not improved by ``stuck_progress`` for ``stuck_time`` (the steering command is still
        given: the caller decides whether to stop). UNREACHABLE (zero velocities) once the
        recoveries of a goal cut off in the map are spent (:mod:`flylog.planner.recovery`)."""
        cfg = self.config
        dx, dy = self.goal[0] - robot_pose.x, self.goal[1] - robot_pose.y
        distance = math.hypot(dx, dy)
        if distance <= cfg.goal_tolerance:
            return Command(0.0, 0.0, Status.GOAL_REACHED)
        stuck = self._monitor.update(distance, t)
        recovering = self._recover(robot_pose, t, stuck)
        if recovering is not None:
            return recovering
        if distance <= cfg.goal_approach_distance:
            direction = (dx, dy)
        else:
            direction = self._heading.update(self.steering_direction(robot_pose), t)
        linear, angular = unicycle_command(
            robot_pose,
            direction,
            max_linear=cfg.max_linear_speed,
            max_angular=cfg.max_angular_speed,
            heading_gain=cfg.heading_gain,
            turn_in_place=math.radians(cfg.turn_in_place_deg),
        )
        near_goal = speed_factor(distance, cfg.goal_slowdown)
        reach = cfg.robot_radius + cfg.obstacle_slowdown
        near_obstacle = speed_factor(
            self.clearance(robot_pose.x, robot_pose.y, reach) - cfg.robot_radius,
            cfg.obstacle_slowdown,
            cfg.min_speed_fraction,
        )
        linear *= min(near_goal, near_obstacle)
        return Command(linear, angular, Status.STUCK if stuck else Status.DRIVING)

    def _recover(self, robot_pose: Pose2D, t: float, stuck: bool) -> Command | None:
        """The recovery's command while the goal is cut off (None: steer along the field)."""
        cfg, seq = self.config, self._recoveries
        before = seq.phase
        cut_off = self.goal_cut_off(robot_pose)
        # recoveries begun for a frontier cut off run to their end: the frontier a turn
        # sees open for a tick would otherwise stop them and start them again, for ever
        frontier = self._frontier_cut or (self._for_frontier and before is not Recovery.NONE)
        phase = seq.step(cut_off or frontier, t, robot_pose)
        if before is Recovery.NONE and phase is not Recovery.NONE:
            self._for_frontier = not cut_off
        if phase is Recovery.EXHAUSTED and not cut_off:
            # the frontier nearest the goal stays cut off, the goal is not: the next one
            self._release, self._frontier_cut, self._for_frontier = True, False, False
            seq.reset()
            return None
        if phase is Recovery.NONE:
            # the map opened to the goal: progress counts from here (not for a frontier,
            # whose recoveries leave the goal as far as it was)
            if before is not Recovery.NONE and not self._for_frontier:
                self._monitor.reset()
            self._for_frontier = False
            return None
        if phase is Recovery.LOOK_AROUND and before is not phase:
            self.map.forget_recent()  # the look-around gathers the evidence clear_stale keeps
        cleared = phase is Recovery.CLEAR_STALE and before is not phase
        if cleared and self.map.clear_stale(cfg.stale_keep_distance):
            self._apply_dirichlet()
        if phase is Recovery.BACK_UP and before is not phase:
            back = Pose2D(
                robot_pose.x - cfg.backup_distance * math.cos(robot_pose.theta),
                robot_pose.y - cfg.backup_distance * math.sin(robot_pose.theta),
                robot_pose.theta,
            )
            room = cfg.robot_radius + cfg.inflation_margin
            if self.clearance(back.x, back.y, room) < room:
                seq.skip_backing_up(t, robot_pose)
        linear, angular = seq.command() or (0.0, 0.0)
        if seq.phase is Recovery.EXHAUSTED:
            status = Status.UNREACHABLE
        else:
            status = Status.STUCK if stuck else Status.DRIVING
        return Command(linear, angular, status, seq.phase)

    def steering_direction(self, robot_pose: Pose2D) -> tuple[float, float]:
        """Where the robot heads (any length): −∇U at the robot, or with ``lookahead`` the
        point that far down the descent path (−∇U if the path ends at once)."""
        cfg = self.config
        gx, gy = self.gradient(robot_pose.x, robot_pose.y)
        steps = math.ceil(cfg.lookahead / cfg.path_step - 1e-9)
        if steps <= 0:
            return (-gx, -gy)
        path = self._descend(robot_pose, steps)
        # a path stopped by an obstacle ends inside it: aim at the last free point
        last = -2 if path.end is PathEnd.OBSTACLE and len(path.points) > 2 else -1
        ahead = path.points[last]
        dx, dy = float(ahead[0]) - robot_pose.x, float(ahead[1]) - robot_pose.y
        if math.hypot(dx, dy) < 0.5 * cfg.path_step:
            return (-gx, -gy)
        return (dx, dy)

    def clearance(self, x: float, y: float, reach: float) -> float:
        """Distance (m) from (x, y) to the nearest remembered obstacle cell's centre, if one
        lies within ``reach``; inf otherwise."""
        return self.map.clearance(x, y, reach)

    def trace_path(self, robot_pose: Pose2D) -> PlannedPath:
        """Gradient descent from the robot (bounded by ``path_max_steps``), and why it
        ended."""
        return self._descend(robot_pose, self.config.path_max_steps)

    def _descend(self, robot_pose: Pose2D, max_steps: int) -> PlannedPath:
        """Gradient descent on the grid from the robot, at most ``max_steps`` steps."""
        cfg = self.config
        return descend_on_grid(
            self._gradients(),
            self.map.obstacles,
            self.geometry,
            (robot_pose.x, robot_pose.y),
            self.goal,
            step=cfg.path_step,
            max_steps=max_steps,
            goal_tolerance=cfg.goal_tolerance,
        )

    def path(self, robot_pose: Pose2D) -> np.ndarray:
        """(K, 2) the path the robot would follow now, in odom, K <= path_max_steps + 2."""
        return self.trace_path(robot_pose).points

    def reset_progress(self) -> None:
        """Restart stuck detection and the recoveries (e.g. after a new goal)."""
        self._monitor.reset()
        self._recoveries.reset()

    # ----------------------------------------------------------------- internals

    def _apply_dirichlet(self) -> None:
        gi, gj = self._goal_cell
        a = self.config.obstacle_weight
        obstacles, values = self.map.obstacles, self.map.values
        # the frontier's sinks (frontier_field): while there are any, they pull in the
        # goal's place, 0 as the goal is; cells that were sinks and are free now restart
        # from their neighbours' mean, not as sinks
        sinks = self._frontier_sinks()
        goal = not sinks.any()
        self._fixed = self._border | obstacles | sinks
        self._fixed[gi, gj] |= goal
        self._u[self._border] = 1.0
        weighted = obstacles & ~self._border
        weighted[gi, gj] = False
        # freed obstacle cells restart from U = 1, their value as the obstacle's skin: the
        # state holds a × value there (0.1 at a = 0.1), which as a free cell would be a deep
        # transient sink next to the obstacle, drawing the robot to it until relaxed away
        self._u[self._weighted & ~weighted] = 1.0
        self._u[weighted] = a * values[weighted]
        freed = self._sink_cells & ~self._fixed
        if not goal and not self._fixed[gi, gj]:
            freed[gi, gj] = True
        if freed.any():
            self._u[freed] = neighbour_mean(self._u)[freed]
        self._sink_cells = sinks
        # freed obstacle cells may hold values above 1, which no free cell has at convergence
        np.minimum(self._u, 1.0, out=self._u, where=~self._fixed)
        self._u[sinks] = 0.0
        if goal:
            self._u[gi, gj] = 0.0
        self._factor = None if a == 1.0 else obs.neighbour_factor(np.where(weighted, a, 1.0))
        self._weighted = weighted
        self._grad_cache = self._field_cache = None

    def _frontier_sinks(self) -> np.ndarray:
        """The frontier cells pinned to 0 now (none without frontier_field, or with the goal
        reachable in known space): unknown cells that are not obstacles."""
        if not self.config.frontier_field or self._sinks is None:
            return np.zeros_like(self._fixed)
        return self._sinks & ~self.map.known & ~self._fixed

    def _sweep(self, n: int, omega: float | None = None) -> float:
        cfg = self.config
        w = cfg.omega if omega is None else omega
        return sor_sweeps(self._u, self._fixed, w, n, cfg.relaxation, self._factor)

    def _field(self) -> np.ndarray:
        """U itself: the relaxed state with the obstacle cells' own values (the state holds
        them times obstacle_weight)."""
        if self._factor is None:
            return self._u
        if self._field_cache is None:
            self._field_cache = np.where(self._weighted, self.map.values, self._u)
        return self._field_cache

    def _gradients(self) -> tuple[np.ndarray, np.ndarray]:
        if self._grad_cache is None:
            self._grad_cache = gradient_field(self._field(), self.geometry.cell_size)
        return self._grad_cache
