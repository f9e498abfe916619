"""The numpy reference of :func:`flylog.fly.generation.rows_order_into` (only tests call it)."""

from __future__ import annotations

import numpy as np

from flylog.geometry import StereoRig


def rows_order_numpy(xyz: np.ndarray, index: np.ndarray, rig: StereoRig) -> np.ndarray:
    """Reference: the order :func:`~flylog.fly.generation.rows_order_into` gives (same
    arithmetic: a fly behind or in the cameras' plane lands off the image)."""
    _, b, depth, _ = rig.optical(xyz[index])
    with np.errstate(divide="ignore", invalid="ignore"):
        v = rig.cy + rig.focal_px * b / depth
        on = (v >= 0.0) & (v < rig.height)
        row = np.where(on, np.floor(np.where(on, v, 0.0)) + 1, 0).astype(np.int64)
    return index[np.argsort(row, kind="stable")]
