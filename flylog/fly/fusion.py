"""Sensor fusion for the flies: sonar in the fitness and in immigration (paper §3.2),
odometry as an operator (paper §3.4)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from flylog.fly.fitness import fitness_serial
from flylog.geometry import StereoRig
from flylog.geometry.kernels import RIG_SIZE, project
from flylog.sensors import SonarReading


def fired_sonars(reading: SonarReading) -> np.ndarray:
    """(k, 5) x, y, cos yaw, sin yaw, range of each fired sonar (what the kernels take)."""
    fired = reading.fired
    m = reading.mounts[fired]
    return np.stack(
        [m[:, 0], m[:, 1], np.cos(m[:, 2]), np.sin(m[:, 2]), reading.ranges[fired]], axis=1
    )


def sonar_confirmations_numpy(
    xyz: np.ndarray, sonars: np.ndarray, cos_half_cone: float, tolerance: float
) -> np.ndarray:
    """Reference: (N,) how many of ``sonars`` (from :func:`fired_sonars`) confirm each fly:
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
    sonars = fired_sonars(reading)
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
        sonars = fired_sonars(reading)
        return sonar_fused_numba(
            vision,
            np.ascontiguousarray(xyz),
            sonars,
            math.cos(reading.half_cone),
            tolerance,
            bonus,
        )
    confirmations = sonar_confirmations(xyz, reading, tolerance, use_numba=False)
    return np.where(vision > 0, vision * (1.0 + bonus) ** confirmations, vision)


@numba.njit(cache=True, nogil=True)
def sonar_fused_numba(vision, xyz, sonars, cos_half_cone, tolerance, bonus):  # pragma: no cover
    """Same values as the numpy path of :func:`sonar_fused`."""
    out = vision.copy()
    sonar_fuse_into(
        vision, xyz, sonars, cos_half_cone, tolerance, bonus, np.arange(vision.shape[0]), out
    )
    return out


@numba.njit(cache=True, nogil=True)
def sonar_fuse_into(
    vision, xyz, sonars, cos_half_cone, tolerance, bonus, index, out
):  # pragma: no cover
    """``out[i]`` = the numpy path of :func:`sonar_fused` for the flies ``i`` of ``index``:
    confirmations counted for every fly, kept only for flies with a positive fitness."""
    k = sonars.shape[0]
    m = index.shape[0]
    # (1 + B)^c for every possible count c, by the same pow as numpy's
    powers = np.empty(k + 1)
    factor = 1.0 + bonus
    for c in range(k + 1):
        powers[c] = factor ** np.float64(c)
    # One sonar at a time over the gathered flies, without a branch: the loop is vectorised
    # (~3× the fly-by-fly loop, whose tests mispredict when many flies sit on the arcs).
    x, y = np.empty(m), np.empty(m)
    counts = np.zeros(m, dtype=np.int64)
    for t in range(m):
        x[t], y[t] = xyz[index[t], 0], xyz[index[t], 1]
    for s in range(k):
        mx, my, c, sn, measured = (
            sonars[s, 0],
            sonars[s, 1],
            sonars[s, 2],
            sonars[s, 3],
            sonars[s, 4],
        )
        for t in range(m):
            dx = x[t] - mx
            dy = y[t] - my
            distance = np.sqrt(dx * dx + dy * dy)
            counts[t] += (abs(distance - measured) <= tolerance) & (
                dx * c + dy * sn >= distance * cos_half_cone
            )
    for t in range(m):
        i = index[t]
        out[i] = vision[i] * powers[counts[t]] if vision[i] > 0 else vision[i]


@dataclass(frozen=True, slots=True)
class ArcDraws:
    """The random candidates of :func:`sonar_immigrants`, drawn in a fixed order so that both
    implementations keep the same ones: candidate j on the arc of fired sonar ``sonar[j]``."""

    sonar: np.ndarray  # (m,) int64: row of fired_arcs(reading)
    cos_bearing: np.ndarray  # (m,) bearing in base_link, uniform in the sonar's cone
    sin_bearing: np.ndarray
    distance: np.ndarray  # (m,) m from the transducer, within tolerance of the range
    height: np.ndarray  # (m,) z, uniform between the ground and the cameras


