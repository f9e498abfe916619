import math

import numpy as np
import pytest

from flylog.planner import Relaxation, sor_sweeps, sor_sweeps_numba, sor_sweeps_numpy

IMPLS = [sor_sweeps_numba, sor_sweeps_numpy]
IDS = ["numba", "numpy"]


def _box(h: int, w: int) -> np.ndarray:
    fixed = np.zeros((h, w), dtype=bool)
    fixed[[0, -1], :] = True
    fixed[:, [0, -1]] = True
    return fixed


def _has_lower_neighbour(u: np.ndarray, i: int, j: int) -> bool:
    return min(u[i - 1, j], u[i + 1, j], u[i, j - 1], u[i, j + 1]) < u[i, j]


def test_numba_equals_numpy_sweep_for_sweep():
    rng = np.random.default_rng(7)
    u = rng.random((23, 31))
    fixed = _box(23, 31) | (rng.random((23, 31)) < 0.1)
    a, b = u.copy(), u.copy()
    for _ in range(6):
        ca = sor_sweeps_numba(a, fixed, 1.7, 1)
        cb = sor_sweeps_numpy(b, fixed, 1.7, 1)
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-14)
        assert ca == pytest.approx(cb, rel=0, abs=1e-14)
        assert ca > 0.0
    # fixed cells are never written
    np.testing.assert_array_equal(a[fixed], u[fixed])


@pytest.mark.parametrize("shape", [(3, 3), (3, 8), (7, 7), (8, 8), (9, 4), (30, 41), (41, 30)])
def test_numba_equals_numpy_bit_for_bit_on_odd_and_even_grids(shape):
    # the numba kernel stores the colours apart and interleaves their rows: the same
    # arithmetic in an order that cannot change any result
    rng = np.random.default_rng(sum(shape))
    u = rng.random(shape)
    fixed = _box(*shape) | (rng.random(shape) < 0.15)
    a, b = u.copy(), u.copy()
    ca = sor_sweeps_numba(a, fixed, 1.9, 9)
    cb = sor_sweeps_numpy(b, fixed, 1.9, 9)
    np.testing.assert_array_equal(a, b)
    assert ca == cb


@pytest.mark.parametrize("sweep", IMPLS, ids=IDS)
def test_zero_sweeps_change_nothing(sweep):
    u = np.random.default_rng(1).random((8, 9))
    before = u.copy()
    assert sweep(u, _box(8, 9), 1.5, 0) == 0.0
    np.testing.assert_array_equal(u, before)


@pytest.mark.parametrize("sweep", IMPLS, ids=IDS)
@pytest.mark.parametrize("height", [3, 12])
def test_strip_converges_to_linear_solution(sweep, height):
    # Dirichlet 1 at the left end, 0 at the right, linear along the long sides: the discrete
    # (and continuous) harmonic function is the linear ramp.
    w = 41
    ramp = np.linspace(1.0, 0.0, w)
    u = np.zeros((height, w))
    u[0, :] = ramp
    u[-1, :] = ramp
    u[:, 0] = 1.0
    u[:, -1] = 0.0
    change = sweep(u, _box(height, w), 1.85, 3000)
    assert change < 1e-12
    np.testing.assert_allclose(u, np.broadcast_to(ramp, u.shape), atol=1e-10)


@pytest.mark.parametrize("sweep", IMPLS, ids=IDS)
@pytest.mark.parametrize("omega", [1.0, 1.8])
def test_gauss_seidel_and_sor_reach_the_same_solution(sweep, omega):
    fixed = _box(25, 25)
    fixed[12, 12] = True
    u = np.ones((25, 25))
    u[12, 12] = 0.0
    sweep(u, fixed, omega, 4000)
    ref = np.ones((25, 25))
    ref[12, 12] = 0.0
    sor_sweeps_numba(ref, fixed, 1.9, 4000)
    np.testing.assert_allclose(u, ref, atol=1e-9)
    # the symmetric problem has a symmetric solution
    np.testing.assert_allclose(u, u.T, atol=1e-9)
    np.testing.assert_allclose(u, u[::-1, :], atol=1e-9)


