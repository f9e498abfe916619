"""The Parquet tables ``flylog metrics`` writes, their documented schemas, and reading them.

``-o NAME.parquet`` gets one row per fly snapshot; beside it ``NAME.summary.parquet`` (one
row) and ``NAME.obstacles.parquet`` (one row per obstacle of the scene). Undefined values
(a ratio over nothing, a goal never reached) are nulls. Every column carries its unit and
description in the Parquet field metadata (``description``, ``unit``), and the file metadata
``flylog.metrics`` holds the configuration used, as JSON.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from flylog.errors import LogError, OutputError
from flylog.io.atomic import Batch
from flylog.io.inputs import input_path
from flylog.io.tables import Column, TableWriter, schema

SUMMARY_SUFFIX = ".summary.parquet"
OBSTACLES_SUFFIX = ".obstacles.parquet"
RELIABILITY_SUFFIX = ".reliability.parquet"
METADATA_KEY = "flylog.metrics"


_F, _I, _B, _S = pa.float64(), pa.int64(), pa.bool_(), pa.string()

SNAPSHOT_COLUMNS = (
    Column("stamp_ns", _I, "ns", "log time of the /flies snapshot"),
    Column("t_s", _F, "s", "time since the first true pose"),
    Column("true_x_m", _F, "m", "true position x at the snapshot (interpolated)"),
    Column("true_y_m", _F, "m", "true position y"),
    Column("true_theta_rad", _F, "rad", "true heading"),
    Column("flies", _I, "", "flies in the snapshot"),
    Column("obstacle_flies", _I, "", "flies taken for obstacles (the run's rule)"),
    Column("in_view", _I, "", "obstacle flies projecting inside the left image"),
    Column("on_surface", _I, "", "obstacle flies in view within tau of the true surface"),
    Column("on_obstacle", _I, "", "obstacle flies on the surface of an obstacle"),
    Column("visible_cells", _I, "", "image cells mostly covered by obstacles"),
    Column("covered_cells", _I, "", "visible-obstacle cells holding a fly on an obstacle"),
    Column("precision", _F, "", "on_surface / in_view"),
    Column("recall", _F, "", "covered_cells / visible_cells"),
    Column("f_score", _F, "", "2PR / (P + R)"),
    Column("median_depth_error", _F, "", "median |d - D| / D of the obstacle flies in view"),
    Column("nearest_true_m", _F, "m", "2-D distance from the robot to the nearest obstacle"),
    Column("nearest_visible_m", _F, "m", "... to the nearest obstacle seen by the left camera"),
    Column("nearest_detected_m", _F, "m", "... to the nearest obstacle fly"),
    # against a ground-truth disparity image (flylog.metrics.image_truth); null for scenes
    Column("disparity_error_median_px", _F, "px", "median |disparity - true| of scored flies"),
    Column("bad1", _F, "", "share of the scored flies off by more than 1 px of disparity"),
    Column("bad2", _F, "", "share of the scored flies off by more than 2 px of disparity"),
    Column("coverage", _F, "", "share of ground-truth cells holding a fly within 2 px"),
)

# the packaged confidence model's calibration on the run (flylog.metrics.calibration)
CONFIDENCE_COLUMNS = (
    Column("confidence_ece", _F, "", "expected calibration error of the flies' confidence"),
    Column("confidence_flies", _I, "", "valid flies in view on known truth, judged for it"),
)

RELIABILITY_COLUMNS = (
    Column("bin_low", _F, "", "lower bound of the confidence bin"),
    Column("bin_high", _F, "", "upper bound of the confidence bin"),
    Column("flies", _I, "", "judged flies whose confidence falls in the bin"),
    Column("mean_confidence", _F, "", "their mean confidence"),
    Column("on_surface_share", _F, "", "their share within tau of the true surface"),
)

SUMMARY_COLUMNS = (
    Column("run", _S, "", "the run file scored"),
    Column("log", _S, "", "the sensor log that gave the ground truth"),
    Column("log_fingerprint", _S, "", "content fingerprint of that log (flylog.io.fingerprint)"),
    Column("run_config", _S, "", "digest of the replay configuration the run records"),
    Column("metrics_config", _S, "", "digest of the metrics configuration scored with"),
    Column("snapshots", _I, "", "fly snapshots scored"),
    Column("duration_s", _F, "s", "time span of the true trajectory"),
    Column("precision", _F, "", "pooled over snapshots: sum on_surface / sum in_view"),
    Column("recall", _F, "", "pooled: sum covered_cells / sum visible_cells"),
    Column("f_score", _F, "", "2PR / (P + R) of the pooled precision and recall"),
    Column("median_depth_error", _F, "", "median relative depth error of all flies in view"),
    Column("nearest_error_m", _F, "m", "median |nearest_detected - nearest_visible|"),
    Column("obstacles", _I, "", "obstacles in the scene"),
    Column("obstacles_visible", _I, "", "obstacles that became visible"),
    Column("obstacles_detected", _I, "", "visible obstacles that were then detected"),
    Column("detection_latency_mean_s", _F, "s", "mean latency visible -> detected"),
    Column("detection_latency_max_s", _F, "s", "largest latency visible -> detected"),
    Column("goal_reached", _B, "", "the true position came within goal_tolerance of the goal"),
    Column("time_to_goal_s", _F, "s", "time from the first true pose to reaching the goal"),
    Column("planner_goal_reached", _B, "", "the planner reported goal_reached (null: no planner)"),
    Column("final_goal_distance_m", _F, "m", "true distance to the goal at the end"),
    Column("path_length_m", _F, "m", "length of the true trajectory"),
    Column("min_clearance_m", _F, "m", "least distance to an obstacle minus the robot radius"),
    Column("collisions", _I, "", "entries into negative clearance"),
    Column("ate_m", _F, "m", "odometry: absolute trajectory error after SE(2) alignment"),
    Column("rpe_m", _F, "m", "odometry: relative pose error, translation, over rpe_delta"),
    Column("rpe_deg", _F, "deg", "odometry: relative pose error, rotation, over rpe_delta"),
    Column("generations", _I, "", "generations the run made (its metadata)"),
    Column("evaluations", _I, "", "fitness evaluations the run made"),
    Column("evaluations_per_s", _F, "1/s", "evaluations / wall_s"),
    Column("wall_s", _F, "s", "wall time of the run"),
    Column("log_duration_s", _F, "s", "log time the run covered"),
    Column("metrics_wall_s", _F, "s", "wall time of flylog metrics itself"),
    # against ground-truth disparity images (flylog.metrics.image_truth); null for scenes
    Column("truth_images", _I, "", "ground-truth disparity images of the log"),
    Column("scored_points", _I, "", "flies (sgbm: points) in view on known ground truth"),
    Column("disparity_error_median_px", _F, "px", "median |disparity - true| of scored flies"),
    Column("bad1", _F, "", "share of the scored flies off by more than 1 px of disparity"),
    Column("bad2", _F, "", "share of the scored flies off by more than 2 px of disparity"),
    Column("coverage", _F, "", "share of ground-truth cells holding a fly within 2 px"),
    Column("sgbm_dense_error_median_px", _F, "px", "sgbm runs: the dense map's median error"),
    Column("sgbm_dense_bad1", _F, "", "sgbm runs: share of matched truth pixels off by > 1 px"),
    Column("sgbm_dense_bad2", _F, "", "sgbm runs: share of matched truth pixels off by > 2 px"),
    Column("sgbm_dense_density", _F, "", "sgbm runs: share of truth pixels the map matched"),
    *CONFIDENCE_COLUMNS,
)

OBSTACLE_COLUMNS = (
    Column("obstacle", _I, "", "index in the scene (file order, then clutter)"),
    Column("kind", _S, "", "box, cylinder or wall"),
    Column("first_visible_s", _F, "s", "first snapshot with min_visible_pixels on it"),
    Column("first_detected_s", _F, "s", "first snapshot since with min_detecting_flies on it"),
    Column("latency_s", _F, "s", "first_detected_s - first_visible_s"),
    Column("max_visible_px", _I, "px", "most pixels of the view it ever covered"),
    Column("max_flies_on", _I, "", "most obstacle flies ever on it"),
)


def clean(value: Any) -> Any:
    """NaN and infinities become nulls."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_table(
    path: Path,
    columns: tuple[Column, ...],
    rows: Iterable[Mapping[str, Any]],
    metadata: dict[str, str],
    batch: Batch | None = None,
) -> None:
    with TableWriter(path, schema(columns), metadata=metadata, batch=batch) as table:
        for row in rows:
            table.append({c.name: clean(row[c.name]) for c in columns})


