import math

import numpy as np
import pytest

from flylog.geometry import Pose2D
from flylog.planner import HarmonicPlanner, PlannerConfig
from flylog.planner import obstacles as obs
from flylog.planner.grid import GridGeometry
from flylog.sensors import SonarReading
from tests.planner.references import box_sum, dense_cells_numpy, seen_free_numpy

# 10 m grid at 0.1 m centred on the origin; the robot at the origin looking along +x.
CFG = PlannerConfig(
    extent=10.0,
    cell_size=0.1,
    robot_radius=0.0,
    inflation_margin=0.0,
    density_radius=0.1,
    confirm_after_views=1,
)
ROBOT = Pose2D(0.0, 0.0, 0.0)
FOV = math.radians(30.0)


def _planner(**changes) -> HarmonicPlanner:
    cfg = PlannerConfig(**{**CFG.__dict__, **changes})
    return HarmonicPlanner.centred_on(cfg, (0.0, 0.0), (4.0, 4.0))


def _cluster(x: float, y: float, n: int) -> np.ndarray:
    # n flies inside the cell whose centre is (x, y), with a z column (ignored)
    rng = np.random.default_rng(n)
    xy = np.array([x, y]) + rng.uniform(-0.04, 0.04, size=(n, 2))
    return np.column_stack([xy, np.full(n, 0.5)])


def _cell(p: HarmonicPlanner, x: float, y: float) -> tuple[int, int]:
    return p.geometry.cell_of(x, y)


def test_density_threshold_counts_flies_per_square_metre():
    # window 3x3 cells = 0.09 m²: 3 flies -> 33.3 /m² (>= 30), 2 flies -> 22.2 /m² (< 30)
    p = _planner(density_threshold=30.0)
    p.update_obstacles(np.vstack([_cluster(2.05, 0.05, 3), _cluster(3.05, 0.05, 2)]), ROBOT, FOV)
    assert p.detected_mask[_cell(p, 2.05, 0.05)]
    assert not p.detected_mask[_cell(p, 3.05, 0.05)]
    assert np.count_nonzero(p.detected_mask) == 1


def test_a_cell_must_be_dense_on_consecutive_updates_to_become_an_obstacle():
    p = _planner(confirm_after_views=2)
    flies = _cluster(2.05, 0.05, 5)
    p.update_obstacles(flies, ROBOT, FOV)
    assert not p.detected_mask.any()  # seen dense once: not yet evidence
    p.update_obstacles(np.empty((0, 3)), ROBOT, FOV)
    p.update_obstacles(flies, ROBOT, FOV)
    assert not p.detected_mask.any()  # the run was broken: counting starts again
    p.update_obstacles(flies, ROBOT, FOV)
    assert p.detected_mask[_cell(p, 2.05, 0.05)]  # dense twice in a row: an obstacle


def test_density_uses_the_window_but_marks_only_cells_with_flies():
    counts = np.zeros((7, 7), dtype=np.int64)
    counts[3, 3] = 2
    counts[3, 4] = 1
    dense = obs.dense_cells(counts, 0.1, 1, 30.0)  # both windows hold 3 flies: 33.3 /m²
    assert dense[3, 3] and dense[3, 4]
    assert np.count_nonzero(dense) == 2
    assert box_sum(counts, 1)[2, 2] == 2
    assert box_sum(counts, 1)[0, 0] == 0


@pytest.mark.parametrize("half_width", [0, 1, 3])
@pytest.mark.parametrize(
    ("rows", "cols"),
    [(slice(5, 17), slice(0, 9)), (slice(0, 30), slice(22, 30)), (slice(12, 13), slice(4, 4))],
)
def test_density_of_a_window_equals_the_whole_grid_s(half_width, rows, cols):
    counts = np.random.default_rng(4).poisson(0.7, (30, 30))
    whole = obs.dense_cells(counts, 0.1, half_width, 40.0)
    window = obs.dense_cells(counts, 0.1, half_width, 40.0, rows, cols)
    np.testing.assert_array_equal(window, whole[rows, cols])
    assert whole.any() and not whole.all()


