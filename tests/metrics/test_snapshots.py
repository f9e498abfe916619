"""Batched snapshot scores (``score_snapshots``) against each snapshot scored alone
(``score_flies``, a batch of one): identical values, field by field, on rendered views and
on hand-made views with every path of the code (blocks, boundaries, partial cells, empty
snapshots), so no snapshot's score depends on the others in its batch. The definitions
themselves are pinned by known geometry in test_flies.py and test_view.py."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from flylog.geometry import Pose2D, StereoRig
from flylog.metrics.config import MetricsConfig
from flylog.metrics.flies import FlyScore, score_flies, score_snapshots, view_at, views_at
from flylog.metrics.view import TrueViews


def _assert_identical(got: FlyScore, want: FlyScore) -> None:
    for name, a, b in zip(FlyScore._fields, got, want, strict=True):
        if isinstance(b, np.ndarray):
            assert a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True), name
        else:
            assert type(a) is type(b), name
            assert a == b or (math.isnan(a) and math.isnan(b)), (name, a, b)


def _flies(rig: StereoRig, depth: np.ndarray, ids: np.ndarray, block: int, rng) -> np.ndarray:
    """Flies on the view's surfaces (±8 % depth, anywhere in their pixel), random ones in
    front of the camera, and some behind it."""
    v, u = np.nonzero(np.isfinite(depth))
    pick = rng.choice(len(u), size=min(len(u), 120), replace=True)
    d = depth[v[pick], u[pick]] * rng.uniform(0.92, 1.08, len(pick))
    pu = u[pick] * block + (block - 1) / 2.0 + rng.uniform(-block / 2, block / 2, len(pick))
    pv = v[pick] * block + (block - 1) / 2.0 + rng.uniform(-block / 2, block / 2, len(pick))
    on = rig.backproject(pu, pv, d)
    loose = rng.uniform([-1.0, -3.0, -0.2], [8.0, 3.0, 1.5], (40, 3))
    return np.concatenate([on, loose])


def _check_batch(xyzs, depth, ids, rig, n_obstacles, config, block, flies=None) -> None:
    got = score_snapshots(xyzs, depth, ids, rig, n_obstacles, config, flies=flies, block=block)
    assert len(got) == len(xyzs)
    for k, score in enumerate(got):
        want = score_flies(
            xyzs[k],
            depth[k],
            ids[k],
            rig,
            n_obstacles,
            config,
            flies=None if flies is None else flies[k],
            block=block,
        )
        _assert_identical(score, want)


@pytest.mark.parametrize("min_width", [160, 40])  # per pixel, and 4 px blocks
def test_batched_scores_equal_the_reference_on_rendered_views(truth, min_width):
    rng = np.random.default_rng(min_width)
    views = TrueViews(truth.scene, truth.rig, min_width)
    times = truth.true.t_ns[:: max(1, len(truth.true) // 6)]
    rendered = [
        views.view(Pose2D(*truth.true.xyt[np.searchsorted(truth.true.t_ns, t)])) for t in times
    ]
    depth = np.stack([r.depth for r in rendered])
    ids = np.stack([r.ids for r in rendered])
    assert (ids >= 0).any() and (ids == -1).any() and (ids == -2).any()
    xyzs = [_flies(truth.rig, d, i, views.block, rng) for d, i in zip(depth, ids, strict=True)]
    xyzs[1] = np.empty((0, 3))  # a snapshot without obstacle flies
    n_obstacles = len(truth.scene.obstacles)
    counts = [len(x) + 7 for x in xyzs]
    for config in (MetricsConfig(), MetricsConfig(cell_px=6, tau=0.1)):  # 6 px cells cut blocks
        _check_batch(xyzs, depth, ids, truth.rig, n_obstacles, config, views.block, counts)


@pytest.mark.parametrize(
    ("size", "block", "cell"),
    [
        ((64, 48), 4, 16),  # whole cells of whole blocks (640x480 in 4 px blocks, 16 px cells)
        ((48, 32), 1, 16),  # whole cells, per pixel
        ((40, 30), 2, 16),  # partial cells at the bottom and right
        ((42, 30), 3, 4),  # cells cutting through blocks
    ],
)
def test_batched_scores_equal_the_reference_on_hand_made_views(size, block, cell):
    """Every way cells tile the view; ids of obstacles beyond the count given."""
    rng = np.random.default_rng(block)
    rig = StereoRig(width=size[0], height=size[1], focal_px=30.0, baseline=0.1, mount_height=0.5)
    shape = (5, size[1] // block, size[0] // block)
    depth = rng.uniform(1.0, 6.0, shape).astype(np.float32)
    ids = rng.integers(-2, 4, shape).astype(np.int16)
    depth[ids == -2] = np.inf
    depth[:, :, : shape[2] // 2] = 3.0  # one wide surface, for interpolated depths
    ids[:, :, : shape[2] // 2] = 1
    xyzs = [_flies(rig, depth[k], ids[k], block, rng) for k in range(5)]
    _check_batch(xyzs, depth, ids, rig, 3, MetricsConfig(cell_px=cell), block)


def test_batched_view_lookup_equals_the_reference_per_snapshot():
    rng = np.random.default_rng(3)
    depth = rng.uniform(1.0, 5.0, (3, 8, 10)).astype(np.float32)
    ids = rng.integers(-1, 2, (3, 8, 10)).astype(np.int16)
    s = np.repeat(np.arange(3), 50)
    iu, iv = rng.integers(0, 40, 150), rng.integers(0, 32, 150)
    d = rng.uniform(1.0, 5.0, 150)
    got_d, got_id = views_at(depth, ids, s, iu, iv, d, 0.05, 4)
    for k in range(3):
        sel = s == k
        want_d, want_id = view_at(depth[k], ids[k], iu[sel], iv[sel], d[sel], 0.05, 4)
        assert np.array_equal(got_d[sel], want_d) and np.array_equal(got_id[sel], want_id)


def test_an_empty_batch_and_views_of_the_wrong_shape():
    rig = StereoRig(width=40, height=30, focal_px=40.0)
    empty = np.empty((0, 15, 20), dtype=np.float32)
    assert (
        score_snapshots([], empty, empty.astype(np.int16), rig, 1, MetricsConfig(), block=2) == []
    )
    depth = np.full((1, 15, 20), 2.0, dtype=np.float32)
    with pytest.raises(ValueError, match="true views of shape"):
        score_snapshots([np.zeros((1, 3))], depth, depth.astype(np.int16), rig, 1, MetricsConfig())


def test_batched_scores_do_not_depend_on_the_batch():
    """Snapshot k scores the same alone or among others."""
    rng = np.random.default_rng(11)
    rig = dataclasses.replace(StereoRig(), width=64, height=48, focal_px=50.0)
    depth = rng.uniform(1.0, 6.0, (4, 12, 16)).astype(np.float32)
    ids = rng.integers(-1, 3, (4, 12, 16)).astype(np.int16)
    xyzs = [_flies(rig, depth[k], ids[k], 4, rng) for k in range(4)]
    together = score_snapshots(xyzs, depth, ids, rig, 3, MetricsConfig(), block=4)
    for k in range(4):
        alone = score_snapshots(
            xyzs[k : k + 1], depth[k : k + 1], ids[k : k + 1], rig, 3, MetricsConfig(), block=4
        )[0]
        _assert_identical(together[k], alone)
