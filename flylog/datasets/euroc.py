"""The EuRoC MAV layout: ``mav0/cam0`` (left) and ``mav0/cam1`` (right), each with
``data.csv`` (``#timestamp [ns],filename``), ``data/`` (grey PNGs) and ``sensor.yaml``
(``T_BS``: the camera in the body frame, 4×4 row-major; ``resolution``; ``intrinsics``
fu, fv, cu, cv; ``distortion_coefficients`` k1, k2, p1, p2 of the radial-tangential
model), and ``state_groundtruth_estimate0/data.csv`` (the body's position and orientation
quaternion w, x, y, z in a gravity-aligned world, z up).

The raw images are rectified with OpenCV (``stereoRectify`` with zero disparity at
infinity, ``alpha = 0``: no invalid pixels; the maps are made once). One log per sequence,
stamped with the cameras' time; pairs are the timestamps both cameras have. The ground
truth becomes ``/truth/pose`` of the rectified cameras' midpoint at each pair's stamp
(interpolated), projected on the ground plane (heading of the optical axis; height, pitch
and roll dropped, with a warning). EuRoC's body is a flying platform, not a robot on the
ground: the log has no mount.
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path

import cv2
import numpy as np

from flylog.datasets.checks import checked_rig, finite
from flylog.datasets.images import read_pair
from flylog.datasets.logwrite import DatasetFrame, Source
from flylog.errors import LogError
from flylog.geometry import Pose2D, StereoRig
from flylog.io.inputs import read_input_text

LAYOUT = (
    "EuRoC MAV: mav0/cam0 and mav0/cam1, each with data.csv, data/ and sensor.yaml, and "
    "mav0/state_groundtruth_estimate0/data.csv (optional)"
)
TRUTH = "state_groundtruth_estimate0"
_MIN_BASELINE_M = 0.001  # StereoRig's smallest baseline
_LIST = re.compile(r"(\w+)\s*:\s*\[([^\]]*)\]", re.S)


class EurocPoseWarning(UserWarning):
    """EuRoC's 6-DoF ground truth is projected on the ground plane for /truth/pose."""


@dataclass(frozen=True)
class Camera:
    """One camera of sensor.yaml: the body → camera transform, intrinsics, distortion."""

    t_bs: np.ndarray  # (4, 4) camera in body
    k: np.ndarray  # (3, 3)
    distortion: np.ndarray  # (4,) k1, k2, p1, p2
    size: tuple[int, int]  # width, height


def read_sensor(path: Path) -> Camera:
    """The camera of a ``sensor.yaml`` (the lists flylog needs, read without a YAML parser:
    ``T_BS``'s ``data``, ``resolution``, ``intrinsics``, ``distortion_coefficients``)."""
    lines = read_input_text(path, "the camera's sensor.yaml").splitlines()
    text = "\n".join(line.split("#", 1)[0] for line in lines)
    lists = {}
    for key, body in _LIST.findall(text):
        try:
            lists[key] = np.array(
                [float(v) for v in body.replace("\n", " ").split(",") if v.strip()]
            )
        except ValueError:
            continue
    model = re.search(r"distortion_model\s*:\s*(\S+)", text)
    if model is not None and model.group(1) != "radial-tangential":
        msg = f"{path}: distortion_model {model.group(1)}; flylog reads radial-tangential"
        raise LogError(msg)
    need = {"data": 16, "resolution": 2, "intrinsics": 4, "distortion_coefficients": 4}
    for key, n in need.items():
        if key not in lists or lists[key].size != n:
            name = "T_BS data" if key == "data" else key
            msg = f"{path}: no {name} list of {n} numbers ({LAYOUT})"
            raise LogError(msg)
    for key in need:
        if not np.all(np.isfinite(lists[key])):
            name = "T_BS data" if key == "data" else key
            msg = f"{path}: {name} holds {lists[key].tolist()}: not finite"
            raise LogError(msg)
    fu, fv, cu, cv = lists["intrinsics"]
    finite(path, "intrinsics' fu", fu, positive=True)
    finite(path, "intrinsics' fv", fv, positive=True)
    for v in lists["resolution"]:
        finite(path, "resolution", v, positive=True)
    k = np.array([[fu, 0.0, cu], [0.0, fv, cv], [0.0, 0.0, 1.0]])
    width, height = (int(v) for v in lists["resolution"])
    return Camera(lists["data"].reshape(4, 4), k, lists["distortion_coefficients"], (width, height))


