"""The camera model: a stereo camera's defects applied to the renderer's ideal images.

The renderer's 8-bit values are read as the light reaching each pixel (rendered value 1: a
white surface). Per camera ``c`` and frame ``k``, in the order light meets them:

0. rolling shutter: row v is exposed around the frame's stamp + v · ``row_period_us``, and
   rendered from the pose at that time, in bands of rows (:func:`shutter_bands`,
   :func:`band_rows`); 0, the default, is a global shutter;
1. motion blur: the mean of ``motion_samples`` renders at poses spread evenly over the
   exposure, centred on the frame's time (each row's, :func:`frame_bands`);
2. optical blur: a Gaussian point spread of ``psf_sigma_px`` (:func:`gaussian_blur`);
3. vignetting: the cos⁴ law's profile ``1 / (1 + a ρ²)²`` (ρ: distance from the principal
   point over the half-diagonal) with ``a`` set by the corner's relative illumination;
4. exposure: electrons ``= value · white_flux · exposure_ms``, times the camera's
   auto-exposure drift (an Ornstein-Uhlenbeck process on the log exposure, :class:`Drift`)
   and its fixed per-pixel gain (PRNU); capped at the full well;
5. noise (EMVA 1288's linear model): Poisson shot noise of the electrons, plus the fixed
   dark offset (DSNU) and Gaussian read noise;
6. gain to digital numbers: ``K = 10^(gain_db / 20) · 255 / full_well`` DN per electron,
   the right camera's times ``right_gain_ratio``;
7. response curve ``(DN / 255) ** gamma`` on [0, 1], quantised to 8 bits (round half up).

Seed discipline: frame ``k`` of camera ``c`` draws its noise from a Generator seeded with
``SeedSequence(seed, spawn_key=(NOISE_STREAM, k, c))``, the drift of camera ``c`` from
``(DRIFT_STREAM, c)`` and its fixed pattern from ``(PATTERN_STREAM, c)``: none of them
depends on anything else drawn in the simulation (the trajectory and the sonars use the
seed's spawned children 0 and 1), so the same scene and seed give the same images.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from flylog.geometry import Pose2D, StereoRig
from flylog.geometry.poses import compose
from flylog.sim.camera_defects import CameraDefects

if TYPE_CHECKING:
    from flylog.sim.render import Band

# Spawn keys of the camera model's streams, after the simulation's children 0 (trajectory)
# and 1 (sonar).
NOISE_STREAM = 2
DRIFT_STREAM = 3
PATTERN_STREAM = 4
# A Gaussian kernel reaches this many sigmas (the weight beyond is 0.3 % of the total).
_PSF_REACH = 3.0
SIDES = ("left", "right")


def frame_rng(seed: int, frame: int, camera: int) -> np.random.Generator:
    """The Generator of frame ``frame``'s noise in camera ``camera`` (0 left, 1 right)."""
    return np.random.default_rng(
        np.random.SeedSequence(seed, spawn_key=(NOISE_STREAM, frame, camera))
    )


def arc_pose(pose: Pose2D, v: float, w: float, dt: float) -> Pose2D:
    """The pose ``dt`` seconds after ``pose`` along the arc of speed ``v`` (m/s) and turn
    rate ``w`` (rad/s)."""
    turn = w * dt
    if abs(turn) < 1e-12:
        step = Pose2D(v * dt, 0.0, 0.0)
    else:
        step = Pose2D(v * math.sin(turn) / w, v * (1.0 - math.cos(turn)) / w, turn)
    return compose(pose, step)


def exposure_offsets(defects: CameraDefects) -> list[float]:
    """The instants (s, from the exposure's middle) the motion blur renders:
    ``motion_samples`` middles of equal slices of the exposure."""
    n = defects.motion_samples
    exposure = defects.exposure_ms / 1000.0
    return [exposure * ((i + 0.5) / n - 0.5) for i in range(n)]


def exposure_poses(pose: Pose2D, v: float, w: float, defects: CameraDefects) -> list[Pose2D]:
    """The poses the motion blur renders: ``motion_samples`` instants at the middles of
    equal slices of the exposure, centred on ``pose`` (the frame's time), moved along the
    arc of the commanded speed ``v`` (m/s) and turn rate ``w`` (rad/s)."""
    if defects.motion_samples == 1:
        return [pose]
    return [arc_pose(pose, v, w, s) for s in exposure_offsets(defects)]


def shutter_bands(height: int, row_period_s: float, band_rows: int) -> list[tuple[float, int, int]]:
    """A rolling shutter's bands of rows: (time of the band from the frame's stamp (s),
    first row, stop row). Row v's exposure middle is the stamp + v · ``row_period_s``; a
    band of ``band_rows`` rows is seen at its middle row's time (a band of one row, exactly
    at its own). A global shutter (``row_period_s`` 0) is one band at the stamp."""
    if row_period_s == 0.0:
        return [(0.0, 0, height)]
    bands = []
    for first in range(0, height, band_rows):
        stop = min(first + band_rows, height)
        bands.append((0.5 * (first + stop - 1) * row_period_s, first, stop))
    return bands