@pytest.mark.parametrize("sweep", IMPLS, ids=IDS)
@pytest.mark.parametrize("with_wall", [False, True], ids=["free", "wall"])
def test_converged_potential_has_no_local_minimum_but_the_goal(sweep, with_wall):
    n = 30
    fixed = _box(n, n)
    if with_wall:
        fixed[5:25, 15] = True  # a wall between most of the box and the goal
    goal = (14, 22)
    fixed[goal] = True
    u = np.ones((n, n))
    u[goal] = 0.0
    assert sweep(u, fixed, 1.9, 5000) < 1e-13
    free = [(i, j) for i in range(1, n - 1) for j in range(1, n - 1) if not fixed[i, j]]
    assert all(_has_lower_neighbour(u, i, j) for i, j in free)
    # steepest descent on the grid from every free cell reaches the goal
    for start in free:
        i, j = start
        for _ in range(n * n):
            if (i, j) == goal:
                break
            nbrs = [(i - 1, j), (i + 1, j), (i, j - 1), (i, j + 1)]
            i, j = min(nbrs, key=lambda c: u[c])
            assert not fixed[i, j] or (i, j) == goal
        assert (i, j) == goal, f"descent from {start} ended at {(i, j)}"


def test_sor_sweeps_dispatches_and_checks_types():
    u = np.random.default_rng(3).random((10, 10))
    a, b = u.copy(), u.copy()
    fixed = _box(10, 10)
    ca = sor_sweeps(a, fixed, 1.5, 3, Relaxation.NUMBA)
    cb = sor_sweeps(b, fixed, 1.5, 3, Relaxation.NUMPY)
    np.testing.assert_allclose(a, b, atol=1e-14)
    assert ca == pytest.approx(cb, abs=1e-14)
    with pytest.raises(ValueError, match="float64"):
        sor_sweeps(u.astype(np.float32), fixed, 1.5, 1, Relaxation.NUMBA)


@pytest.mark.parametrize("shape", [(3, 8), (8, 8), (9, 4), (30, 41)])
def test_numba_equals_numpy_bit_for_bit_with_per_cell_factors(shape):
    rng = np.random.default_rng(3 + sum(shape))
    u = rng.random(shape)
    fixed = _box(*shape) | (rng.random(shape) < 0.15)
    factor = 1.0 / (1.0 + 3.0 * rng.random(shape))  # weighted means: 1/4 … 1
    a, b = u.copy(), u.copy()
    ca = sor_sweeps_numba(a, fixed, 1.7, 7, factor)
    cb = sor_sweeps_numpy(b, fixed, 1.7, 7, factor)
    np.testing.assert_array_equal(a, b)
    assert ca == cb > 0.0


@pytest.mark.parametrize("sweep", IMPLS, ids=IDS)
def test_a_factor_of_a_quarter_everywhere_is_the_plain_mean(sweep):
    rng = np.random.default_rng(5)
    u = rng.random((17, 20))
    fixed = _box(17, 20) | (rng.random((17, 20)) < 0.1)
    a, b = u.copy(), u.copy()
    assert sweep(a, fixed, 1.8, 5, np.full(u.shape, 0.25)) == sweep(b, fixed, 1.8, 5)
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("sweep", IMPLS, ids=IDS)
@pytest.mark.parametrize("weight", [1.0, 0.1, 0.01])
def test_weighted_obstacles_give_the_discrete_robin_solution_along_a_channel(sweep, weight):
    # One free row between two obstacle rows (value 1, weight a, stored as a × 1), the goal
    # (0) at the left end and 1 at the right: with v = 1 − U the free cells obey
    # (2 + 2a) v_j = v_{j−1} + v_{j+1}, so v_j = A r^j + B r^−j with r + 1/r = 2 + 2a.
    # Dirichlet obstacles (a = 1) make v fall by r = 0.27 a cell: exp(−π x / w) in a wide
    # channel; a small weight lets the goal's pull reach far down the channel.
    n = 40
    u = np.full((3, n), weight)
    u[:, 0], u[:, -1] = 0.0, 1.0
    factor = np.full((3, n), 0.25)
    factor[1, 1:-1] = 1.0 / (2.0 + 2.0 * weight)
    fixed = _box(3, n)
    assert sweep(u, fixed, 1.2, 5000, factor) < 1e-14
    r = 1.0 + weight - math.sqrt(weight * weight + 2.0 * weight)
    j = np.arange(n)
    m = n - 1
    expected = (r**j - r ** (2 * m - j)) / (1.0 - r ** (2 * m))  # v_0 = 1, v_m = 0
    np.testing.assert_allclose(1.0 - u[1], expected, rtol=0, atol=1e-12)


def test_sor_sweeps_rejects_a_factor_of_the_wrong_shape():
    u, fixed = np.zeros((6, 7)), _box(6, 7)
    with pytest.raises(ValueError, match=r"factor float64 of shape \(6, 7\)"):
        sor_sweeps(u, fixed, 1.5, 1, Relaxation.NUMPY, np.full((7, 6), 0.25))