def check_output_name(path: Path) -> None:
    """OutputError unless ``path`` names a Parquet file (``NAME.parquet``): the tables
    beside it take their names from it."""
    if Path(path).suffix != ".parquet":
        msg = f"{path}: the metrics output must end in .parquet"
        raise OutputError(msg, parameter="output")


def default_output(run: Path) -> Path:
    """Where ``flylog metrics RUN`` writes without ``-o``: beside the run, ``NAME.metrics.parquet``
    for ``NAME.mcap`` (``NAME.parquet`` is the replay's own step table)."""
    run = Path(run)
    return run.with_name(run.stem + ".metrics.parquet")


def summary_path(path: Path) -> Path:
    """``NAME.summary.parquet`` beside ``NAME.parquet`` (a summary path is kept as is)."""
    path = Path(path)
    if path.name.endswith(SUMMARY_SUFFIX):
        return path
    return path.with_name(path.name.removesuffix(".parquet") + SUMMARY_SUFFIX)


def reliability_path(path: Path) -> Path:
    path = Path(path)
    return path.with_name(path.name.removesuffix(".parquet") + RELIABILITY_SUFFIX)


def obstacles_path(path: Path) -> Path:
    path = Path(path)
    return path.with_name(path.name.removesuffix(".parquet") + OBSTACLES_SUFFIX)


def read_summary(path: Path) -> dict[str, Any]:
    """The one summary row of a metrics output (given its ``-o`` path or the summary)."""
    found = summary_path(path)
    if not found.is_file():
        msg = f"{found}: no such metrics summary (made by `flylog metrics -o {path}`)"
        raise LogError(msg)
    try:
        rows = pq.read_table(input_path(found, "the metrics summary")).to_pylist()
    except (pa.ArrowInvalid, OSError) as exc:
        msg = f"{found}: not a readable Parquet file ({exc})"
        raise LogError(msg) from None
    if len(rows) != 1:
        msg = f"{found}: a metrics summary has one row, this one has {len(rows)}"
        raise LogError(msg)
    return rows[0]
