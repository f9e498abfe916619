"""``flylog import``: thin wrapper over :func:`flylog.datasets.run.import_dataset`."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from flylog.cli.common import OutputPath, human_bytes, progress_bar, reports_errors, stdout

_FORMATS = ("middlebury", "kitti", "euroc")


@click.command(name="import")
@click.argument("layout", metavar="FORMAT", type=click.Choice(_FORMATS))
@click.argument("path", type=click.Path(path_type=Path))
@click.option(
    "-o",
    "--output",
    type=OutputPath(path_type=Path),
    required=True,
    help="The log to write (atomically); for a folder of several scenes, the folder that "
    "gets one NAME.mcap per scene (made if absent).",
)
@click.option(
    "--scene",
    default=None,
    metavar="NAME",
    help="Import only this scene (sub-folder name) of a folder of several. [default: all]",
)
@click.option(
    "--limit",
    type=click.IntRange(min=1, max=sys.maxsize),  # itertools.islice's bound
    default=None,
    metavar="N",
    help="Import the first N stereo pairs of each scene or sequence. [default: all]",
)
@click.option(
    "--frames",
    is_flag=True,
    default=False,
    help="kitti stereo benchmarks: import each scene's multiview frames NNNNNN_00 … _20 as "
    "one sequence log (frame k at k × 100 ms, KITTI's 10 Hz; the ground truth at frame 10) "
    "instead of its frame 10 alone. [default: off]",
)
@reports_errors
def import_(
    layout: str, path: Path, output: Path, scene: str | None, limit: int | None, frames: bool
) -> None:
    """Convert a stereo dataset folder in its published layout into flylog logs: the
    rectified pairs and their calibration, the ground-truth disparity as /truth/disparity,
    true poses as /truth/pose. FORMAT: middlebury (a Middlebury 2014/2021 scene folder of
    im0.png, im1.png, calib.txt and disp0.pfm, or a folder of such scenes: one log each);
    kitti (the 2012/2015 stereo benchmark, training/image_2, image_3, calibration and
    disp_occ_0, or 2012's image_0, image_1 (colored_0, colored_1) and disp_occ: one log
    per pair, or per scene's multiview frames with --frames; or the odometry layout,
    sequences/NN with image_2, image_3, calib.txt, times.txt and poses/NN.txt: one log per
    sequence); euroc (a EuRoC
    MAV sequence, mav0/cam0 and cam1 with data.csv, data/ and sensor.yaml, rectified with
    OpenCV, and state_groundtruth_estimate0 as /truth/pose). Datasets that
    do not give the cameras' mount on a robot make logs without robot geometry (no /tf, no
    ground plane); datasets without odometry, logs without /odom."""
    from flylog.datasets.run import import_dataset

    with progress_bar(f"import {path.name}", unit="logs") as update:
        logs = import_dataset(
            layout, path, output, scene=scene, limit=limit, multiview=frames, on_progress=update
        )
    for log in logs:
        size = human_bytes(log.path.stat().st_size)
        pairs = f"{log.frames} stereo pair{'' if log.frames == 1 else 's'}"
        stdout.print(f"wrote {log.path} ({pairs}, {size}) from {log.source}", soft_wrap=True)
