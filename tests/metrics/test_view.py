"""The true view in pixel blocks: the block rig's rays, depth lookups, cell counts, and the
agreement of decimated metrics with per-pixel ones on a fixture log."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from flylog.geometry import Pose2D, StereoRig
from flylog.metrics.config import MetricsConfig
from flylog.metrics.flies import cell_counts, score_flies, view_at
from flylog.metrics.score import score_run
from flylog.metrics.view import TrueViews, block_rig, view_block
from flylog.sources import read_truth

from .helpers import true_view, write_run

FIXTURE_LOGS = Path(__file__).resolve().parents[2] / "fixtures" / "logs"


@pytest.mark.parametrize(
    ("size", "min_width", "block"),
    [
        ((640, 480), 160, 4),  # the default on the reference camera
        ((160, 120), 160, 1),  # already that narrow: every pixel
        ((640, 480), 100, 5),  # 640 / 6 < 100 would be narrower; 5 divides 640 and 480
        ((752, 480), 160, 4),  # 752 / 4 = 188; 752 is not a multiple of 3
        ((100, 75), 20, 5),
        ((97, 61), 10, 1),  # coprime sizes: no block tiles the image
    ],
)
def test_block_is_the_largest_divisor_leaving_the_view_wide_enough(size, min_width, block):
    rig = StereoRig(width=size[0], height=size[1])
    assert view_block(rig, min_width) == block


def test_block_rig_renders_the_rays_through_the_block_centres(truth):
    """With odd blocks the centre is a pixel of the full image: the coarse view is exactly
    the full view sampled there."""
    rig = dataclasses.replace(truth.rig, width=96, height=72, focal_px=truth.rig.focal_px * 0.6)
    pose = Pose2D(*truth.true.xyt[len(truth.true) // 2])
    full = TrueViews(truth.scene, rig).view(pose)
    coarse = TrueViews(truth.scene, rig, min_width=32).view(pose)
    assert (full.block, coarse.block) == (1, 3)
    assert coarse.depth.shape == (24, 32)
    assert np.array_equal(coarse.ids, full.ids[1::3, 1::3])
    assert (coarse.ids >= 0).any() and (coarse.ids == -1).any()  # obstacles and ground
    np.testing.assert_allclose(coarse.depth, full.depth[1::3, 1::3], rtol=1e-5)
    with pytest.raises(ValueError, match="do not tile"):
        block_rig(rig, 5)


def _plane_view(block: int, *, width: int = 40, height: int = 32):
    """A plane with 1/D = a + b·u + c·v over the full image, sampled at block centres."""
    a, b, c = 0.05, 0.004, 0.007
    rows, cols = height // block, width // block
    v, u = np.mgrid[0:rows, 0:cols] * block + (block - 1) / 2.0
    depth = (1.0 / (a + b * u + c * v)).astype(np.float32)
    return depth, np.full((rows, cols), 3, dtype=np.int16), (a, b, c)


@pytest.mark.parametrize("block", [2, 4])
def test_depth_on_a_plane_is_interpolated_exactly_even_at_the_edges(block):
    depth, ids, (a, b, c) = _plane_view(block)
    v, u = np.mgrid[0:32, 0:40]
    want = 1.0 / (a + b * u.ravel() + c * v.ravel())
    for fly_depth in (want, 2.0 * want):  # on the plane, or far behind it: the same D
        got, hit = view_at(depth, ids, u.ravel(), v.ravel(), fly_depth, 0.05, block)
        np.testing.assert_allclose(got, want, rtol=1e-6)
        assert (hit == 3).all()


def test_pixels_near_a_boundary_are_judged_against_the_side_their_fly_matches():
    """The sky above pixel row 16 (block rows 0–3 of 4 px)."""
    depth, ids, (a, b, c) = _plane_view(4)
    depth[:4], ids[:4] = np.inf, -2

    def plane(u, v):
        return 1.0 / (a + b * u + c * v)

    # Rows 16–17: the plane's own blocks, with sky among the centres around: extrapolated.
    v, u = np.mgrid[16:18, 0:40]
    u, v = u.ravel(), v.ravel()
    got, hit = view_at(depth, ids, u, v, plane(u, v), 0.05, 4)
    np.testing.assert_allclose(got, plane(u, v), rtol=1e-6)
    assert (hit == 3).all()
    # Row 15: a sky block within a block of the plane: a fly on the plane (within tau) is
    # judged against the plane; one far behind it against the block's own sky.
    on, behind = plane(20, 15), 5.0 * plane(20, 15)
    u, v = np.array([20, 20]), np.array([15, 15])
    got, hit = view_at(depth, ids, u, v, np.array([on * 1.04, behind]), 0.05, 4)
    assert got[0] == pytest.approx(on, rel=1e-6) and hit[0] == 3
    assert np.isinf(got[1]) and hit[1] == -2
    # Row 5: sky all around.
    got, hit = view_at(depth, ids, np.array([20]), np.array([5]), np.array([3.0]), 0.05, 4)
    assert np.isinf(got[0]) and hit[0] == -2


def test_beside_a_silhouette_a_fly_is_judged_against_the_side_it_matches():
    """A wall (id 0) at 2 m seen by the centres of block columns 0–3 (pixels 1.5 … 13.5),
    the ground plane (id -1) from block column 4 on: pixel 16 is between the two."""
    ground, _, (a, b, c) = _plane_view(4)
    ids = np.full(ground.shape, -1, dtype=np.int16)
    depth = ground.copy()
    depth[:, :4], ids[:, :4] = 2.0, 0
    on_ground = 1.0 / (a + b * 16 + c * 12)  # 5.05 m
    u, v = np.full(3, 16), np.full(3, 12)
    got, hit = view_at(depth, ids, u, v, np.array([2.0, on_ground, 3.5]), 0.05, 4)
    assert got[0] == pytest.approx(2.0) and hit[0] == 0
    assert got[1] == pytest.approx(on_ground) and hit[1] == -1
    # On neither side: judged against the own block's side (the ground), extrapolated.
    assert got[2] == pytest.approx(on_ground) and hit[2] == -1


def test_one_pixel_blocks_read_the_pixel_itself():
    depth, ids, _ = _plane_view(1)
    depth[3, 7], ids[3, 7] = np.inf, -2
    u, v = np.array([0, 7, 39]), np.array([31, 3, 0])
    got, hit = view_at(depth, ids, u, v, np.array([5.0, 5.0, 5.0]), 0.05, 1)
    assert np.array_equal(got, depth[v, u].astype(float)) and np.array_equal(hit, ids[v, u])


@pytest.mark.parametrize(("block", "cell"), [(1, 3), (2, 4), (4, 16), (4, 6), (3, 5)])
def test_cell_counts_of_blocks_equal_those_of_the_pixels_they_cover(block, cell):
    rng = np.random.default_rng(block * 10 + cell)
    mask = rng.random((60 // block, 84 // block)) < 0.3
    pixels = mask.repeat(block, axis=0).repeat(block, axis=1)
    hits, sizes = cell_counts(mask, cell, block)
    rows, cols = math.ceil(60 / cell), math.ceil(84 / cell)
    assert hits.shape == sizes.shape == (rows, cols)
    for r in range(rows):
        for c in range(cols):
            window = pixels[r * cell : (r + 1) * cell, c * cell : (c + 1) * cell]
            assert (hits[r, c], sizes[r, c]) == (window.sum(), window.size)


def test_score_of_a_blocky_view_counts_pixels():
    rig = StereoRig(width=40, height=30, focal_px=40.0, baseline=0.1, mount_height=0.5)
    depth = np.full((15, 20), np.inf, dtype=np.float32)
    ids = np.full((15, 20), -2, dtype=np.int16)
    depth[:, :10], ids[:, :10] = 4.0, 0  # a wall ahead in the left 20 pixel columns
    v, u = np.mgrid[0:30, 0:20]
    flies = rig.backproject(u.ravel().astype(float), v.ravel().astype(float), np.full(600, 4.0))
    score = score_flies(flies, depth, ids, rig, 1, MetricsConfig(cell_px=10), block=2)
    assert (score.in_view, score.on_surface, score.on_obstacle) == (600, 600, 600)
    assert score.visible_pixels.tolist() == [600]
    assert (score.visible_cells, score.covered_cells) == (6, 6)
    with pytest.raises(ValueError, match="true view of shape"):
        score_flies(flies, depth, ids, rig, 1, MetricsConfig(), block=1)


def _mixed_flies(truth, t_ns: int, rng: np.random.Generator) -> np.ndarray:
    """What a replay leaves: flies on the obstacles' true surfaces (anywhere within their
    pixel) with depth noise of ±8 % (τ = 5 %: some on, some off), plus random flies."""
    depth, ids = true_view(truth, t_ns)
    v, u = np.nonzero(ids >= 0)
    pick = rng.choice(len(u), size=min(len(u), 50), replace=False)
    u, v, d = u[pick], v[pick], depth[v[pick], u[pick]] * rng.uniform(0.92, 1.08, len(pick))
    jitter = rng.uniform(-0.49, 0.49, (2, len(pick)))
    on = truth.rig.backproject(u + jitter[0], v + jitter[1], d)
    return np.concatenate([on, rng.uniform([0.5, -2.0, 0.1], [6.0, 2.0, 1.2], (30, 3))])


@pytest.mark.parametrize("name", ["corridor", "clutter"])
def test_decimated_figures_agree_with_per_pixel_ones_on_a_fixture(name, tmp_path):
    """On these 160×120 logs 2 px blocks see obstacles as 4 px blocks do on 320×240 ones:
    what is lost is the fly near a silhouette whose block sees the other side."""
    log = FIXTURE_LOGS / f"{name}.mcap"
    truth = read_truth(log)
    assert (truth.rig.width, truth.rig.height) == (160, 120)
    rng = np.random.default_rng(7)
    times = truth.true.t_ns[5 :: max(1, len(truth.true) // 8)][:8]
    run = write_run(tmp_path / "run.mcap", [(int(t), _mixed_flies(truth, t, rng)) for t in times])
    full = score_run(run, log, MetricsConfig(truth_width=160)).summary
    assert 0.2 < full["precision"] < 0.8 and 0.2 < full["recall"] < 0.95  # neither 0 nor 1
    for width, tolerance in ((80, 0.02), (40, 0.035)):  # blocks of 2 and 4 px
        coarse = score_run(run, log, MetricsConfig(truth_width=width)).summary
        for key in ("precision", "recall", "f_score"):
            assert coarse[key] == pytest.approx(full[key], abs=tolerance), (width, key)
        assert coarse["median_depth_error"] == pytest.approx(
            full["median_depth_error"], abs=tolerance / 5
        )
        assert coarse["nearest_error_m"] == pytest.approx(full["nearest_error_m"], abs=0.05)
