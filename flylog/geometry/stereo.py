"""The rectified pinhole stereo rig of a real camera pair: projection and back-projection.

The rig is the left camera's intrinsics (focal length, principal point (cx, cy)), the right
camera's horizontal offset ``doffs`` (its principal point is (cx + doffs, cy), Middlebury's
convention: disparity = uL − uR = f·B/Z − doffs), the baseline B, and the pair's mount in
base_link: the midpoint between the optical centres at (mount_x, mount_y, mount_height) and
the optical axes turned by pan (left), tilt (down) and roll. Rectified, both cameras share
their orientation and the right optical centre sits B along the left camera's x axis.

Flies and every other point the rig projects live in base_link, not in the left camera's
frame as in the paper: proprioception moves flies by planar robot motions, sonar cones, the
obstacle rule's ground test (height above z = 0) and the planner's grid are all base_link
quantities, and the rig's one rotation per projection (nine multiply-adds beside a fly's
7×7×3 window) is cheaper than moving every consumer into a tilted frame. The projection's
arithmetic, with the level rig's rotation (zeros and ones), gives the same floating-point
numbers as the horizontal rig's shortcut formulas, so logs from a level rig replay bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flylog.config import param

# Rotation taking optical-frame vectors (x right, y down, z forward) into base_link
# (x forward, y left, z up): columns are the optical axes written in base_link.
OPTICAL_TO_BASE = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
# The same rotation as a quaternion (x, y, z, w): (-0.5, 0.5, -0.5, 0.5).
OPTICAL_IN_BASE_QUAT = (-0.5, 0.5, -0.5, 0.5)
# Stereo pairs per second at most: the rate of high-speed machine-vision cameras.
MAX_FRAME_RATE = 1000.0

Quaternion = tuple[float, float, float, float]
Point = tuple[float, float, float]


def _quat_mul(a: Quaternion, b: Quaternion) -> Quaternion:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def quaternion_matrix(q: Quaternion) -> np.ndarray:
    """The 3×3 rotation of a unit quaternion (x, y, z, w)."""
    x, y, z, w = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def mount_angles(optical_in_base: np.ndarray) -> tuple[float, float, float]:
    """(pan, tilt, roll) in degrees of a camera whose optical frame has the rotation
    ``optical_in_base`` (3×3) in base_link: the inverse of :meth:`StereoRig.rotation`."""
    m = np.asarray(optical_in_base, dtype=float) @ OPTICAL_TO_BASE.T  # Rz(pan)·Ry(tilt)·Rx(roll)
    pan = math.atan2(m[1, 0], m[0, 0])
    tilt = math.atan2(-m[2, 0], math.hypot(m[0, 0], m[1, 0]))
    roll = math.atan2(m[2, 1], m[2, 2])
    return math.degrees(pan), math.degrees(tilt), math.degrees(roll)


@dataclass(frozen=True)
class StereoRig:
    """Two rectified cameras of the same focal length mounted on the robot."""

    width: int = param(640, help="image width", unit="px", min=16, max=8192)
    height: int = param(480, help="image height", unit="px", min=16, max=8192)
    focal_px: float = param(500.0, help="focal length", unit="px", min=1.0)
    baseline: float = param(
        0.12, help="distance between the optical centres", unit="m", min=0.001, max=10.0
    )
    mount_height: float = param(0.5, help="height of the optical centres' midpoint", unit="m")
    mount_x: float = param(0.1, help="forward offset of the optical centres' midpoint", unit="m")
    mount_y: float = param(0.0, help="leftward offset of the optical centres' midpoint", unit="m")
    principal_point: tuple[float, float] | None = param(
        None,
        help="left camera's principal point (cx, cy); none: the image centre ((W−1)/2, (H−1)/2)",
        unit="px",
    )
    doffs: float = param(
        0.0,
        help="right principal point's x minus the left's (disparity = f·B/Z − doffs)",
        unit="px",
    )
    tilt: float = param(0.0, help="downward pitch of the optical axes", unit="deg", min=-60, max=60)
    roll: float = param(
        0.0,
        help="roll about the optical axis (positive lowers the right camera)",
        unit="deg",
        min=-45,
        max=45,
    )
    pan: float = param(0.0, help="leftward yaw of the optical axes", unit="deg", min=-90, max=90)
    frame_rate: float = param(
        15.0, help="stereo pairs per second", unit="Hz", min=0.1, max=MAX_FRAME_RATE
    )

    @property
    def cx(self) -> float:
        """Left camera's principal point, x (px)."""
        if self.principal_point is None:
            return (self.width - 1) / 2.0
        return float(self.principal_point[0])

    @property
    def cy(self) -> float:
        """Both cameras' principal point, y (px)."""
        if self.principal_point is None:
            return (self.height - 1) / 2.0
        return float(self.principal_point[1])

    @property
    def cx_right(self) -> float:
        """Right camera's principal point, x (px)."""
        return self.cx + self.doffs

    @property
    def n_pixels(self) -> int:
        return self.width * self.height

    @property
    def half_fov(self) -> float:
        """Half of the horizontal field of view (rad)."""
        return math.atan2(self.width / 2.0, self.focal_px)

    @property
    def fb(self) -> float:
        """focal · baseline (px·m): the disparity plus doffs at a depth of 1 m."""
        return self.focal_px * self.baseline

    @property
    def is_level(self) -> bool:
        """Optical axes horizontal and along base_link x (no pan, tilt or roll)."""
        return self.tilt == 0.0 and self.roll == 0.0 and self.pan == 0.0

    def mount_quaternion(self) -> Quaternion:
        """The optical frames' rotation in base_link as a quaternion (x, y, z, w)."""
        if self.is_level:
            return OPTICAL_IN_BASE_QUAT
        q = OPTICAL_IN_BASE_QUAT
        for axis, deg in ((0, self.roll), (1, self.tilt), (2, self.pan)):
            half = math.radians(deg) / 2.0
            turn = [0.0, 0.0, 0.0, math.cos(half)]
            turn[axis] = math.sin(half)
            q = _quat_mul((turn[0], turn[1], turn[2], turn[3]), q)
        return q

    def rotation(self) -> np.ndarray:
        """3×3 rotation of the optical frames in base_link (columns: the optical x, y, z
        axes written in base_link); exactly :data:`OPTICAL_TO_BASE` for a level rig."""
        if self.is_level:
            return OPTICAL_TO_BASE.copy()
        return quaternion_matrix(self.mount_quaternion())

    def camera_position(self, side: str) -> Point:
        """Optical centre of 'left' or 'right' in base_link (m)."""
        r = self.rotation()
        half = -self.baseline / 2.0 if side == "left" else self.baseline / 2.0
        mid = (self.mount_x, self.mount_y, self.mount_height)
        return (
            mid[0] + half * float(r[0, 0]),
            mid[1] + half * float(r[1, 0]),
            mid[2] + half * float(r[2, 0]),
        )

    def intrinsics(self, side: str = "left") -> np.ndarray:
        """K, 3×3, of 'left' or 'right'."""
        cx = self.cx if side == "left" else self.cx_right
        return np.array([[self.focal_px, 0.0, cx], [0.0, self.focal_px, self.cy], [0.0, 0.0, 1.0]])

    def projection(self, side: str) -> np.ndarray:
        """P, 3×4, with the left camera as reference: the right P carries -fx·baseline."""
        p = np.zeros((3, 4))
        p[:, :3] = self.intrinsics(side)
        if side == "right":
            p[0, 3] = -self.focal_px * self.baseline
        return p

    def constants(self) -> np.ndarray:
        """The rig as the float64 array the compiled kernels take
        (layout: :mod:`flylog.geometry.kernels`, which this module leaves unimported: it
        imports numba)."""
        m, left, right = self._frame()
        level = 1.0 if self.is_level else 0.0
        return np.array(
            [
                self.focal_px,
                self.cx,
                self.cy,
                self.cx_right,
                *left,
                *right,
                *m[0],
                *m[1],
                *m[2],
                level,
            ],
            dtype=np.float64,
        )

    def _frame(self) -> tuple[list[list[float]], Point, Point]:
        """(base_link → optical rotation rows, left centre, right centre) as Python floats,
        so that arithmetic with float32 points stays float32."""
        m = self.rotation().T.tolist()
        return m, self.camera_position("left"), self.camera_position("right")

    def optical(self, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Points (N, 3) in base_link → (a, b, depth, a_right): their coordinates in the left
        optical frame (x right, y down, depth forward) and their x in the right one."""
        xyz = np.asarray(xyz)
        m, (lx, ly, lz), (rx, ry, rz) = self._frame()
        x, y, z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
        dx, dy, dz = x - lx, y - ly, z - lz
        depth = m[2][0] * dx + m[2][1] * dy + m[2][2] * dz
        a = m[0][0] * dx + m[0][1] * dy + m[0][2] * dz
        b = m[1][0] * dx + m[1][1] * dy + m[1][2] * dz
        ex, ey, ez = x - rx, y - ry, z - rz
        a_right = m[0][0] * ex + m[0][1] * ey + m[0][2] * ez
        return a, b, depth, a_right

    def project(self, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Points (N, 3) in base_link → (uL, uR, v, depth). Depth ≤ 0 means behind the
        cameras; the caller decides what that means (its pixels are then meaningless)."""
        a, b, depth, a_right = self.optical(xyz)
        safe = np.where(depth > 1e-9, depth, 1e-9)
        f = self.focal_px
        u_left = self.cx + f * a / safe
        u_right = self.cx_right + f * a_right / safe
        v = self.cy + f * b / safe
        return u_left, u_right, v, depth

    def backproject(self, u_left: np.ndarray, v: np.ndarray, depth: np.ndarray) -> np.ndarray:
        """Left-image pixels and depths (m along the optical axis) → points (N, 3) in base_link."""
        u_left, v, depth = np.broadcast_arrays(
            np.asarray(u_left, float), np.asarray(v, float), np.asarray(depth, float)
        )
        r = self.rotation().tolist()
        lx, ly, lz = self.camera_position("left")
        f = self.focal_px
        a = (u_left - self.cx) * depth / f
        b = (v - self.cy) * depth / f
        x = lx + (r[0][0] * a + r[0][1] * b + r[0][2] * depth)
        y = ly + (r[1][0] * a + r[1][1] * b + r[1][2] * depth)
        z = lz + (r[2][0] * a + r[2][1] * b + r[2][2] * depth)
        return np.stack([x, y, z], axis=-1)

    def disparity(self, depth: np.ndarray) -> np.ndarray:
        """uL − uR (px) for a depth (m): f·B/Z − doffs."""
        return self.fb / np.asarray(depth) - self.doffs

    def depth_of_disparity(self, disparity: np.ndarray) -> np.ndarray:
        """Depth (m along the optical axis) of a disparity uL − uR (px): f·B/(d + doffs)."""
        return self.fb / (np.asarray(disparity) + self.doffs)

    def resized(self, width: int, height: int) -> StereoRig:
        """The same cameras imaged at ``width``×``height``: focal length, principal point and
        doffs scaled with the width (square pixels)."""
        from dataclasses import replace

        s = width / self.width
        pp = self.principal_point
        return replace(
            self,
            width=width,
            height=height,
            focal_px=self.focal_px * width / self.width,
            principal_point=None
            if pp is None
            else ((pp[0] + 0.5) * s - 0.5, (pp[1] + 0.5) * height / self.height - 0.5),
            doffs=self.doffs * s,
        )
