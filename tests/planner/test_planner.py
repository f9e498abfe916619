import dataclasses
import math

import numpy as np
import pytest

from flylog.config import from_mapping
from flylog.errors import ConfigError
from flylog.geometry import Pose2D
from flylog.planner import (
    HarmonicPlanner,
    PathEnd,
    PlannerConfig,
    Relaxation,
    RelaxEnd,
    Status,
)
from flylog.planner.steering import SmoothedDirection, speed_factor, unicycle_command

# the paper's field and steering: Dirichlet obstacles, unknown cells free, along −∇U at the
# robot, unfiltered
PAPER = {
    "obstacle_weight": 1.0,
    "lookahead": 0.0,
    "heading_smoothing": 0.0,
    "frontier_field": False,
}
SMALL = PlannerConfig(
    extent=6.0, cell_size=0.1, inflation_margin=0.0, confirm_after_views=1, **PAPER
)


def _converged(cfg: PlannerConfig = SMALL, goal=(2.0, 0.0)) -> HarmonicPlanner:
    p = HarmonicPlanner.centred_on(cfg, (0.0, 0.0), goal)
    assert p.relax_until(1e-10, 20_000).end is RelaxEnd.CONVERGED
    return p


def test_config_loads_from_toml_mapping_and_checks_ranges():
    cfg = from_mapping(PlannerConfig, {"omega": 1.5, "relaxation": "numpy"}, source="s.toml")
    assert cfg.omega == 1.5 and cfg.relaxation is Relaxation.NUMPY
    assert PlannerConfig().cells == 200
    with pytest.raises(ConfigError, match=r"s.toml: omega must be below 2"):
        from_mapping(PlannerConfig, {"omega": 2.0}, source="s.toml")
    with pytest.raises(ConfigError, match=r"field 'sweeps_per_tick': must be at least 1"):
        from_mapping(PlannerConfig, {"sweeps_per_tick": 0}, source="s.toml")


def test_goal_off_the_grid_is_a_config_error():
    with pytest.raises(ConfigError, match=r"goal \(5.0, 0.0\) lies outside the planner grid"):
        HarmonicPlanner.centred_on(SMALL, (0.0, 0.0), (5.0, 0.0))


def test_relax_keeps_values_between_ticks_and_converges():
    p = HarmonicPlanner.centred_on(SMALL, (0.0, 0.0), (2.0, 0.0))
    changes = [p.relax() for _ in range(30)]
    assert changes[-1] < changes[0]
    result = p.relax_until(1e-10, 20_000)
    assert result.end is RelaxEnd.CONVERGED and result.max_change <= 1e-10
    assert p.relax_until(0.0, 7).end is RelaxEnd.MAX_SWEEPS
    assert p.relax_until(0.0, 7).sweeps == 7


def test_the_warm_starts_optimal_over_relaxation_settles_the_field_in_a_quarter_of_the_sweeps():
    cfg = PlannerConfig()  # 200×200, the replay's grid
    assert cfg.warm_start_omega == pytest.approx(1.9689, abs=1e-4)
    points = [(x, y) for x in np.linspace(-9.0, 9.0, 13) for y in np.linspace(-9.0, 9.0, 13)]
    runs = []
    # at the ticks' omega, at the warm start's, and the field itself (relaxed to 1e-14)
    for omega, tolerance in (
        (cfg.omega, 1e-10),
        (cfg.warm_start_omega, 1e-10),
        (cfg.warm_start_omega, 1e-14),
    ):
        p = HarmonicPlanner.centred_on(cfg, (0.0, 0.0), (6.0, 0.0))
        result = p.relax_until(tolerance, 50_000, chunk=100, omega=omega)
        runs.append((result, np.array([p.value(x, y) for x, y in points])))
    (slow, u_slow), (fast, u_fast), (_, u) = runs
    assert slow.end is fast.end is RelaxEnd.CONVERGED
    assert (slow.sweeps, fast.sweeps) == (3100, 700)
    # both within the tolerance's reach of the field; the faster one the nearer
    assert np.abs(u_fast - u).max() < np.abs(u_slow - u).max() < 1e-7


