"""The KITTI stereo layouts: the 2012/2015 stereo benchmarks and the odometry sequences.

- Stereo 2015 (``training/`` or ``testing/``): ``image_2/NNNNNN_XX.png`` (left, colour) and
  ``image_3/NNNNNN_XX.png`` (right) for the frames XX = 00 … 20 of scene NNNNNN, the
  calibration ``calib_cam_to_cam/NNNNNN.txt`` (``P_rect_02``, ``P_rect_03``; or
  ``calib/NNNNNN.txt``, ``P2``, ``P3``), and the ground truth of frame 10 only,
  ``disp_occ_0/NNNNNN_10.png`` (all pixels; else ``disp_noc_0``, the non-occluded ones):
  uint16, disparity = value / 256, 0 = unknown.
- Stereo 2012: the grey pair ``image_0``/``image_1`` (cameras 0 and 1, ``calib/NNNNNN.txt``
  ``P0``, ``P1``) with the ground truth ``disp_occ``/``disp_noc`` (aligned with image_0), or
  without it the colour pair ``colored_0``/``colored_1`` (cameras 2 and 3, ``P2``, ``P3``),
  which image_0's ground truth does not fit (the colour cameras sit 6 cm from the grey).
- A scene is its frame 10 at log time 0 (a one-frame log), or with ``multiview`` all its
  frames, frame k at k × 100 ms (KITTI's 10 Hz), the ground truth at frame 10.
- Odometry (``sequences/NN/``): ``image_2/NNNNNN.png``, ``image_3/NNNNNN.png``,
  ``calib.txt`` (``P2``, ``P3``), ``times.txt`` (s per frame) and, beside ``sequences/``,
  ``poses/NN.txt``: per frame the 3×4 pose [R | t] of camera 0 in camera 0's frame at the
  first frame (x right, y down, z forward). One log per sequence; the poses become
  ``/truth/pose`` of the colour cameras' midpoint, projected on the ground plane (the
  camera's x–z plane; its height, pitch and roll are dropped, with a warning).

The images are rectified: the rig is the left projection's focal length and principal
point, the baseline (P_left[0,3] − P_right[0,3]) / f, doffs the right cx − the left's.
KITTI gives no robot: the log has no mount.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np

from flylog.datasets.checks import checked_rig, checked_truth, finite
from flylog.datasets.images import read_pair, read_png
from flylog.datasets.logwrite import DatasetFrame, Source
from flylog.errors import LogError
from flylog.geometry import Pose2D, StereoRig
from flylog.io.inputs import read_input_text

STEREO_LAYOUT = (
    "KITTI stereo 2015: training/image_2/NNNNNN_10.png, training/image_3/NNNNNN_10.png, "
    "training/calib_cam_to_cam/NNNNNN.txt (P_rect_02, P_rect_03) and "
    "training/disp_occ_0/NNNNNN_10.png; KITTI stereo 2012: training/image_0/NNNNNN_10.png, "
    "training/image_1/NNNNNN_10.png (or colored_0, colored_1), training/calib/NNNNNN.txt "
    "(P0, P1; P2, P3 for colored_*) and training/disp_occ/NNNNNN_10.png"
)
ODOMETRY_LAYOUT = (
    "KITTI odometry: sequences/NN/image_2/NNNNNN.png, sequences/NN/image_3/NNNNNN.png, "
    "sequences/NN/calib.txt (P2, P3), sequences/NN/times.txt and poses/NN.txt"
)
TRUTH_FOLDERS = ("disp_occ_0", "disp_noc_0", "disp_occ", "disp_noc")
REFERENCE_FRAME = 10  # the stereo benchmarks' frame with ground truth (NNNNNN_10)
MULTIVIEW_FRAMES = 21  # NNNNNN_00 … NNNNNN_20
MULTIVIEW_RATE_HZ = 10.0  # KITTI's cameras are triggered at 10 Hz


@dataclass(frozen=True)
class StereoFolders:
    """One of the stereo benchmarks' pairs of image folders, and its calibration keys."""

    left: str
    right: str
    calib: tuple[tuple[str, str, str], ...]  # (folder, left key, right key), first found
    truth: bool  # whether the benchmark's ground truth is aligned with ``left``


