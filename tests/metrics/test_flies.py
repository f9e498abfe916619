import numpy as np
import pytest

from flylog.geometry import StereoRig
from flylog.metrics.config import MetricsConfig
from flylog.metrics.flies import (
    cell_counts,
    f_score,
    nearest_visible_distance,
    score_flies,
)

RIG = StereoRig(width=40, height=30, focal_px=40.0, baseline=0.1, mount_height=0.5, mount_x=0.1)


def view_with_wall(distance: float = 4.0, left_columns: int = 20):
    """Obstacle 0 at ``distance`` in the left ``left_columns`` columns, sky elsewhere."""
    depth = np.full((RIG.height, RIG.width), np.inf, dtype=np.float32)
    ids = np.full((RIG.height, RIG.width), -2, dtype=np.int16)
    depth[:, :left_columns] = distance
    ids[:, :left_columns] = 0
    return depth, ids


def flies_at(u, v, depth) -> np.ndarray:
    return RIG.backproject(np.asarray(u, float), np.asarray(v, float), np.asarray(depth, float))


def test_cell_counts_include_partial_cells():
    mask = np.zeros((5, 7), dtype=bool)
    mask[0:2, 0:3] = True
    mask[4, 6] = True
    hits, pixels = cell_counts(mask, 3)
    assert hits.tolist() == [[6, 0, 0], [0, 0, 1]]
    assert pixels.tolist() == [[9, 9, 3], [6, 6, 2]]


def test_flies_on_the_surface_and_off_it():
    depth, ids = view_with_wall()
    cfg = MetricsConfig(cell_px=10)
    v, u = np.mgrid[0:30, 0:20]
    on = flies_at(u.ravel(), v.ravel(), 4.0)
    score = score_flies(on, depth, ids, RIG, 1, cfg)
    assert (score.in_view, score.on_surface, score.on_obstacle) == (600, 600, 600)
    assert score.precision == 1.0
    assert (score.visible_cells, score.covered_cells) == (6, 6)
    assert score.recall == 1.0 and score.f_score == 1.0
    assert np.max(score.depth_errors) < 1e-6
    assert score.flies_on.tolist() == [600]
    assert score.visible_pixels.tolist() == [600]

    # 4 % off is within tau = 5 %; 6 % is not; the sky is never a surface.
    near = score_flies(flies_at(u.ravel(), v.ravel(), 4.16), depth, ids, RIG, 1, cfg)
    far = score_flies(flies_at(u.ravel(), v.ravel(), 4.24), depth, ids, RIG, 1, cfg)
    sky = score_flies(flies_at([30.0], [10.0], [4.0]), depth, ids, RIG, 1, cfg)
    assert near.precision == 1.0 and far.precision == 0.0 and sky.precision == 0.0
    assert np.median(far.depth_errors) == pytest.approx(0.06, rel=1e-6)
    assert far.recall == 0.0 and far.f_score == 0.0
    assert sky.depth_errors.size == 0


def test_half_the_obstacle_covered_gives_recall_one_half():
    depth, ids = view_with_wall(left_columns=40)  # 12 cells of 10 px
    v, u = np.mgrid[0:30, 0:20]
    score = score_flies(
        flies_at(u.ravel(), v.ravel(), 4.0), depth, ids, RIG, 1, MetricsConfig(cell_px=10)
    )
    assert (score.visible_cells, score.covered_cells) == (12, 6)
    assert score.recall == 0.5
    assert score.f_score == pytest.approx(2 * 0.5 / 1.5)


def test_flies_outside_the_image_are_not_judged_but_counted():
    depth, ids = view_with_wall()
    behind = np.array([[-1.0, 0.0, 0.5], [0.05, 0.0, 0.5]])  # behind the cameras
    aside = flies_at([-3.0, 45.0], [10.0, 10.0], [4.0, 4.0])  # left and right of the image
    score = score_flies(np.concatenate([behind, aside]), depth, ids, RIG, 1, MetricsConfig())
    assert (score.obstacle_flies, score.in_view, score.outside_view) == (4, 0, 4)
    assert np.isnan(score.precision)


def test_nearest_distances_of_a_wall_straight_ahead():
    depth, ids = view_with_wall(distance=4.0, left_columns=40)
    # The column through the optical centre is u = cx = 19.5: the nearest point is within
    # half a pixel's lateral extent of straight ahead.
    got = nearest_visible_distance(depth, ids, RIG)
    assert got == pytest.approx(np.hypot(4.1, RIG.baseline / 2), abs=0.06)
    assert got >= 4.1
    flies = np.array([[3.0, 4.0, 0.5], [6.0, 0.0, 0.2]])
    score = score_flies(flies, depth, ids, RIG, 1, MetricsConfig())
    assert score.nearest_detected == 5.0
    assert nearest_visible_distance(depth, np.full_like(ids, -2), RIG) == np.inf


def test_f_score_definition():
    assert f_score(1.0, 0.5) == pytest.approx(2 / 3)
    assert f_score(0.0, 0.0) == 0.0
    assert np.isnan(f_score(np.nan, 1.0))
