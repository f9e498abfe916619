"""Sparse depth images of fly snapshots (flylog.fly.depth_image)."""

import numpy as np
import pytest

from flylog.fly.depth_image import sparse_depth
from flylog.geometry import StereoRig

RIG = StereoRig(width=64, height=48, focal_px=50.0)


def test_each_fly_writes_its_depth_at_its_rounded_left_pixel():
    rng = np.random.default_rng(3)
    xyz = np.column_stack(
        [rng.uniform(2, 6, 40), rng.uniform(-1, 1, 40), rng.uniform(0.2, 0.8, 40)]
    )
    weight = rng.uniform(0.1, 1.0, 40)
    image = sparse_depth(xyz, weight, RIG)
    u, _, v, d = RIG.project(xyz)
    iu, iv = np.rint(u).astype(int), np.rint(v).astype(int)
    inside = (iu >= 0) & (iu < RIG.width) & (iv >= 0) & (iv < RIG.height)
    assert image.depth.dtype == np.float32 and image.depth.shape == (48, 64)
    for k in np.flatnonzero(inside):
        rivals = inside & (iu == iu[k]) & (iv == iv[k])
        best = np.flatnonzero(rivals)[np.argmax(weight[rivals])]
        assert image.depth[iv[k], iu[k]] == np.float32(d[best])
        assert image.weight[iv[k], iu[k]] == np.float32(weight[best])
    assert image.filled == len({(a, b) for a, b in zip(iu[inside], iv[inside], strict=True)})
    assert np.isnan(image.depth).sum() == 48 * 64 - image.filled
    assert (image.weight[np.isnan(image.depth)] == 0).all()


def test_the_heavier_of_two_flies_on_one_pixel_holds_it_and_invalid_flies_none():
    y = RIG.baseline / 2  # on the left camera's optical axis
    xyz = np.array([[3.0, y, 0.5], [4.0, y, 0.5], [-2.0, y, 0.5], [5.0, y, 0.5]])
    image = sparse_depth(xyz, np.array([0.2, 0.9, 1.0, 0.0]), RIG)
    assert image.filled == 1  # behind the cameras, and weight 0: left out
    assert np.nanmax(image.depth) == pytest.approx(4.0 - RIG.mount_x, rel=1e-6)
    assert np.nanmax(image.weight) == np.float32(0.9)
    with pytest.raises(ValueError, match="one weight a fly"):
        sparse_depth(xyz, np.ones(3), RIG)