@dataclass(frozen=True)
class Rectifier:
    """The rectified rig, the maps of both cameras and the rectified left camera's pose in
    the body frame."""

    rig: StereoRig
    maps: tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
    left_in_body: np.ndarray  # (4, 4): rectified left camera → body

    def rectify(self, side: int, image: np.ndarray) -> np.ndarray:
        mx, my = self.maps[side]
        return cv2.remap(image, mx, my, cv2.INTER_LINEAR)


def rectifier(cam0: Camera, cam1: Camera) -> Rectifier:
    """OpenCV's rectification of the pair (zero disparity at infinity, alpha 0)."""
    t_10 = np.linalg.inv(cam1.t_bs) @ cam0.t_bs  # cam0 coordinates → cam1 coordinates
    if np.linalg.norm(t_10[:3, 3]) < _MIN_BASELINE_M:
        msg = (
            f"cam0's and cam1's T_BS put the cameras {np.linalg.norm(t_10[:3, 3]):g} m apart: a "
            "stereo pair's cameras sit apart (a baseline of at least 1 mm)"
        )
        raise LogError(msg)
    r1, r2, p1, p2, *_ = cv2.stereoRectify(
        cam0.k, cam0.distortion, cam1.k, cam1.distortion, cam0.size,
        t_10[:3, :3], t_10[:3, 3].reshape(3, 1), flags=cv2.CALIB_ZERO_DISPARITY, alpha=0,
    )  # fmt: skip
    maps = tuple(
        cv2.initUndistortRectifyMap(c.k, c.distortion, r, p, cam0.size, cv2.CV_32FC1)
        for c, r, p in ((cam0, r1, p1), (cam1, r2, p2))
    )
    f = float(p1[0, 0])
    rig = StereoRig(
        width=cam0.size[0],
        height=cam0.size[1],
        focal_px=f,
        baseline=-float(p2[0, 3]) / float(p2[0, 0]),
        mount_height=0.0,
        mount_x=0.0,
        mount_y=0.0,
        principal_point=(float(p1[0, 2]), float(p1[1, 2])),
        doffs=float(p2[0, 2]) - float(p1[0, 2]),
    )
    rect = np.eye(4)
    rect[:3, :3] = r1.T  # rectified left → raw cam0
    return Rectifier(rig, maps, cam0.t_bs @ rect)  # type: ignore[arg-type]


def _csv_rows(path: Path, what: str) -> Iterator[tuple[int, list[str]]]:
    """(line number, comma-separated fields) of the lines that are not empty or comments."""
    for n, line in enumerate(read_input_text(path, what).splitlines(), start=1):
        if line.strip() and not line.startswith("#"):
            yield n, [field.strip() for field in line.split(",")]


def _stamp(path: Path, n: int, text: str) -> int:
    """A timestamp field (integer ns)."""
    try:
        return int(text)
    except ValueError:
        msg = f"{path}: line {n}: timestamp {text[:40]!r} is not an integer (ns)"
        raise LogError(msg) from None


def _frames_csv(path: Path) -> dict[int, str]:
    out = {}
    for n, fields in _csv_rows(path, "the camera's frame list"):
        if len(fields) < 2 or not fields[1]:
            msg = f"{path}: line {n} is not 'timestamp [ns],filename'"
            raise LogError(msg)
        out[_stamp(path, n, fields[0])] = fields[1]
    return out


# The ground truth's columns: timestamp [ns], position x, y, z [m], quaternion w, x, y, z
_TRUTH_COLUMNS = 8


