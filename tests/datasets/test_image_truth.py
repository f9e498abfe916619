import numpy as np
import pytest

from flylog.geometry import StereoRig
from flylog.metrics.config import MetricsConfig
from flylog.metrics.image_truth import score_dense, score_pixels, score_points, truth_at

NAN = np.nan


def test_truth_is_linear_in_u_where_both_neighbours_are_known_else_the_rounded_pixel():
    d = np.array([[10.0, 12.0, NAN, 20.0], [1.0, 1.0, 1.0, 1.0]], dtype=np.float32)
    u = np.array([0.25, 1.4, 1.6, 2.6, 3.0, 0.5])
    v = np.array([0.0, 0.0, 0.0, 0.0, 0.4, 0.6])
    got = truth_at(d, u, v)
    np.testing.assert_allclose(got, [10.5, 12.0, NAN, 20.0, 20.0, 1.0])


RIG = StereoRig(
    width=64,
    height=48,
    focal_px=80.0,
    baseline=0.2,
    principal_point=(31.0, 23.5),
    doffs=3.0,
    mount_height=0.0,
    mount_x=0.0,
    mount_y=0.0,
)


def _truth() -> np.ndarray:
    truth = np.full((48, 64), 6.0, dtype=np.float32)
    truth[:, 32:] = 10.0
    truth[:16, :16] = NAN  # one cell of the 16 px grid unknown
    return truth


def _points_at(disparity: np.ndarray) -> np.ndarray:
    v, u = np.mgrid[0:48, 0:64]
    depth = RIG.depth_of_disparity(disparity.ravel())
    return RIG.backproject(u.ravel(), v.ravel(), depth)


def test_points_on_the_truth_score_perfectly_and_points_3px_off_are_all_bad():
    truth, config = _truth(), MetricsConfig()
    exact = score_points(_points_at(np.nan_to_num(truth, nan=6.0)), truth, RIG, config)
    assert exact.scored == 64 * 48 - 256 and exact.in_view == 64 * 48
    assert exact.precision == 1.0 and exact.recall == 1.0 and exact.coverage == 1.0
    assert exact.truth_cells == 12 - 1
    assert np.max(exact.disparity_errors) < 1e-6
    off = score_points(_points_at(np.nan_to_num(truth, nan=6.0) + 3.0), truth, RIG, config)
    assert np.all(off.disparity_errors == pytest.approx(3.0))
    assert off.coverage == 0.0
    # 3 px on 6 px + doffs 3 is a third of the depth off: no point is on the surface
    assert off.precision == 0.0 and off.recall == 0.0


def test_points_outside_the_image_or_behind_are_not_scored():
    truth = _truth()
    xyz = np.array([[-1.0, 0.0, 0.0], [5.0, 40.0, 0.0]])  # behind; far off to the left
    score = score_points(xyz, truth, RIG, MetricsConfig())
    assert (score.points, score.in_view, score.scored) == (2, 0, 0)
    assert np.isnan(score.precision) and score.recall == 0.0


def test_a_dense_map_is_scored_where_it_matched_and_truth_is_known():
    truth = _truth()
    dense = np.where(np.isnan(truth), 5.0, truth + 1.5).astype(np.float32)
    dense[40:, :] = np.nan  # no disparity found
    score = score_dense(dense, truth, RIG, MetricsConfig())
    assert score.scored == 40 * 64 - 256
    assert np.all(score.disparity_errors == pytest.approx(1.5))
    u, v = np.array([31.0]), np.array([23.5])
    one = score_pixels(
        u, v, np.array([6.0]), RIG.depth_of_disparity(np.array([6.0])), truth, RIG, MetricsConfig()
    )
    assert one.scored == 1 and one.disparity_errors[0] == 0.0