def test_a_tick_keeps_relaxing_until_the_tolerance_or_the_sweep_bound():
    def planner(**changes):
        cfg = PlannerConfig(**{**SMALL.__dict__, "sweeps_per_tick": 10, **changes})
        return HarmonicPlanner.centred_on(cfg, (0.0, 0.0), (2.0, 0.5))

    fixed = planner(max_sweeps_per_tick=10)
    ref = planner()
    assert fixed.relax() == ref.relax(10)  # at most sweeps_per_tick: exactly that many
    np.testing.assert_array_equal(fixed.potential, ref.potential)
    # adaptive: chunks of 10 sweeps until a sweep changes no cell by more than 1e-9
    adaptive, ref = planner(relax_tolerance=1e-9, max_sweeps_per_tick=10_000), planner()
    change = adaptive.relax()
    chunks = 1
    while ref.relax(10) > 1e-9:
        chunks += 1
    assert change <= 1e-9 and chunks > 2
    np.testing.assert_array_equal(adaptive.potential, ref.potential)
    # bounded: 30 sweeps at most
    bounded, ref = planner(relax_tolerance=0.0, max_sweeps_per_tick=30), planner()
    bounded.relax()
    ref.relax(30)
    np.testing.assert_array_equal(bounded.potential, ref.potential)


@pytest.mark.parametrize("kind", list(Relaxation), ids=lambda k: k.value)
def test_both_relaxations_give_the_same_planner_field(kind):
    cfg = PlannerConfig(extent=6.0, cell_size=0.1, relaxation=kind, confirm_after_views=1)
    p = HarmonicPlanner.centred_on(cfg, (0.0, 0.0), (2.0, 0.5))
    ref = HarmonicPlanner.centred_on(SMALL, (0.0, 0.0), (2.0, 0.5))
    for _ in range(5):
        assert p.relax() == pytest.approx(ref.relax(), abs=1e-14)
    np.testing.assert_allclose(p.potential, ref.potential, atol=1e-7)


def test_command_turns_the_robot_towards_minus_gradient():
    p = _converged()
    gx, gy = p.gradient(0.0, 0.0)
    # −∇U points at the goal cell's centre (2.05, 0.05), the Dirichlet 0 cell
    heading = math.atan2(-gy, -gx)
    assert heading == pytest.approx(math.atan2(0.05, 2.05), abs=0.01)
    facing = p.command(Pose2D(0.0, 0.0, 0.0), 0.0)
    assert facing.status is Status.DRIVING
    floor = math.cos(math.radians(SMALL.turn_in_place_deg))
    share = (math.cos(heading) - floor) / (1.0 - floor)
    assert facing.linear == pytest.approx(SMALL.max_linear_speed * share)
    assert facing.angular == pytest.approx(SMALL.heading_gain * heading)
    left = p.command(Pose2D(0.0, 0.0, math.pi / 2), 0.1)  # goal on the right: turn right
    assert left.angular == pytest.approx(-SMALL.max_angular_speed)
    assert left.linear == 0.0  # beyond turn_in_place_deg: turns in place
    right = p.command(Pose2D(0.0, 0.0, -0.15), 0.2)  # goal a little to the left
    assert right.angular > 0.0 and right.linear > 0.8 * SMALL.max_linear_speed


def test_unicycle_command_saturates_and_stops_on_flat_gradient():
    kw = {"max_linear": 0.5, "max_angular": 1.0, "heading_gain": 2.0}
    assert unicycle_command(Pose2D(), (1.0, 0.0), **kw) == pytest.approx((0.5, 0.0))
    assert unicycle_command(Pose2D(), (-1.0, 0.0), **kw) == pytest.approx((0.0, 1.0))
    lin, ang = unicycle_command(Pose2D(), (math.cos(0.2), math.sin(0.2)), **kw)
    assert (lin, ang) == pytest.approx((0.5 * math.cos(0.2), 0.4))
    assert unicycle_command(Pose2D(), (0.0, 0.0), **kw) == (0.0, 0.0)