# In this order: 2015 (image_2/image_3, colour cameras 2 and 3); 2012's grey pair (cameras
# 0 and 1: the benchmark's pair, its ground truth aligned with image_0); 2012's colour pair
# (cameras 2 and 3, 6 cm from camera 0: image_0's ground truth does not apply to it).
STEREO_FOLDERS = (
    StereoFolders(
        "image_2", "image_3",
        (("calib_cam_to_cam", "P_rect_02", "P_rect_03"), ("calib", "P2", "P3")), truth=True,
    ),
    StereoFolders("image_0", "image_1", (("calib", "P0", "P1"),), truth=True),
    StereoFolders("colored_0", "colored_1", (("calib", "P2", "P3"),), truth=False),
)  # fmt: skip


class KittiPoseWarning(UserWarning):
    """KITTI's 6-DoF poses are projected on the ground plane for /truth/pose."""


def read_calibration(path: Path) -> dict[str, np.ndarray]:
    """``KEY: v1 v2 …`` lines of a KITTI calibration file (non-numeric lines skipped)."""
    out = {}
    for line in read_input_text(path, "the calibration").splitlines():
        key, _, values = line.partition(":")
        try:
            out[key.strip()] = np.array([float(v) for v in values.split()])
        except ValueError:
            continue
    return out


COLOUR_KEYS = (("P_rect_02", "P_rect_03"), ("P2", "P3"))


def _projections(path: Path, keys: tuple[tuple[str, str], ...]) -> tuple[np.ndarray, np.ndarray]:
    calib = read_calibration(path)
    for left, right in keys:
        if left in calib and right in calib:
            p_left, p_right = calib[left], calib[right]
            if p_left.size == 12 and p_right.size == 12:
                return p_left.reshape(3, 4), p_right.reshape(3, 4)
    wanted = " or ".join(f"{left}/{right}" for left, right in keys)
    msg = (
        f"{path}: no {wanted} line of 12 numbers (the left and right cameras' rectified "
        "projections)"
    )
    raise LogError(msg)


def calibration_rig(
    path: Path, width: int, height: int, keys: tuple[tuple[str, str], ...] = COLOUR_KEYS
) -> tuple[StereoRig, float]:
    """The rig of the first (left, right) projections of ``keys`` in the file (P2/P3 by
    default) at ``width``×``height``, and the x of the pair's midpoint in camera 0's frame
    (m; KITTI's poses are camera 0's)."""
    p2, p3 = _projections(path, keys)
    for name, p in (("left", p2), ("right", p3)):
        if not np.all(np.isfinite(p)):
            msg = f"{path}: the {name} camera's projection holds {p.ravel().tolist()}: not finite"
            raise LogError(msg)
        finite(path, f"the {name} camera's focal length", float(p[0, 0]), positive=True)
    f = float(p2[0, 0])
    if not (np.isclose(p2[1, 1], f) and np.isclose(p3[0, 0], f) and np.isclose(p3[1, 1], f)):
        msg = f"{path}: the two projections must share one focal length (square pixels)"
        raise LogError(msg)
    if not np.isclose(p2[1, 2], p3[1, 2]):
        msg = f"{path}: the two projections have different cy: not a rectified pair"
        raise LogError(msg)
    baseline = (float(p2[0, 3]) - float(p3[0, 3])) / f
    if baseline <= 0:
        msg = (
            f"{path}: the projections give a baseline of {baseline} m; the second must be "
            "the right camera's"
        )
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
    rig = checked_rig(rig, path)
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
    raw = read_png(path, depth16=True, what="the ground truth")
    return np.where(raw > 0, raw.astype(np.float32) / np.float32(256.0), np.float32(np.nan))


def _frame_name(name: str, k: int) -> str:
    return f"{name}_{k:02d}.png"


