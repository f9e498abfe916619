"""What the similarity tests share: a small rig, random images and flies (some outside the
image or behind the cameras), and a per-fly float loop over whole-pixel windows that the
compiled kernels' formulas are checked against."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from flylog.fly.fitness import INVALID_FITNESS
from flylog.geometry import StereoRig

SMALL = StereoRig(width=64, height=48, focal_px=50.0, baseline=0.12)


def random_case(seed: int, channels: int, n: int = 300):
    """Random left and right images of ``SMALL`` and ``n`` flies, some of them invalid."""
    rng = np.random.default_rng(seed)
    shape = (SMALL.height, SMALL.width) + ((channels,) if channels > 1 else ())
    left = rng.integers(0, 128, shape, dtype=np.uint8)
    right = rng.integers(0, 128, shape, dtype=np.uint8)
    u = rng.uniform(-10, SMALL.width + 10, n)
    v = rng.uniform(-10, SMALL.height + 10, n)
    depth = rng.choice([-1.0, 1.0], n) * rng.uniform(0.05, 10.0, n)
    return left, right, SMALL.backproject(u, v, depth)


def plain_fitness(
    left,
    right,
    xyz,
    window: int,
    guard: float,
    unlike: Callable[[np.ndarray, np.ndarray], float],
    *,
    centred: bool = True,
) -> np.ndarray:
    """G / (guard·n·C + unlike(dl, dr)) fly by fly in floats, G the paper's Sobel norm,
    dl and dr the left and right windows, zero-mean per channel when ``centred``; invalid
    flies get INVALID_FITNESS."""
    left = left.reshape(left.shape[0], left.shape[1], -1).astype(np.float64)
    right = right.reshape(left.shape).astype(np.float64)
    h = window // 2
    ul, ur, v, depth = SMALL.project(xyz)
    out = np.full(len(xyz), INVALID_FITNESS)
    for i in range(len(xyz)):
        a, b, r = (int(np.floor(x + 0.5)) for x in (ul[i], ur[i], v[i]))
        inside = h <= r < SMALL.height - h and all(h <= c < SMALL.width - h for c in (a, b))
        if depth[i] <= 0 or not inside:
            continue
        pl = left[r - h : r + h + 1, a - h : a + h + 1]
        pr = right[r - h : r + h + 1, b - h : b + h + 1]
        dl, dr = (pl - pl.mean(axis=(0, 1)), pr - pr.mean(axis=(0, 1))) if centred else (pl, pr)
        c = pl[h - 1 : h + 2, h - 1 : h + 2]
        gx = (c[:, 2] - c[:, 0]) * np.array([1, 2, 1])[:, None]
        gy = (c[2] - c[0]) * np.array([1, 2, 1])[:, None]
        g = np.sqrt(np.sqrt((gx.sum(axis=0) ** 2 + gy.sum(axis=0) ** 2).sum()))
        out[i] = g / (guard * dl.size + unlike(dl, dr))
    return out