def test_unicycle_command_turns_in_place_beyond_the_configured_error():
    kw = {"max_linear": 0.5, "max_angular": 1.0, "heading_gain": 2.0}
    turn = math.radians(60.0)
    at = [
        unicycle_command(Pose2D(), (math.cos(e), math.sin(e)), turn_in_place=turn, **kw)[0]
        for e in (0.0, math.radians(30.0), math.radians(59.0), math.radians(61.0), 2.5)
    ]
    # (cos e - cos 60°) / (1 - cos 60°): 1 facing, 0.732 at 30°, about 0.03 at 59°, 0 beyond
    assert at[0] == pytest.approx(0.5)
    assert at[1] == pytest.approx(0.5 * (math.cos(math.radians(30.0)) - 0.5) / 0.5)
    assert 0.0 < at[2] < 0.02
    assert at[3] == 0.0 and at[4] == 0.0
    # the turn itself does not depend on it
    assert unicycle_command(Pose2D(), (0.0, 1.0), turn_in_place=turn, **kw)[1] == 1.0


def test_speed_factor_scales_linearly_within_the_slowdown_distance():
    assert speed_factor(0.25, 0.5) == pytest.approx(0.5)
    assert speed_factor(2.0, 0.5) == 1.0
    assert speed_factor(0.01, 0.5, floor=0.2) == 0.2
    assert speed_factor(-0.1, 0.5) == 0.0  # inside the robot's radius: no forward speed
    assert speed_factor(0.0, 0.0) == 1.0  # slowdown 0: never slows down
    assert speed_factor(math.inf, 0.5) == 1.0


def test_goal_reached_within_tolerance():
    p = _converged()
    assert SMALL.goal_tolerance == 0.05
    cmd = p.command(Pose2D(2.0 - 0.03, 0.03, 1.0), 0.0)  # 0.042 m from the goal
    assert cmd == type(cmd)(0.0, 0.0, Status.GOAL_REACHED)
    assert p.command(Pose2D(2.0 - 0.07, 0.0, 0.0), 0.0).status is Status.DRIVING


def test_final_approach_steers_at_the_goal_point_and_slows_down():
    p = _converged()
    # the potential's sink is the goal cell's centre (2.05, 0.05), not the goal (2.0, 0.0):
    # within goal_approach_distance the robot heads for the goal point itself
    near = p.command(Pose2D(1.75, 0.0, 0.0), 0.0)
    assert near.angular == pytest.approx(0.0, abs=1e-12)
    # and its speed falls with the distance: 0.25 m / goal_slowdown 0.5 m = half speed
    assert near.linear == pytest.approx(SMALL.max_linear_speed * 0.25 / SMALL.goal_slowdown)
    # further out it follows −∇U (towards the cell centre: a small left turn)
    far = p.command(Pose2D(1.0, 0.0, 0.0), 0.0)
    assert far.angular > 0.01
    assert far.linear < SMALL.max_linear_speed * 1.0 / SMALL.goal_slowdown


def _with_obstacle_at(x: float, y: float) -> HarmonicPlanner:
    p = _converged()
    cluster = np.array([[x, y, 0.5]]) + np.random.default_rng(0).uniform(-0.04, 0.04, (40, 3))
    p.update_obstacles(cluster, Pose2D(x - 1.0, y, 0.0), math.radians(30.0))
    assert p.detected_mask.sum() == 1
    return p


def test_clearance_is_the_distance_to_the_nearest_remembered_cell():
    p = _with_obstacle_at(-0.95, 1.05)  # the centre of a cell
    assert p.clearance(-0.95, 0.45, 1.0) == pytest.approx(0.6)
    assert p.clearance(-0.95, 0.45, 0.5) == math.inf  # beyond the reach
    assert _converged().clearance(0.0, 0.0, 5.0) == math.inf


