"""Sonar free space: the cones up to the echoes clear false matches in an empty passage."""

import math

import numpy as np
import pytest

from flylog.geometry import Pose2D
from flylog.planner import HarmonicPlanner, PlannerConfig
from flylog.planner.grid import GridGeometry
from flylog.planner.sonar_free import cone_cells, free_cones
from flylog.sensors import SonarConfig, SonarReading
from tests.planner.references import cone_cells_numpy
from tests.planner.test_map import _passage_flies

GEOMETRY = GridGeometry((-5.0, -5.0), 0.1, 100)
HALF = math.radians(7.5)
WALL_FLIES = 60  # per wall: few beyond the false matches, as in the doorways failure


def _reading(ranges):
    config = SonarConfig()
    return SonarReading(
        0,
        np.asarray(ranges, dtype=float),
        config.mounts(),
        math.radians(config.cone_deg),
        config.max_range,
    )


def test_free_cones_reach_the_echo_less_the_margin_or_the_maximum_range_without_one():
    cones = free_cones(_reading([1.0, np.nan, 2.0, 0.5, np.nan, 3.0]), Pose2D(1, 2, 0.5), 0.15)
    np.testing.assert_allclose(cones[:, 3], [0.85, 2.85, 1.85, 0.35, 2.85, 2.85])
    mounts = SonarConfig().mounts()
    c, s = math.cos(0.5), math.sin(0.5)
    np.testing.assert_allclose(cones[:, 0], 1 + c * mounts[:, 0] - s * mounts[:, 1])
    np.testing.assert_allclose(cones[:, 1], 2 + s * mounts[:, 0] + c * mounts[:, 1])
    np.testing.assert_allclose(cones[:, 2], 0.5 + mounts[:, 2])


def test_cone_cells_lie_half_a_cell_inside_the_edges_and_within_the_reach():
    cones = np.array([[0.0, 0.05, 0.0, 2.0]])  # along +x from the centre row's mid-height
    got = cone_cells(GEOMETRY, cones, HALF)
    xs, ys = GEOMETRY.centres()
    along, across = xs, np.abs(ys - 0.05)
    edge = along * math.sin(HALF) - across * math.cos(HALF)
    np.testing.assert_array_equal(
        got, (edge >= 0.05) & (along > 0) & (np.hypot(xs, ys - 0.05) <= 2.0)
    )
    row = got[50]  # y = 0.05: on the axis from x = 0.45 (0.05 m inside at 0.38 m) to 1.95
    np.testing.assert_array_equal(np.nonzero(row)[0], np.arange(54, 70))
    # y = 0.25, 0.2 m off the axis: half a cell inside the edge from x = 1.90 m
    np.testing.assert_array_equal(np.nonzero(got[52])[0], [69])
    # a window gives the same cells as the whole grid
    rows, cols = slice(40, 70), slice(45, 80)
    np.testing.assert_array_equal(cone_cells(GEOMETRY, cones, HALF, rows, cols), got[rows, cols])
    assert not cone_cells(GEOMETRY, np.array([[0.0, 0.05, 0.0, -0.1]]), HALF).any()


@pytest.mark.parametrize("seed", range(4))
def test_cone_cells_kernel_matches_its_numpy_reference_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    geometry = GridGeometry((rng.uniform(-6, -4), rng.uniform(-6, -4)), 0.1, 100)
    # six cones round a random pose, some with nothing free; windows partly off the grid
    pose = Pose2D(rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-math.pi, math.pi))
    ranges = rng.uniform(0.05, 3.0, 6)
    ranges[rng.random(6) < 0.3] = np.nan
    cones = free_cones(_reading(ranges), pose, 0.15)
    for rows, cols in (
        (slice(None), slice(None)),
        (slice(20, 95), slice(-30, None)),
        (slice(90, 130), slice(0, 7)),
        (slice(50, 40), slice(None)),
    ):
        got = cone_cells(geometry, cones, HALF, rows, cols)
        want = cone_cells_numpy(geometry, cones, HALF, rows, cols)
        assert got.dtype == want.dtype and got.shape == want.shape
        np.testing.assert_array_equal(got, want)
    assert cone_cells(geometry, cones, HALF).any()


def _passage_echoes(pose):
    """The default ring's ranges in the passage of walls y = ±0.6 (heading +x): each cone's
    nearest wall point lies on its outer edge ray; NaN beyond the maximum range."""
    cfg = SonarConfig()
    ranges = []
    for _, y, yaw in cfg.mounts():
        edge = yaw + math.copysign(HALF, yaw)
        wall = math.copysign(0.6, yaw) - (pose.y + y)
        r = wall / math.sin(edge)
        ranges.append(r if r <= cfg.max_range else math.nan)
    return _reading(ranges)


def _false_cluster(rng, pose, n=500):
    """False matches gathered 1–1.6 m ahead in the empty passage, across its middle."""
    return np.column_stack(
        [rng.uniform(pose.x + 1.0, pose.x + 1.6, n), rng.uniform(-0.25, 0.25, n)]
    )


def _drive_with_false_matches(sonar: bool):
    focal = 250.0
    fb, half_fov = focal * 0.12, math.atan2(160.0, focal)
    cfg = PlannerConfig()
    reach = cfg.mapping_range(focal, 0.12)
    p = HarmonicPlanner.centred_on(cfg, (3.0, 0.0), (8.0, 0.0))
    rng = np.random.default_rng(0)
    for k in range(40):  # 2 m down the passage, 5 cm an update
        pose = Pose2D(0.05 * k, 0.0, 0.0)
        flies = np.vstack(
            [
                _passage_flies(rng, pose, fb, half_fov, reach, 1.0, n=WALL_FLIES),
                _false_cluster(rng, pose),
            ]
        )
        cones = None
        if sonar:
            cones = (free_cones(_passage_echoes(pose), pose, cfg.sonar_free_margin), HALF)
        p.update_obstacles(
            flies, pose, half_fov, view_range=reach, focal_baseline=fb, sonar_cones=cones
        )
    return p, pose


def _middle_and_walls(p):
    """The remembered cells' y in the passage's middle (|y| < 0.45 m), and the remembered
    wall cells (0.55 < |y| < 0.8 m) between x = 0.5 and 3.5 m."""
    xs, ys = p.geometry.centres()
    det = p.detected_mask
    walls = det & (np.abs(ys) > 0.55) & (np.abs(ys) < 0.8) & (xs > 0.5) & (xs < 3.5)
    return ys[det & (np.abs(ys) < 0.45)], walls


def test_sonar_free_space_clears_false_matches_inside_the_cones_and_keeps_the_walls():
    without, walls = _middle_and_walls(_drive_with_false_matches(sonar=False)[0])
    with_sonar, walls_with_sonar = _middle_and_walls(_drive_with_false_matches(sonar=True)[0])
    # the cluster's cells across the passage's middle: 0.25 m either side of its axis
    assert without.min() == pytest.approx(-0.25) and without.max() == pytest.approx(0.25)
    # what is left lies dead ahead, between the inner edges of the ±10° cones (2.5° off the
    # axis from transducers 0.035 m either side of it: ±0.09 m at 1.5 m), which hear nothing
    assert len(with_sonar) and np.abs(with_sonar).max() == pytest.approx(0.05)
    # the sonars stop sonar_free_margin short of the walls they echo from
    assert walls.sum() >= 25
    np.testing.assert_array_equal(walls_with_sonar, walls)
