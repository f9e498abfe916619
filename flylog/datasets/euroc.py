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

from flylog.datasets.images import read_png
from flylog.datasets.logwrite import DatasetFrame, Source
from flylog.errors import LogError
from flylog.geometry import Pose2D, StereoRig

LAYOUT = (
    "EuRoC MAV: mav0/cam0 and mav0/cam1, each with data.csv, data/ and sensor.yaml, and "
    "mav0/state_groundtruth_estimate0/data.csv (optional)"
)
TRUTH = "state_groundtruth_estimate0"
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
    text = "\n".join(line.split("#", 1)[0] for line in Path(path).read_text().splitlines())
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
    fu, fv, cu, cv = lists["intrinsics"]
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


def _frames_csv(path: Path) -> dict[int, str]:
    out = {}
    for line in path.read_text().splitlines():
        if not line.strip() or line.startswith("#"):
            continue
        stamp, _, name = line.partition(",")
        out[int(stamp)] = name.strip()
    return out


def _truth(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(stamps (N,) int64, body poses (N, 7): x, y, z, qw, qx, qy, qz)."""
    table = np.loadtxt(path, delimiter=",", comments="#", ndmin=2, dtype=np.float64)
    stamps = np.loadtxt(path, delimiter=",", comments="#", ndmin=2, dtype=np.int64, usecols=0)
    return stamps.ravel(), table[:, 1:8]


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
    for stamp, left_name, right_name in pairs:
        left = rect.rectify(0, read_png(mav / "cam0" / "data" / left_name))
        right = rect.rectify(1, read_png(mav / "cam1" / "data" / right_name))
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
    rect = rectifier(cam0, cam1)
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