def test_forward_speed_falls_near_remembered_obstacles():
    p = _with_obstacle_at(-0.95, 1.05)
    cfg = p.config
    # 0.6 m from the obstacle cell: clearance 0.6 - robot_radius 0.3 = 0.3 of slowdown 0.5
    near = p.command(Pose2D(-0.95, 0.45, 0.0), 0.0)
    share = (0.6 - cfg.robot_radius) / cfg.obstacle_slowdown
    floor = math.cos(math.radians(cfg.turn_in_place_deg))
    gx, gy = p.gradient(-0.95, 0.45)
    error = math.atan2(-gy, -gx)
    expected = cfg.max_linear_speed * (math.cos(error) - floor) / (1 - floor) * share
    assert near.linear == pytest.approx(expected)
    # 1.05 m away (clearance 0.75 m, beyond the slowdown distance): no slow-down
    free = p.command(Pose2D(-0.95, 0.0, 0.0), 0.0)
    gx, gy = p.gradient(-0.95, 0.0)
    error = math.atan2(-gy, -gx)
    full = cfg.max_linear_speed * (math.cos(error) - floor) / (1 - floor)
    assert free.linear == pytest.approx(full) and free.linear > 0.0
    # touching it: never below min_speed_fraction of the full speed (the robot must leave)
    touching = p.command(Pose2D(-0.95, 0.9, 0.0), 0.0)
    gx, gy = p.gradient(-0.95, 0.9)
    error = math.atan2(-gy, -gx)
    full = cfg.max_linear_speed * max(0.0, (math.cos(error) - floor) / (1 - floor))
    assert touching.linear == pytest.approx(full * cfg.min_speed_fraction)


def test_stuck_after_the_configured_time_without_progress():
    cfg = PlannerConfig(
        extent=6.0, cell_size=0.1, stuck_time=3.0, stuck_progress=0.1, confirm_after_views=1
    )
    p = _converged(cfg)
    pose = Pose2D(-1.0, 0.0, 0.0)
    statuses = [p.command(pose, t).status for t in np.arange(0.0, 4.0, 0.5)]
    # best distance set at t=0; stuck from t=3.0 on
    assert statuses == [Status.DRIVING] * 6 + [Status.STUCK] * 2
    # progress (more than 0.1 m closer) clears it; a small creep does not
    assert p.command(Pose2D(-0.95, 0.0, 0.0), 4.0).status is Status.STUCK
    assert p.command(Pose2D(-0.8, 0.0, 0.0), 4.5).status is Status.DRIVING
    assert p.command(Pose2D(-0.8, 0.0, 0.0), 7.4).status is Status.DRIVING
    assert p.command(Pose2D(-0.8, 0.0, 0.0), 7.5).status is Status.STUCK


def test_path_is_bounded_and_says_which_bound_stopped_it():
    cfg = PlannerConfig(
        extent=6.0, cell_size=0.1, path_max_steps=10, path_step=0.05, confirm_after_views=1
    )
    p = _converged(cfg)
    path = p.trace_path(Pose2D(-2.0, 0.0, 0.0))
    assert path.end is PathEnd.MAX_STEPS
    assert path.points.shape == (11, 2)
    assert path.points[-1] == pytest.approx((-1.5, 0.0), abs=0.01)
    # a fresh grid far from the goal is flat (log guess is not flat, so flatten it)
    flat = HarmonicPlanner.centred_on(cfg, (0.0, 0.0), (2.0, 0.0))
    flat._u[1:-1, 1:-1] = 1.0  # private on purpose: an unrelaxed all-ones start
    flat._apply_dirichlet()
    got = flat.trace_path(Pose2D(-2.0, 0.0, 0.0))
    assert got.end is PathEnd.FLAT and got.points.shape == (1, 2)
    assert flat.command(Pose2D(-2.0, 0.0, 0.0), 0.0).linear == 0.0