def _stereo_frames(
    folder: Path, folders: StereoFolders, name: str, indices: tuple[int, ...],
    truth: Path | None, period_ns: int,
) -> Iterator[DatasetFrame]:  # fmt: skip
    """The frames ``indices`` of scene ``name``, frame k stamped k × ``period_ns``, frame 10
    with the ground truth."""
    for k in indices:
        left, right = read_pair(
            folder / folders.left / _frame_name(name, k),
            folder / folders.right / _frame_name(name, k),
        )
        disparity = None
        if truth is not None and k == REFERENCE_FRAME:
            size = (left.shape[1], left.shape[0])
            disparity = checked_truth(truth, read_disparity_png(truth), size)
        yield DatasetFrame(k * period_ns, left, right, disparity)


def _stereo_calibration(
    folder: Path, folders: StereoFolders, name: str
) -> tuple[Path, tuple[tuple[str, str], ...]]:
    for sub, left, right in folders.calib:
        path = folder / sub / f"{name}.txt"
        if path.is_file():
            return path, ((left, right),)
    sub = folders.calib[-1][0]
    return _require(folder / sub / f"{name}.txt", STEREO_LAYOUT), ()


def stereo_sources(folder: Path, *, multiview: bool = False) -> list[Source]:
    """One source per scene NNNNNN of a stereo benchmark folder (``training/``): its pair
    NNNNNN_10 (the one with ground truth) at log time 0, or with ``multiview`` its frames
    NNNNNN_00 … NNNNNN_20 that the folder holds, a 10 Hz sequence."""
    folders = next((f for f in STEREO_FOLDERS if (folder / f.left).is_dir()), None)
    if folders is None:
        msg = f"{folder}: no image_2, image_0 or colored_0 folder ({STEREO_LAYOUT})"
        raise LogError(msg)
    images = folder / folders.left
    _require(folder / folders.right, STEREO_LAYOUT)
    truth_dir = None
    if folders.truth:
        truth_dir = next((folder / t for t in TRUTH_FOLDERS if (folder / t).is_dir()), None)
    out = []
    for reference in sorted(images.glob(f"*_{REFERENCE_FRAME}.png")):
        name = reference.name.removesuffix(f"_{REFERENCE_FRAME}.png")
        indices: tuple[int, ...] = (REFERENCE_FRAME,)
        if multiview:
            ks = range(MULTIVIEW_FRAMES)
            indices = tuple(k for k in ks if (images / _frame_name(name, k)).is_file())
        for k in indices:
            _require(folder / folders.right / _frame_name(name, k), STEREO_LAYOUT)
        calib, keys = _stereo_calibration(folder, folders, name)
        height, width = read_png(reference).shape[:2]
        rig, _ = calibration_rig(calib, width, height, keys)
        if multiview:
            rig = dataclasses.replace(rig, frame_rate=MULTIVIEW_RATE_HZ)
        truth = None if truth_dir is None else truth_dir / reference.name
        if truth is not None and not truth.is_file():
            truth = None
        period_ns = round(1e9 / MULTIVIEW_RATE_HZ) if multiview else 0  # one frame: at 0
        frames = partial(_stereo_frames, folder, folders, name, indices, truth, period_ns)
        out.append(Source(name, folder, rig, frames))
    if not out:
        msg = f"{images}: no NNNNNN_10.png pair ({STEREO_LAYOUT})"
        raise LogError(msg)
    return out


def _numbers(path: Path, what: str, count: int | None) -> list[list[float]]:
    """The rows of whitespace-separated finite numbers of a text file (``count`` a row, if
    given); LogError naming the file and the line otherwise."""
    rows = []
    for n, line in enumerate(read_input_text(path, what).splitlines(), start=1):
        if not line.strip():
            continue
        try:
            row = [float(v) for v in line.split()]
        except ValueError:
            msg = f"{path}: line {n} is {line.strip()[:60]!r}, not {what} (numbers)"
            raise LogError(msg) from None
        if not all(math.isfinite(v) for v in row) or (count is not None and len(row) != count):
            msg = f"{path}: line {n} holds {line.strip()[:60]!r}, not {count or 1} finite numbers"
            raise LogError(msg)
        rows.append(row)
    if not rows:
        msg = f"{path}: empty; it holds {what}, one line a frame"
        raise LogError(msg)
    return rows