@pytest.mark.parametrize("half_width", [0, 1, 3])
@pytest.mark.parametrize("weighted", [False, True])
def test_dense_cells_kernel_matches_its_numpy_reference_bit_for_bit(half_width, weighted):
    rng = np.random.default_rng(half_width)
    counts = rng.poisson(0.7, (40, 40))
    if weighted:  # depth weights as the planner's map sums them: float64 in (0, 1]
        counts = counts * rng.uniform(0.05, 1.0, counts.shape)
    for rows, cols in (
        (slice(None), slice(None)),
        (slice(5, 37), slice(-12, None)),
        (slice(0, 3), slice(30, 60)),
        (slice(9, 9), slice(None)),
    ):
        for threshold in (10.0, 40.0, float(np.median(counts)) * 100.0):
            got = obs.dense_cells(counts, 0.1, half_width, threshold, rows, cols)
            want = dense_cells_numpy(counts, 0.1, half_width, threshold, rows, cols)
            assert got.shape == want.shape
            np.testing.assert_array_equal(got, want)


def test_inflation_by_robot_radius_is_a_disk():
    p = _planner(robot_radius=0.3)
    p.update_obstacles(_cluster(2.05, 0.05, 10), ROBOT, FOV)
    i, j = _cell(p, 2.05, 0.05)
    mask = p.obstacle_mask
    # cells whose centres lie within 3 cells of the obstacle's centre: 29 of them
    assert np.count_nonzero(mask) == 29
    assert mask[i, j + 3] and mask[i + 3, j] and mask[i + 2, j + 2]
    assert not mask[i + 3, j + 1] and not mask[i, j + 4]
    # Dirichlet values: 1 + rise at the detected cell, falling by rise / (r + 1) per cell,
    # and 1 on the skin (the cells touching free space)
    rise = p.config.escape_rise
    u = p.potential
    assert u[i, j] == pytest.approx(1.0 + rise)
    assert u[i, j + 2] == pytest.approx(1.0 + rise * 2 / 4)
    assert u[i + 1, j + 1] == pytest.approx(1.0 + rise * (4 - math.sqrt(2)) / 4)
    assert u[i, j + 3] == 1.0 and u[i + 2, j + 2] == 1.0 and u[i + 3, j] == 1.0
    # free cells stay below every obstacle value after relaxation
    p.relax_until(1e-12, 20_000)
    inner_free = ~mask[1:-1, 1:-1]  # the border ring is Dirichlet 1 too
    assert p._u[1:-1, 1:-1][inner_free].max() < 1.0  # float64 (float32 rounds up to 1)


def test_distance_within_radius():
    mask = np.zeros((9, 9), dtype=bool)
    mask[4, 4] = True
    mask[4, 6] = True
    d = obs.distance_within(mask, 2.0)
    assert d[4, 4] == 0.0 and d[4, 5] == 1.0 and d[4, 8] == 2.0
    assert d[5, 5] == pytest.approx(math.sqrt(2))
    assert d[6, 6] == 2.0 and np.isinf(d[4, 1]) and np.isinf(d[7, 4])


def test_inflate_matches_distance_definition():
    rng = np.random.default_rng(2)
    mask = rng.random((25, 25)) < 0.02
    out = obs.inflate(mask, 2.5)
    ii, jj = np.nonzero(mask)
    gi, gj = np.indices(mask.shape)
    d2 = (gi[..., None] - ii) ** 2 + (gj[..., None] - jj) ** 2
    np.testing.assert_array_equal(out, (d2 <= 2.5**2).any(axis=-1))


def test_flies_outside_the_view_are_ignored():
    p = _planner()
    behind = _cluster(-2.05, 0.05, 10)
    too_far = _cluster(7.05 - 3.0, 3.05, 10)  # off the 30° half-fov
    p.update_obstacles(np.vstack([behind, too_far]), ROBOT, FOV)
    assert not p.detected_mask.any()
    p.update_obstacles(_cluster(4.05, 0.05, 10), ROBOT, FOV, view_range=3.0)
    assert not p.detected_mask.any()


def test_obstacles_outside_the_view_are_remembered():
    p = _planner()
    p.update_obstacles(_cluster(2.05, 0.05, 10), ROBOT, FOV)
    turned = Pose2D(0.0, 0.0, math.pi)
    for _ in range(10):
        p.update_obstacles(np.empty((0, 2)), turned, FOV)
    assert p.detected_mask[_cell(p, 2.05, 0.05)]


def test_obstacles_seen_free_are_cleared_after_the_configured_views():
    p = _planner(clear_after_views=3)
    p.update_obstacles(_cluster(2.05, 0.05, 10), ROBOT, FOV)
    cell = _cell(p, 2.05, 0.05)
    for _ in range(2):
        p.update_obstacles(np.empty((0, 2)), ROBOT, FOV)
        assert p.detected_mask[cell]
    changed = p.update_obstacles(np.empty((0, 2)), ROBOT, FOV)
    assert not p.detected_mask[cell]
    assert changed == 1
    assert not p.obstacle_mask.any()


