"""What an importer checks before it writes a log: geometry a camera can have and ground
truth that can score a run. Each failure is a LogError naming the dataset's file and its
field, in the dataset's own terms (``calib.txt``'s ``baseline`` in mm, KITTI's ``P_rect_03``),
so that nothing impossible reaches replay (a baseline of 0 divides by zero, a NaN focal
length runs the engine on NaN) or metrics (truth all unknown scores every run null).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from flylog.config import from_mapping, to_mapping
from flylog.errors import ConfigError, LogError
from flylog.geometry import StereoRig


def finite(path: Path, field: str, value: float, *, positive: bool = False) -> float:
    """``value`` of ``field`` in ``path`` if it is finite (and with ``positive``, above 0)."""
    if not math.isfinite(value):
        msg = f"{path}: {field} is {value}, not a finite number"
        raise LogError(msg)
    if positive and value <= 0:
        msg = f"{path}: {field} is {value:g}; it must be above 0"
        raise LogError(msg)
    return value


def checked_rig(rig: StereoRig, path: Path) -> StereoRig:
    """``rig`` if its fields are within StereoRig's ranges (focal length ≥ 1 px, baseline
    1 mm to 10 m, frame rate, …), else a LogError naming ``path``, where they come from."""
    try:
        return from_mapping(StereoRig, to_mapping(rig), source=f"{path} (the rig it gives)")
    except ConfigError as exc:
        raise LogError(str(exc)) from None


def checked_truth(path: Path, disparity: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """A ground-truth disparity map (NaN unknown) of the images' ``size`` (width, height)
    with at least one known value above 0; else a LogError naming ``path``."""
    height, width = disparity.shape[:2]
    if (width, height) != size:
        msg = (
            f"{path}: ground truth of {width}×{height} values, but the images are "
            f"{size[0]}×{size[1]} px: it would be scored against misaligned pixels"
        )
        raise LogError(msg)
    known = disparity[np.isfinite(disparity)]
    if known.size == 0:
        msg = f"{path}: the ground truth holds no known disparity (every value unknown)"
        raise LogError(msg)
    if not np.any(known > 0):
        msg = f"{path}: every known disparity of the ground truth is 0 (a point at infinity)"
        raise LogError(msg)
    return disparity
