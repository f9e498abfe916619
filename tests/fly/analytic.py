"""A tiny exact ray-cast renderer for the fly tests: axis-aligned textured boxes.

The texture is a function of the 3-D surface point (value noise on a lattice), so both
cameras see the same colour at the same point and the left depth map is exact ground truth.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flylog.geometry import Pose2D, StereoRig
from flylog.sensors import SonarConfig, SonarReading, StereoPair

Box = tuple[tuple[float, float, float], tuple[float, float, float]]  # (lo, hi) in world


@dataclass(frozen=True)
class Scene:
    boxes: tuple[Box, ...]
    seed: int = 0


def room(*extra: Box, far: float = 5.0, half_width: float = 3.0) -> Scene:
    """A floor, a back wall at x = ``far`` and two side walls, plus ``extra`` boxes."""
    floor = ((-10.0, -10.0, -1.0), (10.0, 10.0, 0.0))
    back = ((far, -10.0, -1.0), (far + 0.2, 10.0, 5.0))
    left = ((-10.0, half_width, -1.0), (far, half_width + 0.2, 5.0))
    right = ((-10.0, -half_width - 0.2, -1.0), (far, -half_width, 5.0))
    return Scene((floor, back, left, right, *extra))


def _texture(points: np.ndarray, seed: int) -> np.ndarray:
    """(P, 3) → (P, 3) uint8: two octaves of trilinear value noise per colour channel."""
    table = np.random.default_rng(seed).uniform(0.0, 1.0, (3, 4096))
    out = np.zeros((len(points), 3))
    for cell, weight in ((0.04, 0.6), (0.12, 0.4)):
        q = points / cell
        base = np.floor(q)
        frac = q - base
        base = base.astype(np.int64)
        for corner in range(8):
            off = np.array([(corner >> 0) & 1, (corner >> 1) & 1, (corner >> 2) & 1])
            idx = base + off
            h = (idx[:, 0] * 73856093) ^ (idx[:, 1] * 19349663) ^ (idx[:, 2] * 83492791)
            w = np.prod(np.where(off == 1, frac, 1.0 - frac), axis=1)
            out += weight * w[:, None] * table[:, h & 4095].T
    return np.clip(out * 255.0, 0, 255).astype(np.uint8)


def _cast(origin: np.ndarray, dirs: np.ndarray, scene: Scene) -> np.ndarray:
    """Ray parameter t of the first hit of origin + t·dirs (inf where nothing is hit)."""
    best = np.full(len(dirs), np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / dirs
        for lo, hi in scene.boxes:
            t1 = (np.asarray(lo) - origin) * inv
            t2 = (np.asarray(hi) - origin) * inv
            near = np.nanmax(np.minimum(t1, t2), axis=1)
            far = np.nanmin(np.maximum(t1, t2), axis=1)
            hit = (far >= near) & (near > 1e-9)
            best = np.where(hit & (near < best), near, best)
    return best


def _world_rotation(pose: Pose2D) -> np.ndarray:
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def render(
    scene: Scene, rig: StereoRig, pose: Pose2D | None = None, *, stamp_ns: int = 0
) -> tuple[StereoPair, np.ndarray]:
    """The stereo pair seen from robot ``pose`` (default: the origin) and the left depth map
    (m along the optical axis, inf = nothing)."""
    pose = Pose2D() if pose is None else pose
    rot = _world_rotation(pose) @ rig.rotation()
    v, u = np.mgrid[0 : rig.height, 0 : rig.width].astype(np.float64)
    images, depth = [], None
    for side, cx in (("left", rig.cx), ("right", rig.cx_right)):
        optical = np.stack(
            [(u - cx) / rig.focal_px, (v - rig.cy) / rig.focal_px, np.ones_like(u)], axis=-1
        ).reshape(-1, 3)
        dirs = optical @ rot.T  # unit optical z, so t is the depth along the optical axis
        cam = np.array(rig.camera_position(side))
        origin = np.array([pose.x, pose.y, 0.0]) + _world_rotation(pose) @ cam
        t = _cast(origin, dirs, scene)
        hit = np.isfinite(t)
        colour = np.zeros((len(t), 3), dtype=np.uint8)
        colour[hit] = _texture(origin + t[hit, None] * dirs[hit], scene.seed)
        images.append(colour.reshape(rig.height, rig.width, 3))
        if side == "left":
            depth = t.reshape(rig.height, rig.width)
    return StereoPair(stamp_ns, images[0], images[1]), depth


def sonar_reading(
    scene: Scene, pose: Pose2D, mounts: np.ndarray, *, cone: float, max_range: float, height: float
) -> SonarReading:
    """Exact sonar ranges: the nearest hit of horizontal rays fanned across each cone."""
    ranges = np.full(len(mounts), np.nan)
    rot = _world_rotation(pose)
    for k, (mx, my, yaw) in enumerate(mounts):
        angles = yaw + np.linspace(-cone / 2, cone / 2, 61)
        dirs = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1) @ rot.T
        origin = np.array([pose.x, pose.y, 0.0]) + rot @ np.array([mx, my, height])
        t = _cast(origin, dirs, scene).min()
        if t <= max_range:
            ranges[k] = t
    return SonarReading(0, ranges, np.asarray(mounts, float), cone, max_range)


def default_sonar_reading(scene: Scene, pose: Pose2D | None = None) -> SonarReading:
    """:func:`sonar_reading` of the default sonar ring (SonarConfig()) at ``pose``."""
    sonars = SonarConfig()
    return sonar_reading(
        scene,
        pose or Pose2D(),
        sonars.mounts(),
        cone=math.radians(sonars.cone_deg),
        max_range=sonars.max_range,
        height=sonars.mount_height,
    )


def true_depth_at(depth: np.ndarray, rig: StereoRig, xyz: np.ndarray) -> np.ndarray:
    """The true depth at each fly's rounded left projection (NaN outside the image)."""
    u, _, v, _ = rig.project(xyz)
    ui, vi = np.floor(u + 0.5), np.floor(v + 0.5)
    inside = (ui >= 0) & (ui < rig.width) & (vi >= 0) & (vi < rig.height)
    out = np.full(len(xyz), np.nan)
    out[inside] = depth[vi[inside].astype(int), ui[inside].astype(int)]
    return out


def on_surface_share(pop_xyz: np.ndarray, fitness: np.ndarray, depth: np.ndarray, rig) -> float:
    """Share of the flies above the median fitness within 5 % of the true depth."""
    top = pop_xyz[fitness > np.median(fitness)]
    truth = true_depth_at(depth, rig, top)
    fly_depth = rig.project(top)[3]
    return float(np.mean(np.abs(fly_depth - truth) <= 0.05 * fly_depth))
