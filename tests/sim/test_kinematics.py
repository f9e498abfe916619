import math

import numpy as np
import pytest

from flylog.geometry import Pose2D
from flylog.sim.kinematics import OdometryConfig, RobotPoses, advance_poses, integrate_unicycle


def test_straight_line_and_pure_rotation_are_exact():
    p = integrate_unicycle(Pose2D(1.0, 2.0, math.pi / 2), 0.5, 0.0, 4.0)
    assert (p.x, p.y, p.theta) == pytest.approx((1.0, 4.0, math.pi / 2))
    r = integrate_unicycle(Pose2D(1.0, 2.0, 0.0), 0.0, math.radians(-15.0), 2.0)
    assert (r.x, r.y, r.theta) == pytest.approx((1.0, 2.0, math.radians(-30.0)))


def test_arc_is_exact_and_composes():
    # Quarter circle of radius 2 to the left, in one step or in a hundred.
    v, w = 1.0, 0.5
    one = integrate_unicycle(Pose2D(), v, w, math.pi)
    assert (one.x, one.y, one.theta) == pytest.approx((2.0, 2.0, math.pi / 2))
    many = Pose2D()
    for _ in range(100):
        many = integrate_unicycle(many, v, w, math.pi / 100)
    assert (many.x, many.y, many.theta) == pytest.approx((one.x, one.y, one.theta))


def test_zero_noise_true_equals_odometry():
    quiet = OdometryConfig(linear_noise=0.0, angular_noise=0.0, angular_noise_floor_deg=0.0)
    poses = RobotPoses(Pose2D(), Pose2D())
    rng = np.random.default_rng(0)
    for k in range(30):
        poses = advance_poses(poses, 0.4, 0.3 * math.sin(k), 1 / 15, quiet, rng)
    assert poses.true == poses.odom
    assert poses.odom.x > 0.5


def drive(seed, config=None):
    config = config or OdometryConfig(linear_noise=0.1, angular_noise=0.1)
    poses = RobotPoses(Pose2D(), Pose2D())
    rng = np.random.default_rng(seed)
    for _ in range(150):
        poses = advance_poses(poses, 0.5, 0.2, 1 / 15, config, rng)
    return poses


def test_noise_makes_truth_drift_deterministically():
    a, b, c = drive(1), drive(1), drive(2)
    assert a == b
    assert a.odom == c.odom  # odometry is the integrated command: noise never reaches it
    gap = math.hypot(a.true.x - a.odom.x, a.true.y - a.odom.y)
    assert 0.01 < gap < 2.0
    assert a.true != c.true


def test_standing_still_does_not_drift():
    poses = RobotPoses(Pose2D(1.0, 1.0, 0.3), Pose2D(1.0, 1.0, 0.3))
    out = advance_poses(poses, 0.0, 0.0, 2.0, OdometryConfig(), np.random.default_rng(0))
    assert out == poses


def test_dt_is_split_into_odometry_steps():
    config = OdometryConfig(rate=50.0)
    rng_a, rng_b = np.random.default_rng(3), np.random.default_rng(3)
    poses = RobotPoses(Pose2D(), Pose2D())
    advance_poses(poses, 0.5, 0.1, 0.1, config, rng_a)  # 5 steps, 2 normals each
    rng_b.standard_normal(10)
    assert rng_a.standard_normal() == rng_b.standard_normal()
