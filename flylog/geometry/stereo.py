"""The rectified, horizontal pinhole stereo rig: projection and back-projection."""

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


@dataclass(frozen=True)
class StereoRig:
    """Two identical, rectified cameras looking straight ahead from the robot."""

    width: int = param(640, help="image width", unit="px", min=16, max=8192)
    height: int = param(480, help="image height", unit="px", min=16, max=8192)
    focal_px: float = param(500.0, help="focal length", unit="px", min=1.0)
    baseline: float = param(
        0.12, help="distance between the optical centres", unit="m", min=0.001, max=10.0
    )
    mount_height: float = param(0.5, help="height of the optical centres", unit="m", min=0.0)
    mount_x: float = param(0.1, help="forward offset of the cameras", unit="m")
    frame_rate: float = param(
        15.0, help="stereo pairs per second", unit="Hz", min=0.1, max=MAX_FRAME_RATE
    )

    @property
    def cx(self) -> float:
        return (self.width - 1) / 2.0

    @property
    def cy(self) -> float:
        return (self.height - 1) / 2.0

    @property
    def n_pixels(self) -> int:
        return self.width * self.height

    @property
    def half_fov(self) -> float:
        """Half of the horizontal field of view (rad)."""
        return math.atan2(self.width / 2.0, self.focal_px)

    def camera_position(self, side: str) -> tuple[float, float, float]:
        """Optical centre of 'left' or 'right' in base_link (m)."""
        y = self.baseline / 2.0 if side == "left" else -self.baseline / 2.0
        return (self.mount_x, y, self.mount_height)

    def intrinsics(self) -> np.ndarray:
        """K, 3×3."""
        return np.array(
            [[self.focal_px, 0.0, self.cx], [0.0, self.focal_px, self.cy], [0.0, 0.0, 1.0]]
        )

    def projection(self, side: str) -> np.ndarray:
        """P, 3×4, with the left camera as reference: the right P carries -fx·baseline."""
        p = np.zeros((3, 4))
        p[:, :3] = self.intrinsics()
        if side == "right":
            p[0, 3] = -self.focal_px * self.baseline
        return p

    def project(self, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Points (N, 3) in base_link → (uL, uR, v, depth). Depth ≤ 0 means behind the
        cameras; the caller decides what that means (its pixels are then meaningless)."""
        xyz = np.asarray(xyz)
        depth = xyz[:, 0] - self.mount_x
        safe = np.where(depth > 1e-9, depth, 1e-9)
        f = self.focal_px
        half_b = self.baseline / 2.0
        u_left = self.cx - f * (xyz[:, 1] - half_b) / safe
        u_right = self.cx - f * (xyz[:, 1] + half_b) / safe
        v = self.cy - f * (xyz[:, 2] - self.mount_height) / safe
        return u_left, u_right, v, depth

    def backproject(self, u_left: np.ndarray, v: np.ndarray, depth: np.ndarray) -> np.ndarray:
        """Left-image pixels and depths (m along the optical axis) → points (N, 3) in base_link."""
        u_left, v, depth = np.broadcast_arrays(
            np.asarray(u_left, float), np.asarray(v, float), np.asarray(depth, float)
        )
        f = self.focal_px
        x = self.mount_x + depth
        y = self.baseline / 2.0 - (u_left - self.cx) * depth / f
        z = self.mount_height - (v - self.cy) * depth / f
        return np.stack([x, y, z], axis=-1)

    def disparity(self, depth: np.ndarray) -> np.ndarray:
        """uL − uR (px) for a depth (m)."""
        return self.focal_px * self.baseline / np.asarray(depth)
