"""The SGBM baseline engine: known geometry, the simulator's frames, determinism, motion."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from flylog.baseline import SgbmConfig
from flylog.baseline.sgbm import (
    MATCHED_AGE,
    SgbmEngine,
    disparity_px,
    sampled_pixels,
    search_start_px,
    stereo_matcher,
    texture_confidence,
)
from flylog.config import from_mapping
from flylog.errors import ConfigError, FlylogError
from flylog.fly import ObstacleFlies
from flylog.fly.population import fitness_summary
from flylog.geometry import Pose2D, StereoRig
from flylog.geometry.proprioception import moved_by_odometry
from flylog.sensors import SonarReading, StereoPair

SCENES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
RIG = StereoRig(width=320, height=240, focal_px=250.0)
CONFIG = SgbmConfig()


def shifted_pair(rig: StereoRig, disparity: int, seed: int = 0) -> StereoPair:
    """A fronto-parallel textured plane at constant ``disparity``: R(u) = L(u + d)."""
    rng = np.random.default_rng(seed)
    # blobs of a few pixels: texture SGBM can match without aliasing
    coarse = rng.uniform(0, 255, (rig.height // 3 + 2, (rig.width + disparity) // 3 + 2))
    texture = np.kron(coarse, np.ones((3, 3)))[: rig.height, : rig.width + disparity]
    texture = texture.astype(np.uint8)
    left = np.ascontiguousarray(texture[:, : rig.width])
    right = np.ascontiguousarray(texture[:, disparity : disparity + rig.width])
    return StereoPair(7, left, right)


@pytest.fixture(scope="module")
def corridor_frame():
    """A 320×240 frame of the corridor scene from its start pose, and its true depth."""
    from flylog.scene.load import load_scene
    from flylog.sim.render import Renderer

    scene = load_scene(SCENES / "corridor.toml")
    cam = scene.spec.camera
    rig = dataclasses.replace(cam, width=320, height=240, focal_px=cam.focal_px * 320 / cam.width)
    frame = Renderer(scene, rig).render(scene.start_pose)
    return rig, StereoPair(11, frame.left, frame.right), frame.depth.astype(float)


def stepped(pair: StereoPair, rig: StereoRig = RIG, config: SgbmConfig = CONFIG, points=2000):
    engine = SgbmEngine(config, rig, points=points)
    engine.set_images(pair)
    return engine, engine.step()


def test_plane_at_known_disparity_gives_its_depth_everywhere():
    d = 12
    engine, _ = stepped(shifted_pair(RIG, d))
    pop = engine.population
    assert fitness_summary(pop.fitness)[1] == len(pop) == 2000
    depth = pop.xyz[:, 0] - RIG.mount_x
    true = RIG.focal_px * RIG.baseline / d
    assert np.mean(np.abs(depth - true) <= 0.01 * true) > 0.98
    # back-projection puts each point on the ray of its left pixel
    u, _, v, _ = RIG.project(pop.xyz)
    assert np.allclose(u, np.rint(u)) and np.allclose(v, np.rint(v))
    # no disparity in the leftmost num_disparities columns (OpenCV leaves them unmatched)
    assert u.min() >= CONFIG.num_disparities - 1


def test_corridor_frame_points_lie_at_the_true_depth(corridor_frame):
    rig, pair, true_depth = corridor_frame
    engine, _ = stepped(pair, rig, points=5000)
    pop = engine.population
    assert len(pop) == 5000
    u, _, v, depth = rig.project(pop.xyz)
    truth = true_depth[np.rint(v).astype(int), np.rint(u).astype(int)]
    # a point on a sky pixel (block edges at silhouettes, ~1.5%) is simply wrong
    sky = ~np.isfinite(truth)
    rel = np.abs(depth - np.where(sky, 1.0, truth)) / np.where(sky, 1.0, truth)
    rel[sky] = np.inf
    # measured 0.93 (the rest: block edges on depth discontinuities, the untextured box)
    assert np.mean(rel <= 0.05) > 0.9
    assert np.median(rel) < 0.03


def test_fitness_is_positive_texture_and_age_passes_any_min_age(corridor_frame):
    rig, pair, _ = corridor_frame
    pop = stepped(pair, rig)[0].population
    assert (pop.fitness >= 1.0).all()
    assert np.array_equal(pop.fitness, pop.vision)
    assert (pop.age == MATCHED_AGE).all() and not pop.stale.any()
    assert (pop.stamp_ns == pair.stamp_ns).all()
    # the obstacle rule's quantile keeps the better-textured share above the ground
    rule = ObstacleFlies(quantile=0.5, ground_margin=0.05, min_age=1000, min_distinctness=0.0)
    keep = rule.mask(pop.xyz, pop.fitness, pop.age)
    above = pop.xyz[:, 2] > 0.05
    assert keep.sum() > 0
    assert np.array_equal(keep, above & (pop.fitness > np.quantile(pop.fitness, 0.5)))


def test_same_pair_same_cloud_and_sonar_changes_nothing(corridor_frame):
    rig, pair, _ = corridor_frame
    a = stepped(pair, rig)[0].population
    engine = SgbmEngine(CONFIG, rig, points=2000)
    engine.set_images(pair)
    reading = SonarReading(0, np.full(6, 0.8), np.zeros((6, 3)), math.radians(15), 3.0)
    engine.set_sonar(reading)
    engine.step()
    b = engine.population
    for name in ("xyz", "fitness", "age", "stamp_ns"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name


def test_motion_moves_the_cloud_and_counts_for_a_pair_not_yet_matched(corridor_frame):
    rig, pair, _ = corridor_frame
    inc = Pose2D(0.05, 0.01, 0.03)
    before_step = SgbmEngine(CONFIG, rig, points=2000)
    before_step.set_images(pair)
    before_step.apply_motion(inc)  # odometry arrives before the frame is processed
    before_step.step()
    after_step, _ = stepped(pair, rig)
    still = after_step.population.xyz
    after_step.apply_motion(inc)
    moved = after_step.population.xyz
    assert np.allclose(moved, moved_by_odometry(still, inc))
    assert np.allclose(before_step.population.xyz, moved)
    # a new pair starts from no motion
    before_step.set_images(pair)
    before_step.step()
    assert np.array_equal(before_step.population.xyz, still)


def test_sampled_pixels_are_evenly_spaced_valid_pixels_in_raster_order():
    disparity = np.full((4, 5), -1.0, dtype=np.float32)
    disparity[1:, 1:] = 3.0  # 12 valid pixels, raster indices 6..9, 11..14, 16..19
    u, v = sampled_pixels(disparity, 2.0, 4)
    assert list(zip(v.tolist(), u.tolist(), strict=True)) == [(1, 1), (1, 4), (2, 3), (3, 2)]
    u, v = sampled_pixels(disparity, 2.0, 100)  # fewer valid than asked: all of them
    assert len(u) == 12 and (disparity[v, u] == 3.0).all()
    u, v = sampled_pixels(disparity, 4.0, 10)
    assert len(u) == len(v) == 0


def test_texture_confidence_is_one_on_flat_grey_and_rises_at_an_edge():
    flat = np.full((20, 30), 90, dtype=np.uint8)
    v, u = np.divmod(np.arange(20 * 30), 30)
    assert np.array_equal(texture_confidence(flat, 5, u, v), np.ones(20 * 30))
    edge = flat.copy()
    edge[:, 15:] = 190
    conf = texture_confidence(edge, 5, u, v).reshape(20, 30)
    assert conf[10, 15] > conf[10, 12] > conf[10, 5] == 1.0
    # a pixel's value is the mean Sobel norm of its block: 400 at the step, 0 beyond ±1 px
    norm = np.zeros(30)
    norm[14:16] = 4 * 100
    assert conf[10, 16] == pytest.approx(1.0 + norm[14:19].sum() / 5)
    # the block is reflected at the border
    assert np.array_equal(conf[0], conf[10])


def test_empty_frame_gives_an_empty_cloud():
    flat = np.full((RIG.height, RIG.width), 128, dtype=np.uint8)
    engine, stats = stepped(StereoPair(3, flat, flat))
    assert len(engine.population) == 0 and stats.evaluations == 0


def test_errors_name_the_problem():
    engine = SgbmEngine(CONFIG, RIG, points=10)
    with pytest.raises(FlylogError, match="no images yet"):
        engine.step()
    small = np.zeros((10, 10), dtype=np.uint8)
    with pytest.raises(FlylogError, match=r"do not match the rig's \(240, 320\)"):
        engine.set_images(StereoPair(0, small, small))
    with pytest.raises(FlylogError, match="must be below the image width"):
        SgbmEngine(SgbmConfig(num_disparities=320), RIG, points=10)
    with pytest.raises(FlylogError, match="baseline > 0"):
        SgbmEngine(CONFIG, dataclasses.replace(RIG, baseline=0.0), points=10)


@pytest.mark.parametrize(
    ("table", "needle"),
    [
        ({"num_disparities": 40}, "multiple of 16, got 40"),
        ({"block_size": 4}, "block_size must be odd"),
        ({"p1_factor": 40}, "p2_factor (32) must exceed p1_factor (40)"),
        ({"mode": "fast"}, "field 'sgbm.mode': expected one of 'sgbm', 'sgbm-3way'"),
    ],
)
def test_config_errors_name_file_and_field(table, needle):
    with pytest.raises(ConfigError) as err:
        from_mapping(SgbmConfig, table, source="run.toml", prefix="sgbm")
    assert needle in str(err.value) and "run.toml" in str(err.value)


def test_cost_is_the_configured_seconds_per_frame():
    assert SgbmConfig(seconds_per_frame=0.04).cost_ns == 40_000_000


@pytest.mark.parametrize("doffs", [-20.0, -20.5, 4.5])
def test_the_search_covers_the_pixel_disparities_of_a_rig_with_doffs(doffs):
    # d = f·B/Z − doffs: with doffs = −20 every point's disparity is above 20 px, beyond a
    # search of 16 disparities from 0; a plane at f·B/Z = 10 px is at d = 10 − doffs px
    config = dataclasses.replace(CONFIG, num_disparities=16)
    rig = dataclasses.replace(RIG, doffs=doffs)
    d = round(10 - doffs)  # the images shift by whole pixels
    engine, _ = stepped(shifted_pair(rig, d), rig=rig, config=config)
    pop = engine.population
    assert len(pop) == 2000
    depth = pop.xyz[:, 0] - rig.mount_x
    true = rig.fb / (d + doffs)
    assert np.mean(np.abs(depth - true) <= 0.01 * true) > 0.98
    u, ur, _, _ = rig.project(pop.xyz)
    assert np.median(u - ur) == pytest.approx(d, abs=0.05)
    start = search_start_px(doffs)
    assert start == (20 if doffs < 0 else 0)
    pair = shifted_pair(rig, d)
    dense = disparity_px(stereo_matcher(config, doffs), pair.left, pair.right)
    assert np.nanmin(dense) >= start and np.isnan(dense[:, : start + 16 - 1]).all()


def test_a_disparity_at_infinity_counts_against_the_image_width():
    with pytest.raises(FlylogError, match=r"less the rig's disparity at infinity \(300 px\)"):
        SgbmEngine(CONFIG, dataclasses.replace(RIG, doffs=-300.0), points=10)
