"""PNG images of the datasets' layouts, read with OpenCV into the contract's channel order."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from flylog.errors import LogError
from flylog.io.inputs import read_input_bytes


def read_png(path: Path, *, depth16: bool = False, what: str = "an image") -> np.ndarray:
    """(H, W, 3) uint8 RGB, or (H, W) uint8 for a grey file; ``depth16``: (H, W) uint16 as
    stored (KITTI's disparity maps). ``what`` the file is, for the inputs' registry."""
    data = np.frombuffer(read_input_bytes(path, what), dtype=np.uint8)
    image = cv2.imdecode(data, cv2.IMREAD_UNCHANGED) if data.size else None
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


def read_pair(left: Path, right: Path) -> tuple[np.ndarray, np.ndarray]:
    """The left and right images of a stereo pair; LogError if their sizes or their kinds
    (grey, colour) differ, naming both files."""
    a, b = read_png(left, what="the left image"), read_png(right, what="the right image")
    if a.shape != b.shape:
        kind = {2: "grey", 3: "colour"}
        msg = (
            f"{right}: {b.shape[1]}×{b.shape[0]} {kind[b.ndim]}, but the left image {left} is "
            f"{a.shape[1]}×{a.shape[0]} {kind[a.ndim]}: a stereo pair's images have one size "
            "and kind"
        )
        raise LogError(msg)
    return a, b


def write_png(path: Path, image: np.ndarray) -> None:
    """Write (H, W, 3) uint8 RGB, (H, W) uint8 or (H, W) uint16 as PNG."""
    image = np.asarray(image)
    if image.ndim == 3:
        image = np.ascontiguousarray(image[:, :, ::-1])
    if not cv2.imwrite(str(path), image):
        msg = f"cannot write {path}"
        raise LogError(msg)