def test_obstacles_nearer_than_clear_min_range_are_never_cleared():
    # close up an obstacle loses its flies (nearer than the engine searches): no evidence
    p = _planner(clear_after_views=1, clear_min_range=1.0)
    p.update_obstacles(np.vstack([_cluster(0.85, 0.05, 10), _cluster(2.05, 0.05, 10)]), ROBOT, FOV)
    near, far = _cell(p, 0.85, 0.05), _cell(p, 2.05, 0.05)
    assert p.detected_mask[near] and p.detected_mask[far]
    for _ in range(5):
        p.update_obstacles(np.empty((0, 2)), ROBOT, FOV)
    assert p.detected_mask[near] and not p.detected_mask[far]
    # once the robot has backed off beyond the range, the cell may be seen free again
    p.update_obstacles(np.empty((0, 2)), Pose2D(-0.5, 0.0, 0.0), FOV)
    assert not p.detected_mask[near]


def test_clearing_can_be_switched_off():
    p = _planner(clear_free_cells=False)
    p.update_obstacles(_cluster(2.05, 0.05, 10), ROBOT, FOV)
    for _ in range(10):
        p.update_obstacles(np.empty((0, 2)), ROBOT, FOV)
    assert p.detected_mask[_cell(p, 2.05, 0.05)]


def test_cells_in_a_detection_shadow_are_not_cleared():
    p = _planner(clear_after_views=1)
    far = _cluster(3.05, 0.05, 10)
    near = _cluster(1.55, 0.05, 10)
    p.update_obstacles(far, ROBOT, FOV)
    for _ in range(5):
        p.update_obstacles(near, ROBOT, FOV)  # the near obstacle hides the far one
    assert p.detected_mask[_cell(p, 3.05, 0.05)]
    assert p.detected_mask[_cell(p, 1.55, 0.05)]


def test_bad_point_shapes_are_rejected():
    p = _planner()
    with pytest.raises(ValueError, match=r"\(M, 2\) or \(M, 3\)"):
        p.update_obstacles(np.zeros(5), ROBOT, FOV)


def test_fly_counts_drop_points_off_the_grid():
    g = GridGeometry((0.0, 0.0), 1.0, 4)
    counts = obs.fly_counts(g, np.array([[0.5, 0.5], [0.6, 0.4], [3.5, 1.5], [9.0, 9.0]]))
    assert counts[0, 0] == 2 and counts[1, 3] == 1 and counts.sum() == 3


@pytest.mark.parametrize("bearing_deg", [0.0, 28.0, -29.0])
def test_view_reaches_its_full_range_across_the_fov(bearing_deg):
    p = _planner(extent=14.0)
    bearing, rng = math.radians(bearing_deg), 5.93
    x, y = rng * math.cos(bearing), rng * math.sin(bearing)
    cx, cy = p.geometry.centre_of(*_cell(p, x, y))
    p.update_obstacles(_cluster(cx, cy, 10), ROBOT, FOV, view_range=6.0)
    assert np.count_nonzero(p.detected_mask) == 1
    assert p.detected_mask[_cell(p, x, y)]


def test_robot_off_the_grid_sees_nothing_and_keeps_memory():
    p = _planner()
    p.update_obstacles(_cluster(2.05, 0.05, 10), ROBOT, FOV)
    far_away = Pose2D(50.0, 0.0, math.pi)
    p.update_obstacles(_cluster(2.05, 1.05, 10), far_away, FOV, view_range=3.0)
    assert np.count_nonzero(p.detected_mask) == 1


@pytest.mark.parametrize("radius", [0.0, 1.0, 2.5, 3.0, 4.2])
def test_distance_within_equals_its_numpy_reference(radius):
    rng = np.random.default_rng(round(radius * 10))
    mask = rng.random((37, 29)) < 0.04
    mask[0, 0] = mask[-1, -1] = True  # stamps clipped at the corners
    np.testing.assert_array_equal(
        obs.distance_within(mask, radius), obs.distance_within_numpy(mask, radius)
    )


def test_neighbour_factor_is_one_over_the_neighbours_total_weight():
    weight = np.ones((5, 6))
    weight[2, 3] = 0.1  # one weighted cell: its four neighbours count it as 0.1
    f = obs.neighbour_factor(weight)
    assert f[0, 0] == f[4, 5] == 0.25  # the border is never relaxed
    assert f[1, 1] == 0.25 and f[2, 3] == 0.25
    for i, j in [(1, 3), (3, 3), (2, 2), (2, 4)]:
        assert f[i, j] == pytest.approx(1.0 / 3.1, rel=1e-15)
    assert np.count_nonzero(f != 0.25) == 4


