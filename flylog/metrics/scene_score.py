"""A run (fly snapshots, planner) scored against the scene of its sensor log.

The run file is a ``flylog replay`` output or a closed-loop ``flylog simulate`` log (which is
then also the sensor log). Ground truth is rendered only at the snapshot times, from the
true pose interpolated there, by the simulator's depth path, on a grid of pixel blocks at
least ``truth_width`` blocks wide (``flylog.metrics.view``). Definitions: see
``flylog.metrics.flies`` (flies), ``flylog.metrics.obstacles`` (latency) and
``flylog.metrics.trajectory`` (ATE, RPE); the robot's metrics use the true trajectory
(``/truth/pose``): path length, clearance = distance to the nearest footprint − robot
radius, collisions = entries into negative clearance, goal reached = the true position
within ``goal_tolerance`` of the goal at some time.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from flylog.errors import LogError
from flylog.fly.obstacles import ObstacleFlies
from flylog.io import contract
from flylog.io.reader import LogReader
from flylog.io.records import LogMessage
from flylog.io.tables import table_row
from flylog.metrics import tables
from flylog.metrics.config import MetricsConfig
from flylog.metrics.flies import f_score, ratio, score_snapshots
from flylog.metrics.obstacles import ObstacleDetection as Detections
from flylog.metrics.obstacles import detect_obstacles
from flylog.metrics.result import MetricsResult, RunFacts, run_facts
from flylog.metrics.trajectory import (
    PoseInterpolator,
    associate,
    ate_rmse,
    count_entries,
    first_arrival,
    path_length,
    rpe_rmse,
)
from flylog.metrics.view import TrueViews
from flylog.scene.load import distance_to_obstacles
from flylog.sources.truth import LogTruth

# Odometry and truth are written at the same instants by the simulator; allow one 50 Hz
# period of mismatch for logs from elsewhere (evo's --t_max_diff default is 10 ms).
_MAX_MATCH_NS = 20_000_000
# Snapshots scored together (flylog.metrics.flies.score_snapshots), at most ~4 M view pixels at once
# (64 views of 160x120 blocks; 13 per-pixel 640x480 views).
_BATCH = 64
_BATCH_PIXELS = 1 << 22


# Columns of runs scored against ground-truth images (flylog.metrics.image_run): NaN here.
_IMAGE_COLUMNS = ("disparity_error_median_px", "bad1", "bad2", "coverage")
_DENSE_COLUMNS = (
    "sgbm_dense_error_median_px",
    "sgbm_dense_bad1",
    "sgbm_dense_bad2",
    "sgbm_dense_density",
)


class _Snapshot(NamedTuple):
    """A /flies snapshot waiting to be scored: its time and obstacle flies."""

    t_ns: int
    xyz: np.ndarray  # (M, 3) obstacle flies
    flies: int  # flies in the snapshot


def _snapshot_row(t_ns: int, t0_ns: int, pose: np.ndarray, score: Any) -> dict[str, Any]:
    values = {
        "stamp_ns": int(t_ns),
        "t_s": (t_ns - t0_ns) / 1e9,
        "true_x_m": float(pose[0]),
        "true_y_m": float(pose[1]),
        "true_theta_rad": float(pose[2]),
        "flies": score.flies,
        "obstacle_flies": score.obstacle_flies,
        "in_view": score.in_view,
        "on_surface": score.on_surface,
        "on_obstacle": score.on_obstacle,
        "visible_cells": score.visible_cells,
        "covered_cells": score.covered_cells,
        "precision": score.precision,
        "recall": score.recall,
        "f_score": score.f_score,
        "median_depth_error": (
            float(np.median(score.depth_errors)) if len(score.depth_errors) else math.nan
        ),
        "nearest_true_m": math.nan,  # filled in for all snapshots at once
        "nearest_visible_m": score.nearest_visible,
        "nearest_detected_m": score.nearest_detected,
        **dict.fromkeys(_IMAGE_COLUMNS, math.nan),
    }
    return table_row(tables.SNAPSHOT_COLUMNS, values)


def _robot_summary(truth: LogTruth, config: MetricsConfig) -> dict[str, Any]:
    true = truth.true
    if len(true) == 0:
        msg = f"{truth.path}: /truth/pose has no messages"
        raise LogError(msg)
    t0 = true.t_ns[0]
    arrival = first_arrival(true, truth.goal, config.goal_tolerance)
    clearance = distance_to_obstacles(truth.scene, true.xy) - truth.scene.spec.robot.radius
    i_ref, i_est = associate(true.t_ns, truth.odom.t_ns, _MAX_MATCH_NS)
    ref, est = true.xyt[i_ref], truth.odom.xyt[i_est]
    rpe_m, rpe_rad = rpe_rmse(true.t_ns[i_ref], ref, est, delta_s=config.rpe_delta)
    gx, gy = truth.goal
    return {
        "duration_s": float(true.t_ns[-1] - t0) / 1e9,
        "goal_reached": arrival is not None,
        "time_to_goal_s": math.nan if arrival is None else (true.t_ns[arrival] - t0) / 1e9,
        "final_goal_distance_m": math.hypot(true.xyt[-1, 0] - gx, true.xyt[-1, 1] - gy),
        "path_length_m": path_length(true.xy),
        "min_clearance_m": float(clearance.min()),
        "collisions": count_entries(clearance < 0),
        "ate_m": ate_rmse(ref[:, :2], est[:, :2]),
        "rpe_m": rpe_m,
        "rpe_deg": math.degrees(rpe_rad),
    }


class _SceneScoring:
    """One run's snapshots scored against the scene, in batches of views rendered at the
    true poses; collects the snapshot rows and what the summary and the obstacle table pool."""

    def __init__(
        self,
        truth: LogTruth,
        config: MetricsConfig,
        rule: ObstacleFlies,
        run_path: Path,
        on_progress: Callable[[float, float], None] | None,
    ) -> None:
        self.truth, self.config, self.rule, self.run_path = truth, config, rule, run_path
        self.on_progress = on_progress
        self.t0, self.t_end = int(truth.true.t_ns[0]), int(truth.true.t_ns[-1])
        self.gap = round(config.max_time_gap * 1e9)
        self.n_obstacles = len(truth.scene.obstacles)
        self.views = TrueViews(truth.scene, truth.rig, config.truth_width)
        self.true_pose = PoseInterpolator(truth.true)
        view_pixels = (truth.rig.width // self.views.block) * (truth.rig.height // self.views.block)
        self.batch = max(1, min(_BATCH, _BATCH_PIXELS // view_pixels))
        self.rows: list[dict[str, Any]] = []
        self.visible_px: list[np.ndarray] = []
        self.flies_on: list[np.ndarray] = []
        self.errors: list[np.ndarray] = []
        self.statuses: set[str] = set()
        self.pending: list[_Snapshot] = []

    def read(self, messages: Iterator[LogMessage]) -> None:
        """Take the run's planner statuses and snapshots, scoring each full batch."""
        for m in messages:
            if m.topic == contract.PLANNER_COMMAND:
                self.statuses.add(m.value["status"])
                continue
            self.pending.append(self._snapshot(m))
            if len(self.pending) == self.batch:
                self._score_pending()
        if self.pending:
            self._score_pending()
        xy = np.array([[r["true_x_m"], r["true_y_m"]] for r in self.rows]).reshape(-1, 2)
        nearest_true = distance_to_obstacles(self.truth.scene, xy)
        for row, nearest in zip(self.rows, nearest_true, strict=True):
            row["nearest_true_m"] = float(nearest)

    def _snapshot(self, m: LogMessage) -> _Snapshot:
        """A /flies snapshot's obstacle flies (the run's rule), LogError when it lies outside
        the true trajectory or lacks a field the rule reads."""
        t, t0, t_end = m.log_time_ns, self.t0, self.t_end
        if not t0 - self.gap <= t <= t_end + self.gap:
            msg = (
                f"{self.run_path}: the snapshot at {t / 1e9:.3f} s lies outside the true "
                f"trajectory of {self.truth.path} ({t0 / 1e9:.3f}–{t_end / 1e9:.3f} s): "
                "is it the run of this log?"
            )
            raise LogError(msg)
        cloud = m.value
        if self.rule.uses_distinctness and cloud.distinct is None:
            msg = (
                f"{self.run_path}: the run's obstacle rule reads each fly's distinctness, but "
                f"its /flies snapshot at {t / 1e9:.3f} s has no 'distinct' field: was the run "
                "written by another flylog version?"
            )
            raise LogError(msg)
        keep = self.rule.mask(cloud.xyz, cloud.fitness, cloud.age, cloud.distinct)
        return _Snapshot(t, cloud.xyz[keep], len(cloud.xyz))

    def _score_pending(self) -> None:
        pending, t0, t_end = self.pending, self.t0, self.t_end
        poses = self.true_pose(np.array([p.t_ns for p in pending]))
        depth, ids = self.views.render(poses)
        scores = score_snapshots(
            [p.xyz for p in pending],
            depth,
            ids,
            self.truth.rig,
            self.n_obstacles,
            self.config,
            flies=[p.flies for p in pending],
            block=self.views.block,
        )
        for p, pose, score in zip(pending, poses, scores, strict=True):
            t = p.t_ns
            self.rows.append(_snapshot_row(t, t0, pose, score))
            self.visible_px.append(score.visible_pixels)
            self.flies_on.append(score.flies_on)
            self.errors.append(score.depth_errors)
            if self.on_progress is not None:
                self.on_progress((t - t0) / 1e9, (t_end - t0) / 1e9)
        pending.clear()

    def detections(self) -> Detections:
        """When each obstacle became visible and was detected."""
        rows, n = self.rows, self.n_obstacles
        return detect_obstacles(
            np.array([r["t_s"] for r in rows]),
            np.array(self.visible_px).reshape(len(rows), n),
            np.array(self.flies_on).reshape(len(rows), n),
            min_visible_pixels=self.config.min_visible_pixels,
            min_detecting_flies=self.config.min_detecting_flies,
        )

    def obstacle_rows(self, det: Detections) -> list[dict[str, Any]]:
        return [
            table_row(
                tables.OBSTACLE_COLUMNS,
                {
                    "obstacle": k,
                    "kind": ob.kind.value,
                    "first_visible_s": float(det.first_visible[k]),
                    "first_detected_s": float(det.first_detected[k]),
                    "latency_s": float(det.latency[k]),
                    "max_visible_px": int(det.max_visible_pixels[k]),
                    "max_flies_on": int(det.max_flies_on[k]),
                },
            )
            for k, ob in enumerate(self.truth.scene.obstacles)
        ]

    def fly_summary(self, det: Detections) -> dict[str, Any]:
        """The summary's pooled fly and obstacle columns."""
        rows = self.rows

        def total(key: str) -> int:
            return sum(r[key] for r in rows)

        precision = ratio(total("on_surface"), total("in_view"))
        recall = ratio(total("covered_cells"), total("visible_cells"))
        all_errors = np.concatenate(self.errors) if self.errors else np.empty(0)
        near = np.array([r["nearest_detected_m"] - r["nearest_visible_m"] for r in rows])
        near = near[np.isfinite(near)]
        latency = det.latency[np.isfinite(det.latency)]
        return {
            "snapshots": len(rows),
            "precision": precision,
            "recall": recall,
            "f_score": f_score(precision, recall),
            "median_depth_error": float(np.median(all_errors)) if len(all_errors) else math.nan,
            "nearest_error_m": float(np.median(np.abs(near))) if len(near) else math.nan,
            "obstacles": self.n_obstacles,
            "obstacles_visible": int(np.isfinite(det.first_visible).sum()),
            "obstacles_detected": int(np.isfinite(det.first_detected).sum()),
            "detection_latency_mean_s": float(latency.mean()) if len(latency) else math.nan,
            "detection_latency_max_s": float(latency.max()) if len(latency) else math.nan,
        }


