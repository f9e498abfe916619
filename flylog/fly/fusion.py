"""Sensor fusion for the flies: sonar in the fitness and in immigration (paper §3.2),
odometry as an operator (paper §3.4)."""

from __future__ import annotations

import math

import numba
import numpy as np

from flylog.geometry import Pose2D, StereoRig, inverse, transform_points_2d
from flylog.sensors import SonarReading


def _fired_sonars(reading: SonarReading) -> np.ndarray:
    """(k, 5) x, y, cos yaw, sin yaw, range of each fired sonar."""
    fired = reading.fired
    m = reading.mounts[fired]
    return np.stack(
        [m[:, 0], m[:, 1], np.cos(m[:, 2]), np.sin(m[:, 2]), reading.ranges[fired]], axis=1
    )


def sonar_confirmations_numpy(
    xyz: np.ndarray, sonars: np.ndarray, cos_half_cone: float, tolerance: float
) -> np.ndarray:
    """Reference: (N,) how many of ``sonars`` (from :func:`_fired_sonars`) confirm each fly:
    it lies in the sonar's 2-D cone (angle to the axis ≤ half angle, i.e. axis·d ≥ |d|·cos)
    and its 2-D distance to the transducer is within ``tolerance`` of the measured range."""
    counts = np.zeros(len(xyz), dtype=np.int64)
    for mx, my, c, s, measured in sonars:
        dx, dy = xyz[:, 0] - mx, xyz[:, 1] - my
        distance = np.sqrt(dx * dx + dy * dy)
        in_cone = dx * c + dy * s >= distance * cos_half_cone
        counts += in_cone & (np.abs(distance - measured) <= tolerance)
    return counts


@numba.njit(cache=True, nogil=True)
def sonar_confirmations_numba(xyz, sonars, cos_half_cone, tolerance):  # pragma: no cover
    """Same counts as :func:`sonar_confirmations_numpy`, in one pass over the flies."""
    counts = np.zeros(xyz.shape[0], dtype=np.int64)
    for i in range(xyz.shape[0]):
        for k in range(sonars.shape[0]):
            dx = xyz[i, 0] - sonars[k, 0]
            dy = xyz[i, 1] - sonars[k, 1]
            distance = np.sqrt(dx * dx + dy * dy)
            if (
                abs(distance - sonars[k, 4]) <= tolerance
                and dx * sonars[k, 2] + dy * sonars[k, 3] >= distance * cos_half_cone
            ):
                counts[i] += 1
    return counts


def sonar_confirmations(
    xyz: np.ndarray, reading: SonarReading, tolerance: float, *, use_numba: bool = True
) -> np.ndarray:
    """(N,) how many fired sonars of ``reading`` confirm each fly (see the reference)."""
    sonars = _fired_sonars(reading)
    cos_half = math.cos(reading.half_cone)
    if use_numba:
        return sonar_confirmations_numba(np.ascontiguousarray(xyz), sonars, cos_half, tolerance)
    return sonar_confirmations_numpy(xyz, sonars, cos_half, tolerance)


def sonar_fused(
    vision: np.ndarray,
    xyz: np.ndarray,
    reading: SonarReading,
    *,
    bonus: float,
    tolerance: float,
    use_numba: bool = True,
) -> np.ndarray:
    """The multisensor fitness: vision × (1 + B) per confirming sonar. Multiplicative, so a
    fly the images reject gains little (paper §3.2); non-positive fitnesses are unchanged."""
    if use_numba:
        sonars = _fired_sonars(reading)
        return sonar_fused_numba(
            vision, np.ascontiguousarray(xyz), sonars, math.cos(reading.half_cone), tolerance,
            bonus,
        )  # fmt: skip
    confirmations = sonar_confirmations(xyz, reading, tolerance, use_numba=False)
    return np.where(vision > 0, vision * (1.0 + bonus) ** confirmations, vision)


@numba.njit(cache=True, nogil=True)
def sonar_fused_numba(vision, xyz, sonars, cos_half_cone, tolerance, bonus):  # pragma: no cover
    """Same values as the numpy path of :func:`sonar_fused`, confirmations counted on the fly
    and only for flies with a positive fitness."""
    out = vision.copy()
    factor = 1.0 + bonus
    for i in range(xyz.shape[0]):
        if not vision[i] > 0:
            continue
        count = 0
        for k in range(sonars.shape[0]):
            dx = xyz[i, 0] - sonars[k, 0]
            dy = xyz[i, 1] - sonars[k, 1]
            distance = np.sqrt(dx * dx + dy * dy)
            if (
                abs(distance - sonars[k, 4]) <= tolerance
                and dx * sonars[k, 2] + dy * sonars[k, 3] >= distance * cos_half_cone
            ):
                count += 1
        out[i] = vision[i] * factor ** np.float64(count)
    return out


def sonar_immigrants(
    rng: np.random.Generator,
    reading: SonarReading,
    n: int,
    rig: StereoRig,
    *,
    tolerance: float,
    margin: int,
    tries: int = 8,
) -> np.ndarray:
    """Up to ``n`` flies on fired sonars' range arcs: a fired sonar chosen uniformly, a
    bearing uniform in its cone, a range uniform within ``tolerance`` of the measured one,
    a height uniform between the ground and the cameras; only candidates inside both images
    (``margin`` px in) are kept. At most ``tries``·n candidates are drawn, so this may return
    fewer than ``n`` (none if no sonar fired or no arc is in view)."""
    fired = np.flatnonzero(reading.fired)
    if n <= 0 or len(fired) == 0:
        return np.empty((0, 3))
    m = tries * n
    k = fired[rng.integers(0, len(fired), m)]
    mounts = reading.mounts[k]
    bearing = mounts[:, 2] + rng.uniform(-reading.half_cone, reading.half_cone, m)
    rng_range = reading.ranges[k] + rng.uniform(-tolerance, tolerance, m)
    height = rng.uniform(0.0, rig.mount_height, m)
    xyz = np.stack(
        [
            mounts[:, 0] + rng_range * np.cos(bearing),
            mounts[:, 1] + rng_range * np.sin(bearing),
            height,
        ],
        axis=1,
    )
    u_left, u_right, v, depth = rig.project(xyz)
    inside = (depth > 0) & (v >= margin) & (v <= rig.height - 1 - margin)
    for u in (u_left, u_right):
        inside &= (u >= margin) & (u <= rig.width - 1 - margin)
    return xyz[inside][:n]


def moved_by_odometry(xyz: np.ndarray, increment: Pose2D) -> np.ndarray:
    """Proprioception as an operator: the flies, fixed in the world, seen from the robot
    after it moved by ``increment`` (the odometry increment ``relative(prev, new)``)."""
    return transform_points_2d(inverse(increment), xyz)
