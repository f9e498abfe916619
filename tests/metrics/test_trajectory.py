import math

import numpy as np
import pytest

from flylog.metrics.trajectory import (
    align_se2,
    associate,
    ate_rmse,
    count_entries,
    first_arrival,
    interpolate_poses,
    path_length,
    relative_poses,
    rpe_pairs,
    rpe_rmse,
)
from flylog.sources.trajectory import trajectory

S = 1_000_000_000


def straight(speed: float, n: int = 51, rate: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(n) / rate
    return (t * S).astype(np.int64), np.stack([speed * t, 0 * t, 0 * t], axis=1)


def curve(n: int = 200) -> np.ndarray:
    s = np.linspace(0, 6, n)
    return np.stack([3 * np.cos(s / 3), 2 * np.sin(s / 2), s], axis=1)


def test_alignment_recovers_a_known_rigid_motion():
    ref = curve()[:, :2]
    a = 0.7
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    est = (ref - [1.0, -2.0]) @ rot  # est = R⁻¹(ref − t)
    got_rot, got_t = align_se2(ref, est)
    np.testing.assert_allclose(got_rot, rot, atol=1e-12)
    np.testing.assert_allclose(got_t, [1.0, -2.0], atol=1e-12)
    assert ate_rmse(ref, est) == pytest.approx(0.0, abs=1e-12)
    unaligned = ate_rmse(ref, est, align=False)
    assert unaligned == pytest.approx(np.sqrt(np.mean(np.sum((ref - est) ** 2, axis=1))))
    assert unaligned > 1.0


def test_ate_of_a_speed_error_on_a_line_is_the_spread_of_the_drift():
    t_ns, ref = straight(1.0)
    _, est = straight(1.1)
    t = t_ns / S
    # Aligned by a translation only: the residual is 0.1·(t − mean t).
    assert ate_rmse(ref[:, :2], est[:, :2]) == pytest.approx(0.1 * t.std(), rel=1e-9)


def test_rpe_of_a_speed_error_is_the_extra_distance_per_delta():
    t_ns, ref = straight(1.0)
    _, est = straight(1.1)
    trans, rot = rpe_rmse(t_ns, ref, est, delta_s=1.0)
    assert trans == pytest.approx(0.1, rel=1e-9)
    assert rot == pytest.approx(0.0, abs=1e-12)
    assert np.isnan(rpe_rmse(t_ns, ref, est, delta_s=10.0)[0])  # longer than the data


def test_rpe_ignores_a_global_rigid_offset_and_sees_a_heading_drift():
    t_ns = (np.arange(200) * 0.05 * S).astype(np.int64)
    ref = curve()
    shifted = relative_poses(np.tile([[1.0, 2.0, 0.5]], (200, 1)), ref)  # a rigid motion
    assert rpe_rmse(t_ns, ref, shifted, delta_s=1.0) == pytest.approx((0.0, 0.0), abs=1e-9)
    drift = ref.copy()
    drift[:, 2] += 0.01 * t_ns / S  # 0.01 rad per second more than true
    _, rot = rpe_rmse(t_ns, ref, drift, delta_s=1.0)
    assert rot == pytest.approx(0.01, rel=1e-6)


def test_rpe_pairs_are_consecutive_and_at_least_delta_apart():
    t = np.array([0, 3, 10, 12, 20, 21, 29, 35])
    i, j = rpe_pairs(t, 10)
    assert i.tolist() == [0, 2, 4]
    assert j.tolist() == [2, 4, 7]


def test_association_keeps_the_nearest_times_within_the_limit():
    ref = np.array([0, 100, 200, 300, 400])
    est = np.array([5, 190, 260, 1000])
    i_ref, i_est = associate(ref, est, 20)
    assert i_ref.tolist() == [0, 2]
    assert i_est.tolist() == [0, 1]
    assert associate(ref, est[:0], 20)[0].size == 0


def test_interpolation_crosses_the_heading_wrap_and_clamps():
    traj = trajectory([0, 10, 20], [(0, 0, 3.0), (1, 2, -3.0), (2, 4, -2.9)])
    got = interpolate_poses(traj, np.array([5, -5, 25]))
    np.testing.assert_allclose(got[0, :2], [0.5, 1.0])
    # halfway from 3.0 to -3.0 the short way round is ±pi
    assert abs(abs(got[0, 2]) - math.pi) < 1e-9
    np.testing.assert_allclose(got[1], [0, 0, 3.0])
    np.testing.assert_allclose(got[2], [2, 4, -2.9])


def test_path_length_entries_and_arrival():
    xy = np.array([[0, 0], [3, 4], [3, 0]], dtype=float)
    assert path_length(xy) == pytest.approx(9.0)
    assert count_entries(np.array([True, True, False, True, False, False, True])) == 3
    assert count_entries(np.array([False, False])) == 0
    assert count_entries(np.array([], dtype=bool)) == 0
    t_ns, poses = straight(1.0)
    traj = trajectory(t_ns, poses)
    assert first_arrival(traj, (2.0, 0.1), 0.15) == 20 - 1  # x = 1.9 is within 0.15
    assert first_arrival(traj, (2.0, 1.0), 0.15) is None