def test_path_into_obstacle_or_off_grid_is_reported():
    cfg = PlannerConfig(
        extent=6.0,
        cell_size=0.1,
        robot_radius=0.0,
        inflation_margin=0.0,
        confirm_after_views=1,
        **PAPER,
    )
    p = _converged(cfg)
    p._u[:] = p.geometry.centres()[0] / 10.0  # private on purpose: U rises along +x
    p._grad_cache = None
    assert p.trace_path(Pose2D(0.0, 0.0, 0.0)).end is PathEnd.LEFT_GRID
    wall = np.array([[-1.05, y] for y in np.arange(-1.0, 1.0, 0.01)])
    p.update_obstacles(wall, Pose2D(0.0, 0.0, math.pi), 0.8)
    p._u[1:-1, 1:-1] = (p.geometry.centres()[0] / 10.0 + 0.5)[1:-1, 1:-1]
    p._grad_cache = None
    got = p.trace_path(Pose2D(0.0, 0.0, 0.0))
    assert got.end is PathEnd.OBSTACLE
    assert got.points[-1][0] == pytest.approx(-1.0, abs=0.06)


def _simulate(cfg: PlannerConfig, wall: np.ndarray, start: Pose2D, goal, max_time: float):
    """Closed loop: planner ticks at cfg.tick_rate, unicycle integrated at 10x that rate."""
    p = HarmonicPlanner.centred_on(cfg, (0.0, 0.0), goal)
    pose = start
    dt = cfg.tick_period / 10
    track = [(pose.x, pose.y)]
    inside = 0
    t = 0.0
    status = Status.DRIVING
    while t < max_time:
        p.update_obstacles(wall, pose, math.radians(30.0))
        p.relax()
        cmd = p.command(pose, t)
        status = cmd.status
        if status is not Status.DRIVING:
            break
        for _ in range(10):
            th = pose.theta + cmd.angular * dt
            pose = Pose2D(
                pose.x + cmd.linear * dt * math.cos(pose.theta),
                pose.y + cmd.linear * dt * math.sin(pose.theta),
                math.atan2(math.sin(th), math.cos(th)),
            )
            track.append((pose.x, pose.y))
            i, j = p.geometry.cell_of(pose.x, pose.y)
            inside += int(p.detected_mask[i, j])
        t += cfg.tick_period
    return p, status, np.array(track), inside, t


@pytest.mark.parametrize("kind", list(Relaxation), ids=lambda k: k.value)
def test_end_to_end_robot_drives_around_a_wall_to_the_goal(kind):
    # unknown cells free: the field leads straight at the goal until the wall is seen (with
    # frontier_field the robot may go round it without ever looking at it)
    cfg = PlannerConfig(
        extent=10.0,
        cell_size=0.1,
        relaxation=kind,
        sweeps_per_tick=40,
        confirm_after_views=1,
        frontier_field=False,
    )
    # a wall 3 m wide across the straight line from start to goal, seen by the cameras
    ys = np.arange(-1.5, 1.5, 0.02)
    wall = np.column_stack([np.zeros_like(ys), ys, np.full_like(ys, 0.3)])
    start, goal = Pose2D(-3.0, 0.2, math.pi / 2), (3.0, 0.0)
    p, status, track, inside, t = _simulate(cfg, wall, start, goal, max_time=120.0)
    assert status is Status.GOAL_REACHED, f"{status} at t={t:.1f}s, at {track[-1]}"
    assert np.hypot(*(track[-1] - goal)) <= cfg.goal_tolerance + 0.06
    assert inside == 0
    # the wall was seen and went around, not through
    assert p.detected_mask.any()
    crossing = track[np.argmin(np.abs(track[:, 0]))]
    assert abs(crossing[1]) > 1.5 + cfg.robot_radius - 0.1
    # and the track never came closer to a wall fly than the inflation allows, less a cell
    d = np.min(np.hypot(track[:, None, 0] - wall[None, :, 0], track[:, None, 1] - wall[None, :, 1]))
    assert d > cfg.robot_radius - cfg.cell_size


