"""The visual heading (flylog.fly.heading): the flies measure the odometry's turn error."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from flylog.errors import ConfigError
from flylog.fly.heading import (
    HeadingConfig,
    comparable_flies,
    depth_insensitive,
    fused_yaw,
    measure_yaw,
    scan_peak,
    yaw_scores_numba,
    yaw_scores_numpy,
)
from flylog.geometry import Pose2D, compose
from flylog.scene.load import load_scene
from flylog.sim.render import Renderer

SCENES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
TURN = 0.5 / 15  # rad: one frame period (15 Hz) turning on the spot at 0.5 rad/s


@pytest.fixture(scope="module")
def corridor():
    """The corridor scene seen at 320×240 (focal 250 px, the closed loop's), and points on
    its surfaces: the true depth under 6000 pixels (continuous positions) of the start view."""
    scene = load_scene(SCENES / "corridor.toml")
    rig = dataclasses.replace(scene.spec.camera, width=320, height=240, focal_px=250.0)
    renderer = Renderer(scene, rig)
    start = scene.start_pose
    first = renderer.render(start)
    rng = np.random.default_rng(0)
    u, v = rng.uniform(4, rig.width - 4, 6000), rng.uniform(4, rig.height - 4, 6000)
    depth = first.depth[np.round(v).astype(int), np.round(u).astype(int)].astype(float)
    seen = np.isfinite(depth)
    points = rig.backproject(u[seen], v[seen], depth[seen])
    return rig, renderer, start, first, points


def _after(corridor, increment: Pose2D, error_px: float):
    """The pair seen after the robot moved by ``increment`` and turned ``error_px`` (pixels
    at the image centre) more than that."""
    rig, renderer, start, _, _ = corridor
    extra = Pose2D(0.0, 0.0, error_px / rig.focal_px)
    return renderer.render(compose(compose(start, increment), extra))


@pytest.mark.parametrize(
    ("increment", "error_px"),
    [
        (Pose2D(0.0, 0.0, TURN), 0.0),
        (Pose2D(0.0, 0.0, TURN), 0.6),
        (Pose2D(0.0, 0.0, -TURN), -0.9),
        (Pose2D(0.0, 0.0, 2 * TURN), 1.2),
        (Pose2D(0.03, 0.0, 0.01), -0.4),  # driving 0.45 m/s, turning 0.15 rad/s
    ],
)
def test_the_scan_finds_the_turn_the_odometry_missed(corridor, increment, error_px):
    # Measured: errors 0.01-0.05 px on these five (the closed-loop spread is 0.11 px).
    rig, _, _, first, points = corridor
    after = _after(corridor, increment, error_px)
    config = HeadingConfig()
    found = measure_yaw(
        (first.left, first.right), (after.left, after.right), points, increment, rig, config
    )
    assert found.flies == config.flies
    assert found.yaw is not None
    assert found.yaw * rig.focal_px == pytest.approx(error_px, abs=0.1)


def test_numba_and_numpy_scans_agree(corridor):
    rig, _, _, first, points = corridor
    increment = Pose2D(0.01, 0.0, TURN)
    after = _after(corridor, increment, 0.4)
    offsets = HeadingConfig().offsets(rig.focal_px)
    chosen = points[comparable_flies(points, increment, rig, offsets, 7)][:500]
    pairs = (first.left, first.right), (after.left, after.right)
    args = (*pairs, chosen, increment, rig, offsets, 7, 1.0)
    np.testing.assert_allclose(yaw_scores_numba(*args), yaw_scores_numpy(*args), rtol=1e-12)


def test_grey_images_give_the_same_scan_as_numpy(corridor):
    rig, _, _, first, points = corridor
    increment = Pose2D(0.0, 0.0, -TURN)
    after = _after(corridor, increment, -0.3)
    grey = [
        np.ascontiguousarray(a[:, :, 1]) for a in (first.left, first.right, after.left, after.right)
    ]
    offsets = HeadingConfig().offsets(rig.focal_px)
    chosen = points[comparable_flies(points, increment, rig, offsets, 5)][:300]
    args = ((grey[0], grey[1]), (grey[2], grey[3]), chosen, increment, rig, offsets, 5, 1.0)
    np.testing.assert_allclose(yaw_scores_numba(*args), yaw_scores_numpy(*args), rtol=1e-12)


def test_too_few_flies_measure_nothing(corridor):
    rig, _, _, first, points = corridor
    after = _after(corridor, Pose2D(0.0, 0.0, TURN), 0.5)
    config = HeadingConfig(min_flies=100)
    pairs = (first.left, first.right), (after.left, after.right)
    found = measure_yaw(*pairs, points[:50], Pose2D(0.0, 0.0, TURN), rig, config)
    assert found.yaw is None
    assert found.flies <= 50


def test_flies_leaving_the_images_over_the_scan_are_not_compared(corridor):
    rig, _, _, _, _ = corridor
    offsets = HeadingConfig().offsets(rig.focal_px)
    # one fly 3 m ahead at the image centre, one at the left border, one behind the cameras
    edge_y = (rig.cx - 3) * 3.0 / rig.focal_px + rig.baseline / 2
    points = np.array([[3.1, 0.06, 0.5], [3.1, edge_y, 0.5], [-1.0, 0.0, 0.5]])
    ok = comparable_flies(points, Pose2D(), rig, offsets, 7)
    assert ok.tolist() == [True, False, False]


def test_scan_peak_is_the_vertex_of_the_parabola_and_none_at_the_ends():
    offsets = np.arange(-4, 5) * 0.25
    assert scan_peak(offsets, -((offsets - 0.3) ** 2)) == pytest.approx(0.3)
    assert scan_peak(offsets, offsets) is None  # rising to the last: the peak may lie beyond
    assert scan_peak(offsets, -offsets) is None


def test_the_odometry_variance_follows_the_turn_rate_noise():
    config = HeadingConfig()
    # 1/15 s turning at 0.5 rad/s: sd = 0.5 deg/s + 5 % of 0.5 rad/s per 20 ms step
    sd = math.radians(0.5) + 0.05 * 0.5
    expected = (1 / 15) * sd * sd / 50.0
    assert config.odometry_variance(Pose2D(0.0, 0.0, 0.5 / 15), 1 / 15) == pytest.approx(expected)
    assert config.odometry_variance(Pose2D(), 1 / 15) == 0.0  # standing still: no error
    assert config.odometry_variance(Pose2D(0.03, 0.0, 0.0), 0.0) == 0.0


def test_the_fused_turn_weighs_odometry_against_the_measurement():
    assert fused_yaw(0.002, 1e-6, 1e-3) == pytest.approx(0.001)  # equal variances: half
    assert fused_yaw(0.002, 0.0, 1e-3) == 0.0  # odometry without error: no correction
    assert fused_yaw(0.002, 1.0, 1e-6) == pytest.approx(0.002)  # exact measurement: all of it
    # gated: 2 mrad off against an innovation sd of sqrt(2) mrad is 1.41 sd
    assert fused_yaw(0.002, 1e-6, 1e-3, gate=1.5) == pytest.approx(0.001)
    assert fused_yaw(0.002, 1e-6, 1e-3, gate=1.4) == 0.0


def test_the_scan_is_symmetric_and_an_even_window_is_refused():
    offsets = HeadingConfig(span_px=1.5, step_px=0.25).offsets(250.0)
    assert len(offsets) == 13
    np.testing.assert_allclose(offsets, -offsets[::-1])
    assert offsets[6] == 0.0
    with pytest.raises(ConfigError, match=r"heading\.window must be odd"):
        HeadingConfig(window=6)


def test_a_measurement_is_due_after_the_keyframe_distance_turn_or_pairs():
    cfg = HeadingConfig(keyframe_distance=0.2, keyframe_turn_deg=20.0, keyframe_frames=15)
    assert not cfg.due(Pose2D(0.19, 0.0, math.radians(19.9)), 14)
    assert cfg.due(Pose2D(0.12, 0.16, 0.0), 1)  # 0.2 m, whichever way
    assert cfg.due(Pose2D(0.0, 0.0, -math.radians(20.0)), 1)
    assert cfg.due(Pose2D(0.0, 0.0, 0.0), 15)


def test_turning_on_the_spot_every_fly_is_depth_insensitive_driving_the_near_edges_are_not(
    corridor,
):
    rig, _, _, _, points = corridor
    # 20° on the spot moves the cameras 0.1 m·0.35 sideways: a 0.5 px disparity error moves
    # every fly's column by 0.035 · 0.5 / 0.12 = 0.15 px, within 0.2
    turned = Pose2D(0.0, 0.0, math.radians(20.0))
    assert depth_insensitive(points, turned, rig, 0.5, 0.2).all()
    # 0.2 m ahead the column moves from u to cx + (u − cx)·Z/(Z − t): a disparity error δ
    # (a depth error Z²·δ/(focal·baseline)) moves it by |u − cx|·t·Z²/(Z − t)²·δ/(focal·baseline)
    # to first order
    u, _, _, z = rig.project(points)
    t = 0.2
    moves = np.abs(u - rig.cx) * t * z**2 / (z - t) ** 2 * 0.5 / (rig.focal_px * rig.baseline)
    kept = depth_insensitive(points, Pose2D(t, 0.0, 0.0), rig, 0.5, 0.2)
    assert kept[moves < 0.17].all() and not kept[moves > 0.23].any()
    assert 0.2 < kept.mean() < 0.8