def read_times(path: Path) -> np.ndarray:
    """times.txt: one time (s) a frame, increasing; LogError naming the line otherwise."""
    times = np.array([row[0] for row in _numbers(path, "frame times", 1)])
    back = np.flatnonzero(np.diff(times) <= 0)
    if back.size:
        k = int(back[0]) + 1
        msg = (
            f"{path}: line {k + 1} gives {times[k]:g} s after {times[k - 1]:g} s: frame times "
            "increase (a repeated or decreasing time)"
        )
        raise LogError(msg)
    return times


def read_poses(path: Path) -> np.ndarray:
    """poses/NN.txt: one 3×4 pose (12 finite numbers) a line."""
    return np.array(_numbers(path, "poses", 12))


def ground_pose(pose: np.ndarray, mid_x: float) -> Pose2D:
    """A camera-0 pose [R | t] (x right, y down, z forward) → the colour pair's midpoint on
    the ground plane: forward z → x, left −x → y, heading of the optical axis."""
    r, t = pose[:, :3], pose[:, 3]
    centre = t + r[:, 0] * mid_x
    return Pose2D(float(centre[2]), float(-centre[0]), math.atan2(-r[0, 2], r[2, 2]))


def _sequence(
    folder: Path, rig: StereoRig, mid_x: float, poses: np.ndarray | None
) -> Iterator[DatasetFrame]:
    times = read_times(folder / "times.txt")
    for k, t in enumerate(times):
        name = f"{k:06d}.png"
        left, right = read_pair(folder / "image_2" / name, folder / "image_3" / name)
        pose = None if poses is None else ground_pose(poses[k].reshape(3, 4), mid_x)
        yield DatasetFrame(round(float(t) * 1e9), left, right, true_pose=pose)


def sequence_source(folder: Path) -> Source:
    """The source of one odometry sequence folder ``sequences/NN``."""
    for name in ("image_2", "image_3", "calib.txt", "times.txt"):
        _require(folder / name, ODOMETRY_LAYOUT)
    first = _require(folder / "image_2" / "000000.png", ODOMETRY_LAYOUT)
    height, width = read_png(first).shape[:2]
    times = read_times(folder / "times.txt")
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
        poses = read_poses(pose_file)
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


def _sequence_only(folder: Path, multiview: bool) -> Source:
    if multiview:
        msg = (
            f"{folder}: an odometry sequence, a sequence log already; the multiview import "
            "is for the stereo benchmarks' frames NNNNNN_00 … NNNNNN_20"
        )
        raise LogError(msg)
    return sequence_source(folder)


def _is_stereo(folder: Path) -> bool:
    return any((folder / f.left).is_dir() for f in STEREO_FOLDERS)


def sources(path: Path, *, multiview: bool = False) -> list[Source]:
    """The sources of a KITTI folder: a stereo benchmark (its root, or ``training/``; with
    ``multiview`` each scene's frames 00 … 20), an odometry dataset (its root holding
    ``sequences/``) or one sequence folder."""
    path = Path(path)
    if not path.is_dir():
        msg = f"{path}: no such folder ({STEREO_LAYOUT}; or {ODOMETRY_LAYOUT})"
        raise LogError(msg)
    if _is_stereo(path / "training"):
        return stereo_sources(path / "training", multiview=multiview)
    if (path / "image_2").is_dir() and (path / "times.txt").is_file():
        return [_sequence_only(path, multiview)]
    if _is_stereo(path):
        return stereo_sources(path, multiview=multiview)
    if (path / "sequences").is_dir():
        found = [
            _sequence_only(p, multiview)
            for p in sorted((path / "sequences").iterdir())
            if p.is_dir()
        ]
        if found:
            return found
    msg = f"{path}: image_2 missing: not a KITTI folder ({STEREO_LAYOUT}; or {ODOMETRY_LAYOUT})"
    raise LogError(msg)