def fired_arcs(reading: SonarReading) -> np.ndarray:
    """(k, 4) x, y, yaw, range of each fired sonar (what :func:`sonar_immigrants_into` takes)."""
    fired = reading.fired
    m = reading.mounts[fired]
    return np.ascontiguousarray(
        np.stack([m[:, 0], m[:, 1], m[:, 2], reading.ranges[fired]], axis=1), dtype=np.float64
    )


def arc_constants(rig: StereoRig, margin: int) -> np.ndarray:
    """What :func:`sonar_immigrants_into` needs of the rig, as one float64 array."""
    extra = [margin, rig.width - 1 - margin, rig.height - 1 - margin, rig.mount_height]
    return np.concatenate([rig.constants(), np.array(extra, dtype=np.float64)])


# The random stream of sonar immigrants: candidates in chunks of n (the flies wanted), at most
# ``tries`` chunks, stopping after the chunk that completes the n; 4 U[0, 1) per candidate, in
# candidate order: the fired sonar ⌊U·k⌋, then bearing, distance and height, each drawn as
# rng.uniform draws them (low + (high − low)·U). Both implementations draw exactly these.


def arc_draws(
    rng: np.random.Generator, reading: SonarReading, m: int, rig: StereoRig, tolerance: float
) -> ArcDraws:
    """``m`` candidates on fired sonars' range arcs (a fired sonar chosen uniformly, a bearing
    uniform in its cone, a distance uniform within ``tolerance`` of the measured range)."""
    arcs = fired_arcs(reading)
    n_fired = len(arcs)
    w = rng.random((m, 4))
    k = np.minimum((w[:, 0] * n_fired).astype(np.int64), n_fired - 1)
    half = reading.half_cone
    bearing = arcs[k, 2] + (-half + (half - -half) * w[:, 1])
    distance = arcs[k, 3] + (-tolerance + (tolerance - -tolerance) * w[:, 2])
    height = 0.0 + (rig.mount_height - 0.0) * w[:, 3]
    # the C library's cos and sin, as the compiled kernel calls them: numpy's own vectorised
    # versions may differ in the last bit on some CPUs (AVX-512)
    angles = bearing.tolist()
    cos = np.array([math.cos(a) for a in angles], dtype=np.float64)
    sin = np.array([math.sin(a) for a in angles], dtype=np.float64)
    return ArcDraws(k, cos, sin, distance, height)


def arc_immigrants_numpy(
    draws: ArcDraws, reading: SonarReading, n: int, rig: StereoRig, margin: int
) -> np.ndarray:
    """Reference: the first ``n`` candidates of ``draws`` inside both images."""
    arcs = fired_arcs(reading)[draws.sonar]
    xyz = np.stack(
        [
            arcs[:, 0] + draws.distance * draws.cos_bearing,
            arcs[:, 1] + draws.distance * draws.sin_bearing,
            draws.height,
        ],
        axis=1,
    )
    u_left, u_right, v, depth = rig.project(xyz)
    inside = (depth > 0) & (v >= margin) & (v <= rig.height - 1 - margin)
    for u in (u_left, u_right):
        inside &= (u >= margin) & (u <= rig.width - 1 - margin)
    return xyz[inside][:n]


