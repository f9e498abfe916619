"""Goal cut off in the map: the planner says so, tries its recoveries in order, then
UNREACHABLE."""

import math

import numpy as np

from flylog.geometry import Pose2D
from flylog.planner import HarmonicPlanner, PlannerConfig, Status
from flylog.planner.recovery import Recovery

CFG = PlannerConfig(extent=6.0, cut_off_time=0.5, backup_distance=0.3, backup_speed=0.15)
GOAL = (2.0, 0.0)
FOV = math.radians(30.0)


def _ring(radius: float, centre=GOAL) -> np.ndarray:
    a = np.linspace(0.0, 2.0 * math.pi, 400, endpoint=False)
    return np.column_stack([centre[0] + radius * np.cos(a), centre[1] + radius * np.sin(a)])


def _drive(p, seconds, echoes, dt=0.1, heading=0.0):
    """Tick the planner at 10 Hz, moving the robot with each command; the (t, command,
    pose) of every tick."""
    pose, out = Pose2D(0.0, 0.0, heading), []
    for k in range(round(seconds / dt)):
        t = k * dt
        now = echoes(t) if callable(echoes) else echoes
        p.update_obstacles(np.empty((0, 2)), pose, FOV, sonar_xy=now)
        p.relax()
        cmd = p.command(pose, t)
        out.append((t, cmd, pose))
        theta = pose.theta + cmd.angular * dt
        pose = Pose2D(
            pose.x + cmd.linear * dt * math.cos(pose.theta),
            pose.y + cmd.linear * dt * math.sin(pose.theta),
            theta,
        )
    return out


def test_an_open_map_needs_no_recovery():
    p = HarmonicPlanner.centred_on(CFG, (1.0, 0.0), GOAL)
    assert not p.goal_cut_off(Pose2D(0.0, 0.0, 0.0))
    ticks = _drive(p, 3.0, None)
    assert all(c.recovery is Recovery.NONE for _, c, _ in ticks)


def test_recoveries_run_in_order_then_the_goal_is_unreachable():
    p = HarmonicPlanner.centred_on(CFG, (1.0, 0.0), GOAL)
    ring = _ring(0.9)  # echoed every tick: current evidence, never stale
    ticks = _drive(p, 30.0, ring)
    assert p.goal_cut_off(Pose2D(0.0, 0.0, 0.0))
    phases = [c.recovery for _, c, _ in ticks]
    order = [ph for k, ph in enumerate(phases) if k == 0 or ph is not phases[k - 1]]
    assert order == [
        Recovery.NONE,
        Recovery.LOOK_AROUND,
        Recovery.CLEAR_STALE,
        Recovery.BACK_UP,
        Recovery.EXHAUSTED,
    ]
    first = phases.index(Recovery.LOOK_AROUND)
    assert ticks[first][0] == 0.5  # after cut_off_time
    look = [(c, pose) for _, c, pose in ticks if c.recovery is Recovery.LOOK_AROUND]
    assert all(c.linear == 0.0 and c.angular == CFG.max_angular_speed for c, _ in look)
    turned = look[-1][1].theta - look[0][1].theta + CFG.max_angular_speed * 0.1
    assert turned >= 2.0 * math.pi - 1e-9
    back = [(c, pose) for _, c, pose in ticks if c.recovery is Recovery.BACK_UP]
    assert all(c.linear == -CFG.backup_speed and c.angular == 0.0 for c, _ in back)
    start, end = back[0][1], ticks[phases.index(Recovery.EXHAUSTED)][2]
    assert math.hypot(end.x - start.x, end.y - start.y) >= CFG.backup_distance - 1e-9
    spent = [c for _, c, _ in ticks if c.recovery is Recovery.EXHAUSTED]
    assert spent and all(
        c.status is Status.UNREACHABLE and c.linear == c.angular == 0.0 for c in spent
    )
    assert ticks[first - 1][1].status is Status.DRIVING


def test_looking_around_clears_cells_seen_free():
    p = HarmonicPlanner.centred_on(CFG, (1.0, 0.0), GOAL)
    p.update_obstacles(np.empty((0, 2)), Pose2D(0.0, 0.0, 0.0), FOV, sonar_xy=_ring(0.9))
    # facing away, the robot does not see the ring until it turns round
    ticks = _drive(p, 20.0, None, heading=math.pi)
    phases = [c.recovery for _, c, _ in ticks]
    assert Recovery.LOOK_AROUND in phases and Recovery.CLEAR_STALE not in phases
    assert phases[-1] is Recovery.NONE and not p.goal_cut_off(ticks[-1][2])


