"""The Portable Float Map (PFM) format of Middlebury's disparity maps.

A header of three text lines: ``Pf`` (one channel) or ``PF`` (three), ``WIDTH HEIGHT``, and
a scale whose sign gives the byte order (negative: little endian, positive: big endian);
then float32 values, rows from the bottom of the image to its top.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from flylog.errors import LogError
from flylog.io.inputs import read_input_bytes


def read_pfm(path: Path) -> np.ndarray:
    """(H, W) or (H, W, 3) float32, rows top to bottom as images store them."""
    data = read_input_bytes(path, "the ground truth")
    # four whitespace-separated fields (magic, width, height, scale), then one whitespace byte
    fields: list[bytes] = []
    at = 0
    while len(fields) < 4 and at < len(data):
        while at < len(data) and data[at : at + 1].isspace():
            at += 1
        end = at
        while end < len(data) and not data[end : end + 1].isspace():
            end += 1
        fields.append(data[at:end])
        at = end
    at += 1
    if len(fields) < 4:
        fields += [b""] * (4 - len(fields))
    magic, size, scale_text = fields[0], fields[1] + b" " + fields[2], fields[3]
    if magic not in (b"Pf", b"PF"):
        msg = f"{path}: not a PFM file (it starts with {magic[:8]!r}, not 'Pf' or 'PF')"
        raise LogError(msg)
    try:
        width, height = (int(v) for v in size.split())
        scale = float(scale_text)
    except ValueError:
        msg = f"{path}: PFM header {size!r} {scale_text!r} is not 'WIDTH HEIGHT' and a scale"
        raise LogError(msg) from None
    if not (math.isfinite(scale) and scale != 0):
        msg = (
            f"{path}: PFM scale is {scale_text.decode(errors='replace')!r}; its sign gives the "
            "byte order (negative: little endian), so it is a finite number other than 0"
        )
        raise LogError(msg)
    channels = 3 if magic == b"PF" else 1
    dtype = np.dtype("<f4" if scale < 0 else ">f4")
    count = width * height * channels
    if len(data) - at < count * 4:
        msg = f"{path}: PFM of {width}×{height}×{channels} holds only {len(data) - at} bytes"
        raise LogError(msg)
    values = np.frombuffer(data, dtype=dtype, count=count, offset=at).astype(np.float32)
    shape = (height, width, 3) if channels == 3 else (height, width)
    return np.ascontiguousarray(values.reshape(shape)[::-1])


def write_pfm(path: Path, image: np.ndarray, *, little_endian: bool = True) -> None:
    """Write (H, W) or (H, W, 3) values as float32 PFM (rows written bottom to top)."""
    image = np.asarray(image, dtype=np.float32)
    if image.ndim not in (2, 3) or (image.ndim == 3 and image.shape[2] != 3):
        msg = f"PFM holds (H, W) or (H, W, 3) images, got {image.shape}"
        raise ValueError(msg)
    height, width = image.shape[:2]
    magic = b"PF" if image.ndim == 3 else b"Pf"
    dtype = np.dtype("<f4" if little_endian else ">f4")
    header = magic + b"\n" + f"{width} {height}\n{-1.0 if little_endian else 1.0}\n".encode()
    Path(path).write_bytes(header + image[::-1].astype(dtype).tobytes())
