"""``sensor_msgs/msg/Image`` and ``CompressedImage`` → the arrays the engine takes:
(H, W, 3) uint8 RGB, or (H, W) uint8 grey.

rgb8, bgr8, rgba8, bgra8 and mono8 come back as read-only views of the message bytes (no
copy); mono16 is scaled to 8 bits (the top byte); bayer_* is demosaiced by OpenCV;
CompressedImage is decoded by OpenCV (jpeg, png).
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Any

import numpy as np

from flylog.errors import LogError

# ROS Bayer pattern → OpenCV's demosaicing code name. OpenCV names a pattern by the second
# row's first two pixels (cv_bridge's table): ROS "rggb" is OpenCV's "BG".
_BAYER = MappingProxyType(
    {"rggb": "BayerBG", "bggr": "BayerRG", "gbrg": "BayerGR", "grbg": "BayerGB"}
)
RAW_ENCODINGS = (
    *("rgb8", "bgr8", "rgba8", "bgra8", "mono8", "mono16"),
    *(f"bayer_{p}{bits}" for p in _BAYER for bits in (8, 16)),
)
COMPRESSED_FORMATS = ("jpeg", "png")
_CHANNELS = MappingProxyType({"rgb8": 3, "bgr8": 3, "rgba8": 4, "bgra8": 4, "mono8": 1})


class UnsupportedImage(LogError):
    """An image's encoding or format is not one flylog reads (the caller names the topic)."""


def _rows(msg: Any, channels: int, dtype: str) -> np.ndarray:
    """The (H, W, channels) pixels of a raw image, a view of its bytes."""
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    item = np.dtype(dtype).itemsize
    data = msg.data
    if step < w * channels * item or len(data) < step * (h - 1) + w * channels * item:
        text = f"image of {w}×{h} {msg.encoding} has step {step} and only {len(data)} bytes"
        raise LogError(text)
    if step % item:
        text = f"image of {w}×{h} {msg.encoding} has step {step}, not a multiple of {item}"
        raise LogError(text)
    strides = (step, channels * item, item)
    return np.ndarray((h, w, channels), dtype=dtype, buffer=data, strides=strides)


def raw_image(msg: Any) -> np.ndarray:
    """A ``sensor_msgs/msg/Image`` in one of RAW_ENCODINGS as RGB or grey uint8."""
    encoding = str(msg.encoding).lower()
    channels = _CHANNELS.get(encoding)
    if channels is not None:
        view = _rows(msg, channels, "u1")
        if encoding == "mono8":
            return view[..., 0]
        if encoding.startswith("bgr"):
            return view[..., 2::-1]
        return view[..., :3]
    if encoding == "mono16" or (encoding.startswith("bayer_") and encoding.endswith("16")):
        big = bool(msg.is_bigendian)
        wide = _rows(msg, 1, ">u2" if big else "<u2")[..., 0]
        grey = (wide >> 8).astype(np.uint8)
        return grey if encoding == "mono16" else _demosaic(grey, encoding[6:10])
    if encoding.startswith("bayer_") and encoding.endswith("8"):
        return _demosaic(np.ascontiguousarray(_rows(msg, 1, "u1")[..., 0]), encoding[6:10])
    text = f"image encoding '{msg.encoding}' is not supported ({', '.join(RAW_ENCODINGS)} are)"
    raise UnsupportedImage(text)


def _demosaic(mosaic: np.ndarray, pattern: str) -> np.ndarray:
    import cv2

    if pattern not in _BAYER:
        text = f"Bayer pattern '{pattern}' is not one of {', '.join(_BAYER)}"
        raise UnsupportedImage(text)
    code = getattr(cv2, f"COLOR_{_BAYER[pattern]}2RGB")
    return np.asarray(cv2.cvtColor(np.ascontiguousarray(mosaic), code))


def compressed_image(msg: Any) -> np.ndarray:
    """A ``sensor_msgs/msg/CompressedImage`` (jpeg or png) as RGB or grey uint8."""
    import cv2

    fmt = str(msg.format).lower()
    if not any(name in fmt for name in (*COMPRESSED_FORMATS, "jpg")):
        text = f"compressed format '{msg.format}' is not supported (jpeg and png are)"
        raise UnsupportedImage(text)
    pixels = cv2.imdecode(np.asarray(msg.data, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
    if pixels is None:
        text = f"the {msg.format} image does not decode"
        raise LogError(text)
    if pixels.dtype == np.uint16:
        pixels = (np.asarray(pixels, dtype=np.uint16) >> 8).astype(np.uint8)
    if pixels.ndim == 2:
        return np.asarray(pixels)
    code = cv2.COLOR_BGRA2RGB if pixels.shape[2] == 4 else cv2.COLOR_BGR2RGB
    return np.asarray(cv2.cvtColor(pixels, code))


def image_of(msgtype: str, msg: Any) -> np.ndarray:
    """Either image message type as RGB or grey uint8."""
    return compressed_image(msg) if msgtype.endswith("CompressedImage") else raw_image(msg)
