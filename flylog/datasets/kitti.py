"""The KITTI stereo layouts: the 2012/2015 stereo benchmarks and the odometry sequences.

- Stereo (``training/`` or ``testing/``): ``image_2/NNNNNN_10.png`` (left, colour),
  ``image_3/NNNNNN_10.png`` (right), the calibration ``calib_cam_to_cam/NNNNNN.txt``
  (2015: ``P_rect_02``, ``P_rect_03``) or ``calib/NNNNNN.txt`` (2012: ``P2``, ``P3``), and
  the ground truth ``disp_occ_0/NNNNNN_10.png`` (all pixels; else ``disp_noc_0``, the
  non-occluded ones): uint16, disparity = value / 256, 0 = unknown. One log per pair, at
  log time 0.
- Odometry (``sequences/NN/``): ``image_2/NNNNNN.png``, ``image_3/NNNNNN.png``,
  ``calib.txt`` (``P2``, ``P3``), ``times.txt`` (s per frame) and, beside ``sequences/``,
  ``poses/NN.txt``: per frame the 3×4 pose [R | t] of camera 0 in camera 0's frame at the
  first frame (x right, y down, z forward). One log per sequence; the poses become
  ``/truth/pose`` of the colour cameras' midpoint, projected on the ground plane (the
  camera's x–z plane; its height, pitch and roll are dropped, with a warning).

The images are rectified: the rig is P2's focal length and principal point, the baseline
(P2[0,3] − P3[0,3]) / f, doffs P3's cx − P2's. KITTI gives no robot: the log has no mount.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Iterator
from functools import partial
from pathlib import Path

import numpy as np

from flylog.datasets.images import read_png
from flylog.datasets.logwrite import DatasetFrame, Source
from flylog.errors import LogError
from flylog.geometry import Pose2D, StereoRig

STEREO_LAYOUT = (
    "KITTI stereo: training/image_2/NNNNNN_10.png, training/image_3/NNNNNN_10.png, "
    "training/calib_cam_to_cam/NNNNNN.txt (P_rect_02, P_rect_03) or training/calib/NNNNNN.txt "
    "(P2, P3), and training/disp_occ_0/NNNNNN_10.png"
)
ODOMETRY_LAYOUT = (
    "KITTI odometry: sequences/NN/image_2/NNNNNN.png, sequences/NN/image_3/NNNNNN.png, "
    "sequences/NN/calib.txt (P2, P3), sequences/NN/times.txt and poses/NN.txt"
)
TRUTH_FOLDERS = ("disp_occ_0", "disp_noc_0", "disp_occ", "disp_noc")
_REFERENCE = "_10"  # the stereo benchmarks' pair with ground truth


class KittiPoseWarning(UserWarning):
    """KITTI's 6-DoF poses are projected on the ground plane for /truth/pose."""


def read_calibration(path: Path) -> dict[str, np.ndarray]:
    """``KEY: v1 v2 …`` lines of a KITTI calibration file (non-numeric lines skipped)."""
    out = {}
    for line in Path(path).read_text().splitlines():
        key, _, values = line.partition(":")
        try:
            out[key.strip()] = np.array([float(v) for v in values.split()])
        except ValueError:
            continue
    return out


def _projections(path: Path) -> tuple[np.ndarray, np.ndarray]:
    calib = read_calibration(path)
    for left, right in (("P_rect_02", "P_rect_03"), ("P2", "P3")):
        if left in calib and right in calib:
            p2, p3 = calib[left], calib[right]
            if p2.size == 12 and p3.size == 12:
                return p2.reshape(3, 4), p3.reshape(3, 4)
    msg = (
        f"{path}: no P_rect_02/P_rect_03 or P2/P3 line of 12 numbers (the left and right "
        "colour cameras' rectified projections)"
    )
    raise LogError(msg)


def calibration_rig(path: Path, width: int, height: int) -> tuple[StereoRig, float]:
    """The rig of P2/P3 at ``width``×``height``, and the x of the pair's midpoint in camera
    0's frame (m; KITTI's poses are camera 0's)."""
    p2, p3 = _projections(path)
    f = float(p2[0, 0])
    if not (np.isclose(p2[1, 1], f) and np.isclose(p3[0, 0], f) and np.isclose(p3[1, 1], f)):
        msg = f"{path}: P2 and P3 must share one focal length (square pixels)"
        raise LogError(msg)
    if not np.isclose(p2[1, 2], p3[1, 2]):
        msg = f"{path}: P2 and P3 have different cy: not a rectified pair"
        raise LogError(msg)
    baseline = (float(p2[0, 3]) - float(p3[0, 3])) / f
    if baseline <= 0:
        msg = f"{path}: P2 and P3 give a baseline of {baseline} m; the right camera must be P3"
        raise LogError(msg)
    rig = StereoRig(
        width=width,
        height=height,
        focal_px=f,
        baseline=baseline,
        mount_height=0.0,
        mount_x=0.0,
        mount_y=0.0,
        principal_point=(float(p2[0, 2]), float(p2[1, 2])),
        doffs=float(p3[0, 2]) - float(p2[0, 2]),
    )
    # P = K [I | −C]: the optical centre's x is −P[0,3] / f
    mid_x = -(float(p2[0, 3]) + float(p3[0, 3])) / (2.0 * f)
    return rig, mid_x


def _require(path: Path, layout: str) -> Path:
    if not path.exists():
        msg = f"{path}: missing ({layout})"
        raise LogError(msg)
    return path


