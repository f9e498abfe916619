"""The harmonic-function planner (paper §2.3): a grid over the odometric frame holding a
potential U with ∇²U = 0, relaxed a few sweeps at a time, and steering along −∇U.

Dirichlet cells: 1 on the border, 0 at the goal cell, and 1 on the skin of (inflated)
obstacles, rising inside them towards the detected cells (``escape_rise``, see
:func:`~flylog.planner.obstacles.obstacle_values`) so a robot inside one is steered out. The
grid keeps its values between ticks: obstacle changes only re-pin cells and the following
sweeps carry the change through, as the paper's continually iterated function does.

``obstacle_weight`` (1: the paper's form) is the weight an obstacle cell has in the mean of
its free neighbours. With Dirichlet obstacles (weight 1), 1 − U decays like exp(−π x / w)
along a channel of free width w (Connolly & Grupen's known weakness of Dirichlet harmonic
fields): in the corridor scene the goal's pull 10 m down the 2.2 m channel (~1e-7) is
weaker than that of the detour out of the back and round a wall, and −∇U at the start
points backwards. A weight a < 1 is a Robin boundary: the decay per cell along a one-cell
channel falls from r = 0.27 (a = 1) to r = 1 + a − √(a² + 2a) (0.78 at a = 0.03), so the
shorter way wins. Every free cell is still a weighted mean of its neighbours with positive
weights: the discrete maximum principle holds and the only minimum is the goal.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import numpy as np

from flylog.errors import ConfigError
from flylog.geometry import Pose2D
from flylog.planner import obstacles as obs
from flylog.planner.config import PlannerConfig
from flylog.planner.grid import GridGeometry, bilinear, centred_origin, gradient_field
from flylog.planner.relax import sor_sweeps
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


class RelaxEnd(enum.Enum):
    """Which bound stopped :meth:`HarmonicPlanner.relax_until`."""

    CONVERGED = "converged"  # the last sweep changed no cell by more than the tolerance
    MAX_SWEEPS = "max_sweeps"  # the sweep budget ran out first


@dataclass(frozen=True, slots=True)
class RelaxResult:
    sweeps: int
    max_change: float
    end: RelaxEnd


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
        self._remembered = np.zeros((n, n), dtype=bool)  # detected, before inflation
        self._seen_free_count = np.zeros((n, n), dtype=np.int32)
        self._seen_dense_count = np.zeros((n, n), dtype=np.int32)
        self._obstacles = np.zeros((n, n), dtype=bool)  # inflated
        self._obstacle_values = np.zeros((n, n))  # Dirichlet values on self._obstacles
        self._inflated_from = self._remembered.copy()  # what those two were made from
        self._fixed = np.zeros((n, n), dtype=bool)
        # the relaxed state: obstacle cells hold obstacle_weight × their value, so the
        # sweep's weighted mean needs no per-neighbour weights (see obs.neighbour_factor)
        self._u = self._initial_guess()
        self._factor: np.ndarray | None = None  # None: the plain mean (obstacle_weight 1)
        self._weighted = np.zeros((n, n), dtype=bool)  # cells holding weight × value
        self._field_cache: np.ndarray | None = None
        self._apply_dirichlet()
        self._monitor = ProgressMonitor(config.stuck_time, config.stuck_progress)
        self._heading = SmoothedDirection(config.heading_smoothing)
        self._grad_cache: tuple[np.ndarray, np.ndarray] | None = None

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
        view = self._obstacles.view()
        view.flags.writeable = False
        return view

    @property
    def detected_mask(self) -> np.ndarray:
        """(H, W) bool, read-only: remembered obstacle cells before inflation."""
        view = self._remembered.view()
        view.flags.writeable = False
        return view

    # ----------------------------------------------------------------- obstacles

    def update_obstacles(
        self,
        points_odom_xy: np.ndarray,
        robot_pose: Pose2D,
        half_fov: float,
        view_range: float | None = None,
        sonar_xy: np.ndarray | None = None,
    ) -> int:
        """Fold the obstacle flies seen now (points (M, 2) or (M, 3) in odom) into the grid.

        Cells dense inside the view sector for ``confirm_after_views`` updates in a row
        become obstacles; cells outside the view keep
        what they were; with ``clear_free_cells``, a remembered cell seen free (in view,
        not dense, not in a detection's shadow, at least ``clear_min_range`` away)
        ``clear_after_views`` updates in a row is forgotten. The cells holding a point of
        ``sonar_xy`` (M, 2) in odom (sonar echoes: :func:`~flylog.planner.obstacles.
        sonar_arc_points`) become obstacles at once and are not seen free this update.
        Returns how many inflated obstacle cells changed.
        """
        cfg = self.config
        vr = cfg.view_range if view_range is None else float(view_range)
        counts = obs.fly_counts(self.geometry, points_odom_xy)
        # only the cells within the view range of the robot can be seen: work on that window
        rows, cols = self._window(robot_pose, vr)
        dense = obs.dense_cells(
            counts, cfg.cell_size, cfg.density_window_cells, cfg.density_threshold, rows, cols
        )
        rng, bearing = obs.polar_of_cells(self.geometry, robot_pose, rows, cols)
        in_view = obs.view_mask(rng, bearing, half_fov, vr)
        # a cell counts as detected once it has been dense in view confirm_after_views
        # updates in a row (cells outside the window start counting again)
        dense_now = dense & in_view
        count = np.zeros_like(self._seen_dense_count)
        count[rows, cols] = np.where(dense_now, self._seen_dense_count[rows, cols] + 1, 0)
        self._seen_dense_count = count
        detected = dense_now & (count[rows, cols] >= cfg.confirm_after_views)
        echoed = None
        if sonar_xy is not None and len(sonar_xy):
            echoed = obs.fly_counts(self.geometry, sonar_xy) > 0
        if cfg.clear_free_cells:
            # a dense cell is not free, and hides what lies behind it, confirmed or not
            free = obs.seen_free(in_view, dense_now, rng, bearing, half_fov, cfg.cell_size, vr)
            free &= rng >= cfg.clear_min_range
            if echoed is not None:
                free &= ~echoed[rows, cols]
            seen = np.zeros_like(self._seen_free_count)
            seen[rows, cols] = np.where(free, self._seen_free_count[rows, cols] + 1, 0)
            self._seen_free_count = seen
            self._remembered &= self._seen_free_count < cfg.clear_after_views
        self._remembered[rows, cols] |= detected
        if echoed is not None:
            self._remembered |= echoed
        before, before_values = self._obstacles, self._obstacle_values
        self._set_obstacles()
        changed = int(np.count_nonzero(before != self._obstacles))
        if changed or not np.array_equal(before_values, self._obstacle_values):
            self._apply_dirichlet()
        return changed

    def clear_obstacles(self) -> None:
        """Forget every obstacle (the potential relaxes back over the freed cells)."""
        self._remembered[:] = False
        self._seen_free_count[:] = 0
        self._seen_dense_count[:] = 0
        self._set_obstacles()
        self._apply_dirichlet()

    # ----------------------------------------------------------------- relaxation

    def relax(self, sweeps: int | None = None) -> float:
        """Run ``sweeps`` SOR sweeps; return the largest change of the last sweep.

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
        change = self._sweep(n)
        if sweeps is not None:
            return change
        done = n
        while change > cfg.relax_tolerance and done < cfg.max_sweeps_per_tick:
            more = min(n, cfg.max_sweeps_per_tick - done)
            change = self._sweep(more)
            done += more
        return change

    def relax_until(self, tolerance: float, max_sweeps: int, chunk: int = 10) -> RelaxResult:
        """Sweep in chunks until the last sweep's largest change is at most ``tolerance`` or
        ``max_sweeps`` are spent (for tests, warm starts and benchmarks; ticks use relax)."""
        done, change = 0, math.inf
        while done < max_sweeps:
            n = min(chunk, max_sweeps - done)
            change = self.relax(n)
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
        given: the caller decides whether to stop)."""
        cfg = self.config
        dx, dy = self.goal[0] - robot_pose.x, self.goal[1] - robot_pose.y
        distance = math.hypot(dx, dy)
        if distance <= cfg.goal_tolerance:
            return Command(0.0, 0.0, Status.GOAL_REACHED)
        stuck = self._monitor.update(distance, t)
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
        rows, cols = self._window(Pose2D(x, y, 0.0), reach)
        ii, jj = np.nonzero(self._remembered[rows, cols])
        if not len(ii):
            return math.inf
        cx, cy = self.geometry.centre_of(ii + rows.start, jj + cols.start)
        d = float(np.min(np.hypot(cx - x, cy - y)))
        return d if d <= reach else math.inf

    def trace_path(self, robot_pose: Pose2D) -> PlannedPath:
        """Gradient descent from the robot (bounded by ``path_max_steps``), and why it
        ended."""
        return self._descend(robot_pose, self.config.path_max_steps)

    def _descend(self, robot_pose: Pose2D, max_steps: int) -> PlannedPath:
        """Gradient descent on the grid from the robot, at most ``max_steps`` steps."""
        cfg = self.config
        return descend_on_grid(
            self._gradients(),
            self._obstacles,
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
        """Restart stuck detection (e.g. after a new goal)."""
        self._monitor.reset()

    # ----------------------------------------------------------------- internals

    def _initial_guess(self) -> np.ndarray:
        """A start close to the obstacle-free solution, log(distance) from the goal, so the
        robot has a descent direction from the first tick (the relaxation refines it)."""
        x, y = self.geometry.centres()
        d = np.hypot(x - self.goal[0], y - self.goal[1]) / self.geometry.cell_size
        guess = np.log1p(d)
        return guess / guess.max()

    def _set_obstacles(self) -> None:
        # most updates remember the same cells (464 of the 600 ticks of replay's 60 s
        # reference): the inflation and the values are a function of them only
        if np.array_equal(self._remembered, self._inflated_from):
            return
        self._inflated_from = self._remembered.copy()
        cfg = self.config
        distance = obs.distance_within(self._remembered, cfg.inflation_cells)
        self._obstacles = np.isfinite(distance)
        self._obstacle_values = obs.obstacle_values(distance, cfg.inflation_cells, cfg.escape_rise)

    def _apply_dirichlet(self) -> None:
        gi, gj = self._goal_cell
        a = self.config.obstacle_weight
        self._fixed = self._border | self._obstacles
        self._fixed[gi, gj] = True
        self._u[self._border] = 1.0
        weighted = self._obstacles & ~self._border
        weighted[gi, gj] = False
        # freed obstacle cells restart from U = 1, their value as the obstacle's skin: the
        # state holds a × value there (0.1 at a = 0.1), which as a free cell would be a deep
        # transient sink next to the obstacle, drawing the robot to it until relaxed away
        self._u[self._weighted & ~weighted] = 1.0
        self._u[weighted] = a * self._obstacle_values[weighted]
        # freed obstacle cells may hold values above 1, which no free cell has at convergence
        np.minimum(self._u, 1.0, out=self._u, where=~self._fixed)
        self._u[gi, gj] = 0.0
        self._factor = None if a == 1.0 else obs.neighbour_factor(np.where(weighted, a, 1.0))
        self._weighted = weighted
        self._grad_cache = self._field_cache = None

    def _sweep(self, n: int) -> float:
        cfg = self.config
        return sor_sweeps(self._u, self._fixed, cfg.omega, n, cfg.relaxation, self._factor)

    def _field(self) -> np.ndarray:
        """U itself: the relaxed state with the obstacle cells' own values (the state holds
        them times obstacle_weight)."""
        if self._factor is None:
            return self._u
        if self._field_cache is None:
            self._field_cache = np.where(self._weighted, self._obstacle_values, self._u)
        return self._field_cache

    def _window(self, pose: Pose2D, reach: float) -> tuple[slice, slice]:
        """Rows and cols of the cells whose centres may lie within ``reach`` of the pose."""
        ox, oy = self.geometry.origin
        c, n = self.geometry.cell_size, self.geometry.cells

        def span(centre: float) -> slice:
            lo = math.floor((centre - reach) / c - 0.5)
            hi = math.ceil((centre + reach) / c - 0.5) + 1
            return slice(min(max(lo, 0), n), min(max(hi, 0), n))

        return span(pose.y - oy), span(pose.x - ox)

    def _gradients(self) -> tuple[np.ndarray, np.ndarray]:
        if self._grad_cache is None:
            self._grad_cache = gradient_field(self._field(), self.geometry.cell_size)
        return self._grad_cache
