"""The stereo rig of two rectified cameras from their calibration and their mounts: what a
flylog log's ``/camera/*/calibration`` and ``/tf`` and a ROS 2 bag's ``CameraInfo`` and
``/tf_static`` both say, read by one function, :func:`calibrated_rig`.

From the rectified projection matrices: the focal length and the principal point (cx, cy)
of the left P, ``doffs`` = the right P's cx − the left's, the baseline B = −P_right[0, 3] / fx.
From the mounts (each camera's optical centre and rectified optical axes in base_link):
the midpoint between the optical centres and the pan, tilt and roll of the axes. What
:class:`~flylog.geometry.StereoRig` cannot represent is a LogError saying what differs:
non-square or skewed pixels, two focal lengths, rows that do not align (the right cy, or a
right camera off the left one's x axis), cameras turned differently, a mount beyond the
rig's angle ranges.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from flylog.errors import LogError
from flylog.geometry.stereo import StereoRig, mount_angles

# How far a calibration may be from what StereoRig represents: focal lengths (relative),
# principal point rows and skew (px), a right camera's offset off the left's x axis and its
# position against the transforms (relative to the baseline), the cameras' axes (matrix
# entries).
RELATIVE_TOLERANCE = 1e-6
PIXEL_TOLERANCE = 1e-3
OFFSET_TOLERANCE = 1e-3
AXES_TOLERANCE = 1e-3


@dataclass(frozen=True)
class Mount:
    """A rectified camera on the robot: its optical centre (3,) and its optical axes
    (3, 3, columns x right, y down, z forward written in base_link)."""

    position: np.ndarray
    axes: np.ndarray


def calibrated_rig(
    size: tuple[int, int],
    left_p: np.ndarray,
    right_p: np.ndarray,
    left: Mount,
    right: Mount | None,
    frame_rate: float,
    *,
    where: str,
    calibration: str,
    transforms: str,
) -> StereoRig:
    """The rig of a rectified pair: ``left_p`` and ``right_p`` (3, 4) with the left camera
    as reference, images of ``size`` (width, height), the left camera mounted at ``left``.

    ``right`` is the right camera's mount when the transforms give one: it must sit B along
    the left camera's x axis with the same axes. Without it the right camera is placed
    there. Errors name ``where`` (the log or bag) and ``calibration`` (the topics the P
    matrices come from) or ``transforms`` (the mounts' topic).
    """
    width, height = size
    fx, cx, cy, doffs = _intrinsics(left_p, right_p, f"{where}: {calibration}")
    baseline = -float(right_p[0, 3]) / fx
    _horizontal(right_p, fx, baseline, f"{where}: {calibration}")
    along = left.position + baseline * left.axes[:, 0]
    if right is not None:
        tolerance = OFFSET_TOLERANCE * max(baseline, 1e-3)
        if not np.allclose(along, right.position, rtol=0.0, atol=tolerance):
            msg = (
                f"{where}: {transforms} puts the cameras at {left.position.tolist()} and "
                f"{right.position.tolist()} m, but the P matrices of {calibration} give a "
                f"baseline of {baseline} m: flylog's stereo rig needs the right camera "
                f"{baseline} m along the left camera's x axis (a rectified pair)"
            )
            raise LogError(msg)
        if not np.allclose(left.axes, right.axes, rtol=0.0, atol=AXES_TOLERANCE):
            msg = (
                f"{where}: {transforms} turns the two cameras differently: flylog's stereo "
                f"rig needs a rectified pair (both optical frames parallel)"
            )
            raise LogError(msg)
        along = right.position
    pan, tilt, roll = (a + 0.0 for a in mount_angles(left.axes))  # + 0.0: no −0°
    _within_ranges({"pan": pan, "tilt": tilt, "roll": roll}, f"{where}: {transforms}")
    mid = (left.position + along) / 2.0
    centre = ((width - 1) / 2.0, (height - 1) / 2.0)
    return StereoRig(
        width=width,
        height=height,
        focal_px=fx,
        baseline=baseline,
        mount_height=float(mid[2]),
        mount_x=float(mid[0]),
        mount_y=float(mid[1]),
        principal_point=None if (cx, cy) == centre else (cx, cy),
        doffs=doffs,
        tilt=tilt,
        roll=roll,
        pan=pan,
        frame_rate=frame_rate,
    )


def _intrinsics(
    left_p: np.ndarray, right_p: np.ndarray, where: str
) -> tuple[float, float, float, float]:
    """(fx, cx, cy, doffs) of the pair, or a LogError for what the rig cannot represent."""
    fx, fy = float(left_p[0, 0]), float(left_p[1, 1])
    if fx <= 0.0:
        msg = f"{where}: the left P has fx = {fx}: a calibrated camera has a positive focal length"
        raise LogError(msg)
    if not math.isclose(fy, fx, rel_tol=RELATIVE_TOLERANCE) or abs(left_p[0, 1]) > PIXEL_TOLERANCE:
        msg = (
            f"{where}: the left P has fx = {fx}, fy = {fy} and skew {float(left_p[0, 1])}: "
            f"flylog's stereo rig needs square pixels (fx = fy, no skew)"
        )
        raise LogError(msg)
    rfx, rfy = float(right_p[0, 0]), float(right_p[1, 1])
    if not (
        math.isclose(rfx, fx, rel_tol=RELATIVE_TOLERANCE)
        and math.isclose(rfy, fx, rel_tol=RELATIVE_TOLERANCE)
    ):
        msg = (
            f"{where}: the right P has fx = {rfx} and fy = {rfy}, the left {fx}: flylog's "
            f"stereo rig needs one focal length for both rectified cameras"
        )
        raise LogError(msg)
    if abs(right_p[0, 1]) > PIXEL_TOLERANCE:
        msg = (
            f"{where}: the right P has skew {float(right_p[0, 1])}: flylog's stereo rig "
            f"needs square pixels (no skew)"
        )
        raise LogError(msg)
    cx, cy = float(left_p[0, 2]), float(left_p[1, 2])
    if abs(float(right_p[1, 2]) - cy) > PIXEL_TOLERANCE:
        msg = (
            f"{where}: the right P has cy = {float(right_p[1, 2])}, the left {cy}: the rows "
            f"of a rectified pair align (one cy), so this pair is not rectified"
        )
        raise LogError(msg)
    return fx, cx, cy, float(right_p[0, 2]) - cx


def _horizontal(right_p: np.ndarray, fx: float, baseline: float, where: str) -> None:
    """Refuse a right camera that is not B to the right along the left camera's x axis.
    P_right[:, 3] = K·t with t = −(the right optical centre in the left camera's frame)."""
    tz = float(right_p[2, 3])
    down = 0.0 - (float(right_p[1, 3]) - float(right_p[1, 2]) * tz) / fx
    forward = 0.0 - tz
    if baseline <= 0.0:
        msg = (
            f"{where}: the right P gives a baseline of {baseline} m (−P[0, 3] / fx): the "
            f"right camera of a stereo pair sits to the right of the left one (P[0, 3] < 0)"
        )
        raise LogError(msg)
    if max(abs(down), abs(forward)) > OFFSET_TOLERANCE * baseline:
        msg = (
            f"{where}: the right P puts the right camera {down} m down and {forward} m forward of "
            f"the left one beside {baseline} m to the right: flylog's stereo rig needs the "
            f"right camera along the left camera's x axis (a horizontal rectified pair)"
        )
        raise LogError(msg)


def _within_ranges(angles: dict[str, float], where: str) -> None:
    limits = {f.name: f.metadata for f in dataclasses.fields(StereoRig)}
    for name, value in angles.items():
        lo, hi = limits[name]["min"], limits[name]["max"]
        if not lo <= value <= hi:
            msg = (
                f"{where} mounts the cameras with a {name} of {value:.6g}°: flylog's stereo "
                f"rig represents {lo:g}° to {hi:g}°"
            )
            raise LogError(msg)