@pytest.mark.parametrize("rise", [0.1, 0.0])
def test_path_from_inside_an_inflated_obstacle_leaves_it(rise):
    cfg = PlannerConfig(
        extent=6.0, cell_size=0.1, robot_radius=0.5, escape_rise=rise, confirm_after_views=1
    )
    p = _converged(cfg)
    robot = Pose2D(-1.0, 0.0, 0.0)
    # flies 0.3 m to the robot's left: the robot now sits in the inflated obstacle
    flies = np.column_stack([np.full(20, -1.0), np.linspace(0.26, 0.34, 20)])
    p.update_obstacles(flies, robot, math.radians(100.0))
    i, j = p.geometry.cell_of(robot.x, robot.y)
    assert p.obstacle_mask[i, j]
    p.relax_until(1e-10, 20_000)
    got = p.trace_path(robot)
    if rise == 0.0:  # a flat 1 inside the obstacle: no way out
        assert got.end is PathEnd.FLAT
        assert p.command(robot, 0.0).linear == 0.0
        return
    assert got.end is PathEnd.GOAL
    cells = [p.geometry.cell_of(x, y) for x, y in got.points]
    inside = [bool(p.obstacle_mask[c]) for c in cells]
    first_free = inside.index(False)
    assert not any(inside[first_free:])
    # moving away from the flies: the first steps go down (−y) and on towards the goal
    assert got.points[first_free][1] < 0.0


def test_cleared_obstacles_relax_back_to_the_obstacle_free_field():
    p = _converged()
    fresh = _converged()
    wall = np.column_stack([np.full(100, 1.0), np.linspace(-0.5, 0.5, 100)])
    p.update_obstacles(wall, Pose2D(0.0, 0.0, 0.0), 0.8)
    assert p.obstacle_mask.any()
    p.relax_until(1e-10, 20_000)
    assert np.abs(p.potential - fresh.potential).max() > 0.01
    p.clear_obstacles()
    assert not p.obstacle_mask.any() and not p.detected_mask.any()
    assert p.potential.max() == 1.0  # the freed core (1 + rise) is clipped back to 1
    p.relax_until(1e-10, 20_000)
    np.testing.assert_allclose(p.potential, fresh.potential, atol=1e-6)


@pytest.mark.parametrize("weight", [1.0, 0.1])
def test_freed_obstacle_cells_restart_at_the_skin_value_not_as_a_sink(weight):
    p = _converged(dataclasses.replace(SMALL, obstacle_weight=weight))
    wall = np.column_stack([np.full(100, 1.0), np.linspace(-0.5, 0.5, 100)])
    p.update_obstacles(wall, Pose2D(0.0, 0.0, 0.0), 0.8)
    p.update_obstacles(wall, Pose2D(0.0, 0.0, 0.0), 0.8)  # confirmed
    was = p.obstacle_mask.copy()
    assert was.any()
    p.relax(50)
    p.clear_obstacles()
    # before any sweep the freed cells hold U = 1, not weight × value (a sink at 0.1)
    np.testing.assert_array_equal(p.potential[was], 1.0)


def _corridor_planner(
    weight: float, kind: Relaxation = Relaxation.NUMBA, lookahead: float = 0.0
) -> HarmonicPlanner:
    """The corridor scene's walls (y = ±1.5 from x = −1 to 11.5, open at both ends) and its
    four obstacles (unrotated) as detected cells, start (0, 0), goal (10.5, 0), the
    experiments' 20 m grid, inflated by 0.4 m; converged."""
    cfg = PlannerConfig(
        obstacle_weight=weight, relaxation=kind, lookahead=lookahead, inflation_margin=0.1
    )
    p = HarmonicPlanner.centred_on(cfg, (5.25, 0.0), (10.5, 0.0))
    x, y = p.geometry.centres()
    walls = (np.abs(np.abs(y) - 1.5) < 0.05) & (x > -1.0) & (x < 11.5)
    boxes = [(3.0, 0.9, 0.3, 0.3), (5.5, -0.9, 0.35, 0.3), (7.5, 0.95, 0.25, 0.25)]
    boxes.append((9.0, -0.95, 0.25, 0.25))
    for cx, cy, hx, hy in boxes:
        walls |= (np.abs(x - cx) < hx) & (np.abs(y - cy) < hy)
    p.set_detected(walls)
    assert p.relax_until(1e-13, 20_000, chunk=100).end is RelaxEnd.CONVERGED
    return p


