"""The conventional stereo pipeline: OpenCV StereoSGBM on complete frames, as a fly-like cloud.

:class:`SgbmEngine` has the interface the replay pipeline drives (:class:`FlyEngine`'s):
``set_images``, ``set_sonar``, ``apply_motion``, ``step`` and ``population``, so the same
planner, the same ``/flies`` topic and the same metrics serve both. One ``step`` processes
the newest stereo pair completely:

1. dense disparity with ``cv2.StereoSGBM`` (left image as reference, sub-pixel, with
   OpenCV's uniqueness, left-right and speckle checks);
2. the *valid* pixels: a disparity d at least focal·baseline / ``max_depth`` − doffs (d =
   f·B/Z − doffs, the rig's right-camera offset; the search starts at
   :func:`search_start_px`, ⌊−doffs⌋ when doffs < 0, else 0);
3. ``points`` of them, evenly spaced in raster order (every k-th valid pixel, so the cloud
   covers the valid pixels with a uniform density and is the same for the same images);
4. at depth f·B/(d + doffs), back-projected with :meth:`StereoRig.backproject` (principal
   point and mount pose included) into base_link, then moved by the
   odometry received since the pair was set, so the cloud is in the current robot frame.

The cloud is a :class:`~flylog.fly.population.Population` whose fields mean:

- ``fitness`` = ``vision`` = 1 + the mean Sobel gradient norm (3×3, grey levels) over the
  matched block around the pixel in the left image: positive for every point, higher where
  the match had more texture to rely on. The obstacle rule's quantile q therefore keeps the
  points whose texture is strictly above the q-quantile of the cloud's: about the best
  textured (1 − q) share (fewer if many values tie at the threshold; ``quantile = 0`` keeps
  all but the least textured).
- ``age`` = :data:`MATCHED_AGE` for every point: a matched pixel is evidence, not a random
  guess, so any ``min_age`` of the rule lets it through.
- ``stale`` False, ``stamp_ns`` the pair's stamp.

No sonar fusion: the conventional pipeline is vision only (``set_sonar`` is accepted and
ignored, so the comparison with the flies isolates what fusion and asynchrony add).
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from flylog.baseline.config import SgbmConfig, SgbmMode
from flylog.errors import FlylogError
from flylog.fly.population import Population
from flylog.fly.stats import GenerationStats
from flylog.geometry import Pose2D, StereoRig, compose
from flylog.geometry.proprioception import moved_by_odometry
from flylog.sensors import SonarReading, StereoPair

# The largest integer a float32 /flies cloud stores exactly: above any sensible min_age.
MATCHED_AGE = 2**24

_CV_MODES = {
    SgbmMode.SGBM: cv2.STEREO_SGBM_MODE_SGBM,
    SgbmMode.SGBM_3WAY: cv2.STEREO_SGBM_MODE_SGBM_3WAY,
    SgbmMode.HH: cv2.STEREO_SGBM_MODE_HH,
    SgbmMode.HH4: cv2.STEREO_SGBM_MODE_HH4,
}

_IDENTITY = Pose2D(0.0, 0.0, 0.0)


def search_start_px(doffs: float) -> int:
    """The matcher's smallest disparity (px) for a rig's ``doffs``: 0, or with doffs < 0
    (every point's disparity f·B/Z − doffs exceeds −doffs) the disparity at infinity
    ⌊−doffs⌋, so the search range covers depths from f·B/num_disparities to infinity as it
    does for doffs = 0. With doffs > 0 the search starts at 0: a dataset with doffs > 0
    (Middlebury) crops its pairs so that disparities are ≥ 0, and the range then reaches
    the nearer depths f·B/(num_disparities + doffs) (on the Motorcycle pair, doffs
    31.086 px, true disparities 7.2–59.9 px: all inside [0, 64))."""
    return max(0, math.floor(-doffs))


def stereo_matcher(config: SgbmConfig, doffs: float = 0.0) -> cv2.StereoSGBM:
    """The OpenCV matcher the configuration describes, for a rig's ``doffs``."""
    channels = 1 if config.grey else 3
    area = channels * config.block_size**2
    return cv2.StereoSGBM.create(
        minDisparity=search_start_px(doffs),
        numDisparities=config.num_disparities,
        blockSize=config.block_size,
        P1=config.p1_factor * area,
        P2=config.p2_factor * area,
        disp12MaxDiff=config.disp12_max_diff,
        preFilterCap=config.pre_filter_cap,
        uniquenessRatio=config.uniqueness_ratio,
        speckleWindowSize=config.speckle_window_size,
        speckleRange=config.speckle_range,
        mode=_CV_MODES[config.mode],
    )


def grey_levels(image: np.ndarray) -> np.ndarray:
    """(H, W) uint8 grey levels of an (H, W) grey or (H, W, 3) RGB uint8 image."""
    image = np.asarray(image)
    return image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)