def _truth(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(stamps (N,) int64, body poses (N, 7): x, y, z, qw, qx, qy, qz), stamps increasing."""
    stamps, poses = [], []
    for n, fields in _csv_rows(path, "the ground truth"):
        if len(fields) < _TRUTH_COLUMNS:
            msg = (
                f"{path}: line {n} has {len(fields)} columns; the ground truth has at least "
                f"{_TRUTH_COLUMNS}: timestamp, p_x, p_y, p_z, q_w, q_x, q_y, q_z"
            )
            raise LogError(msg)
        stamps.append(_stamp(path, n, fields[0]))
        try:
            pose = [float(v) for v in fields[1:_TRUTH_COLUMNS]]
        except ValueError:
            pose = [math.nan]
        if not all(math.isfinite(v) for v in pose) or not any(pose[3:7]):
            msg = f"{path}: line {n}: the position and quaternion are not 7 finite numbers"
            raise LogError(msg)
        poses.append(pose)
    if not stamps:
        msg = f"{path}: empty; the ground truth has one line a pose"
        raise LogError(msg)
    t = np.array(stamps, dtype=np.int64)
    if np.any(np.diff(t) <= 0):
        msg = f"{path}: the timestamps do not increase (a repeated or decreasing one)"
        raise LogError(msg)
    return t, np.array(poses)


def _rotation(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])  # fmt: skip


def ground_poses(stamps: np.ndarray, body: np.ndarray, left_in_body: np.ndarray,
                 baseline: float) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """(N, 2) midpoint x, y and (N,) heading of the rectified cameras' optical axis."""
    xy, heading = np.empty((len(stamps), 2)), np.empty(len(stamps))
    mid = left_in_body[:3, :3] @ np.array([baseline / 2.0, 0.0, 0.0]) + left_in_body[:3, 3]
    for i, pose in enumerate(body):
        r = _rotation(pose[3:7])
        xy[i] = (pose[:3] + r @ mid)[:2]
        axis = r @ left_in_body[:3, 2]
        heading[i] = math.atan2(axis[1], axis[0])
    return xy, np.unwrap(heading)


def _sequence(
    mav: Path, pairs: list[tuple[int, str, str]], rect: Rectifier, truth: tuple | None
) -> Iterator[DatasetFrame]:
    if truth is not None:
        t_ns, xy, heading = truth
    size = (rect.rig.width, rect.rig.height)
    for stamp, left_name, right_name in pairs:
        paths = (mav / "cam0" / "data" / left_name, mav / "cam1" / "data" / right_name)
        raw = read_pair(*paths)
        if (raw[0].shape[1], raw[0].shape[0]) != size:
            msg = (
                f"{paths[0]}: {raw[0].shape[1]}×{raw[0].shape[0]} px, but sensor.yaml's "
                f"resolution is {size[0]}×{size[1]}"
            )
            raise LogError(msg)
        left, right = rect.rectify(0, raw[0]), rect.rectify(1, raw[1])
        pose = None
        if truth is not None and t_ns[0] <= stamp <= t_ns[-1]:
            at = float(stamp)
            pose = Pose2D(
                float(np.interp(at, t_ns, xy[:, 0])),
                float(np.interp(at, t_ns, xy[:, 1])),
                math.remainder(float(np.interp(at, t_ns, heading)), math.tau),
            )
        yield DatasetFrame(stamp, left, right, true_pose=pose)


def sources(path: Path) -> list[Source]:
    """The one source of a EuRoC sequence folder (the one holding ``mav0``, or ``mav0``)."""
    path = Path(path)
    mav = path if path.name == "mav0" else path / "mav0"
    for name in ("cam0/data.csv", "cam0/sensor.yaml", "cam0/data", "cam1/data.csv",
                 "cam1/sensor.yaml", "cam1/data"):  # fmt: skip
        if not (mav / name).exists():
            msg = f"{mav / name}: missing ({LAYOUT})"
            raise LogError(msg)
    cam0, cam1 = (
        read_sensor(mav / "cam0" / "sensor.yaml"),
        read_sensor(mav / "cam1" / "sensor.yaml"),
    )
    if cam0.size != cam1.size:
        msg = f"{mav}: cam0 is {cam0.size} px and cam1 {cam1.size} px; flylog needs one size"
        raise LogError(msg)
    try:
        rect = rectifier(cam0, cam1)
    except LogError as exc:
        raise LogError(f"{mav / 'cam1' / 'sensor.yaml'}: {exc}") from None
    rect = replace(rect, rig=checked_rig(rect.rig, mav / "cam1" / "sensor.yaml"))
    left, right = _frames_csv(mav / "cam0" / "data.csv"), _frames_csv(mav / "cam1" / "data.csv")
    pairs = [(t, left[t], right[t]) for t in sorted(left) if t in right]
    if not pairs:
        msg = f"{mav}: cam0/data.csv and cam1/data.csv share no timestamp: no stereo pair"
        raise LogError(msg)
    rig = rect.rig
    if len(pairs) > 1:
        rig = replace(rig, frame_rate=1e9 * (len(pairs) - 1) / (pairs[-1][0] - pairs[0][0]))
    truth = None
    truth_csv = mav / TRUTH / "data.csv"
    if truth_csv.is_file():
        stamps, body = _truth(truth_csv)
        xy, heading = ground_poses(stamps, body, rect.left_in_body, rig.baseline)
        truth = (stamps.astype(np.float64), xy, heading)
        msg = (
            f"{truth_csv}: the 6-DoF ground truth is projected on the ground plane for "
            "/truth/pose (the cameras' midpoint, the optical axis's heading); height, pitch "
            "and roll are dropped"
        )
        warnings.warn(msg, EurocPoseWarning, stacklevel=3)
    name = path.name if path.name != "mav0" else path.parent.name
    return [Source(name, mav, rig, partial(_sequence, mav, pairs, rect, truth))]
