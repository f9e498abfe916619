import math

import numpy as np
import pytest

from flylog.geometry import Pose2D
from flylog.scene import parse_scene
from flylog.scene.footprints import ray_hits_numpy
from flylog.sensors import SonarConfig
from flylog.sim.sonar import nearest_in_cone, sonar_ranges, true_sonar_ranges

QUIET = SonarConfig(noise_std=0.0, max_range=5.0)


def scene_with(obstacles: str):
    return parse_scene('name = "s"\n' + obstacles, "mem")


def wall_ahead(x, absorbing=False):
    return f"""
[[obstacles]]
kind = "wall"
start = [{x}, -10.0]
end = [{x}, 10.0]
thickness = 0.2
sonar_absorbing = {str(absorbing).lower()}
"""


def test_wall_straight_ahead_gives_known_ranges():
    scene = scene_with(wall_ahead(2.1))  # front face at x = 2.0
    config = SonarConfig(noise_std=0.0, max_range=2.5)
    got = true_sonar_ranges(scene, config, Pose2D())
    mounts = config.mounts()
    half = math.radians(QUIET.cone_deg) / 2
    # Perpendicular distance where the wall's normal lies inside the cone, else along the
    # cone's edge nearest to the normal.
    off = np.maximum(np.abs(mounts[:, 2]) - half, 0.0)
    expect = (2.0 - mounts[:, 0]) / np.cos(off)
    expect[expect > config.max_range] = np.nan
    np.testing.assert_allclose(got, expect, rtol=1e-12)
    assert np.isnan(got[0]) and np.isnan(got[-1])  # the ±50° cones reach the wall at 2.54 m
    assert np.all(np.isfinite(got[1:-1]))
    # Same wall, robot moved: only the relative geometry matters.
    moved = true_sonar_ranges(scene_with(wall_ahead(5.1)), config, Pose2D(3.0, 1.0, 0.0))
    np.testing.assert_allclose(moved, expect, rtol=1e-12)


def test_absorbing_obstacle_is_ignored_and_range_limits_give_nan():
    absorbing = scene_with(wall_ahead(1.1, absorbing=True) + wall_ahead(2.1))
    got = true_sonar_ranges(absorbing, QUIET, Pose2D())
    behind = true_sonar_ranges(scene_with(wall_ahead(2.1)), QUIET, Pose2D())
    np.testing.assert_array_equal(got, behind)
    far = true_sonar_ranges(scene_with(wall_ahead(9.0)), QUIET, Pose2D())
    assert np.all(np.isnan(far))
    blind = SonarConfig(noise_std=0.0, min_range=0.5)
    near = true_sonar_ranges(scene_with(wall_ahead(0.4)), blind, Pose2D())
    assert np.isnan(near[2]) and np.isnan(near[3])


def test_obstacle_behind_or_outside_the_cones_is_not_seen():
    post = '[[obstacles]]\nkind = "cylinder"\ncenter = [-1.5, 0.0]\nradius = 0.2\n'
    assert np.all(np.isnan(true_sonar_ranges(scene_with(post), QUIET, Pose2D())))
    turned = true_sonar_ranges(scene_with(post), QUIET, Pose2D(0.0, 0.0, math.pi))
    # The -10° sonar, now looking back at 170°, sees the post near the edge of its cone:
    # a little farther than the post's nearest point (1.1035 m from the transducer).
    sx, sy = -0.2 * math.cos(math.radians(10)), 0.2 * math.sin(math.radians(10))
    nearest = math.hypot(-1.5 - sx, sy) - 0.2
    assert nearest < turned[2] < nearest + 0.03
    assert np.sum(np.isfinite(turned)) >= 2


def test_exact_cone_distance_matches_a_dense_fan_of_rays():
    text = "\n".join(
        f'[[obstacles]]\nkind = "box"\ncenter = [{x}, {y}]\nsize = [0.6, 0.3]\nyaw_deg = {a}'
        for x, y, a in [(1.5, 0.4, 20), (2.0, -0.6, 70), (3.0, 0.0, 0), (1.2, 1.5, 45)]
    )
    fp = scene_with(text).footprints

    rng = np.random.default_rng(5)
    for _ in range(20):
        yaw, half = rng.uniform(-math.pi, math.pi), math.radians(rng.uniform(5, 30))
        exact = nearest_in_cone(fp, 0.0, 0.0, yaw, half)
        fan = min(
            np.min(ray_hits_numpy(fp, 0.0, 0.0, math.cos(a), math.sin(a))[0])
            for a in np.linspace(yaw - half, yaw + half, 2001)
        )
        assert exact <= fan + 1e-12
        assert (math.isinf(exact) and math.isinf(fan)) or fan - exact < 2e-3


def test_noise_is_seeded_and_has_the_configured_spread():
    scene = scene_with(wall_ahead(2.1))
    config = SonarConfig(noise_std=0.05)
    a = sonar_ranges(scene, config, Pose2D(), np.random.default_rng(9))
    b = sonar_ranges(scene, config, Pose2D(), np.random.default_rng(9))
    np.testing.assert_array_equal(a, b)
    assert np.array_equal(np.isnan(a), np.isnan(true_sonar_ranges(scene, config, Pose2D())))
    rng = np.random.default_rng(10)
    truth = true_sonar_ranges(scene, config, Pose2D())
    errors = np.array([sonar_ranges(scene, config, Pose2D(), rng) - truth for _ in range(400)])
    assert np.nanstd(errors[:, 2]) == pytest.approx(0.05, rel=0.15)
