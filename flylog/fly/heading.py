"""Visual heading: the flies measure how far the odometry's turn since a keyframe is off.

Odometry integrates wheel turns; its heading error grows with every radian turned (slip) and
every second driven, and a heading error tilts the whole path that follows. The flies fitted
to a stereo pair (the keyframe) are points of the world: moved by the odometry since, they
should look, in a later pair, like the patches they covered in the keyframe. Rotating them
by a small extra yaw ε and comparing patches over a scan of ε finds the rotation the images
agree with; a yaw shifts the image sideways by about focal·ε pixels whatever the depth, so
flies at a wrong depth hardly bias it while the robot turns in place.

The comparison is the fitness formula across time instead of across cameras: for each fly,
G of the keyframe's left patch (the horizontal Sobel: a yaw moves the image horizontally)
over the engine's dissimilarity (``engine.similarity``, :mod:`flylog.fly.measures`, its
sums taken in float; the keyframe's patch in the place of the left one) between its
keyframe patch and its patch in the later pair, left and right cameras summed; the scan's
peak (a parabola through its neighbours) is the measured ε.

A measurement is made once the robot has driven ``keyframe_distance`` or turned
``keyframe_turn_deg`` since the keyframe (or ``keyframe_frames`` pairs came); that pair
becomes the next keyframe. Measured one frame apart, each measurement's error (0.09-0.21 px
on closed-loop runs at 320×240) adds up frame after frame to as much as the odometry's own
error driving straight; against a keyframe 11-38° of turn on the spot back, it is 0.04-0.11
px, against 0.6-1.3 px of odometric error.

That measurement is fused with the odometry's own turn since the keyframe (a one-dimensional
Kalman update): weights from the odometry's turn-rate noise over the span and the
measurement's spread. A robot standing still has no odometric error to correct, and gets
none.

Two implementations of the scan with identical results: :func:`yaw_scores_numba` and
:func:`yaw_scores_numpy` (a short gather reference). The settings:
:class:`~flylog.fly.heading_config.HeadingConfig`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numba
import numpy as np

from flylog.fly.config import Similarity
from flylog.fly.fitness import as_planes, rig_constants
from flylog.fly.heading_config import HeadingConfig
from flylog.fly.measure import Measure, dissimilarity, patch_sums
from flylog.fly.measures import measure_of
from flylog.fly.population import Population
from flylog.geometry import Pose2D, StereoRig, relative
from flylog.geometry.kernels import CX, CX_RIGHT, CY, FOCAL, optical
from flylog.geometry.proprioception import moved_by_odometry
from flylog.sensors import StereoPair

KEYFRAME_FLIES = 3  # flies kept with a keyframe, per one compared (some leave the view)


@dataclass(frozen=True, slots=True)
class YawMeasurement:
    """One measured turn error: ``yaw`` (rad, to add to the odometry's turn) and
    how many flies measured it; ``yaw`` is None when the scan found no inner peak."""

    yaw: float | None
    flies: int


def moved_and_turned(xyz: np.ndarray, increment: Pose2D, extra_yaw: float) -> np.ndarray:
    """Points fixed in the world, seen after the robot moved by ``increment`` and then turned
    by ``extra_yaw`` more (rad) about its own origin."""
    return moved_by_odometry(moved_by_odometry(xyz, increment), Pose2D(0.0, 0.0, extra_yaw))


def _inside(rig: StereoRig, xyz: np.ndarray, margin: int) -> np.ndarray:
    """Whether each point lies in front of the cameras with the bilinear samples of its
    margin-wide neighbourhood inside both images."""
    u_left, u_right, v, depth = rig.project(xyz)
    ok = (depth > 0) & (v >= margin) & (v <= rig.height - 2 - margin)
    for u in (u_left, u_right):
        ok &= (u >= margin) & (u <= rig.width - 2 - margin)
    return ok


def comparable_flies(
    xyz: np.ndarray, increment: Pose2D, rig: StereoRig, offsets: np.ndarray, window: int
) -> np.ndarray:
    """Mask of the points (base_link at pair k) whose patches lie inside both images at pair
    k and at pair k+1 for every scanned yaw: the scan sums the same flies at every yaw (a
    point's column moves monotonically with the yaw, so the two ends of the scan decide)."""
    h = window // 2
    ok = _inside(rig, xyz, h)
    for extra in (offsets[0], offsets[-1]):
        ok &= _inside(rig, moved_and_turned(xyz, increment, float(extra)), h)
    return ok


def depth_insensitive(
    xyz: np.ndarray, increment: Pose2D, rig: StereoRig, disparity_error: float, parallax: float
) -> np.ndarray:
    """Mask of the points (base_link at pair k) whose column after ``increment`` moves by at
    most ``parallax`` px when their disparity at pair k is off by ±``disparity_error`` px
    (each moved along its ray): where the motion is mostly parallax (driving, a near fly off
    the image centre), a depth error reads as yaw."""
    u_left, u_right, v, depth = rig.project(xyz)
    disparity = u_left - u_right + rig.doffs  # f·B/Z
    after = rig.project(moved_by_odometry(xyz, increment))[0]
    ok = depth > 0
    for error in (-disparity_error, disparity_error):
        shifted = np.maximum(disparity + error, 1e-6)
        moved = rig.backproject(u_left, v, rig.fb / shifted)
        ok &= np.abs(rig.project(moved_by_odometry(moved, increment))[0] - after) <= parallax
    return ok


def bilinear_patches(image: np.ndarray, u: np.ndarray, v: np.ndarray, h: int) -> np.ndarray:
    """(M, 2h+1, 2h+1, C) float64: the image sampled bilinearly on the pixel grid around
    each (u, v), a sub-pixel position (column, row)."""
    planes = as_planes(image).astype(np.float64)
    off = np.arange(-h, h + 1)
    uu = u[:, None, None] + off[None, None, :]
    vv = v[:, None, None] + off[None, :, None]
    x0, y0 = np.floor(uu).astype(np.intp), np.floor(vv).astype(np.intp)
    fx, fy = (uu - x0)[..., None], (vv - y0)[..., None]
    top = planes[y0, x0] * (1.0 - fx) + planes[y0, x0 + 1] * fx
    bottom = planes[y0 + 1, x0] * (1.0 - fx) + planes[y0 + 1, x0 + 1] * fx
    return top * (1.0 - fy) + bottom * fy


def yaw_scores_numpy(
    before: tuple[np.ndarray, np.ndarray],
    after: tuple[np.ndarray, np.ndarray],
    xyz: np.ndarray,
    increment: Pose2D,
    rig: StereoRig,
    offsets: np.ndarray,
    window: int,
    guard: float,
    similarity: Similarity = Similarity.ZSSD,
) -> np.ndarray:
    """Reference: for each extra yaw of ``offsets``, Σ over the points ``xyz`` (base_link at
    pair k, all :func:`comparable_flies`) of G_k·(1/(D_left + g) + 1/(D_right + g)), D the
    ``similarity``'s dissimilarity (:func:`patch_dissimilarity_numpy`) between each point's
    patch in pair k (``before``: left, right images) and in pair k+1 (``after``), both
    sampled bilinearly at the point's exact projections (a rounded projection makes each
    fly's score a step function of the yaw, whose sum is biased wherever the flies' sub-pixel
    phases are not spread evenly); G_k = sqrt(|gx|) of the pair-k left patch (central
    differences)."""
    h = window // 2
    n = window * window
    channels = as_planes(before[0]).shape[2]
    g = guard * n * channels
    measure = measure_of(similarity)
    u_left, u_right, v, _ = rig.project(xyz)
    left_k = bilinear_patches(before[0], u_left, v, h)
    right_k = bilinear_patches(before[1], u_right, v, h)
    gx = left_k[:, h, h + 1] - left_k[:, h, h - 1]
    weight = np.sqrt(np.sqrt((gx * gx).sum(axis=1)))
    scores = np.empty(len(offsets))
    for j, extra in enumerate(offsets):
        ul, ur, vv, _ = rig.project(moved_and_turned(xyz, increment, float(extra)))
        total = np.zeros(len(xyz))
        for patch_k, image, u in ((left_k, after[0], ul), (right_k, after[1], ur)):
            sample = bilinear_patches(image, u, vv, h)
            a, b = patch_k.reshape(len(xyz), -1), sample.reshape(len(xyz), -1)
            unlike = patch_dissimilarity_numpy(a, b, channels, measure)
            total += 1.0 / (unlike + g)
        scores[j] = float((weight * total).sum())
    return scores


def patch_dissimilarity_numpy(
    a: np.ndarray, b: np.ndarray, channels: int, measure: Measure
) -> np.ndarray:
    """Reference: the ``measure``'s dissimilarity of (M, n·C) float patch pairs (layout of
    :func:`_sample`), from its sums in float (:attr:`~flylog.fly.measure.WindowSums.numpy`,
    the additions in the compiled kernel's order)."""
    n = a.shape[1] // channels
    return measure.finish_numpy(measure.sums.numpy(a, b, channels), n, channels)


@numba.njit(cache=True, nogil=True)
def _sample(rows, channels, u, v, h, out):  # pragma: no cover - compiled
    """:func:`bilinear_patches` of one position into ``out`` ((2h+1)²·C, row-major, channel
    last); ``rows``: an image as (H, W·C) uint8."""
    x0 = math.floor(u)
    y0 = math.floor(v)
    fx = u - x0
    fy = v - y0
    t = 0
    for r in range(-h, h + 1):
        top = rows[y0 + r]
        bottom = rows[y0 + r + 1]
        for c in range(-h, h + 1):
            a = (x0 + c) * channels
            for ch in range(channels):
                upper = float(top[a + ch]) * (1.0 - fx) + float(top[a + channels + ch]) * fx
                lower = float(bottom[a + ch]) * (1.0 - fx) + float(bottom[a + channels + ch]) * fx
                out[t] = upper * (1.0 - fy) + lower * fy
                t += 1


@numba.njit(cache=True, nogil=True)
def patch_dissimilarity(a, b, channels, n, measure):  # pragma: no cover - compiled
    """The ``measure``'s dissimilarity between two sampled patches (layout of
    :func:`_sample`), from its sums in float (:func:`patch_dissimilarity_numpy`)."""
    return dissimilarity(measure, patch_sums(measure, a, b, channels), n, channels)


@numba.njit(cache=True, nogil=True)
def _yaw_scores_kernel(
    lk, rk, l1, r1, channels, xyz, moved, offsets, k, window, guard, measure, out
):  # pragma: no cover - compiled
    """:func:`yaw_scores_numpy`'s sums; ``moved``: the points after the odometry increment
    (before the extra yaw), all comparable; images as (H, W·C) uint8 rows."""
    focal, cx, cy, cx_right = k[FOCAL], k[CX], k[CY], k[CX_RIGHT]
    h = window // 2
    n = window * window
    size = n * channels
    g = guard * n * channels
    m = xyz.shape[0]
    left_k = np.empty((m, size))
    right_k = np.empty((m, size))
    weight = np.empty(m)
    centre = (h * window + h) * channels
    for i in range(m):
        a, b, depth, ar = optical(k, xyz[i, 0], xyz[i, 1], xyz[i, 2])
        v = cy + focal * b / depth
        _sample(lk, channels, cx + focal * a / depth, v, h, left_k[i])
        _sample(rk, channels, cx_right + focal * ar / depth, v, h, right_k[i])
        grad2 = 0.0
        for ch in range(channels):
            gx = left_k[i, centre + channels + ch] - left_k[i, centre - channels + ch]
            grad2 += gx * gx
        weight[i] = math.sqrt(math.sqrt(grad2))
    sample = np.empty(size)
    for j in range(offsets.shape[0]):
        # the robot turned by offsets[j] more sees a world point p at R(-offsets[j]) p
        c, s = math.cos(offsets[j]), math.sin(offsets[j])
        total = 0.0
        for i in range(m):
            x = c * moved[i, 0] + s * moved[i, 1]
            y = -s * moved[i, 0] + c * moved[i, 1]
            a, b, depth, ar = optical(k, x, y, moved[i, 2])
            v = cy + focal * b / depth
            _sample(l1, channels, cx + focal * a / depth, v, h, sample)
            zl = patch_dissimilarity(left_k[i], sample, channels, n, measure)
            _sample(r1, channels, cx_right + focal * ar / depth, v, h, sample)
            zr = patch_dissimilarity(right_k[i], sample, channels, n, measure)
            total += weight[i] * (1.0 / (zl + g) + 1.0 / (zr + g))
        out[j] = total


def yaw_scores_numba(
    before: tuple[np.ndarray, np.ndarray],
    after: tuple[np.ndarray, np.ndarray],
    xyz: np.ndarray,
    increment: Pose2D,
    rig: StereoRig,
    offsets: np.ndarray,
    window: int,
    guard: float,
    similarity: Similarity = Similarity.ZSSD,
) -> np.ndarray:
    """:func:`yaw_scores_numpy`, compiled (the same sums; the patches' sampling and the sum
    over flies up to the order of the additions)."""
    rows = []
    for image in (*before, *after):
        planes = as_planes(image)
        height, width, channels = planes.shape
        rows.append(planes.reshape(height, width * channels))
    xyz = np.ascontiguousarray(xyz, dtype=np.float64)
    moved = np.ascontiguousarray(moved_by_odometry(xyz, increment), dtype=np.float64)
    out = np.empty(len(offsets))
    lk, rk, l1, r1 = rows
    _yaw_scores_kernel(
        lk,
        rk,
        l1,
        r1,
        channels,
        xyz,
        moved,
        np.asarray(offsets, np.float64),
        rig_constants(rig),
        window,
        float(guard),
        measure_of(similarity),
        out,
    )
    return out


def scan_peak(offsets: np.ndarray, scores: np.ndarray) -> float | None:
    """The yaw of the scan's highest score, refined by a parabola through its neighbours;
    None when the highest lies at either end (the true peak may lie beyond)."""
    i = int(np.argmax(scores))
    if i == 0 or i == len(scores) - 1:
        return None
    y0, y1, y2 = scores[i - 1], scores[i], scores[i + 1]
    curvature = y0 - 2.0 * y1 + y2
    shift = 0.5 * (y0 - y2) / curvature if curvature < 0.0 else 0.0
    return float(offsets[i] + shift * (offsets[i + 1] - offsets[i]))


def measure_yaw(
    before: tuple[np.ndarray, np.ndarray],
    after: tuple[np.ndarray, np.ndarray],
    xyz: np.ndarray,
    increment: Pose2D,
    rig: StereoRig,
    config: HeadingConfig,
    *,
    similarity: Similarity = Similarity.ZSSD,
    use_numba: bool = True,
) -> YawMeasurement:
    """The turn error between pair k (``before``, the keyframe) and a later pair (``after``)
    measured by the points ``xyz`` (the fittest flies first, base_link at pair k) moved by the
    odometry ``increment``: the first ``config.flies`` of them that stay comparable over the
    scan, their patches compared with the engine's ``similarity``."""
    offsets = config.offsets(rig.focal_px)
    points = np.asarray(xyz, dtype=np.float64)
    points = points[comparable_flies(points, increment, rig, offsets, config.window)]
    if config.max_parallax_px > 0:
        keep = depth_insensitive(
            points, increment, rig, config.disparity_error_px, config.max_parallax_px
        )
        points = points[keep]
    points = points[: config.flies]
    if len(points) < config.min_flies or len(offsets) < 3:
        return YawMeasurement(None, len(points))
    scores_of = yaw_scores_numba if use_numba else yaw_scores_numpy
    scores = scores_of(
        before, after, points, increment, rig, offsets, config.window, config.guard, similarity
    )
    return YawMeasurement(scan_peak(offsets, scores), len(points))


def fused_yaw(
    measured: float, odometry_variance: float, measurement_sd: float, gate: float = math.inf
) -> float:
    """The Kalman update of a zero-mean prior of variance ``odometry_variance`` (rad²) by a
    measurement ``measured`` of sd ``measurement_sd`` (rad): the correction to apply; 0 for
    a measurement more than ``gate`` sd of the innovation from 0."""
    total = odometry_variance + measurement_sd * measurement_sd
    if total <= 0.0 or measured * measured > gate * gate * total:
        return 0.0
    return measured * odometry_variance / total


@dataclass
class _Keyframe:
    """The pair the next heading measurement compares with: its flies (base_link there), the
    robot's pose there, and what came since (pairs, the odometry's heading variance)."""

    pair: StereoPair
    xyz: np.ndarray
    pose: Pose2D
    pairs: int = 0
    variance: float = 0.0


class VisualHeading:
    """The engine's visual heading over a sequence of stereo pairs: keeps a keyframe (a pair
    and the flies fitted to it), and when a measurement is due (``config``) measures the
    turn since with the flies (:func:`measure_yaw`, the engine's ``similarity``) and fuses
    it with the odometry's (:func:`fused_yaw`). The pose bookkeeping around it (odometry at
    a pair's stamp, the correction applied to later odometry) is the caller's
    (:class:`flylog.replay.pose_tracker.PoseTracker`)."""

    def __init__(
        self, config: HeadingConfig, rig: StereoRig, similarity: Similarity = Similarity.ZSSD
    ) -> None:
        self._config = config
        self._rig = rig
        self._similarity = similarity
        self._keyframe: _Keyframe | None = None  # what the next measurement compares with

    def turn(
        self,
        previous: StereoPair,
        pair: StereoPair,
        engine_pose: Pose2D,
        pose: Pose2D,
        population: Callable[[], Population],
    ) -> tuple[float | None, int]:
        """The heading correction (rad) to add to ``pose`` (the robot's pose at ``pair``, from
        the odometry), and the fitness evaluations its measurement made; None when no
        measurement is made (not due, no turn since the keyframe, no inner peak).
        ``previous`` is the pair before, ``engine_pose`` the pose at it: when no keyframe is
        kept, ``previous`` with the fittest flies of ``population()`` (base_link there)
        becomes one."""
        cfg = self._config
        if not cfg.enabled:
            return None, 0
        if self._keyframe is None:
            pop = population()
            fittest = np.argsort(-pop.fitness, kind="stable")
            fittest = fittest[pop.fitness[fittest] > 0][: KEYFRAME_FLIES * cfg.flies]
            self._keyframe = _Keyframe(previous, pop.xyz[fittest], engine_pose)
        key = self._keyframe
        key.pairs += 1
        key.variance += cfg.odometry_variance(
            relative(engine_pose, pose), (pair.stamp_ns - previous.stamp_ns) / 1e9
        )
        since = relative(key.pose, pose)
        if key.variance == 0.0 or not cfg.due(since, key.pairs):
            return None, 0
        self._keyframe = None
        if abs(since.theta) < math.radians(cfg.min_turn_deg):
            return None, 0
        measured = measure_yaw(
            (key.pair.left, key.pair.right),
            (pair.left, pair.right),
            key.xyz,
            since,
            self._rig,
            cfg,
            similarity=self._similarity,
        )
        evaluations = cfg.evaluations(measured.flies)
        if measured.yaw is None:
            return None, evaluations
        sd = cfg.measurement_sd_px / self._rig.focal_px
        return fused_yaw(measured.yaw, key.variance, sd, cfg.gate), evaluations
