"""The planner's obstacle memory: which cells hold an obstacle, from the flies and sonars
seen over time, and their inflation by the robot's footprint.

Each update works on the cells within the view range: a cell dense with (depth-weighted)
fly weight in view for ``confirm_after_views`` updates in a row becomes remembered; a
remembered cell seen free ``clear_after_views`` updates in a row is forgotten. *Seen free*
is either of: in the view sector and nearer than the first dense cell of its bearing (not
in a shadow), or looked through by more fly weight than lies in it
(:mod:`flylog.planner.evidence`). Sonar echoes mark their arcs at once. The inflated cells
(robot radius plus ``inflation_margin``) are what the harmonic field treats as obstacles.
The cells ever seen free, heard free, found dense or echoed, and those the robot stands on,
are *known* (:attr:`ObstacleMap.known`, never forgotten): the others are where the
frontier lies (:mod:`flylog.planner.frontier`).
"""

from __future__ import annotations

import math

import numpy as np

from flylog.geometry import Pose2D
from flylog.planner import evidence as ev
from flylog.planner import obstacles as obs
from flylog.planner import sonar_free as sf
from flylog.planner.config import PlannerConfig
from flylog.planner.grid import GridGeometry


class ObstacleMap:
    """Remembered obstacle cells on ``geometry`` and their inflation (``config``'s rules)."""

    def __init__(self, config: PlannerConfig, geometry: GridGeometry) -> None:
        self.config = config
        self.geometry = geometry
        shape = geometry.shape
        self.remembered = np.zeros(shape, dtype=bool)  # detected, before inflation
        self.obstacles = np.zeros(shape, dtype=bool)  # inflated
        self.values = np.zeros(shape)  # Dirichlet values on self.obstacles
        self.current = np.zeros(shape, dtype=bool)  # dense or echoed at the latest update
        self.recent = np.zeros(shape, dtype=bool)  # dense or echoed since forget_recent
        self.recent_seen = np.zeros(shape, dtype=bool)  # in view, not shadowed, since then
        self.known = np.zeros(shape, dtype=bool)  # ever seen, heard free, or an obstacle
        self.version = 0  # bumped whenever obstacles or values change
        self.known_version = 0  # bumped whenever known gains cells
        self._seen_free_count = np.zeros(shape, dtype=np.int32)
        self._seen_dense_count = np.zeros(shape, dtype=np.int32)
        self._inflated_from = self.remembered.copy()

    def update(
        self,
        points_odom_xy: np.ndarray,
        robot_pose: Pose2D,
        half_fov: float,
        view_range: float,
        sonar_xy: np.ndarray | None = None,
        focal_baseline: float | None = None,
        sonar_cones: tuple[np.ndarray, float] | None = None,
    ) -> int:
        """Fold one update's obstacle flies (M, 2+) in odom and sonar arc points (M, 2) into
        the memory; ``focal_baseline`` (pixels × metres) turns on the depth weighting and the
        lines of sight; ``sonar_cones``, the sonars' free cones (n, 4) as
        :func:`~flylog.planner.sonar_free.free_cones` gives them and their half opening
        angle (rad), clear the cells they cover (with ``sonar_clears``). Returns how many
        inflated obstacle cells changed."""
        cfg = self.config
        vr = float(view_range)
        pts = np.asarray(points_odom_xy, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] < 2:
            msg = f"obstacle points must be (M, 2) or (M, 3), got shape {pts.shape}"
            raise ValueError(msg)
        rows, cols = self.window(robot_pose, vr)
        weight, through = self._fly_evidence(pts, robot_pose, vr, focal_baseline)
        sonar_free = None
        if sonar_cones is not None and cfg.sonar_clears:
            sonar_free = sf.cone_cells(self.geometry, sonar_cones[0], sonar_cones[1], rows, cols)
            # the flies the sonars hear nothing at weigh nothing in the density either
            weight = weight.astype(np.float64, copy=True)
            weight[rows, cols][sonar_free] = 0.0
        dense = obs.dense_cells(
            weight, cfg.cell_size, cfg.density_window_cells, cfg.density_threshold, rows, cols
        )
        looked_through = None
        if through is not None:
            looked_through = through[rows, cols] > weight[rows, cols]
            dense &= ~looked_through
        rng, bearing = obs.polar_of_cells(self.geometry, robot_pose, rows, cols)
        in_view = obs.view_mask(rng, bearing, half_fov, vr)
        dense_now = dense & in_view
        count = np.zeros_like(self._seen_dense_count)
        count[rows, cols] = np.where(dense_now, self._seen_dense_count[rows, cols] + 1, 0)
        self._seen_dense_count = count
        detected = dense_now & (count[rows, cols] >= cfg.confirm_after_views)
        seen = obs.seen_free(in_view, dense_now, rng, bearing, half_fov, cfg.cell_size, vr)
        self.recent_seen[rows, cols] |= seen | dense_now
        # seen, as far as a fly counts fully (ev.full_weight_range): farther, a wall is mapped
        # late or not at all, and the cells behind it would count as seen free
        near = rng <= ev.full_weight_range(focal_baseline, cfg.full_weight_depth_error, vr)
        known = ((seen | dense_now) & near) | (rng <= cfg.robot_radius)  # the robot's cells
        if looked_through is not None:
            known |= looked_through & in_view & near
        if sonar_free is not None:
            known |= sonar_free
        echoed = None
        if sonar_xy is not None and len(sonar_xy):
            echoed = obs.fly_counts(self.geometry, sonar_xy) > 0
        if cfg.clear_free_cells:
            free = seen.copy()
            if looked_through is not None:
                free |= looked_through & in_view
            if sonar_free is not None:
                free |= sonar_free
            free &= rng >= cfg.clear_min_range
            if echoed is not None:
                free &= ~echoed[rows, cols]
            counted = np.zeros_like(self._seen_free_count)
            counted[rows, cols] = np.where(free, self._seen_free_count[rows, cols] + 1, 0)
            self._seen_free_count = counted
            self.remembered &= self._seen_free_count < cfg.clear_after_views
        self.remembered[rows, cols] |= detected
        self.current[:] = False
        self.current[rows, cols] = dense_now
        if echoed is not None:
            self.remembered |= echoed
            self.current |= echoed
        self.recent |= self.current
        self._learn(known, rows, cols, echoed)
        return self._inflate()

    def _learn(
        self, known: np.ndarray, rows: slice, cols: slice, echoed: np.ndarray | None
    ) -> None:
        """Add an update's cells seen, heard free or echoed to :attr:`known`."""
        before = int(np.count_nonzero(self.known))
        self.known[rows, cols] |= known
        if echoed is not None:
            self.known |= echoed
        if int(np.count_nonzero(self.known)) != before:
            self.known_version += 1

    def _fly_evidence(
        self, pts: np.ndarray, pose: Pose2D, view_range: float, focal_baseline: float | None
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Fly weight in each cell, and the weight of the lines of sight through each cell
        (None without ``focal_baseline`` or with ``full_weight_depth_error`` 0: every fly
        counts 1, as in the paper's density)."""
        cfg = self.config
        if focal_baseline is None or cfg.full_weight_depth_error <= 0.0 or not len(pts):
            return obs.fly_counts(self.geometry, pts), None
        ranges = np.hypot(pts[:, 0] - pose.x, pts[:, 1] - pose.y)
        errors = ev.depth_errors(ranges, focal_baseline)
        weights = ev.depth_weights(ranges, focal_baseline, cfg.full_weight_depth_error)
        weight = ev.weighted_counts(self.geometry, pts, weights)
        if not cfg.see_through:
            return weight, None
        stops = np.minimum(ev.ray_stops(ranges, errors, cfg.cell_size), view_range)
        through = ev.seen_through(self.geometry, (pose.x, pose.y), pts, stops, weights)
        return weight, through

    def replace(self, detected: np.ndarray, known: np.ndarray | None = None) -> int:
        """Remember exactly the cells of ``detected`` (H, W) bool (a map of known geometry);
        ``known`` (H, W) bool: the cells that count as seen (None: every cell); how many
        inflated cells changed."""
        self.remembered[:] = detected
        self.known[:] = True if known is None else known
        self.known_version += 1
        return self._inflate()

    def clear(self) -> int:
        """Forget every obstacle; how many inflated cells changed."""
        self.remembered[:] = False
        self.current[:] = False
        self.recent[:] = False
        self.recent_seen[:] = False
        self._seen_free_count[:] = 0
        self._seen_dense_count[:] = 0
        return self._inflate()

    def forget_recent(self) -> None:
        """Start gathering the evidence :meth:`clear_stale` keeps afresh (from the next
        update on)."""
        self.recent[:] = False
        self.recent_seen[:] = False

    def clear_stale(self, keep_distance: float) -> int:
        """Forget the remembered cells that the cameras saw (in view, not in a shadow) in
        the updates since :meth:`forget_recent` and that lie farther than ``keep_distance``
        (m) from every cell of those updates' evidence (dense in view, or echoed); how many
        were forgotten. The planner calls :meth:`forget_recent` as the look-around begins:
        a wall seen anywhere round the robot is kept, and so is every cell the look-around
        could not see (beyond the mapping range, or behind a wall), which no view
        contradicts."""
        near = obs.distance_within(self.recent, keep_distance / self.config.cell_size)
        seen = obs.distance_within(self.recent_seen, 1.0)  # the cell or a neighbour
        stale = self.remembered & ~np.isfinite(near) & np.isfinite(seen)
        self.remembered &= ~stale
        self._inflate()
        return int(np.count_nonzero(stale))

    def window(self, pose: Pose2D, reach: float) -> tuple[slice, slice]:
        """Rows and cols of the cells whose centres may lie within ``reach`` of the pose."""
        ox, oy = self.geometry.origin
        c, n = self.geometry.cell_size, self.geometry.cells

        def span(centre: float) -> slice:
            lo = math.floor((centre - reach) / c - 0.5)
            hi = math.ceil((centre + reach) / c - 0.5) + 1
            return slice(min(max(lo, 0), n), min(max(hi, 0), n))

        return span(pose.y - oy), span(pose.x - ox)

    def clearance(self, x: float, y: float, reach: float) -> float:
        """Distance (m) from (x, y) to the nearest remembered cell's centre, if one lies
        within ``reach``; inf otherwise."""
        rows, cols = self.window(Pose2D(x, y, 0.0), reach)
        ii, jj = np.nonzero(self.remembered[rows, cols])
        if not len(ii):
            return math.inf
        cx, cy = self.geometry.centre_of(ii + rows.start, jj + cols.start)
        d = float(np.min(np.hypot(cx - x, cy - y)))
        return d if d <= reach else math.inf

    def _inflate(self) -> int:
        """Re-inflate if the remembered cells changed; how many inflated cells changed."""
        # most updates remember the same cells (464 of the 600 ticks of replay's 60 s
        # reference): the inflation and the values are a function of them only
        if np.array_equal(self.remembered, self._inflated_from):
            return 0
        self._inflated_from = self.remembered.copy()
        cfg = self.config
        before, before_values = self.obstacles, self.values
        distance = obs.distance_within(self.remembered, cfg.inflation_cells)
        self.obstacles = np.isfinite(distance)
        self.values = obs.obstacle_values(distance, cfg.inflation_cells, cfg.escape_rise)
        changed = int(np.count_nonzero(before != self.obstacles))
        if changed or not np.array_equal(before_values, self.values):
            self.version += 1
        return changed