def _reading(ranges, angles_deg=(-50.0, 0.0, 50.0)) -> SonarReading:
    yaw = np.radians(angles_deg)
    mounts = np.stack([0.2 * np.cos(yaw), 0.2 * np.sin(yaw), yaw], axis=1)
    return SonarReading(0, np.array(ranges, float), mounts, math.radians(15.0), 3.0)


def test_sonar_arc_points_lie_on_the_near_echoes_arcs_only():
    reading = _reading([0.6, math.nan, 2.0])  # the 50° sonar's echo is beyond the reach
    pts = obs.sonar_arc_points(reading, 1.0, 0.05)
    mount = reading.mounts[0]
    dx, dy = pts[:, 0] - mount[0], pts[:, 1] - mount[1]
    np.testing.assert_allclose(np.hypot(dx, dy), 0.6)
    bearing = np.degrees(np.arctan2(dy, dx))
    assert bearing.min() == pytest.approx(-57.5) and bearing.max() == pytest.approx(-42.5)
    assert np.max(np.hypot(*np.diff(pts, axis=0).T)) <= 0.05 + 1e-12  # no cell skipped
    assert obs.sonar_arc_points(_reading([math.nan] * 3), 1.0, 0.05).shape == (0, 2)


def test_sonar_echo_cells_become_obstacles_at_once_and_are_not_seen_free():
    # the echo lies in the cameras' view, where no fly is: the echo wins this update
    p = _planner(confirm_after_views=3, clear_after_views=1)
    echo = obs.sonar_arc_points(_reading([math.nan, 0.75, math.nan]), 1.0, 0.05)
    p.update_obstacles(np.empty((0, 2)), ROBOT, FOV, sonar_xy=echo)
    cell = _cell(p, 0.95, 0.01)  # the arc crosses x = 0.95 at y = 0.01
    assert p.detected_mask[cell]
    # without the echo, the cell in view and free of flies is forgotten
    p.update_obstacles(np.empty((0, 2)), ROBOT, FOV)
    assert not p.detected_mask[cell]
    # beside the view the echo is remembered
    behind = Pose2D(0.0, 0.0, math.pi)
    p.update_obstacles(np.empty((0, 2)), behind, FOV, sonar_xy=echo)
    p.update_obstacles(np.empty((0, 2)), behind, FOV)
    assert p.detected_mask[cell]


def test_flies_are_mapped_only_as_far_as_the_rig_resolves_depth():
    # one pixel of disparity spans Z²/(f·B) of depth: 0.5 m at Z = sqrt(0.5·500·0.12)
    cfg = PlannerConfig(view_range=6.0, max_depth_per_pixel=0.5)
    assert cfg.mapping_range(500.0, 0.12) == pytest.approx(math.sqrt(30.0))
    assert cfg.mapping_range(250.0, 0.12) == pytest.approx(math.sqrt(15.0))
    assert cfg.mapping_range(5000.0, 0.12) == 6.0  # never beyond the view range
    assert PlannerConfig(max_depth_per_pixel=0.0).mapping_range(250.0, 0.12) == 6.0
    p = _planner()
    reach = cfg.mapping_range(250.0, 0.12)  # 3.87 m
    p.update_obstacles(_cluster(4.05, 0.05, 10), ROBOT, FOV, view_range=reach)
    assert not p.detected_mask.any()
    p.update_obstacles(_cluster(3.55, 0.05, 10), ROBOT, FOV, view_range=reach)
    assert p.detected_mask.any()


@pytest.mark.parametrize("seed", range(3))
def test_seen_free_kernel_matches_its_numpy_reference_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    geometry = GridGeometry((-5.0, -5.0), 0.1, 100)
    pose = Pose2D(rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(-math.pi, math.pi))
    rows, cols = slice(10, 90), slice(5, 100)
    ranges, bearing = obs.polar_of_cells(geometry, pose, rows, cols)
    half_fov, view_range = math.radians(30.0), 4.0
    in_view = obs.view_mask(ranges, bearing, half_fov, view_range)
    detected = rng.random(ranges.shape) < 0.02
    got = obs.seen_free(in_view, detected, ranges, bearing, half_fov, 0.1, view_range)
    want = seen_free_numpy(in_view, detected, ranges, bearing, half_fov, 0.1, view_range)
    np.testing.assert_array_equal(got, want)
    assert got.any() and (in_view & ~got & ~detected).any()  # some cells lie in a shadow