def test_dirichlet_obstacles_send_the_robot_out_of_the_corridor_a_small_weight_through_it():
    # Dirichlet obstacles (the paper's form): 1 − U decays like exp(−π x / w) along the
    # 2.2 m free channel, so from the start the detour out of the back opening and round
    # a wall beats the 10.5 m straight channel: −∇U points backwards.
    paper = _corridor_planner(1.0)
    assert paper.gradient(0.0, 0.0)[0] > 0.0
    assert 1.0 - paper.value(0.0, 0.0) < 1e-5
    robin = _corridor_planner(0.03)
    gx, gy = robin.gradient(0.0, 0.0)
    assert gx < 0.0 and abs(gy) < 0.1 * abs(gx)
    assert abs(gx) > 100.0 * abs(paper.gradient(0.0, 0.0)[0])
    path = robin.trace_path(Pose2D(0.0, 0.0, 0.0))
    assert path.points[:, 0].min() > -0.05  # never backwards
    assert np.abs(path.points[:, 1]).max() < 1.5 - 0.4  # inside the inflated walls
    assert np.hypot(*(path.points[-1] - (10.5, 0.0))) < 0.1


@pytest.mark.parametrize("kind", list(Relaxation), ids=lambda k: k.value)
def test_weighted_obstacles_keep_u_harmonic_without_local_minima(kind):
    cfg = PlannerConfig(
        extent=6.0,
        cell_size=0.1,
        obstacle_weight=0.05,
        relaxation=kind,
        escape_rise=0.1,
        inflation_margin=0.1,  # the descent passes within goal_tolerance of the goal point
    )
    p = HarmonicPlanner.centred_on(cfg, (0.0, 0.0), (2.0, 0.0))
    x, y = p.geometry.centres()
    p.set_detected((np.abs(x - 1.0) < 0.05) & (np.abs(y) < 1.0))  # a wall across
    assert p.relax_until(1e-12, 50_000, chunk=100).end is RelaxEnd.CONVERGED
    u, obstacles = p.potential.astype(np.float64), p.obstacle_mask
    # U is the obstacles' own values on them (skin 1), below 1 in free space
    np.testing.assert_array_equal(
        u[obstacles & ~p._border], p.map.values[obstacles & ~p._border].astype(np.float32)
    )
    free = ~obstacles & ~p._border
    assert u[free].max() < 1.0 and u[free].min() == 0.0
    # no free cell but the goal is a local minimum of U
    gi, gj = p.geometry.cell_of(2.0, 0.0)
    for i, j in zip(*np.nonzero(free), strict=True):
        if (i, j) != (gi, gj):
            assert _has_lower_neighbour(u, i, j), (i, j)
    # the path from behind the wall goes round it to the goal
    path = p.trace_path(Pose2D(0.0, 0.0, 0.0))
    assert path.end is PathEnd.GOAL


def _has_lower_neighbour(u: np.ndarray, i: int, j: int) -> bool:
    return min(u[i - 1, j], u[i + 1, j], u[i, j - 1], u[i, j + 1]) < u[i, j]


def test_obstacle_weight_must_be_positive():
    with pytest.raises(ConfigError, match="obstacle_weight must be above 0"):
        PlannerConfig(obstacle_weight=0.0)