def read_disparity_png(path: Path) -> np.ndarray:
    """KITTI's uint16 disparity: value / 256 px, 0 → NaN (unknown)."""
    raw = read_png(path, depth16=True)
    return np.where(raw > 0, raw.astype(np.float32) / np.float32(256.0), np.float32(np.nan))


def _pair(folder: Path, name: str, rig: StereoRig, truth: Path | None) -> Iterator[DatasetFrame]:
    left = read_png(folder / "image_2" / f"{name}{_REFERENCE}.png")
    right = read_png(folder / "image_3" / f"{name}{_REFERENCE}.png")
    disparity = None if truth is None else read_disparity_png(truth)
    yield DatasetFrame(0, left, right, disparity)


def stereo_sources(folder: Path) -> list[Source]:
    """One source per NNNNNN_10 pair of a stereo benchmark folder (``training/``)."""
    images = _require(folder / "image_2", STEREO_LAYOUT)
    _require(folder / "image_3", STEREO_LAYOUT)
    truth_dir = next((folder / t for t in TRUTH_FOLDERS if (folder / t).is_dir()), None)
    out = []
    for left in sorted(images.glob(f"*{_REFERENCE}.png")):
        name = left.name.removesuffix(f"{_REFERENCE}.png")
        _require(folder / "image_3" / left.name, STEREO_LAYOUT)
        calib = folder / "calib_cam_to_cam" / f"{name}.txt"
        if not calib.is_file():
            calib = _require(folder / "calib" / f"{name}.txt", STEREO_LAYOUT)
        height, width = read_png(left).shape[:2]
        rig, _ = calibration_rig(calib, width, height)
        truth = None if truth_dir is None else truth_dir / left.name
        if truth is not None and not truth.is_file():
            truth = None
        out.append(Source(name, left.parent.parent, rig, partial(_pair, folder, name, rig, truth)))
    if not out:
        msg = f"{images}: no NNNNNN_10.png pair ({STEREO_LAYOUT})"
        raise LogError(msg)
    return out


def ground_pose(pose: np.ndarray, mid_x: float) -> Pose2D:
    """A camera-0 pose [R | t] (x right, y down, z forward) → the colour pair's midpoint on
    the ground plane: forward z → x, left −x → y, heading of the optical axis."""
    r, t = pose[:, :3], pose[:, 3]
    centre = t + r[:, 0] * mid_x
    return Pose2D(float(centre[2]), float(-centre[0]), math.atan2(-r[0, 2], r[2, 2]))


def _sequence(
    folder: Path, rig: StereoRig, mid_x: float, poses: np.ndarray | None
) -> Iterator[DatasetFrame]:
    times = np.loadtxt(folder / "times.txt", ndmin=1)
    for k, t in enumerate(times):
        name = f"{k:06d}.png"
        left, right = read_png(folder / "image_2" / name), read_png(folder / "image_3" / name)
        pose = None if poses is None else ground_pose(poses[k].reshape(3, 4), mid_x)
        yield DatasetFrame(round(float(t) * 1e9), left, right, true_pose=pose)


def sequence_source(folder: Path) -> Source:
    """The source of one odometry sequence folder ``sequences/NN``."""
    for name in ("image_2", "image_3", "calib.txt", "times.txt"):
        _require(folder / name, ODOMETRY_LAYOUT)
    first = _require(folder / "image_2" / "000000.png", ODOMETRY_LAYOUT)
    height, width = read_png(first).shape[:2]
    times = np.loadtxt(folder / "times.txt", ndmin=1)
    for k in range(len(times)):
        for side in ("image_2", "image_3"):
            _require(folder / side / f"{k:06d}.png", ODOMETRY_LAYOUT)
    rig, mid_x = calibration_rig(folder / "calib.txt", width, height)
    if len(times) > 1:
        rate = (len(times) - 1) / (float(times[-1]) - float(times[0]))
        rig = dataclasses.replace(rig, frame_rate=rate)
    pose_file = folder.parent.parent / "poses" / f"{folder.name}.txt"
    poses = None
    if pose_file.is_file():
        poses = np.loadtxt(pose_file, ndmin=2)
        if poses.shape != (len(times), 12):
            msg = (
                f"{pose_file}: {poses.shape[0]} poses of {poses.shape[1]} numbers; times.txt "
                f"has {len(times)} frames (12 numbers a pose)"
            )
            raise LogError(msg)
        msg = (
            f"{pose_file}: the 6-DoF poses are projected on the ground plane (camera x–z) "
            "for /truth/pose; height, pitch and roll are dropped"
        )
        warnings.warn(msg, KittiPoseWarning, stacklevel=3)
    return Source(folder.name, folder, rig, partial(_sequence, folder, rig, mid_x, poses))


def sources(path: Path) -> list[Source]:
    """The sources of a KITTI folder: a stereo benchmark (its root, or ``training/``), an
    odometry dataset (its root holding ``sequences/``) or one sequence folder."""
    path = Path(path)
    if not path.is_dir():
        msg = f"{path}: no such folder ({STEREO_LAYOUT}; or {ODOMETRY_LAYOUT})"
        raise LogError(msg)
    if (path / "training" / "image_2").is_dir():
        return stereo_sources(path / "training")
    if (path / "image_2").is_dir() and (path / "times.txt").is_file():
        return [sequence_source(path)]
    if (path / "image_2").is_dir():
        return stereo_sources(path)
    if (path / "sequences").is_dir():
        found = [sequence_source(p) for p in sorted((path / "sequences").iterdir()) if p.is_dir()]
        if found:
            return found
    msg = f"{path}: image_2 missing: not a KITTI folder ({STEREO_LAYOUT}; or {ODOMETRY_LAYOUT})"
    raise LogError(msg)
