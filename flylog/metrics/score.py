"""``flylog metrics``: score a run (fly snapshots, planner) against its sensor log's truth.

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

import dataclasses
import itertools
import json
import math
import time
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from flylog.config import from_mapping, to_mapping
from flylog.errors import LogError
from flylog.fly.obstacles import ObstacleFlies
from flylog.io import contract, open_log
from flylog.io.atomic import Batch
from flylog.io.reader import LogReader
from flylog.io.records import LogMessage
from flylog.metrics import tables
from flylog.metrics.config import MetricsConfig
from flylog.metrics.flies import f_score, ratio, score_snapshots
from flylog.metrics.obstacles import detect_obstacles
from flylog.metrics.provenance import check_run_log, config_digest, run_config_digest
from flylog.metrics.trajectory import (
    PoseInterpolator,
    associate,
    ate_rmse,
    count_entries,
    first_arrival,
    path_length,
    rpe_rmse,
)
from flylog.metrics.truth import LogTruth, read_truth
from flylog.metrics.view import TrueViews
from flylog.scene.load import distance_to_obstacles

# Odometry and truth are written at the same instants by the simulator; allow one 50 Hz
# period of mismatch for logs from elsewhere (evo's --t_max_diff default is 10 ms).
_MAX_MATCH_NS = 20_000_000
# Run messages decoded ahead of the scoring by a background thread (a /flies snapshot of
# 5000 flies is ~100 kB): the run's chunks decompress and pass their CRC checks, which
# release the GIL, while the truth is read and views render.
_READ_AHEAD = 64
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


@dataclass(frozen=True)
class RunFacts:
    """What a run file says about itself (its ``flylog.replay`` metadata)."""

    rule: ObstacleFlies
    generations: int | None = None
    evaluations: int | None = None
    wall_seconds: float | None = None
    log_duration: float | None = None


class _Snapshot(NamedTuple):
    """A /flies snapshot waiting to be scored: its time and obstacle flies."""

    t_ns: int
    xyz: np.ndarray  # (M, 3) obstacle flies
    flies: int  # flies in the snapshot


@dataclass(frozen=True)
class MetricsResult:
    """Rows of the three tables (``flylog.metrics.tables`` documents the columns)."""

    snapshots: list[dict[str, Any]]
    obstacles: list[dict[str, Any]]
    summary: dict[str, Any]
    config: MetricsConfig
    # the confidence's reliability table (flylog.metrics.calibration.reliability), or none
    reliability: list[dict[str, Any]] = dataclasses.field(default_factory=list)


def _number(meta: dict[str, str], key: str, kind: type) -> Any:
    if key not in meta:
        return None
    try:
        return kind(float(meta[key])) if kind is int else float(meta[key])
    except ValueError:
        return None


def run_facts(reader: LogReader, config: MetricsConfig) -> RunFacts:
    """The obstacle rule and run statistics of a run file. A run without flylog's
    configuration, or whose ``[obstacles]`` table has no ``min_distinctness``, is scored by
    the paper's rule (no distinctness: its clouds carry none)."""
    meta = reader.metadata().get(contract.REPLAY_METADATA, {})
    rule = ObstacleFlies(min_distinctness=0.0)
    if "config" in meta:
        try:
            table = json.loads(meta["config"]).get("obstacles", {})
        except json.JSONDecodeError as exc:
            msg = f"{reader.path}: metadata {contract.REPLAY_METADATA}.config is not JSON ({exc})"
            raise LogError(msg) from None
        source = f"{reader.path}: metadata {contract.REPLAY_METADATA}.config"
        table = {"min_distinctness": 0.0, **table}
        rule = from_mapping(ObstacleFlies, table, source=source, prefix="obstacles")
    return RunFacts(
        rule=rule,
        generations=_number(meta, "generations", int),
        evaluations=_number(meta, "evaluations", int),
        wall_seconds=_number(meta, "wall_seconds", float),
        log_duration=_number(meta, "log_duration", float),
    )