def test_lookahead_steers_at_the_point_that_far_down_the_descent_path():
    cfg = PlannerConfig(**{**SMALL.__dict__, "obstacle_weight": 0.03, "lookahead": 0.5})
    p = HarmonicPlanner.centred_on(cfg, (0.0, 0.0), (2.0, 0.0))
    x, y = p.geometry.centres()
    p.set_detected((np.abs(x - 0.8) < 0.05) & (np.abs(y) < 1.0))  # a wall across
    assert p.relax_until(1e-10, 20_000).end is RelaxEnd.CONVERGED
    pose = Pose2D(0.8, -1.5, 0.0)  # below the wall's end: the path bends round it
    path = p.trace_path(pose).points
    k = 10  # 0.5 m in steps of path_step 0.05 m
    dx, dy = p.steering_direction(pose)
    np.testing.assert_allclose((dx, dy), path[k] - (pose.x, pose.y), atol=1e-12)
    # without lookahead: −∇U at the robot, a different heading on the bend
    gx, gy = p.gradient(pose.x, pose.y)
    plain = HarmonicPlanner.centred_on(
        PlannerConfig(**{**cfg.__dict__, "lookahead": 0.0}), (0.0, 0.0), (2.0, 0.0)
    )
    plain.set_detected(p.detected_mask)
    plain._u[:] = p._u
    np.testing.assert_allclose(plain.steering_direction(pose), (-gx, -gy), atol=0)
    assert abs(math.atan2(dy, dx) - math.atan2(-gy, -gx)) > 0.03


def _drive_through_corridor(p: HarmonicPlanner) -> tuple[Pose2D, float]:
    """Noise-free unicycle on the converged field at 10 Hz: the end pose and ∫w² dt."""
    from flylog.sim.kinematics import integrate_unicycle

    pose, w2 = Pose2D(0.0, 0.0, 0.0), 0.0
    for k in range(1200):
        c = p.command(pose, 0.1 * k)
        if c.status is Status.GOAL_REACHED:
            break
        w2 += c.angular**2 * 0.1
        pose = integrate_unicycle(pose, c.linear, c.angular, 0.1)
    return pose, w2


def test_lookahead_turns_less_through_the_corridor():
    # the simulated heading noise grows with the turn rate: its variance with ∫w² dt
    plain = _corridor_planner(0.03)
    ahead = _corridor_planner(0.03, lookahead=0.5)
    end_plain, w2_plain = _drive_through_corridor(plain)
    end_ahead, w2_ahead = _drive_through_corridor(ahead)
    for end in (end_plain, end_ahead):
        assert math.hypot(end.x - 10.5, end.y) <= plain.config.goal_tolerance
    assert w2_ahead < 0.8 * w2_plain


def test_smoothed_direction_follows_a_step_with_its_time_constant():
    s = SmoothedDirection(0.5)
    assert s.update((2.0, 0.0), 0.0) == (1.0, 0.0)  # the first direction, as a unit vector
    # a step to +y: after one time constant (in small steps) the angle is about 1 − 1/e of
    # the way for small steps of a vector that is renormalised each time: between 40° and 90°
    for k in range(1, 51):
        x, y = s.update((0.0, 3.0), k * 0.01)
    assert math.isclose(math.hypot(x, y), 1.0)
    assert 40.0 < math.degrees(math.atan2(y, x)) < 90.0
    for k in range(51, 600):
        x, y = s.update((0.0, 3.0), k * 0.01)
    assert math.degrees(math.atan2(y, x)) > 89.9
    # a flat direction passes through and does not move the filter
    assert s.update((0.0, 0.0), 7.0) == (0.0, 0.0)
    assert s.update((1.0, 0.0), 5.99) == (x, y)  # no time elapsed since the last update


def test_no_smoothing_passes_every_direction_through():
    s = SmoothedDirection(0.0)
    assert s.update((3.0, 4.0), 0.0) == (3.0, 4.0)
    assert s.update((-1.0, 0.0), 0.1) == (-1.0, 0.0)


def test_smoothing_turns_less_through_a_flickering_field():
    """Directions alternating ±60° about +x at 10 Hz: the smoothed heading swings less than
    half as far from +x as the raw one."""
    s = SmoothedDirection(0.5)
    angles = []
    for k in range(100):
        a = math.radians(60.0 if k % 2 else -60.0)
        x, y = s.update((math.cos(a), math.sin(a)), 0.1 * k)
        angles.append(math.degrees(math.atan2(y, x)))
    assert max(abs(a) for a in angles[10:]) < 30.0
