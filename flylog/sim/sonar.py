"""Simulated sonar ring (paper §3.1): nearest obstacle surface inside each 2-D cone.

Exact 2-D geometry rather than the paper's z-buffer, so the sonar also works outside the
cameras' view: the smallest distance from a transducer to the part of a convex footprint
that lies inside its cone (a convex sector, for cones under 180°) is either the footprint's
closest point, when that point lies inside the cone, or the first hit of one of the cone's
two edge rays. Obstacle heights are ignored (every obstacle reaches the transducers'
height); the ground is never an echo; ``sonar_absorbing`` obstacles are never seen.
A nearest surface closer than ``min_range`` (the transducer's blind zone) or farther than
``max_range`` gives no echo (NaN).
"""

from __future__ import annotations

import math

import numpy as np

from flylog.geometry import Pose2D, transform_points_2d
from flylog.scene.footprints import Footprints, closest_points, ray_hits_numpy
from flylog.scene.load import Scene
from flylog.sensors import SonarConfig


def nearest_in_cone(fp: Footprints, x: float, y: float, yaw: float, half_cone: float) -> float:
    """Exact 2-D distance from (x, y) to the nearest footprint point within ±half_cone of yaw
    (inf if none). Only the footprints in ``fp`` are considered."""
    if len(fp) == 0:
        return math.inf
    q = closest_points(fp, x, y)
    dist = np.hypot(q[:, 0] - x, q[:, 1] - y)
    bearing = np.arctan2(q[:, 1] - y, q[:, 0] - x) - yaw
    off_axis = np.abs(np.arctan2(np.sin(bearing), np.cos(bearing)))
    # Inside a footprint (distance 0) counts as a touching echo.
    inside = (off_axis <= half_cone) | (dist == 0.0)
    best = float(np.min(np.where(inside, dist, np.inf)))
    for edge in (yaw - half_cone, yaw + half_cone):
        t_in, t_out, _, _ = ray_hits_numpy(fp, x, y, math.cos(edge), math.sin(edge))
        hit = t_out >= t_in
        if np.any(hit):
            best = min(best, float(np.min(np.maximum(t_in[hit], 0.0))))
    return best


def _visible(fp: Footprints) -> Footprints:
    keep = fp.sonar_visible
    return Footprints(**{k: getattr(fp, k)[keep] for k in fp.__dataclass_fields__})


def true_sonar_ranges(scene: Scene, config: SonarConfig, pose: Pose2D) -> np.ndarray:
    """(n,) noise-free ranges from the true pose: NaN where no echo."""
    fp = _visible(scene.footprints)
    mounts = config.mounts()
    world = transform_points_2d(pose, mounts[:, :2])
    half = math.radians(config.cone_deg) / 2.0
    out = np.full(len(mounts), np.nan)
    for i, (x, y) in enumerate(world):
        d = nearest_in_cone(fp, float(x), float(y), pose.theta + mounts[i, 2], half)
        if config.min_range <= d <= config.max_range:
            out[i] = d
    return out


def sonar_ranges(
    scene: Scene, config: SonarConfig, pose: Pose2D, rng: np.random.Generator
) -> np.ndarray:
    """(n,) measured ranges (m) from the true pose, NaN = no echo, with Gaussian noise.

    Draws one normal per transducer every call (fired or not), so the random stream does not
    depend on the geometry. Noisy ranges are clipped at 0.
    """
    ranges = true_sonar_ranges(scene, config, pose)
    noise = rng.standard_normal(ranges.shape[0]) * config.noise_std
    return np.maximum(ranges + noise, 0.0)