@numba.njit(cache=True, nogil=True)
def sonar_immigrants_into(rng, arcs, half_cone, tolerance, k, tries, out):  # pragma: no cover
    """Draws candidates in the stream order above (n = len(out)) and fills ``out`` with the
    first ones inside both images, as :func:`arc_immigrants_numpy` keeps them
    (``StereoRig.project``'s arithmetic, in its order); returns how many. ``arcs`` from
    :func:`fired_arcs` (at least one row), ``k`` from :func:`arc_constants`."""
    lo, hi_u, hi_v, mount_h = k[RIG_SIZE], k[RIG_SIZE + 1], k[RIG_SIZE + 2], k[RIG_SIZE + 3]
    n = out.shape[0]
    n_fired = arcs.shape[0]
    found = 0
    for _ in range(tries):
        if found == n:
            break
        for _ in range(n):  # a whole chunk is drawn, even past the n-th fly found
            w0, w1, w2, w3 = rng.random(), rng.random(), rng.random(), rng.random()
            if found == n:
                continue
            s = min(np.int64(w0 * n_fired), n_fired - 1)
            bearing = arcs[s, 2] + (-half_cone + (half_cone - -half_cone) * w1)
            distance = arcs[s, 3] + (-tolerance + (tolerance - -tolerance) * w2)
            x = arcs[s, 0] + distance * np.cos(bearing)
            y = arcs[s, 1] + distance * np.sin(bearing)
            z = 0.0 + (mount_h - 0.0) * w3
            u_left, u_right, v, depth = project(k, x, y, z)
            if not depth > 0:
                continue
            if lo <= v <= hi_v and lo <= u_left <= hi_u and lo <= u_right <= hi_u:
                out[found, 0], out[found, 1], out[found, 2] = x, y, z
                found += 1
    return found


def sonar_immigrants(
    rng: np.random.Generator,
    reading: SonarReading,
    n: int,
    rig: StereoRig,
    *,
    tolerance: float,
    margin: int,
    tries: int = 8,
    use_numba: bool = False,
) -> np.ndarray:
    """Up to ``n`` flies on fired sonars' range arcs: a fired sonar chosen uniformly, a
    bearing uniform in its cone, a range uniform within ``tolerance`` of the measured one,
    a height uniform between the ground and the cameras; only candidates inside both images
    (``margin`` px in) are kept. Candidates are drawn n at a time, at most ``tries`` times, so
    this may return fewer than ``n`` (none if no sonar fired or no arc is in view)."""
    if n <= 0 or not reading.fired.any():
        return np.empty((0, 3))
    if use_numba:
        out = np.empty((n, 3))
        count = sonar_immigrants_into(
            rng,
            fired_arcs(reading),
            float(reading.half_cone),
            float(tolerance),
            arc_constants(rig, margin),
            tries,
            out,
        )
        return out[:count]
    batches: list[np.ndarray] = []
    for _ in range(tries):
        batches.append(
            arc_immigrants_numpy(
                arc_draws(rng, reading, n, rig, tolerance), reading, n, rig, margin
            )
        )
        if sum(map(len, batches)) >= n:
            break
    return np.concatenate(batches)[:n]


@numba.njit(cache=True, nogil=True)
def score_into(im, measure, fu, flies, index, fuse_index):  # pragma: no cover - compiled
    """A generation's scoring in one call: the vision fitness of the flies ``index`` of
    ``flies`` (:class:`~flylog.fly.bundles.Flies`) on the pair ``im``
    (:class:`~flylog.fly.bundles.Images`) by ``measure``
    (:func:`~flylog.fly.fitness.fitness_serial`, their ``stale`` cleared and ``stamp_ns`` set
    to the pair's stamp), then the fused fitness of the flies ``fuse_index``: the vision
    fitness, times the sonar bonus of ``fu`` (:class:`~flylog.fly.bundles.Fusion`,
    :func:`sonar_fuse_into`) if it has a fired sonar."""
    if index.shape[0] > 0:
        fitness_serial(im, measure, flies.xyz, index, flies.vision)
        for t in range(index.shape[0]):
            flies.stale[index[t]] = False
            flies.stamp_ns[index[t]] = im.stamp
    if fu.sonars.shape[0] > 0:
        sonar_fuse_into(
            flies.vision,
            flies.xyz,
            fu.sonars,
            fu.cos_half_cone,
            fu.tolerance,
            fu.bonus,
            fuse_index,
            flies.fitness,
        )
    else:
        for t in range(fuse_index.shape[0]):
            flies.fitness[fuse_index[t]] = flies.vision[fuse_index[t]]
