"""The obstacle map: depth-weighted flies, lines of sight, a passage on known geometry."""

import math

import numpy as np
import pytest

from flylog.geometry import Pose2D
from flylog.planner import HarmonicPlanner, PlannerConfig
from flylog.planner import evidence as ev
from flylog.planner.grid import GridGeometry
from flylog.planner.reach import reachable_from
from tests.planner.references import reachable_from_numpy, seen_through_numpy

GEOMETRY = GridGeometry((-5.0, -5.0), 0.1, 100)


def test_depth_weight_is_one_up_to_the_full_weight_error_and_falls_as_one_over_z2():
    fb = 30.0  # 320×240, the bundled rig: 250 px × 0.12 m
    w = ev.depth_weights(np.array([1.0, math.sqrt(4.5), 3.0, 6.0]), fb, 0.15)
    np.testing.assert_allclose(w, [1.0, 1.0, 0.15 / (9.0 / 30.0), 0.15 / (36.0 / 30.0)])
    np.testing.assert_allclose(ev.depth_errors(np.array([2.0]), fb), [4.0 / 30.0])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_seen_through_matches_its_numpy_reference(seed):
    rng = np.random.default_rng(seed)
    pts = rng.uniform(-7.0, 7.0, size=(300, 2))  # some off the grid: lines cut at the edge
    origin = (float(rng.uniform(-1, 1)), float(rng.uniform(-1, 1)))
    ranges = np.hypot(pts[:, 0] - origin[0], pts[:, 1] - origin[1])
    stops = ranges - rng.uniform(-0.5, 1.0, size=len(pts))
    weights = rng.uniform(0.1, 1.0, size=len(pts))
    got = ev.seen_through(GEOMETRY, origin, pts, stops, weights)
    want = seen_through_numpy(GEOMETRY, origin, pts, stops, weights)
    np.testing.assert_array_equal(got, want)
    assert got.sum() > 0


def test_a_line_of_sight_marks_the_cells_before_its_stop_once_each():
    # a line along +x from the centre of cell (50, 50) to x = 1.0, seen through to 0.42 m
    pts = np.array([[1.0, 0.05]])
    out = ev.seen_through(GEOMETRY, (0.05, 0.05), pts, np.array([0.42]), np.array([0.5]))
    row = out[50]
    np.testing.assert_array_equal(np.nonzero(row)[0], [50, 51, 52, 53, 54])  # x 0.05 … 0.45
    assert set(row[row > 0]) == {0.5} and out.sum() == pytest.approx(2.5)


@pytest.mark.parametrize("seed", [0, 1])
def test_reachable_region_matches_its_numpy_reference(seed):
    free = np.random.default_rng(seed).random((40, 50)) > 0.35
    for cell in ((0, 0), (20, 25), (39, 49)):
        np.testing.assert_array_equal(reachable_from(free, cell), reachable_from_numpy(free, cell))


def _passage_flies(rng, pose, focal_baseline, half_fov, reach, sigma_px, n=400):
    """Flies on the faces y = ±0.6 of two walls ahead of a camera at ``pose`` (heading +x),
    each placed at the depth of its disparity plus Gaussian noise of ``sigma_px`` pixels."""
    out = []
    for face in (0.6, -0.6):
        x = rng.uniform(pose.x + 0.3, pose.x + reach, size=n)
        x = x[np.abs(np.arctan2(face - pose.y, x - pose.x)) <= half_fov]
        z = x - pose.x
        disparity = np.maximum(focal_baseline / z + rng.normal(0.0, sigma_px, len(z)), 1e-3)
        scale = focal_baseline / disparity / z
        out.append(np.column_stack([pose.x + z * scale, pose.y + (face - pose.y) * scale]))
    return np.vstack(out)


def _drive_down_the_passage(width, sigma_px, **changes):
    focal = 500.0 * width / 640.0
    fb, half_fov = focal * 0.12, math.atan2(width / 2.0, focal)
    cfg = PlannerConfig(**changes)
    reach = cfg.mapping_range(focal, 0.12)
    p = HarmonicPlanner.centred_on(cfg, (3.0, 0.0), (8.0, 0.0))
    rng = np.random.default_rng(width)
    for k in range(60):  # 3 m down the passage, 5 cm an update
        pose = Pose2D(0.05 * k, 0.0, 0.0)
        flies = _passage_flies(rng, pose, fb, half_fov, reach, sigma_px)
        p.update_obstacles(flies, pose, half_fov, view_range=reach, focal_baseline=fb)
    return p


def _mapped_gaps(p):
    """Per grid column between x = 0.5 and 5.5 m: the free width between the nearest
    detected cells' edges above and below the passage's axis."""
    det = p.detected_mask
    ox, oy = p.geometry.origin
    centres = (np.arange(p.geometry.cells) + 0.5) * p.cell_size
    ys, xs = oy + centres, ox + centres
    gaps = []
    for j in np.nonzero((xs > 0.5) & (xs < 5.5))[0]:
        up, down = ys[det[:, j] & (ys > 0)], ys[det[:, j] & (ys < 0)]
        if len(up) and len(down):
            gaps.append((up.min() - 0.05) - (down.max() + 0.05))
    return np.array(gaps)


@pytest.mark.parametrize("width", [320, 640])
def test_walls_1_2_m_apart_stay_1_2_m_apart_in_the_map_and_the_passage_stays_open(width):
    p = _drive_down_the_passage(width, sigma_px=1.0)
    gaps = _mapped_gaps(p)
    assert len(gaps) >= 30
    assert np.median(gaps) == pytest.approx(1.2)
    assert gaps.min() >= 1.1 - 1e-9  # at worst one cell off, in a few columns
    free = ~p.obstacle_mask
    ahead = reachable_from(free, p.geometry.cell_of(5.5, 0.0))
    assert ahead[p.geometry.cell_of(0.5, 0.0)]  # a free channel all along


def test_counting_every_fly_as_one_narrows_the_same_passage():
    # the paper's density, no lines of sight: depth noise plants cells inside the passage
    p = _drive_down_the_passage(320, sigma_px=1.0, full_weight_depth_error=0.0)
    gaps = _mapped_gaps(p)
    assert gaps.min() <= 0.8 + 1e-9 and np.median(gaps) <= 1.0 + 1e-9


@pytest.mark.parametrize(
    ("margin", "cells_wide", "open_"),
    [(0.05, 9, True), (0.05, 8, False), (0.1, 11, True), (0.1, 10, False)],
)
def test_inflation_keeps_a_passage_open_from_its_stated_width(margin, cells_wide, open_):
    # walls mapped as cells whose centres lie cells_wide - 1 cells apart: a passage of
    # cells_wide cells, face to face (the wall cells' half cells each side)
    cfg = PlannerConfig(extent=4.0, inflation_margin=margin)
    p = HarmonicPlanner.centred_on(cfg, (0.0, 0.0), (1.5, 0.0))
    row0 = 5
    walls = np.zeros(p.geometry.shape, dtype=bool)
    walls[row0, 2:-2] = walls[row0 + cells_wide - 1, 2:-2] = True
    p.set_detected(walls)
    free = ~p.obstacle_mask
    left = reachable_from(free, (row0 + cells_wide // 2, 3))
    assert bool(left[row0 + cells_wide // 2, p.geometry.cells - 4]) is open_
    # the stated width: (2·floor((robot_radius + margin) / cell) + 3) cells
    assert (cells_wide >= 2 * math.floor((0.3 + margin) / 0.1 + 1e-9) + 3) is open_
