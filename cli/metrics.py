"""``flylog metrics``: thin wrapper over :func:`flylog.metrics.score.score_run`."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import click

from flylog.cli.common import OutputPath, progress_bar, reports_errors, stdout
from flylog.cli.config_options import config_option, config_overrides

METRICS = "flylog.metrics.config:MetricsConfig"

# (summary column, label): the unit is the column's (flylog.metrics.tables).
_SHOWN = (
    ("snapshots", "fly snapshots"),
    ("precision", "precision"),
    ("recall", "recall"),
    ("f_score", "F-score"),
    ("median_depth_error", "median relative depth error"),
    ("nearest_error_m", "nearest obstacle: median |detected − visible|"),
    ("obstacles_detected", "obstacles detected"),
    ("obstacles_visible", "obstacles visible"),
    ("detection_latency_mean_s", "detection latency, mean"),
    ("detection_latency_max_s", "detection latency, max"),
    ("goal_reached", "goal reached"),
    ("planner_goal_reached", "planner said goal reached"),
    ("time_to_goal_s", "time to goal"),
    ("final_goal_distance_m", "final distance to goal"),
    ("path_length_m", "path length"),
    ("min_clearance_m", "minimum clearance"),
    ("collisions", "collisions"),
    ("ate_m", "odometry ATE (aligned)"),
    ("rpe_m", "odometry RPE, translation"),
    ("rpe_deg", "odometry RPE, rotation"),
    ("generations", "generations"),
    ("evaluations_per_s", "evaluations per second"),
    ("wall_s", "run wall time"),
    ("metrics_wall_s", "metrics wall time"),
)

# Against an imported dataset's ground-truth disparity (flylog.metrics.image_run).
_IMAGE_SHOWN = (
    ("snapshots", "fly snapshots"),
    ("truth_images", "ground-truth images"),
    ("scored_points", "flies scored (in view, on known truth)"),
    ("precision", "precision"),
    ("recall", "recall"),
    ("f_score", "F-score"),
    ("median_depth_error", "median relative depth error"),
    ("disparity_error_median_px", "median disparity error"),
    ("bad1", "bad1 (share off by > 1 px)"),
    ("bad2", "bad2 (share off by > 2 px)"),
    ("coverage", "coverage (cells with a fly within 2 px)"),
    ("sgbm_dense_error_median_px", "SGBM dense map: median error"),
    ("sgbm_dense_bad2", "SGBM dense map: bad2"),
    ("sgbm_dense_density", "SGBM dense map: share of truth matched"),
    ("generations", "generations"),
    ("wall_s", "run wall time"),
    ("metrics_wall_s", "metrics wall time"),
)


# The packaged confidence model's calibration (flylog.metrics.calibration).
_CONFIDENCE_SHOWN = ("confidence_ece", "confidence: expected calibration error")


def _fmt(value: Any) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "—"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    return f"{value:.4g}"


@click.command()
@click.argument("run", type=click.Path(dir_okay=False, path_type=Path))
@click.option(
    "--log",
    "log",
    type=click.Path(path_type=Path),
    default=None,
    help="The sensor log the run was made from (ground truth): a flylog log, or a ROS 2 bag "
    "with /truth/odom and its scene (`flylog export --ros2 --truth`). [default: RUN itself, "
    "for a closed-loop log]",
)
@click.option(
    "-o",
    "--output",
    type=OutputPath(dir_okay=False, path_type=Path),
    default=None,
    help="Per-snapshot table NAME.parquet; NAME.summary.parquet (one row), "
    "NAME.obstacles.parquet and, for a run with flies, NAME.reliability.parquet (the "
    "confidence's reliability diagram) are written beside it. [default: beside the run, "
    "RUN.metrics.parquet for RUN.mcap]",
)
@click.option(
    "--config",
    "config_file",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="TOML file of metrics thresholds (fields of flylog.metrics.config.MetricsConfig).",
)
@config_option(METRICS, "tau", "--tau", metavar="TAU")
@config_option(METRICS, "goal_tolerance", "--goal-tolerance", metavar="M")
@config_option(METRICS, "rpe_delta", "--rpe-delta", metavar="S")
@reports_errors
def metrics(
    run: Path,
    log: Path | None,
    output: Path | None,
    config_file: Path | None,
    tau: float | None,
    goal_tolerance: float | None,
    rpe_delta: float | None,
) -> None:
    """Score RUN (a `flylog replay` output or a closed-loop log) against the ground truth
    of its sensor log: fly precision/recall, obstacle detection latency, the robot's path,
    clearance, collisions and odometric drift. On an imported dataset's log (ground-truth
    disparity images, no scene): precision/recall, disparity error, bad1, bad2 and coverage
    of the flies (or SGBM's points, and its dense map). Writes Parquet tables; prints the
    summary."""
    from flylog.cli.tables import print_fitted
    from flylog.config import from_mapping, read_toml, replace_dotted
    from flylog.io.collisions import Role, check_outputs
    from flylog.metrics.config import MetricsConfig
    from flylog.metrics.score import score_run
    from flylog.metrics.tables import (
        SUMMARY_COLUMNS,
        check_output_name,
        default_output,
        obstacles_path,
        reliability_path,
        summary_path,
    )
    from flylog.metrics.write import write_metrics, write_reliability

    output = default_output(run) if output is None else output
    check_output_name(output)  # before the scoring, which takes a while
    inputs = [Role(run, "the run", "run")]
    inputs += [Role(log, "the sensor log", "log")] if log is not None else []
    inputs += [Role(config_file, "the configuration", "config_file")] if config_file else []
    outputs = [
        Role(output, "the snapshot table", "output"),
        Role(summary_path(output), "the summary table", "output"),
        Role(obstacles_path(output), "the obstacle table", "output"),
        Role(reliability_path(output), "the reliability table", "output"),
    ]
    check_outputs(inputs, outputs)

    config = MetricsConfig()
    if config_file is not None:
        config = from_mapping(MetricsConfig, read_toml(config_file), source=str(config_file))
    config = replace_dotted(config, config_overrides())
    with progress_bar(f"metrics {run.name}", unit="s") as update:
        result = score_run(run, log if log is not None else run, config, on_progress=update)
    paths: list[Path] = [*write_metrics(result, output)]
    reliability = write_reliability(result, output)
    paths += [reliability] if reliability is not None else []
    shown = _SHOWN if result.summary.get("truth_images") is None else _IMAGE_SHOWN
    # Rows with a value for this run only: a replay has no time to goal, a fly run on a
    # dataset no SGBM dense map.
    unit = {c.name: c.unit for c in SUMMARY_COLUMNS}
    rows = [
        [label, _fmt(result.summary[key]), unit[key]] for key, label in (*shown, _CONFIDENCE_SHOWN)
    ]
    rows = [row for row in rows if row[1] != "—"]
    print_fitted(stdout, f"metrics of {run}", ["metric", "value", "unit"], rows, right=[1])
    stdout.print("wrote " + ", ".join(str(p) for p in paths))
