"""Frontiers nearest the goal first (planner.frontier_field): a room whose walls are mapped
only where the robot has looked, a passage from its door, the goal beyond."""

from __future__ import annotations

import numpy as np

from flylog.geometry import Pose2D
from flylog.planner import HarmonicPlanner, PlannerConfig
from flylog.planner.frontier import frontier_sinks

GOAL = (6.0, 2.0)


def _room(frontier: bool) -> HarmonicPlanner:
    """A 4 m room round the robot (all of it seen) whose east wall is mapped but for a
    1.2 m door, a passage 2.5 m long from the door (seen, its walls mapped); the room's
    other walls are not mapped and nothing beyond the room and the passage is known."""
    p = HarmonicPlanner.centred_on(
        PlannerConfig(extent=14.0, frontier_field=frontier), (1.5, 0.0), GOAL
    )
    x, y = p.geometry.centres()
    room = (np.abs(x) <= 2.0) & (np.abs(y) <= 2.0)
    passage = (x >= 2.0) & (x <= 4.5) & (np.abs(y) <= 0.6)
    east = (np.abs(x - 2.05) < 0.1) & (np.abs(y) <= 2.1) & (np.abs(y) > 0.6)
    sides = (x >= 2.0) & (x <= 4.5) & (np.abs(np.abs(y) - 0.65) < 0.1)
    p.set_detected(east | sides, room | passage | east | sides)
    p.update_frontier(Pose2D(0.0, 0.0, 0.0))
    p.relax_until(1e-9, 50_000)
    return p


def _leaves_room(path: np.ndarray) -> np.ndarray:
    out = np.nonzero((np.abs(path[:, 0]) > 2.0) | (np.abs(path[:, 1]) > 2.0))[0]
    return path[out[0]]


def test_unknown_cells_free_lead_through_the_wall_not_mapped():
    path = _room(False).trace_path(Pose2D(0.0, 0.0, 0.0)).points
    x, y = _leaves_room(path)
    assert y > 2.0 and x < 2.0  # out through the north wall, not the door
    assert np.hypot(*(path[-1] - GOAL)) < 0.2


def test_the_frontier_nearest_the_goal_leads_through_the_door_and_the_passage():
    p = _room(True)
    path = p.trace_path(Pose2D(0.0, 0.0, 0.0)).points
    x, y = _leaves_room(path)
    assert abs(x - 2.0) < 0.1 and abs(y) < 0.6  # through the door
    # the descent ends at the passage's far end, the frontier cells nearest the goal
    assert np.all(np.abs(path[-50:, 1]) < 0.6)
    assert np.all(path[-50:, 0] > 4.3)


def test_sinks_are_the_goal_once_reachable_in_known_space_and_none_in_a_closed_room():
    known = np.zeros((30, 30), dtype=bool)
    known[2:18, 2:18] = True
    obstacles = np.zeros_like(known)
    i, j = np.indices(known.shape)
    distance = np.hypot(i - 10.0, j - 25.0) * 0.1
    sinks = frontier_sinks(known, obstacles, (5, 5), (10, 25), distance, band=0.01)
    assert sinks is not None
    # the unknown cells beside the known square nearest the goal: column 18, rows 9-11
    assert sorted(zip(*np.nonzero(sinks), strict=True)) == [(9, 18), (10, 18), (11, 18)]
    assert frontier_sinks(known, obstacles, (5, 5), (10, 10), distance, band=0.01) is None
    inner = np.zeros_like(known)
    inner[3:17, 3:17] = True
    walls = known & ~inner  # the square's rim, mapped
    closed = frontier_sinks(known, walls, (5, 5), (10, 25), distance, band=0.01)
    assert closed is not None and not closed.any()


def test_cells_count_as_seen_only_as_far_as_a_fly_counts_fully():
    """No fly in view: the cells in view are seen free up to the view range, but known only
    up to sqrt(full_weight_depth_error × f·B) (2.12 m for f·B = 30 px·m), and the robot's
    own cells are known too."""
    cfg = PlannerConfig(extent=12.0)
    p = HarmonicPlanner.centred_on(cfg, (0.0, 0.0), (5.0, 0.0))
    pose = Pose2D(0.0, 0.0, 0.0)
    p.update_obstacles(np.zeros((0, 2)), pose, np.radians(30.0), 4.7, focal_baseline=30.0)
    x, y = p.geometry.centres()
    r = np.hypot(x, y)
    known = p.map.known
    reach = np.sqrt(cfg.full_weight_depth_error * 30.0)
    assert known[(r < reach - 0.1) & (np.abs(np.arctan2(y, x)) < np.radians(25.0))].all()
    assert not known[r > reach + 0.1].any()
    assert known[r <= cfg.robot_radius].all()