def _run_summary(facts: RunFacts, wall0: float) -> dict[str, Any]:
    """The summary's columns of the run's own statistics (its metadata)."""
    evals_per_s = (
        facts.evaluations / facts.wall_seconds
        if facts.evaluations is not None and facts.wall_seconds
        else math.nan
    )
    return {
        "generations": facts.generations,
        "evaluations": facts.evaluations,
        "evaluations_per_s": evals_per_s,
        "wall_s": math.nan if facts.wall_seconds is None else facts.wall_seconds,
        "log_duration_s": math.nan if facts.log_duration is None else facts.log_duration,
        "metrics_wall_s": time.perf_counter() - wall0,
    }


def score_scene(
    run: str | Path,
    log: str | Path,
    truth: LogTruth,
    config: MetricsConfig,
    reader: LogReader,
    messages: Iterator[LogMessage],
    on_progress: Callable[[float, float], None] | None,
    wall0: float,
) -> MetricsResult:
    """Score the run's snapshots (``messages``: /flies and /planner/command) and its robot
    against ``truth``, the scene of the sensor log ``log``."""
    facts = run_facts(reader, config)
    present = reader.topics()
    robot = _robot_summary(truth, config)
    if contract.FLIES not in present:
        warnings.warn(
            f"{reader.path} has no {contract.FLIES} topic: only the robot is scored",
            UserWarning,
            stacklevel=3,
        )
    scoring = _SceneScoring(truth, config, facts.rule, Path(reader.path), on_progress)
    scoring.read(messages)
    det = scoring.detections()
    planner = None
    if contract.PLANNER_COMMAND in present:
        planner = contract.CommandStatus.GOAL_REACHED.value in scoring.statuses
    summary = {
        "run": str(run),
        "log": str(log),
        **scoring.fly_summary(det),
        "planner_goal_reached": planner,
        **robot,
        **_run_summary(facts, wall0),
        "truth_images": None,
        "scored_points": None,
        **dict.fromkeys(_IMAGE_COLUMNS + _DENSE_COLUMNS, math.nan),
    }
    return MetricsResult(scoring.rows, scoring.obstacle_rows(det), summary, config)