def test_clearing_stale_cells_reopens_a_goal_cut_off_by_old_cells():
    cfg = PlannerConfig(**{**CFG.__dict__, "clear_free_cells": False})  # not seen free
    p = HarmonicPlanner.centred_on(cfg, (1.0, 0.0), GOAL)
    ring = _ring(0.9)
    p.update_obstacles(np.empty((0, 2)), Pose2D(0.0, 0.0, 0.0), FOV, sonar_xy=ring)
    # seen once and never again (no echo, out of view): stale, far from current evidence
    ticks = _drive(p, 20.0, None)
    phases = [c.recovery for _, c, _ in ticks]
    k = phases.index(Recovery.CLEAR_STALE)
    assert Recovery.BACK_UP not in phases and phases[k + 1] is Recovery.NONE
    assert not p.goal_cut_off(ticks[-1][2]) and not p.detected_mask.any()


def test_no_back_up_into_a_remembered_obstacle():
    p = HarmonicPlanner.centred_on(CFG, (1.0, 0.0), GOAL)
    behind = np.column_stack([np.full(50, -0.3), np.linspace(-0.5, 0.5, 50)])
    ticks = _drive(p, 30.0, np.vstack([_ring(0.9), behind]))
    phases = [c.recovery for _, c, _ in ticks]
    assert Recovery.EXHAUSTED in phases
    assert all(c.linear >= 0.0 for _, c, _ in ticks if c.recovery is not Recovery.NONE)


def test_the_sequence_ends_when_the_goal_is_reachable_again():
    p = HarmonicPlanner.centred_on(CFG, (1.0, 0.0), GOAL)
    ring = _ring(0.9)
    ticks = _drive(p, 5.0, ring)
    assert ticks[-1][1].recovery is Recovery.LOOK_AROUND
    p.clear_obstacles()
    cmd = p.command(ticks[-1][2], 5.0)
    assert cmd.recovery is Recovery.NONE and p.recovery is Recovery.NONE


def test_cells_seen_during_the_look_around_are_not_stale():
    """A wall heard on one tick in the middle of the look-around (not at its end) is kept
    by clear_stale: the goal stays cut off and is reported unreachable."""
    cfg = PlannerConfig(**{**CFG.__dict__, "clear_free_cells": False})
    p = HarmonicPlanner.centred_on(cfg, (1.0, 0.0), GOAL)
    ring = _ring(0.9)
    p.update_obstacles(np.empty((0, 2)), Pose2D(0.0, 0.0, 0.0), FOV, sonar_xy=ring)
    ticks = _drive(p, 30.0, lambda t: ring if abs(t - 5.0) < 0.05 else None)
    phases = [c.recovery for _, c, _ in ticks]
    assert phases.index(Recovery.LOOK_AROUND) < 50 < phases.index(Recovery.CLEAR_STALE)
    assert ticks[-1][1].status is Status.UNREACHABLE and p.detected_mask.any()


def test_cells_the_look_around_cannot_see_are_not_stale():
    """As test_clearing_stale_cells_reopens_a_goal_cut_off_by_old_cells, but the ring (1.1
    m off at its nearest) lies beyond the view range (0.5 m): no view contradicts it, so
    clear_stale keeps it and the goal is unreachable."""
    cfg = PlannerConfig(**{**CFG.__dict__, "clear_free_cells": False, "view_range": 0.5})
    p = HarmonicPlanner.centred_on(cfg, (1.0, 0.0), GOAL)
    p.update_obstacles(np.empty((0, 2)), Pose2D(0.0, 0.0, 0.0), FOV, sonar_xy=_ring(0.9))
    ticks = _drive(p, 30.0, None)
    phases = [c.recovery for _, c, _ in ticks]
    assert Recovery.CLEAR_STALE in phases and phases[-1] is Recovery.EXHAUSTED
    assert ticks[-1][1].status is Status.UNREACHABLE and p.detected_mask.any()