# A band's rows are all seen from the pose at its middle row's time; the bands are as tall as
# keeps every pixel within this many pixels of where its own row's time would put it.
BAND_MOTION_PX = 0.1
# The nearest surface the bound protects (m): nearer ones move faster in the image.
BAND_NEAR_M = 0.5


def band_rows(rig: StereoRig, v: float, w: float, row_period_s: float) -> int:
    """The most rows a rolling shutter's band may hold while the robot moves at speed ``v``
    (m/s) and turn rate ``w`` (rad/s): a row is at most (rows - 1) / 2 row periods from
    its band's time, and no pixel moves by more than :data:`BAND_MOTION_PX` in that time.

    The image speed is bounded at the image's corners (normalised (x, y), the largest
    both): turning moves a pixel by f·|w|·√((1 + x²)² + (xy)²) per second whatever the
    depth; the camera's own motion, forward at ``v`` and sideways at |w| times its distance
    from the turning axis, moves a surface at depth Z by at most f·(ρ·|v| + |w|·d·(1 + ρ))
    / Z, ρ = √(x² + y²), taken at Z = :data:`BAND_NEAR_M`."""
    if row_period_s == 0.0:
        return rig.height
    f = rig.focal_px
    # the farthest column from either camera's principal point
    x = max(rig.cx, rig.width - 1 - rig.cx, rig.cx_right, rig.width - 1 - rig.cx_right) / f
    y = max(rig.cy, rig.height - 1 - rig.cy) / f
    rho = math.hypot(x, y)
    reach = math.hypot(rig.mount_x, abs(rig.mount_y) + rig.baseline / 2.0)
    turning = f * abs(w) * math.hypot(1.0 + x * x, x * y)
    moving = f * (rho * abs(v) + abs(w) * reach * (1.0 + rho)) / BAND_NEAR_M
    per_row = (turning + moving) * row_period_s
    if per_row == 0.0:
        return rig.height
    return max(1, min(rig.height, 1 + math.floor(2.0 * BAND_MOTION_PX / per_row)))


def frame_bands(
    pose: Pose2D,
    v: float,
    w: float,
    defects: CameraDefects,
    bands: list[tuple[float, int, int]],
) -> list[list[Band]]:
    """The renders of one frame, each a list of bands (pose, first row, stop row): one per
    motion-blur sample, whose band of rows is seen from the pose at that row's time plus
    the sample's offset in the exposure, along the arc of the commanded speed ``v`` and
    turn rate ``w`` (the robot at ``pose`` at the frame's stamp). A global shutter gives
    the poses of :func:`exposure_poses`, one band each."""
    if defects.motion_samples == 1:
        return [
            [
                (pose if t == 0.0 else arc_pose(pose, v, w, t), first, stop)
                for t, first, stop in bands
            ]
        ]
    return [
        [(arc_pose(pose, v, w, t + s), first, stop) for t, first, stop in bands]
        for s in exposure_offsets(defects)
    ]


def gaussian_kernel(sigma: float) -> np.ndarray:
    """The normalised sampled Gaussian reaching 3 sigmas (at least one tap each side)."""
    reach = max(1, math.ceil(_PSF_REACH * sigma))
    x = np.arange(-reach, reach + 1, dtype=float)
    kernel = np.exp(-0.5 * (x / sigma) ** 2)
    return kernel / kernel.sum()


def gaussian_blur(image: np.ndarray, sigma: float) -> np.ndarray:
    """(H, W, C) float ``image`` convolved with a separable Gaussian of ``sigma`` pixels,
    borders mirrored (the edge pixel not repeated)."""
    if sigma <= 0.0:
        return image
    kernel = gaussian_kernel(sigma)
    reach = len(kernel) // 2
    height, width = image.shape[:2]
    rows = np.pad(image, ((reach, reach), (0, 0), (0, 0)), mode="reflect")
    out = np.zeros_like(image)
    for t, weight in enumerate(kernel):
        out += weight * rows[t : t + height]
    cols = np.pad(out, ((0, 0), (reach, reach), (0, 0)), mode="reflect")
    out = np.zeros_like(image)
    for t, weight in enumerate(kernel):
        out += weight * cols[:, t : t + width]
    return out


