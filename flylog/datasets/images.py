"""PNG images of the datasets' layouts, read with OpenCV into the contract's channel order."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from flylog.errors import LogError


def read_png(path: Path, *, depth16: bool = False) -> np.ndarray:
    """(H, W, 3) uint8 RGB, or (H, W) uint8 for a grey file; ``depth16``: (H, W) uint16 as
    stored (KITTI's disparity maps)."""
    flags = cv2.IMREAD_UNCHANGED
    image = cv2.imread(str(path), flags)
    if image is None:
        msg = f"{path}: not a readable image"
        raise LogError(msg)
    if depth16:
        if image.dtype != np.uint16 or image.ndim != 2:
            msg = f"{path}: expected a one-channel 16-bit PNG, got {image.dtype} {image.shape}"
            raise LogError(msg)
        return image
    if image.dtype != np.uint8:
        msg = f"{path}: expected 8-bit pixels, got {image.dtype}"
        raise LogError(msg)
    if image.ndim == 3 and image.shape[2] == 4:
        image = image[:, :, :3]
    if image.ndim == 3:
        return np.ascontiguousarray(image[:, :, ::-1])
    return image


def write_png(path: Path, image: np.ndarray) -> None:
    """Write (H, W, 3) uint8 RGB, (H, W) uint8 or (H, W) uint16 as PNG."""
    image = np.asarray(image)
    if image.ndim == 3:
        image = np.ascontiguousarray(image[:, :, ::-1])
    if not cv2.imwrite(str(path), image):
        msg = f"cannot write {path}"
        raise LogError(msg)
