"""``flylog export``: thin wrapper over :func:`flylog.metrics.tum.export_tum` (``--tum``)
and :func:`flylog.ros2.export.export_ros2` (``--ros2``)."""

from __future__ import annotations

from pathlib import Path

import click

from flylog.cli.common import OutputPath, progress_bar, reports_errors, stdout


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
    help="Write the sensor log SOURCE as the rosbag2 directory OUT (MCAP storage, standard "
    "sensor_msgs/nav_msgs/tf2_msgs types, /tf_static transient-local), atomically.",
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
    source: Path, out_dir: Path | None, ros2_dir: Path | None, image_format: str, truth: bool
) -> None:
    """Export SOURCE: its trajectories in the TUM format (`--tum`: `timestamp tx ty tz qx
    qy qz qw`, for evo: `evo_ape tum true.tum odom.tum --align`; planned.tum holds the first
    pose of each /planner/path message; SOURCE a sensor log, closed-loop log, run file or
    ROS 2 bag), or a sensor log as a ROS 2 bag (`--ros2`)."""
    if (out_dir is None) == (ros2_dir is None):
        msg = "give exactly one of --tum OUTDIR and --ros2 OUT"
        raise click.UsageError(msg)
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
