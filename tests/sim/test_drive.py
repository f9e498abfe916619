import math
from pathlib import Path

import numpy as np
import pytest

from flylog.geometry import Pose2D
from flylog.scene import distance_to_obstacles, load_scene, parse_scene
from flylog.sim.drive import Driver, PlanDriver
from flylog.sim.kinematics import OdometryConfig, RobotPoses, advance_poses

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
QUIET = OdometryConfig(linear_noise=0.0, angular_noise=0.0, angular_noise_floor_deg=0.0)


def simulate(scene, driver: Driver, seconds, odometry=QUIET, rate=15.0):
    poses = RobotPoses(scene.start_pose, scene.start_pose)
    rng = np.random.default_rng(0)
    trail = [poses.true]
    for k in range(round(seconds * rate)):  # bounded: never waits for the goal
        v, w = driver.command(k / rate, poses.odom)
        poses = advance_poses(poses, v, w, 1 / rate, odometry, rng)
        trail.append(poses.true)
    return poses, np.array([[p.x, p.y] for p in trail])


def test_timed_commands_are_piecewise_constant():
    scene = parse_scene(
        """
name = "c"
[[drive.commands]]
t_start = 1.0
v = 0.5
[[drive.commands]]
t_start = 2.0
w_deg = -15.0
""",
        "mem",
    )
    driver = PlanDriver.from_scene(scene)
    assert driver.command(0.5, Pose2D()) == (0.0, 0.0)
    assert driver.command(1.0, Pose2D()) == (0.5, 0.0)
    assert driver.command(1.99, Pose2D()) == (0.5, 0.0)
    assert driver.command(7.0, Pose2D()) == (0.0, pytest.approx(math.radians(-15.0)))
    assert not driver.finished


def test_turn_fixture_turns_one_degree_right_per_frame():
    scene = load_scene(FIXTURES / "turn.toml")
    poses, _ = simulate(scene, PlanDriver.from_scene(scene), 1.0)
    assert math.degrees(poses.odom.theta) == pytest.approx(-15.0)
    assert (poses.odom.x, poses.odom.y) == (0.0, 0.0)


def test_waypoint_driver_reaches_every_waypoint():
    scene = parse_scene(
        """
name = "w"
[robot]
start = [0.0, 0.0, 90.0]
[drive]
waypoints = [[2.0, 0.0], [2.0, 2.0], [-1.0, 1.0]]
tolerance = 0.1
""",
        "mem",
    )
    driver = PlanDriver.from_scene(scene)
    poses, trail = simulate(scene, driver, 60.0)
    assert driver.finished
    for wx, wy in scene.spec.drive.waypoints:
        assert np.hypot(trail[:, 0] - wx, trail[:, 1] - wy).min() <= 0.1
    assert math.hypot(poses.true.x + 1.0, poses.true.y - 1.0) <= 0.1
    assert driver.command(99.0, poses.odom) == (0.0, 0.0)


def test_without_a_plan_the_robot_drives_to_the_goal():
    scene = parse_scene('name = "g"\n[robot]\ngoal = [3.0, -2.0]\n', "mem")
    poses, _ = simulate(scene, PlanDriver.from_scene(scene), 30.0)
    assert math.hypot(poses.odom.x - 3.0, poses.odom.y + 2.0) <= scene.spec.drive.tolerance


def test_corridor_plan_reaches_the_goal_without_touching_anything():
    scene = load_scene(FIXTURES / "corridor.toml")
    driver = PlanDriver.from_scene(scene)
    poses, trail = simulate(scene, driver, scene.spec.duration)
    assert driver.finished
    clearance = distance_to_obstacles(scene, trail).min()
    assert clearance > scene.spec.robot.radius
    gx, gy = scene.goal
    assert math.hypot(poses.odom.x - gx, poses.odom.y - gy) <= scene.spec.drive.tolerance