def disparity_px(matcher: cv2.StereoSGBM, left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """(H, W) float32 disparity uL − uR in pixels (sub-pixel); NaN where none was found
    (OpenCV marks those minDisparity − 1)."""
    fixed = matcher.compute(np.ascontiguousarray(left), np.ascontiguousarray(right))
    # StereoSGBM returns 4 fractional bits.
    found = fixed >= 16 * matcher.getMinDisparity()
    return np.where(found, fixed.astype(np.float32) / np.float32(16.0), np.float32(np.nan))


def texture_confidence(
    grey: np.ndarray, block_size: int, u: np.ndarray, v: np.ndarray
) -> np.ndarray:
    """(N,) float64 at the pixels (u, v): 1 + the mean 3×3 Sobel gradient norm (grey levels)
    over the ``block_size`` block around each (borders reflected)."""
    r = block_size // 2
    # Integer Sobel (exact), then only the N blocks: a whole-image float box filter costs a
    # third of SGBM at 640×480, and cv2.blur's last bits vary from run to run.
    gx = np.pad(cv2.Sobel(grey, cv2.CV_16S, 1, 0, ksize=3), r, mode="symmetric")
    gy = np.pad(cv2.Sobel(grey, cv2.CV_16S, 0, 1, ksize=3), r, mode="symmetric")
    offsets = np.arange(block_size)
    rows = (np.asarray(v)[:, None] + offsets)[:, :, None]  # padded coordinates: + r − r
    cols = (np.asarray(u)[:, None] + offsets)[:, None, :]
    norm = np.hypot(gx[rows, cols].astype(np.float64), gy[rows, cols].astype(np.float64))
    return 1.0 + norm.reshape(len(norm), block_size * block_size).mean(axis=1)


def sampled_pixels(
    disparity: np.ndarray, min_disparity: float, count: int
) -> tuple[np.ndarray, np.ndarray]:
    """(u, v) int64 of at most ``count`` pixels with ``disparity >= min_disparity``, evenly
    spaced in raster order among them (all of them if there are fewer)."""
    valid = np.flatnonzero(disparity.ravel() >= min_disparity)
    if len(valid) > count:
        valid = valid[(np.arange(count, dtype=np.int64) * len(valid)) // count]
    v, u = np.divmod(valid, disparity.shape[1])
    return u, v


class SgbmEngine:
    """StereoSGBM over a stereo rig, frame by frame, exposing its points as a Population.

    ``points`` is the size of the cloud (replay passes the fly population size, so both
    engines hand the planner and the metrics as many points).
    """

    def __init__(self, config: SgbmConfig, rig: StereoRig, *, points: int) -> None:
        if rig.baseline <= 0:
            msg = f"stereo matching needs a stereo baseline > 0, got {rig.baseline} m"
            raise FlylogError(msg)
        start = search_start_px(rig.doffs)
        if start + config.num_disparities >= rig.width:
            msg = (
                f"sgbm.num_disparities ({config.num_disparities} px) must be below the image "
                f"width ({rig.width} px)"
                + (f" less the rig's disparity at infinity ({start} px)" if start else "")
            )
            raise FlylogError(msg)
        if points < 1:
            msg = f"the cloud needs at least one point, got {points}"
            raise FlylogError(msg)
        self.config = config
        self.rig = rig
        self.points = points
        self._matcher = stereo_matcher(config, rig.doffs)
        # measured disparities are f·B/Z − doffs; the matcher searches from
        # search_start_px(doffs), so with doffs > 0 points beyond f·B/doffs are not found
        self._min_disparity = max(rig.fb / config.max_depth - rig.doffs, 0.0)
        self._pop = Population.fresh(np.empty((0, 3)))
        self._pair: StereoPair | None = None
        self._since_pair = _IDENTITY  # odometry increment since the pair was set
        self._frames = 0

    # --- inputs -----------------------------------------------------------------------------

    def set_images(self, pair: StereoPair) -> StereoPair:
        """Process this pair at the next ``step`` (returned as it is: SGBM matches it
        unchanged). Its ``readout`` (a rolling shutter's motion) is not used: a conventional
        matcher takes the whole frame and has no model of a row's time, so its points are
        placed at the stamp."""
        left, right = np.asarray(pair.left), np.asarray(pair.right)
        expected = (self.rig.height, self.rig.width)
        ok = left.shape == right.shape and left.shape[:2] == expected
        ok = ok and (left.ndim == 2 or (left.ndim == 3 and left.shape[2] == 3))
        if not ok or left.dtype != np.uint8 or right.dtype != np.uint8:
            msg = (
                f"stereo pair at {pair.stamp_ns} ns: images {left.shape} {left.dtype} and "
                f"{right.shape} {right.dtype} do not match the rig's {expected} (grey or RGB "
                "uint8)"
            )
            raise FlylogError(msg)
        self._pair = pair
        self._since_pair = _IDENTITY
        return pair

    def set_sonar(self, reading: SonarReading) -> None:
        """Accepted and ignored: the conventional pipeline has no sonar fusion."""

    def apply_motion(self, increment: Pose2D) -> None:
        """Move the cloud by the inverse of the robot's motion ``increment`` (like the flies'
        proprioception), and remember it for the points of the pair not yet processed."""
        if len(self._pop):
            self._pop.xyz = moved_by_odometry(self._pop.xyz, increment)
        self._since_pair = compose(self._since_pair, increment)

    # --- outputs ----------------------------------------------------------------------------

    @property
    def population(self) -> Population:
        """A read-only snapshot of the newest cloud (empty before the first ``step``)."""
        return self._pop.copy(readonly=True)

    @property
    def generation(self) -> int:
        """Frames processed so far."""
        return self._frames

    # --- one frame --------------------------------------------------------------------------

    def steps(self, count: int) -> list[GenerationStats]:
        """``count`` calls of :meth:`step` (each matches the same pair again)."""
        return [self.step() for _ in range(count)]

    def step(self) -> GenerationStats:
        """Match the newest pair and replace the cloud with its points. ``evaluations`` is 0:
        SGBM makes no fitness evaluations (replay charges it ``seconds_per_frame`` instead)."""
        if self._pair is None:
            msg = "the SGBM engine has no images yet: call set_images() before step()"
            raise FlylogError(msg)
        cfg, rig, pair = self.config, self.rig, self._pair
        left_grey, right_grey = grey_levels(pair.left), grey_levels(pair.right)
        if cfg.grey:
            disparity = disparity_px(self._matcher, left_grey, right_grey)
        else:
            disparity = disparity_px(self._matcher, _rgb(pair.left), _rgb(pair.right))
        u, v = sampled_pixels(disparity, self._min_disparity, self.points)
        depth = rig.depth_of_disparity(disparity[v, u].astype(np.float64))
        xyz = rig.backproject(u, v, depth)
        if self._since_pair != _IDENTITY:
            xyz = moved_by_odometry(xyz, self._since_pair)
        fitness = texture_confidence(left_grey, cfg.block_size, u, v)
        n = len(fitness)
        self._pop = Population(
            xyz=np.ascontiguousarray(xyz, dtype=np.float64),
            fitness=fitness,
            vision=fitness.copy(),
            stale=np.zeros(n, dtype=bool),
            stamp_ns=np.full(n, pair.stamp_ns, dtype=np.int64),
            age=np.full(n, MATCHED_AGE, dtype=np.int32),
        )
        self._frames += 1
        return GenerationStats(
            generation=self._frames,
            evaluations=0,
            image_stamp_ns=pair.stamp_ns,
            survivors=0,
            offspring=0,
            immigrants=0,
            sonar_immigrants=0,
        )


def _rgb(image: np.ndarray) -> np.ndarray:
    """Three channels for colour matching (a grey image is repeated)."""
    image = np.asarray(image)
    return image if image.ndim == 3 else np.repeat(image[:, :, None], 3, axis=2)
