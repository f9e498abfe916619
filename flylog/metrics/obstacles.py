"""Per-obstacle detection latency over a run's snapshots.

An obstacle becomes *visible* at the first snapshot where at least ``min_visible_pixels``
pixels of the true left view see it, and *detected* at the first snapshot from then on
where at least ``min_detecting_flies`` obstacle flies lie on it (on a surface, the pixel of
their projection seeing that obstacle; see ``flylog.metrics.flies``). The latency is the
time between the two; NaN if it was never visible or never detected.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class ObstacleDetection(NamedTuple):
    """(n_obstacles,) arrays: times in s of the snapshot clock; NaN for never."""

    first_visible: np.ndarray
    first_detected: np.ndarray
    max_visible_pixels: np.ndarray  # int64
    max_flies_on: np.ndarray  # int64

    @property
    def latency(self) -> np.ndarray:
        return self.first_detected - self.first_visible


def detect_obstacles(
    t_s: np.ndarray,
    visible_pixels: np.ndarray,
    flies_on: np.ndarray,
    *,
    min_visible_pixels: int,
    min_detecting_flies: int,
) -> ObstacleDetection:
    """From the per-snapshot (S, n) pixel and fly counts at snapshot times ``t_s`` (S,)."""
    t_s = np.asarray(t_s, dtype=float)
    visible_pixels = np.asarray(visible_pixels, dtype=np.int64)
    flies_on = np.asarray(flies_on, dtype=np.int64)
    if visible_pixels.ndim != 2 or visible_pixels.shape != flies_on.shape:
        msg = f"counts must be two (S, n) arrays, got {visible_pixels.shape}, {flies_on.shape}"
        raise ValueError(msg)
    n = visible_pixels.shape[1]
    first_visible = np.full(n, np.nan)
    first_detected = np.full(n, np.nan)
    visible = visible_pixels >= min_visible_pixels
    detected = flies_on >= min_detecting_flies
    for k in range(n):
        seen = np.flatnonzero(visible[:, k])
        if len(seen) == 0:
            continue
        s0 = seen[0]
        first_visible[k] = t_s[s0]
        found = np.flatnonzero(detected[s0:, k])
        if len(found):
            first_detected[k] = t_s[s0 + found[0]]
    empty = len(t_s) == 0
    return ObstacleDetection(
        first_visible=first_visible,
        first_detected=first_detected,
        max_visible_pixels=np.zeros(n, np.int64) if empty else visible_pixels.max(axis=0),
        max_flies_on=np.zeros(n, np.int64) if empty else flies_on.max(axis=0),
    )
