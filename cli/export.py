"""``flylog export``: thin wrapper over :func:`flylog.metrics.tum.export_tum` (``--tum``),
:func:`flylog.ros2.export.export_ros2` (``--ros2`` of a sensor log),
:func:`flylog.ros2.run_export.export_run_ros2` (``--ros2`` of a run) and
:func:`flylog.fly.snapshot_export.export_ply` (``--ply``)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

from flylog.cli.common import OutputPath, progress_bar, reports_errors, stdout

if TYPE_CHECKING:
    from flylog.fly.confidence import ConfidenceModel


@click.command()
@click.argument("source", type=click.Path(path_type=Path))
@click.option(
    "--tum",
    "out_dir",
    type=OutputPath(file_okay=False, path_type=Path),
    default=None,
    metavar="OUTDIR",
    help="Write true.tum, odom.tum and planned.tum (those SOURCE holds) into OUTDIR.",
)
@click.option(
    "--ros2",
    "ros2_dir",
    type=OutputPath(path_type=Path),
    default=None,
    metavar="OUT",
    help="Write SOURCE as the rosbag2 directory OUT (MCAP storage, standard ROS 2 types), "
    "atomically: a sensor log's sensor topics, or a run's flies (PointCloud2, depth images), "
    "map, potential, path, commands and pose (docs/ros2.md).",
)
@click.option(
    "--with-log",
    "with_log",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    metavar="LOG",
    help="--ros2 of a run: also write the sensor log LOG the run was replayed from, so one "
    "bag plays the robot and its flies. [default: the run's topics only]",
)
@click.option(
    "--ply",
    "ply_dir",
    type=click.Path(path_type=Path),
    default=None,
    metavar="DIR",
    help="Write the run SOURCE's fly snapshots as PLY files (binary, x y z fitness age "
    "distinct confidence as float32 vertex properties) into the new directory DIR.",
)
@click.option(
    "--at",
    type=click.FloatRange(min=0.0),
    default=None,
    metavar="SECONDS",
    help="--ply: only the snapshot nearest this time after the run's start (s). "
    "[default: every snapshot]",
)
@click.option(
    "--image-format",
    type=click.Choice(["rgb8", "bgr8", "png", "jpeg"]),
    default="rgb8",
    show_default=True,
    help="--ros2: images as sensor_msgs/Image rgb8 or bgr8, or CompressedImage png or jpeg "
    "(quality 95).",
)
@click.option(
    "--truth",
    is_flag=True,
    default=False,
    help="--ros2: also write the ground truth, the true pose as nav_msgs/Odometry on "
    "/truth/odom and the scene file in metadata.yaml (replay never reads them; metrics "
    "does). [default: off]",
)
@reports_errors
def export(
    source: Path,
    out_dir: Path | None,
    ros2_dir: Path | None,
    with_log: Path | None,
    ply_dir: Path | None,
    at: float | None,
    image_format: str,
    truth: bool,
) -> None:
    """Export SOURCE: its trajectories in the TUM format (`--tum`: `timestamp tx ty tz qx
    qy qz qw`, for evo: `evo_ape tum true.tum odom.tum --align`; planned.tum holds the first
    pose of each /planner/path message; SOURCE a sensor log, closed-loop log, run file or
    ROS 2 bag), a sensor log or a run as a ROS 2 bag (`--ros2`), or a run's fly snapshots as
    PLY files (`--ply`)."""
    if sum(x is not None for x in (out_dir, ros2_dir, ply_dir)) != 1:
        msg = "give exactly one of --tum OUTDIR, --ros2 OUT and --ply DIR"
        raise click.UsageError(msg)
    if at is not None and ply_dir is None:
        msg = "--at SECONDS picks the snapshot of --ply DIR: give --ply DIR too"
        raise click.UsageError(msg)
    if with_log is not None and ros2_dir is None:
        msg = "--with-log LOG adds a sensor log to --ros2 OUT: give --ros2 OUT too"
        raise click.UsageError(msg)
    if ply_dir is not None:
        _export_ply(source, ply_dir, at)
        return
    from flylog.ros2.run_export import is_run

    if ros2_dir is not None and (with_log is not None or is_run(source)):
        _export_run(source, ros2_dir, with_log, image_format, truth)
        return
    if ros2_dir is not None:
        from flylog.ros2.export import export_ros2
        from flylog.ros2.messages import ImageFormat

        with progress_bar(f"export {source.name}", unit="s") as update:
            summary = export_ros2(
                source, ros2_dir, image_format=ImageFormat(image_format), truth=truth,
                on_progress=update,
            )  # fmt: skip
        stdout.print(f"{summary.output}: {summary.messages} messages on {summary.topics} topics")
        return
    from flylog.metrics.tum import export_tum

    assert out_dir is not None
    written = export_tum(source, out_dir)
    for name, path in written.items():
        stdout.print(f"{name}: {path}")


def _confidence(source: Path) -> ConfidenceModel | None:
    """The packaged confidence model, with a warning when the run was replayed with another
    engine configuration than the one it was fitted for."""
    import warnings

    from flylog.fly import confidence
    from flylog.io import open_log
    from flylog.metrics.calibration import engine_digest

    model = confidence.load()
    if model is not None and engine_digest(open_log(source)) not in ("", model.engine):
        warnings.warn(
            f"{source} was replayed with another engine or obstacle configuration than the "
            f"confidence model was fitted for (digest {model.engine}): its confidence may "
            "not be calibrated (docs/export.md#confidence)",
            UserWarning,
            stacklevel=2,
        )
    return model


def _export_ply(source: Path, ply_dir: Path, at: float | None) -> None:
    from flylog.fly.snapshot_export import export_ply

    with progress_bar(f"export {source.name}", unit="s") as update:
        done = export_ply(
            source, ply_dir, at=at, confidence=_confidence(source), on_progress=update
        )
    stdout.print(f"{done.output}: {done.files} PLY files, {done.points} points")


def _export_run(
    source: Path, ros2_dir: Path, with_log: Path | None, image_format: str, truth: bool
) -> None:
    from flylog.ros2.messages import ImageFormat
    from flylog.ros2.run_export import export_run_ros2

    with progress_bar(f"export {source.name}", unit="s") as update:
        summary = export_run_ros2(
            source,
            ros2_dir,
            log=with_log,
            image_format=ImageFormat(image_format),
            truth=truth,
            confidence=_confidence(source),
            on_progress=update,
        )
    stdout.print(f"{summary.output}: {summary.messages} messages on {summary.topics} topics")
