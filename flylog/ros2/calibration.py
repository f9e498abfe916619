"""``sensor_msgs/msg/CameraInfo`` → rectification maps and the stereo rig.

A raw camera (D ≠ 0 or R ≠ I) is rectified with OpenCV: ``initUndistortRectifyMap`` (or its
``fisheye`` twin for ``equidistant``) from K, D, R and the rectified P, computed once per
calibration; a rectified camera (D = 0, R = I) passes untouched. The rectified P matrices
and the rectified cameras' mounts then define the rig (:func:`rig_from_calibration`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from flylog.errors import LogError
from flylog.geometry import StereoRig
from flylog.geometry.calibrated import Mount, calibrated_rig

MODELS = ("plumb_bob", "rational_polynomial", "equidistant")


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
        int(msg.width),
        int(msg.height),
        K,
        D,
        R,
        P,
        str(msg.distortion_model),
        str(msg.header.frame_id),
    )


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
    mounts: tuple[Mount, Mount | None],
    frame_rate: float,
    *,
    where: str,
    calibration: str,
    transforms: str,
) -> StereoRig:
    """The rig of two cameras from their rectified P matrices and their raw optical frames'
    mounts in base_link (the right one None when the transforms do not place it apart from
    the left one): :func:`flylog.geometry.calibrated.calibrated_rig`, whose LogErrors name
    ``where`` (the bag) and ``calibration`` (the CameraInfo topics) or ``transforms``."""
    if (left.width, left.height) != (right.width, right.height):
        msg = (
            f"{where}: {calibration}: the cameras differ in size ({left.width}×{left.height} and "
            f"{right.width}×{right.height}), which flylog's stereo rig does not support"
        )
        raise LogError(msg)
    left_mount, right_mount = mounts
    return calibrated_rig(
        (left.width, left.height),
        left.P,
        right.P,
        _rectified(left, left_mount),
        None if right_mount is None else _rectified(right, right_mount),
        frame_rate,
        where=where,
        calibration=calibration,
        transforms=transforms,
    )


def _rectified(camera: CameraModel, mount: Mount) -> Mount:
    """The rectified camera's mount: the raw one's optical centre, its axes turned by Rᵀ."""
    return Mount(mount.position, rectified_orientation(camera, mount.axes))
