"""Frontiers nearest the goal first (``planner.frontier_field``): where the field pulls the
robot while the goal is not in the space it has seen.

A cell is *known* once the cameras have seen it (in view, not in a shadow), a sonar has
heard it free, or an obstacle was found in it (:attr:`~flylog.planner.map.ObstacleMap.
known`). The *frontier* is the unknown cells (not obstacles) beside the known free cells
the robot can reach from where it stands. While the goal is not among those reachable
cells, the frontier cells nearest the goal in a straight line (within ``band`` metres of the
nearest one) are the field's sinks in the goal's place; unknown cells are still free space.
The robot goes to see the unknown space on the goal's side of what it knows, instead of
following the goal's pull round the outside of walls it has not mapped yet (with the goal
as the sink, each unmapped stretch of wall opens such a way: docs/navigation.md). Once the
goal is reachable in known space it is the sink again."""

from __future__ import annotations

import numpy as np

from flylog.planner.reach import reachable_from


def beside(region: np.ndarray) -> np.ndarray:
    """(H, W) bool: the cells 4-adjacent to a cell of ``region`` (region's cells too)."""
    out = region.copy()
    out[1:, :] |= region[:-1, :]
    out[:-1, :] |= region[1:, :]
    out[:, 1:] |= region[:, :-1]
    out[:, :-1] |= region[:, 1:]
    return out


def reachable_frontier(
    known: np.ndarray, obstacles: np.ndarray, start: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray]:
    """(region, frontier), each (H, W) bool: the known free cells reachable from the cell
    ``start``, and the unknown cells (not obstacles) beside them."""
    region = reachable_from(known & ~obstacles, start)
    return region, beside(region) & ~known & ~obstacles


def nearest_cells(cells: np.ndarray, goal_distance: np.ndarray, band: float) -> np.ndarray:
    """The cells of ``cells`` within ``band`` (m) of their least ``goal_distance`` (m)."""
    if not cells.any():
        return cells.copy()
    return cells & (goal_distance <= float(goal_distance[cells].min()) + band)


def frontier_sinks(
    known: np.ndarray,
    obstacles: np.ndarray,
    start: tuple[int, int],
    goal: tuple[int, int],
    goal_distance: np.ndarray,
    band: float,
) -> np.ndarray | None:
    """(H, W) bool: the frontier cells within ``band`` (m) of the frontier's least
    ``goal_distance`` (m, each cell's straight-line distance to the goal), as seen from the
    cell ``start``; None when ``goal`` is among the known free cells reachable from
    ``start`` (the goal is the sink). Empty when no frontier is reachable: the known free
    space round the robot is closed."""
    region, frontier = reachable_frontier(known, obstacles, start)
    if region[goal]:
        return None
    return nearest_cells(frontier, goal_distance, band)
