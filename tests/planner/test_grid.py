import numpy as np
import pytest

from flylog.geometry import Pose2D
from flylog.planner import GridGeometry, HarmonicPlanner, PlannerConfig
from flylog.planner.grid import bilinear, centred_origin, gradient_field


def test_orientation_row_zero_at_origin_y_columns_along_x():
    g = GridGeometry((-1.0, 2.0), 0.1, 20)
    assert g.cell_of(-1.0 + 0.05, 2.0 + 0.25) == (2, 0)
    assert g.cell_of(-1.0 + 0.35, 2.0 + 0.05) == (0, 3)
    assert g.centre_of(2, 0) == pytest.approx((-0.95, 2.25))
    x, y = g.centres()
    assert (x[2, 0], y[2, 0]) == pytest.approx((-0.95, 2.25))
    rows, cols, inside = g.cells_of(np.array([[-0.95, 2.25], [5.0, 2.0], [np.nan, 2.0]]))
    assert inside.tolist() == [True, False, False]
    assert (rows[0], cols[0]) == (2, 0)


def test_centred_origin_puts_the_point_at_the_grid_centre():
    cfg = PlannerConfig(extent=4.0, cell_size=0.1)
    p = HarmonicPlanner.centred_on(cfg, (1.0, -2.0), (2.0, -2.0))
    assert p.origin == pytest.approx((-1.0, -4.0))
    assert centred_origin((1.0, -2.0), 4.0) == pytest.approx((-1.0, -4.0))
    assert p.potential.shape == (40, 40)
    assert p.potential.dtype == np.float32


def test_bilinear_value_and_gradient_exact_on_a_linear_function():
    g = GridGeometry((-3.0, 1.0), 0.2, 30)
    x, y = g.centres()
    a, b, c = 0.37, -1.25, 2.0
    u = a * x + b * y + c
    gx, gy = gradient_field(u, g.cell_size)
    rng = np.random.default_rng(5)
    for px, py in rng.uniform([-2.9, 1.1], [2.9, 6.9], size=(50, 2)):
        assert bilinear(u, g, px, py) == pytest.approx(a * px + b * py + c, abs=1e-12)
        assert bilinear(gx, g, px, py) == pytest.approx(a, abs=1e-9)
        assert bilinear(gy, g, px, py) == pytest.approx(b, abs=1e-9)


def test_planner_gradient_is_exact_on_a_linear_potential():
    cfg = PlannerConfig(extent=4.0, cell_size=0.1)
    p = HarmonicPlanner(cfg, (0.0, 0.0), (2.0, 2.0))
    x, y = p.geometry.centres()
    p._u[:] = 0.1 * x - 0.05 * y  # a known field; private on purpose (no public setter)
    p._grad_cache = None
    assert p.gradient(1.23, 2.71) == pytest.approx((0.1, -0.05), abs=1e-9)
    assert p.value(1.23, 2.71) == pytest.approx(0.1 * 1.23 - 0.05 * 2.71, abs=1e-12)


def test_bilinear_interpolates_between_centres():
    g = GridGeometry((0.0, 0.0), 1.0, 3)
    f = np.array([[0.0, 1.0, 0.0], [2.0, 4.0, 0.0], [0.0, 0.0, 0.0]])
    # halfway between the centres of [0,0], [0,1], [1,0], [1,1]
    assert bilinear(f, g, 1.0, 1.0) == pytest.approx((0 + 1 + 2 + 4) / 4)
    # clamped outside the outermost centres
    assert bilinear(f, g, -5.0, 0.5) == pytest.approx(0.0)


def test_path_starts_at_robot_and_reaches_goal_on_converged_field():
    cfg = PlannerConfig(extent=6.0, cell_size=0.1)
    p = HarmonicPlanner.centred_on(cfg, (0.0, 0.0), (2.0, 1.0))
    p.relax_until(1e-10, 20_000)
    path = p.trace_path(Pose2D(-2.0, -1.5, 0.0))
    assert path.end.value == "goal"
    assert path.points[0] == pytest.approx((-2.0, -1.5))
    assert path.points[-1] == pytest.approx((2.0, 1.0))
    steps = np.linalg.norm(np.diff(path.points[:-1], axis=0), axis=1)
    np.testing.assert_allclose(steps, cfg.path_step, rtol=1e-9)


@pytest.mark.parametrize("shape", [(2, 2), (3, 7), (40, 40), (201, 200)])
def test_gradient_field_is_numpys_gradient_value_for_value(shape):
    u = np.random.default_rng(11).normal(size=shape) * 1e3
    gy, gx = np.gradient(u, 0.05)
    ours_x, ours_y = gradient_field(u, 0.05)
    assert np.array_equal(ours_x, gx) and np.array_equal(ours_y, gy)
    gy, gx = np.gradient(u[:, ::-1], 0.05)  # not contiguous
    assert np.array_equal(gradient_field(u[:, ::-1], 0.05)[0], gx)


def test_gradient_field_refuses_a_grid_too_small():
    with pytest.raises(ValueError, match="at least 2 x 2"):
        gradient_field(np.zeros((1, 5)), 0.1)
    with pytest.raises(ValueError, match="float64"):
        gradient_field(np.zeros((5, 5), np.float32), 0.1)
