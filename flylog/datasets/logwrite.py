"""The log every importer writes: the contract's camera topics from a dataset's frames, its
ground truth under ``/truth/``, and what it was imported from (``flylog.dataset``).

A dataset that does not say where its cameras sit on a robot gives a log without robot
geometry: no ``/tf`` (no base_link → camera transforms), metadata ``mount = "none"``; a
dataset without odometry gives a log without ``/odom``. Nothing is invented in their place.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flylog.errors import LogError
from flylog.geometry import Pose2D, StereoRig
from flylog.io import contract, encode
from flylog.io.atomic import Batch
from flylog.io.writer import LogWriter


@dataclass(frozen=True)
class DatasetFrame:
    """One stereo pair of a dataset, rectified, with what the dataset knows of it."""

    stamp_ns: int
    left: np.ndarray  # (H, W, 3) uint8 RGB or (H, W) uint8 grey
    right: np.ndarray
    disparity: np.ndarray | None = None  # (H, W) float32 px of the left image, NaN unknown
    true_pose: Pose2D | None = None  # on the ground plane, in the dataset's world frame


@dataclass(frozen=True)
class Source:
    """One log's worth of a dataset: a scene, a pair, a sequence."""

    name: str  # the log's file name without .mcap
    path: Path  # the folder (or file) it comes from
    rig: StereoRig
    frames: Callable[[], Iterator[DatasetFrame]]  # streamed, in time order
    mount: bool = False  # whether rig's mount is the dataset's (else: none given)


def write_dataset_log(
    path: Path,
    rig: StereoRig,
    frames: Iterable[DatasetFrame],
    metadata: dict[str, str],
    *,
    on_frame: Callable[[int], None] | None = None,
    batch: Batch | None = None,
) -> int:
    """Write the frames (streamed, in time order) as a flylog log at ``path`` (atomically,
    with ``batch``'s other logs if given); return how many. ``rig`` gives the calibration;
    its mount is not written (the log has no ``/tf``), as ``metadata`` says
    (``mount = "none"``)."""
    count = 0
    with LogWriter(path, batch=batch) as log:
        for frame in frames:
            t = frame.stamp_ns
            if count == 0:
                for side, topic in contract.CALIBRATION_TOPICS.items():
                    log.write(topic, t, encode.camera_calibration(rig, side, t))
            for side, image in (("left", frame.left), ("right", frame.right)):
                frame_id = contract.CAMERA_FRAMES[side]
                log.write(contract.IMAGE_TOPICS[side], t, encode.raw_image(image, t, frame_id))
            if frame.disparity is not None:
                left_frame = contract.CAMERA_FRAMES["left"]
                truth = encode.disparity_image(frame.disparity, t, left_frame)
                log.write(contract.TRUTH_DISPARITY, t, truth)
            if frame.true_pose is not None:
                pose = encode.pose_in_frame(frame.true_pose, t, contract.ODOM_FRAME)
                log.write(contract.TRUTH_POSE, t, pose)
            count += 1
            if on_frame is not None:
                on_frame(count)
        if count == 0:
            msg = f"{path}: the dataset gave no stereo pair to write"
            raise LogError(msg)
        log.add_metadata(contract.DATASET_METADATA, {**metadata, "frames": str(count)})
    return count
