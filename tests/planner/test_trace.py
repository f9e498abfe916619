"""The compiled path trace against the plain-Python descent it replaces."""

from __future__ import annotations

import numpy as np
import pytest

from flylog.geometry import Pose2D
from flylog.planner import HarmonicPlanner, PlannerConfig
from flylog.planner.grid import bilinear, gradient_field
from flylog.planner.steering import PathEnd, descend
from flylog.planner.trace import descend_on_grid


def _planner(walls: bool) -> HarmonicPlanner:
    cfg = PlannerConfig(extent=6.0, cell_size=0.1, robot_radius=0.2)
    planner = HarmonicPlanner.centred_on(cfg, (0.0, 0.0), (2.2, 0.3))
    if walls:
        # a wall across the way, seen from the start
        ys = np.linspace(-1.0, 0.8, 60)
        wall = np.column_stack([np.full_like(ys, 0.6), ys])
        for _ in range(cfg.confirm_after_views):
            planner.update_obstacles(wall, Pose2D(-2.0, 0.0, 0.0), 1.0)
    planner.relax_until(1e-9, 6000)
    return planner


@pytest.mark.parametrize("walls", [False, True])
@pytest.mark.parametrize(
    ("start", "max_steps"),
    [((-2.0, 0.0), None), ((-2.0, 0.0), 7), ((1.0, -2.5), None), ((0.6, 0.0), None)],
)
def test_compiled_descent_follows_the_python_descent(walls, start, max_steps):
    planner = _planner(walls)
    cfg, grid, blocked = planner.config, planner.geometry, planner.obstacle_mask
    gx, gy = gradient_field(planner.potential.astype(np.float64), cfg.cell_size)
    whole = max_steps is None
    max_steps = cfg.path_max_steps if whole else max_steps
    bounds = {"step": cfg.path_step, "max_steps": max_steps, "goal_tolerance": cfg.goal_tolerance}
    reference = descend(
        start,
        planner.goal,
        lambda x, y: (bilinear(gx, grid, x, y), bilinear(gy, grid, x, y)),
        lambda x, y: bool(blocked[grid.cell_of(x, y)]) if grid.contains(x, y) else None,
        **bounds,
    )
    ours = descend_on_grid((gx, gy), blocked, grid, start, planner.goal, **bounds)
    if whole:
        assert ours.end == reference.end
        assert len(ours.points) > 10
        np.testing.assert_allclose(ours.points, reference.points, rtol=0, atol=1e-12)
    else:
        assert ours.end is PathEnd.MAX_STEPS and len(ours.points) == max_steps + 1
        np.testing.assert_allclose(ours.points, reference.points[: max_steps + 1], atol=1e-9)
