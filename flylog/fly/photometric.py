"""Photometric matching of a stereo pair before the flies compare it (``engine.photometric``).

Real cameras differ from the simulator's ideal ones in two ways the zero-mean SSD feels: the
right camera's gain differs from the left's (two auto-exposures settle apart), and both
images carry sensor noise. With ``matched`` (the default) each pair is, before any fly is
scored on it:

1. smoothed, both images alike, by a Gaussian whose σ grows with the noise estimated in
   them: ``σ_blur = min(BLUR_MAX_PX, BLUR_PER_NOISE · (σ_noise − NOISE_FLOOR))`` px, zero below
   the floor. ``σ_noise`` is Immerkær's estimate (a 3×3 Laplacian-like mask's mean absolute
   response, which cancels a locally linear image; textured images read above their true
   noise): 1.0 grey level on the simulator's ideal images (the fixture `corridor`), 2.0–2.2
   on its realistic ones (EMVA 1288's noise model, docs/simulator.md), 2.5 on the Middlebury
   motorcycle pair as it is and 6.3 with noise σ = 8 added;
2. the right image's grey levels mapped linearly so that its mean and standard deviation,
   over the channels and a grid of every :data:`GRID_PX`-th row and column, are the left
   one's: a gain and an offset between the cameras, one pair at a time (an auto-exposure's
   drift is followed).

Measured (5000 flies, 50 generations, zssd, sub-pixel, the better half within 2 px, the mean
of seeds 0 and 1; ``bench_real_pair``'s ``default_table``) on the motorcycle pair as it is /
right image 25 % brighter / noise σ = 8 on both / both: ``none`` 0.980 / 0.699 / 0.486 /
0.217; ``matched`` 0.995 / 0.996 / 0.966 / 0.948. A floating-point prototype of the same
steps (other noise draws) gave, for the gain step alone (no smoothing), 0.966 / 0.856 /
0.497 / 0.323, for the smoothing alone 0.995 / 0.954 / 0.955 / 0.802, and with per-channel
gains instead of one 0.994 / 0.994 / 0.954 / 0.952: both steps are needed, one gain is
enough. Both steps read every pixel once (no fly's fitness depends on pixels it does not
read, but its window's pixels depend on their neighbours within 3 σ_blur); their cost is
charged to the replay's virtual clock as fitness evaluations (:func:`charged_evaluations`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import cv2
import numpy as np

# σ_blur = BLUR_PER_NOISE · (σ_noise − NOISE_FLOOR), at most BLUR_MAX_PX. Chosen on the
# motorcycle pair's four conditions and the realistic corridor (seeds 0, 1; docs/engine.md).
BLUR_PER_NOISE = 0.5
NOISE_FLOOR = 1.0  # grey levels
BLUR_MAX_PX = 2.0
GRID_PX = 8  # the gain's statistics read every 8th row and column
# The matching's cost charged to the virtual clock, in fitness evaluations a pixel:
# `bench_photometric` times it against the engine's evaluations in the same run, 0.040 at
# 320×240 and 0.030 at 640×480 (a loaded 2-core host); the larger is charged.
EVALUATIONS_PER_PIXEL = 0.04

_IMMERKAER = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], dtype=np.float32)


class Matching(NamedTuple):
    """What :func:`matched` did to a pair."""

    noise: float  # Immerkær's σ, grey levels, the mean of the two images'
    blur_px: float  # the Gaussian's σ (0: none)
    gain: float  # the right image's grey levels were multiplied by this
    offset: float  # then this added


def grey(image: np.ndarray) -> np.ndarray:
    """The image as uint8 grey levels (RGB weighted as OpenCV's RGB2GRAY)."""
    image = np.ascontiguousarray(image)
    return cv2.cvtColor(image, cv2.COLOR_RGB2GRAY) if image.ndim == 3 else image


def noise_sd(image: np.ndarray) -> float:
    """Immerkær's (1996) estimate of the noise's σ in grey levels: sqrt(π/2)/6 times the mean
    absolute response of the mask [[1,-2,1],[-2,4,-2],[1,-2,1]] inside the image."""
    g = grey(image)
    h, w = g.shape[:2]
    if h < 3 or w < 3:
        return 0.0
    response = cv2.filter2D(g, cv2.CV_32F, _IMMERKAER)[1:-1, 1:-1]
    total = cv2.norm(response, cv2.NORM_L1)
    return math.sqrt(math.pi / 2.0) * total / (6.0 * (h - 2) * (w - 2))


def blur_px(noise: float) -> float:
    """The Gaussian's σ for a noise estimate."""
    return min(BLUR_MAX_PX, max(0.0, BLUR_PER_NOISE * (noise - NOISE_FLOOR)))


def gain_table(gain: float, offset: float) -> np.ndarray:
    """The 256 grey levels mapped by ``gain · v + offset``, rounded and clipped to uint8."""
    levels = np.arange(256, dtype=np.float64) * gain + offset
    return np.clip(np.rint(levels), 0, 255).astype(np.uint8)


def charged_evaluations(width: int, height: int) -> int:
    """The evaluations a pair of ``width`` × ``height`` images costs to match."""
    return math.ceil(EVALUATIONS_PER_PIXEL * width * height)


def matched(left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray, Matching]:
    """The pair smoothed by its noise and its right image matched to the left's grey-level
    mean and standard deviation (uint8, the shapes given), and what was done."""
    left, right = np.ascontiguousarray(left), np.ascontiguousarray(right)
    noise = 0.5 * (noise_sd(left) + noise_sd(right))
    sigma = blur_px(noise)
    if sigma > 0.0:
        left = cv2.GaussianBlur(left, (0, 0), sigma, borderType=cv2.BORDER_REFLECT)
        right = cv2.GaussianBlur(right, (0, 0), sigma, borderType=cv2.BORDER_REFLECT)
    gl = left[::GRID_PX, ::GRID_PX].astype(np.float64)
    gr = right[::GRID_PX, ::GRID_PX].astype(np.float64)
    sl, sr = float(gl.std()), float(gr.std())
    gain = sl / sr if sr > 0.0 and sl > 0.0 else 1.0
    offset = float(gl.mean()) - gain * float(gr.mean())
    if gain != 1.0 or offset != 0.0:
        right = cv2.LUT(right, gain_table(gain, offset))
    return left, right, Matching(noise, sigma, gain, offset)