def _snapshot_row(t_ns: int, t0_ns: int, pose: np.ndarray, score: Any) -> dict[str, Any]:
    return {
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


def score_run(
    run: str | Path,
    log: str | Path,
    config: MetricsConfig = MetricsConfig(),  # noqa: B008 (frozen, immutable)
    *,
    on_progress: Callable[[float, float], None] | None = None,
) -> MetricsResult:
    """Score ``run`` against the ground truth of the sensor log ``log`` (may be the same
    file): its scene, or its ground-truth disparity images (an imported dataset's log,
    :mod:`flylog.metrics.image_run`). ``on_progress(done, total)`` reports progress in
    seconds of log time."""
    from flylog.metrics.image_run import has_image_truth, score_image_run

    wall0 = time.perf_counter()
    reader = open_log(run)
    replayed = reader.metadata().get(contract.REPLAY_METADATA, {})
    fingerprint = check_run_log(run, log, replayed)  # before any work: the right log?
    if has_image_truth(log):
        result: MetricsResult = score_image_run(run, log, config)
        return _with_confidence(result, run, log, reader)
    provenance = {
        "log_fingerprint": fingerprint,
        "run_config": run_config_digest(replayed),
        "metrics_config": config_digest(to_mapping(config)),
    }
    present = reader.topics()
    topics = [t for t in (contract.FLIES, contract.PLANNER_COMMAND) if t in present]
    # Reading starts now, in its thread (the first message read here starts it).
    messages = reader.messages(topics, read_ahead=_READ_AHEAD) if topics else None
    first = next(messages, None) if messages is not None else None
    try:
        ahead = [] if first is None else [first]
        stream = itertools.chain(ahead, () if messages is None else messages)
        result = _scored(run, log, config, reader, stream, on_progress, wall0)
        result = dataclasses.replace(result, summary={**result.summary, **provenance})
        return _with_confidence(result, run, log, reader)
    finally:
        if messages is not None:
            messages.close()  # stops the reading thread if scoring failed


def _scored(
    run: str | Path,
    log: str | Path,
    config: MetricsConfig,
    reader: LogReader,
    messages: Iterator[LogMessage],
    on_progress: Callable[[float, float], None] | None,
    wall0: float,
) -> MetricsResult:
    truth = read_truth(log)
    facts = run_facts(reader, config)
    present = reader.topics()
    true = truth.true
    robot = _robot_summary(truth, config)
    t0, t_end = int(true.t_ns[0]), int(true.t_ns[-1])
    gap = round(config.max_time_gap * 1e9)
    n_obstacles = len(truth.scene.obstacles)
    views = TrueViews(truth.scene, truth.rig, config.truth_width)
    true_pose = PoseInterpolator(true)

    if contract.FLIES not in present:
        warnings.warn(
            f"{reader.path} has no {contract.FLIES} topic: only the robot is scored",
            UserWarning,
            stacklevel=3,
        )
    rows: list[dict[str, Any]] = []
    visible_px: list[np.ndarray] = []
    flies_on: list[np.ndarray] = []
    errors: list[np.ndarray] = []
    statuses: set[str] = set()
    view_pixels = (truth.rig.width // views.block) * (truth.rig.height // views.block)
    batch = max(1, min(_BATCH, _BATCH_PIXELS // view_pixels))
    pending: list[_Snapshot] = []

    def score_pending() -> None:
        poses = true_pose(np.array([p.t_ns for p in pending]))
        depth, ids = views.render(poses)
        scores = score_snapshots(
            [p.xyz for p in pending],
            depth,
            ids,
            truth.rig,
            n_obstacles,
            config,
            flies=[p.flies for p in pending],
            block=views.block,
        )
        for p, pose, score in zip(pending, poses, scores, strict=True):
            t = p.t_ns
            rows.append(_snapshot_row(t, t0, pose, score))
            visible_px.append(score.visible_pixels)
            flies_on.append(score.flies_on)
            errors.append(score.depth_errors)
            if on_progress is not None:
                on_progress((t - t0) / 1e9, (t_end - t0) / 1e9)
        pending.clear()

    for m in messages:
        if m.topic == contract.PLANNER_COMMAND:
            statuses.add(m.value["status"])
            continue
        t = m.log_time_ns
        if not t0 - gap <= t <= t_end + gap:
            msg = (
                f"{reader.path}: the snapshot at {t / 1e9:.3f} s lies outside the true "
                f"trajectory of {truth.path} ({t0 / 1e9:.3f}–{t_end / 1e9:.3f} s): "
                "is it the run of this log?"
            )
            raise LogError(msg)
        cloud = m.value
        if facts.rule.uses_distinctness and cloud.distinct is None:
            msg = (
                f"{reader.path}: the run's obstacle rule reads each fly's distinctness, but "
                f"its /flies snapshot at {t / 1e9:.3f} s has no 'distinct' field: was the run "
                "written by another flylog version?"
            )
            raise LogError(msg)
        keep = facts.rule.mask(cloud.xyz, cloud.fitness, cloud.age, cloud.distinct)
        pending.append(_Snapshot(t, cloud.xyz[keep], len(cloud.xyz)))
        if len(pending) == batch:
            score_pending()
    if pending:
        score_pending()

    xy = np.array([[r["true_x_m"], r["true_y_m"]] for r in rows]).reshape(-1, 2)
    for row, nearest in zip(rows, distance_to_obstacles(truth.scene, xy), strict=True):
        row["nearest_true_m"] = float(nearest)
    t_s = np.array([r["t_s"] for r in rows])
    det = detect_obstacles(
        t_s,
        np.array(visible_px).reshape(len(rows), n_obstacles),
        np.array(flies_on).reshape(len(rows), n_obstacles),
        min_visible_pixels=config.min_visible_pixels,
        min_detecting_flies=config.min_detecting_flies,
    )
    obstacle_rows = [
        {
            "obstacle": k,
            "kind": ob.kind.value,
            "first_visible_s": float(det.first_visible[k]),
            "first_detected_s": float(det.first_detected[k]),
            "latency_s": float(det.latency[k]),
            "max_visible_px": int(det.max_visible_pixels[k]),
            "max_flies_on": int(det.max_flies_on[k]),
        }
        for k, ob in enumerate(truth.scene.obstacles)
    ]

    def total(key: str) -> int:
        return sum(r[key] for r in rows)

    precision = ratio(total("on_surface"), total("in_view"))
    recall = ratio(total("covered_cells"), total("visible_cells"))
    all_errors = np.concatenate(errors) if errors else np.empty(0)
    near = np.array([r["nearest_detected_m"] - r["nearest_visible_m"] for r in rows])
    near = near[np.isfinite(near)]
    latency = det.latency[np.isfinite(det.latency)]
    planner = None
    if contract.PLANNER_COMMAND in present:
        planner = contract.CommandStatus.GOAL_REACHED.value in statuses
    evals_per_s = (
        facts.evaluations / facts.wall_seconds
        if facts.evaluations is not None and facts.wall_seconds
        else math.nan
    )
    summary = {
        "run": str(run),
        "log": str(log),
        "snapshots": len(rows),
        "precision": precision,
        "recall": recall,
        "f_score": f_score(precision, recall),
        "median_depth_error": float(np.median(all_errors)) if len(all_errors) else math.nan,
        "nearest_error_m": float(np.median(np.abs(near))) if len(near) else math.nan,
        "obstacles": n_obstacles,
        "obstacles_visible": int(np.isfinite(det.first_visible).sum()),
        "obstacles_detected": int(np.isfinite(det.first_detected).sum()),
        "detection_latency_mean_s": float(latency.mean()) if len(latency) else math.nan,
        "detection_latency_max_s": float(latency.max()) if len(latency) else math.nan,
        "planner_goal_reached": planner,
        **robot,
        "generations": facts.generations,
        "evaluations": facts.evaluations,
        "evaluations_per_s": evals_per_s,
        "wall_s": math.nan if facts.wall_seconds is None else facts.wall_seconds,
        "log_duration_s": math.nan if facts.log_duration is None else facts.log_duration,
        "metrics_wall_s": time.perf_counter() - wall0,
        "truth_images": None,
        "scored_points": None,
        **dict.fromkeys(_IMAGE_COLUMNS + _DENSE_COLUMNS, math.nan),
    }
    return MetricsResult(rows, obstacle_rows, summary, config)


def _with_confidence(
    result: MetricsResult, run: str | Path, log: str | Path, reader: LogReader
) -> MetricsResult:
    """``result`` with the packaged confidence model's calibration on the run's flies
    (:mod:`flylog.metrics.calibration`): the summary's ``confidence_ece`` and
    ``confidence_flies`` (NaN and 0 without /flies or without a model) and the reliability
    table."""
    from flylog.fly import confidence
    from flylog.metrics.calibration import score_confidence

    model = confidence.load()
    if model is None or contract.FLIES not in reader.topics():
        summary = {**result.summary, "confidence_ece": math.nan, "confidence_flies": 0}
        return dataclasses.replace(result, summary=summary)
    score = score_confidence(run, log, result.config, model)
    summary = {**result.summary, "confidence_ece": score.ece, "confidence_flies": score.flies}
    return dataclasses.replace(result, summary=summary, reliability=score.table)


def write_reliability(result: MetricsResult, output: str | Path) -> Path | None:
    """Write the reliability table (``NAME.reliability.parquet`` beside ``output``), when the
    result has one; returns its path."""
    if not result.reliability:
        return None
    path = tables.reliability_path(Path(output))
    meta = {tables.METADATA_KEY: json.dumps(to_mapping(result.config))}
    tables.write_table(path, tables.RELIABILITY_COLUMNS, result.reliability, meta)
    return path


def write_metrics(result: MetricsResult, output: str | Path) -> tuple[Path, Path, Path]:
    """Write the snapshot table to ``output`` and the summary and obstacle tables beside it
    (``NAME.summary.parquet``, ``NAME.obstacles.parquet``), published together (all three
    new, or all three as they were); returns the three paths."""
    output = Path(output)
    tables.check_output_name(output)
    meta = {tables.METADATA_KEY: json.dumps(to_mapping(result.config))}
    paths = (output, tables.summary_path(output), tables.obstacles_path(output))
    with Batch() as batch:
        tables.write_table(paths[0], tables.SNAPSHOT_COLUMNS, result.snapshots, meta, batch)
        tables.write_table(paths[1], tables.SUMMARY_COLUMNS, [result.summary], meta, batch)
        tables.write_table(paths[2], tables.OBSTACLE_COLUMNS, result.obstacles, meta, batch)
    return paths
