"""``sensor_msgs/msg/CameraInfo`` → rectification maps and the stereo rig.

A raw camera (D ≠ 0 or R ≠ I) is rectified with OpenCV: ``initUndistortRectifyMap`` (or its
``fisheye`` twin for ``equidistant``) from K, D, R and the rectified P, computed once per
calibration; a rectified camera (D = 0, R = I) passes untouched. The rectified P matrices
then define the rig (:func:`rig_from_calibration`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from flylog.errors import LogError
from flylog.geometry import StereoRig
from flylog.geometry.stereo import OPTICAL_TO_BASE

MODELS = ("plumb_bob", "rational_polynomial", "equidistant")
# How far a rectified rig may be from what StereoRig represents: principal point (px),
# focal lengths (relative), camera axes (rad).
PIXEL_TOLERANCE = 1e-3
RELATIVE_TOLERANCE = 1e-6
ANGLE_TOLERANCE = 1e-4


@dataclass(frozen=True)
class CameraModel:
    """One camera's calibration: image size, K (3, 3), D, R (3, 3), P (3, 4), its model
    and the frame its images are in."""

    width: int
    height: int
    K: np.ndarray
    D: np.ndarray
    R: np.ndarray
    P: np.ndarray
    model: str
    frame_id: str

    @property
    def is_raw(self) -> bool:
        """Whether images need rectifying (distortion, or a rectifying rotation)."""
        return bool(np.any(self.D != 0.0)) or not np.allclose(self.R, np.eye(3), atol=1e-12)


def camera_model(msg: Any) -> CameraModel:
    """A decoded CameraInfo as a CameraModel (LogError if its matrices are malformed)."""
    try:
        K = np.asarray(msg.k, dtype=float).reshape(3, 3)
        R = np.asarray(msg.r, dtype=float).reshape(3, 3)
        P = np.asarray(msg.p, dtype=float).reshape(3, 4)
    except ValueError as exc:
        text = f"CameraInfo has malformed K, R or P ({exc})"
        raise LogError(text) from None
    D = np.asarray(msg.d, dtype=float).ravel()
    if not np.any(P):  # uncalibrated (all zeros): nothing to rectify to
        text = "CameraInfo has an all-zero P: the camera is not calibrated"
        raise LogError(text)
    return CameraModel(
        int(msg.width), int(msg.height), K, D, R, P, str(msg.distortion_model),
        str(msg.header.frame_id),
    )  # fmt: skip


class Rectifier:
    """Remaps a raw camera's images onto its rectified P (maps computed once)."""

    def __init__(self, camera: CameraModel) -> None:
        import cv2

        size = (camera.width, camera.height)
        new_k = camera.P[:, :3]
        if camera.model == "equidistant":
            if camera.D.size < 4:
                text = f"an equidistant calibration needs 4 coefficients, D has {camera.D.size}"
                raise LogError(text)
            self._maps = cv2.fisheye.initUndistortRectifyMap(
                camera.K, camera.D[:4], camera.R, new_k, size, cv2.CV_16SC2
            )
        elif camera.model in ("plumb_bob", "rational_polynomial"):
            self._maps = cv2.initUndistortRectifyMap(
                camera.K, camera.D, camera.R, new_k, size, cv2.CV_16SC2
            )
        else:
            text = f"distortion model '{camera.model}' is not supported ({', '.join(MODELS)} are)"
            raise LogError(text)

    def __call__(self, image: np.ndarray) -> np.ndarray:
        import cv2

        return np.asarray(
            cv2.remap(np.ascontiguousarray(image), *self._maps, interpolation=cv2.INTER_LINEAR)
        )


def rectifier(camera: CameraModel) -> Rectifier | None:
    """The camera's Rectifier, or None when its images are rectified already."""
    return Rectifier(camera) if camera.is_raw else None


def rectified_orientation(camera: CameraModel, in_base: np.ndarray) -> np.ndarray:
    """The rectified camera's axes in base_link, given the raw camera's (R maps raw camera
    coordinates to rectified ones)."""
    return in_base @ camera.R.T


def rig_from_calibration(
    left: CameraModel,
    right: CameraModel,
    mount: tuple[np.ndarray, np.ndarray],
    frame_rate: float,
    where: str,
) -> StereoRig:
    """The rig of two rectified cameras (their P matrices) with the left one's rectified
    optical frame at ``mount`` = (position (3,), axes (3, 3)) in base_link.

    StereoRig represents square pixels, the principal point at the image centre in both
    cameras, optical axes along base_link's x and the left camera at y = +baseline/2; any
    other calibration is a LogError naming ``where`` (bag and topic) and what differs.
    """
    pl, pr = left.P, right.P
    fx = float(pl[0, 0])
    cx, cy = (left.width - 1) / 2.0, (left.height - 1) / 2.0

    def refuse(what: str) -> LogError:
        return LogError(f"{where}: {what}, which flylog's stereo rig does not yet support")

    if (left.width, left.height) != (right.width, right.height):
        raise refuse(f"the cameras differ in size ({left.width}×{left.height} and "
                     f"{right.width}×{right.height})")  # fmt: skip
    if not math.isclose(float(pl[1, 1]), fx, rel_tol=RELATIVE_TOLERANCE):
        raise refuse(f"the rectified P has fx = {fx} and fy = {pl[1, 1]} (non-square pixels)")
    if not (abs(pl[0, 2] - cx) <= PIXEL_TOLERANCE and abs(pl[1, 2] - cy) <= PIXEL_TOLERANCE):
        raise refuse(f"the principal point is ({pl[0, 2]}, {pl[1, 2]}), not the image "
                     f"centre ({cx}, {cy})")  # fmt: skip
    if not (
        math.isclose(float(pr[0, 0]), fx, rel_tol=RELATIVE_TOLERANCE)
        and abs(pr[0, 2] - pl[0, 2]) <= PIXEL_TOLERANCE
        and abs(pr[1, 2] - pl[1, 2]) <= PIXEL_TOLERANCE
        and pr[1, 3] == 0.0
    ):
        raise refuse(
            "the right camera's rectified P differs from the left one's in focal length or "
            "principal point (a horizontal offset doffs, or not rectified)"
        )
    baseline = -float(pr[0, 3]) / fx
    position, axes = mount
    angle = _angle_between(axes, OPTICAL_TO_BASE)
    if angle > ANGLE_TOLERANCE:
        raise refuse(f"the left camera is turned {math.degrees(angle):.3g}° away from looking "
                     f"straight ahead along base_link's x")  # fmt: skip
    x, y, z = (float(v) for v in position)
    if baseline <= 0 or not math.isclose(y, baseline / 2.0, rel_tol=1e-3, abs_tol=1e-6):
        raise refuse(f"the right camera's P gives a baseline of {baseline} m but the left "
                     f"camera sits at y = {y} m (a rig not symmetric about base_link)")  # fmt: skip
    return StereoRig(
        width=left.width,
        height=left.height,
        focal_px=fx,
        baseline=baseline,
        mount_height=z,
        mount_x=x,
        frame_rate=frame_rate,
    )


def _angle_between(a: np.ndarray, b: np.ndarray) -> float:
    """The angle of the rotation taking b to a (rad)."""
    c = (float(np.trace(a @ b.T)) - 1.0) / 2.0
    return math.acos(max(-1.0, min(1.0, c)))
