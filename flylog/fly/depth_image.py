"""A fly snapshot as a sparse depth image at the left camera's pixels: what depth-image
consumers (nvblox, a costmap's depth layer) take from a stereo pipeline.

Each fly in front of the left camera whose rounded projection falls in the image writes its
depth along the left optical axis (m) at that pixel; where several flies share a pixel, the
one of highest weight (its confidence, else its fitness) holds it. Pixels without a fly are
NaN in the depth image (REP 118: NaN is "no measurement") and 0 in the weight image.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from flylog.geometry import StereoRig


class SparseDepth(NamedTuple):
    """(H, W) float32 images of the left camera: depth (m, NaN where no fly) and the weight
    of the fly that holds each pixel (0 where none)."""

    depth: np.ndarray
    weight: np.ndarray

    @property
    def filled(self) -> int:
        """Pixels holding a fly."""
        return int(np.count_nonzero(np.isfinite(self.depth)))


def sparse_depth(xyz: np.ndarray, weight: np.ndarray, rig: StereoRig) -> SparseDepth:
    """The flies ``xyz`` (N, 3, base_link) with their ``weight`` (N,) as a sparse depth image
    of ``rig``'s left camera; flies of non-finite or non-positive weight are left out (the
    invalid flies: fitness 0)."""
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    weight = np.asarray(weight, dtype=np.float64).reshape(-1)
    if len(weight) != len(xyz):
        msg = f"sparse_depth needs one weight a fly, got {len(weight)} for {len(xyz)} flies"
        raise ValueError(msg)
    h, w = rig.height, rig.width
    depth = np.full((h, w), np.nan, dtype=np.float32)
    held = np.zeros((h, w), dtype=np.float32)
    if len(xyz) == 0:
        return SparseDepth(depth, held)
    u, _, v, d = rig.project(xyz)
    iu, iv = np.rint(u), np.rint(v)
    keep = (d > 0) & (iu >= 0) & (iu < w) & (iv >= 0) & (iv < h)
    keep &= np.isfinite(weight) & (weight > 0)
    iu, iv, d, wt = iu[keep].astype(np.int64), iv[keep].astype(np.int64), d[keep], weight[keep]
    # Sorted by pixel, then weight: the last fly of each pixel's run is its heaviest.
    flat = iv * w + iu
    order = np.lexsort((wt, flat))
    flat = flat[order]
    last = np.append(flat[1:] != flat[:-1], True)
    pick = order[last]
    depth.reshape(-1)[flat[last]] = d[pick]
    held.reshape(-1)[flat[last]] = wt[pick]
    return SparseDepth(depth, held)