def vignetting(rig: StereoRig, side: str, corner: float) -> np.ndarray:
    """(H, W) relative illumination: the cos⁴ law's ``1 / (1 + a ρ²)²``, ρ the distance
    from the camera's principal point over the half-diagonal, ``a`` such that ρ = 1 gives
    ``corner``."""
    a = corner**-0.5 - 1.0
    cx = rig.cx if side == "left" else rig.cx_right
    half_diagonal = math.hypot((rig.width - 1) / 2.0, (rig.height - 1) / 2.0)
    u = (np.arange(rig.width) - cx) / half_diagonal
    v = (np.arange(rig.height) - rig.cy) / half_diagonal
    rho2 = v[:, None] ** 2 + u[None, :] ** 2
    return 1.0 / (1.0 + a * rho2) ** 2


class Drift:
    """One camera's auto-exposure drift: ``exp(x_k)`` at frame ``k``, ``x`` an
    Ornstein-Uhlenbeck process of stationary sd ``drift_sd`` and time constant
    ``drift_tau_s``, sampled exactly at the frame period (x_0 drawn from the stationary
    law). Its innovations come from the camera's own stream, so frame k's value depends only
    on the seed, the camera and k."""

    def __init__(self, defects: CameraDefects, period_s: float, seed: int, camera: int) -> None:
        self._sd = defects.drift_sd
        self._keep = math.exp(-period_s / defects.drift_tau_s)
        self._rng = np.random.default_rng(
            np.random.SeedSequence(seed, spawn_key=(DRIFT_STREAM, camera))
        )
        self._x: list[float] = []

    def factor(self, frame: int) -> float:
        if self._sd == 0.0:
            return 1.0
        while len(self._x) <= frame:
            z = float(self._rng.standard_normal())
            if not self._x:
                self._x.append(self._sd * z)
            else:
                innovation = self._sd * math.sqrt(1.0 - self._keep**2) * z
                self._x.append(self._x[-1] * self._keep + innovation)
        return math.exp(self._x[frame])


@dataclass(frozen=True)
class _Camera:
    """What stays fixed for one camera: its illumination profile, pattern and gain."""

    light: np.ndarray  # (H, W, 1) electrons per rendered unit: flux, exposure, vignetting, PRNU
    dark: np.ndarray | None  # (H, W, 1) DSNU offset in electrons, or None
    dn_per_electron: float


class CameraModel:
    """Applies :class:`CameraDefects` to rendered stereo pairs, frame by frame."""

    def __init__(
        self, defects: CameraDefects, rig: StereoRig, *, seed: int, period_s: float
    ) -> None:
        self.defects = defects
        self.seed = seed
        d = defects
        self._cameras = []
        self._drifts = []
        for c, side in enumerate(SIDES):
            light = d.white_flux * d.exposure_ms * vignetting(rig, side, d.vignetting_corner)
            pattern = np.random.default_rng(
                np.random.SeedSequence(seed, spawn_key=(PATTERN_STREAM, c))
            )
            shape = (rig.height, rig.width)
            prnu = pattern.standard_normal(shape)
            dsnu = pattern.standard_normal(shape)
            if d.prnu > 0.0:
                light = light * np.maximum(1.0 + d.prnu * prnu, 0.0)
            dark = d.dsnu_e * dsnu[..., None] if d.dsnu_e > 0.0 else None
            gain = 10.0 ** (d.gain_db / 20.0) * (d.right_gain_ratio if c == 1 else 1.0)
            self._cameras.append(_Camera(light[..., None], dark, gain * 255.0 / d.full_well))
            self._drifts.append(Drift(d, period_s, seed, c))

    def expose(self, frame: int, camera: int, radiance: np.ndarray) -> np.ndarray:
        """Camera ``camera``'s 8-bit image of frame ``frame`` from ``radiance``, the (H, W,
        3) light in rendered units (the mean of the exposure's renders over 255)."""
        d, cam = self.defects, self._cameras[camera]
        rng = frame_rng(self.seed, frame, camera)
        light = gaussian_blur(radiance, d.psf_sigma_px)
        electrons = light * cam.light * self._drifts[camera].factor(frame)
        np.minimum(electrons, d.full_well, out=electrons)
        if d.shot_noise:
            electrons = rng.poisson(electrons).astype(float)
        if cam.dark is not None:
            electrons = electrons + cam.dark
        if d.read_noise_e > 0.0:
            electrons = electrons + rng.normal(0.0, d.read_noise_e, electrons.shape)
        level = np.clip(electrons * (cam.dn_per_electron / 255.0), 0.0, 1.0)
        if d.gamma != 1.0:
            level = level**d.gamma
        return np.floor(level * 255.0 + 0.5).astype(np.uint8)

    def pair(
        self, frame: int, renders: list[tuple[np.ndarray, np.ndarray]]
    ) -> tuple[np.ndarray, np.ndarray]:
        """The (left, right) images of frame ``frame`` from the exposure's (left, right)
        renders (uint8, one pair per pose of :func:`exposure_poses`)."""
        out = []
        for c in range(2):
            radiance = np.mean([r[c] for r in renders], axis=0, dtype=float) / 255.0
            out.append(self.expose(frame, c, radiance))
        return out[0], out[1]
