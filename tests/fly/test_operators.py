import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flylog.fly.neighbours import NeighbourCounter, grid_buffer_size, neighbour_counts_numpy
from flylog.fly.operators import newcomer_constants, newcomers_into, newcomers_numpy, random_flies
from flylog.fly.population import sharing_radius
from flylog.fly.selection import shared_fitness, survivor_indices
from flylog.geometry import StereoRig
from tests.fly.reference_operators import crossover2, crossover3, mutated, offspring
from tests.fly.reference_selection import (
    neighbour_counts_numba,
    shared_fitness_numba,
    survivor_indices_numba,
)

RIG = StereoRig()


def test_initialisation_uniform_in_left_image_and_inverse_depth():
    rng = np.random.default_rng(0)
    xyz = random_flies(rng, RIG, 200_000, d_min=0.5, d_max=20.0, margin=3)
    u, _, v, depth = RIG.project(xyz)
    assert u.min() >= 3 and u.max() <= RIG.width - 4
    assert v.min() >= 3 and v.max() <= RIG.height - 4
    inv = 1.0 / depth
    assert inv.min() >= 1 / 20.0 - 1e-12 and inv.max() <= 1 / 0.5 + 1e-12
    # Uniform: deciles of each coordinate are evenly spaced (within sampling noise).
    for x, lo, hi in ((u, 3, RIG.width - 4), (v, 3, RIG.height - 4), (inv, 1 / 20, 1 / 0.5)):
        deciles = np.quantile(x, np.linspace(0.1, 0.9, 9))
        np.testing.assert_allclose(deciles, lo + (hi - lo) * np.linspace(0.1, 0.9, 9), rtol=0.01)


def test_sharing_radius_formula():
    assert sharing_radius(640 * 480, 5000) == pytest.approx(0.5 * (math.sqrt(61.44) - 1))
    assert sharing_radius(100, 1000) == 0.0


SELECTIONS = [survivor_indices, survivor_indices_numba]
SHARINGS = [shared_fitness, shared_fitness_numba]


@pytest.mark.parametrize("select", SELECTIONS)
def test_selection_keeps_the_best_fraction_in_index_order(select):
    fitness = np.array([0.1, 0.9, -1.0, 0.5, 0.5, 0.3])
    assert list(select(fitness, 3)) == [1, 3, 4]
    assert list(select(fitness, 4)) == [1, 3, 4, 5]
    assert list(select(fitness, 6)) == [0, 1, 2, 3, 4, 5]
    assert list(select(fitness, 0)) == []
    # Ties at the cut: the lowest indices stay.
    assert list(select(np.array([0.2, 0.5, 0.2, 0.9, 0.2]), 3)) == [0, 1, 3]


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 300), st.floats(0.01, 1.0))
def test_selection_kernel_equals_reference(seed, n, share):
    rng = np.random.default_rng(seed)
    fitness = np.round(rng.normal(size=n), 1)  # rounded: many ties, also at the cut
    fitness[rng.random(n) < 0.1] = -1.0
    keep = max(1, round(share * n))
    expected = survivor_indices(fitness, keep)
    assert len(expected) == keep and np.all(np.diff(expected) > 0)
    # the same flies as the first `keep` of a stable sort, best first
    np.testing.assert_array_equal(expected, np.sort(np.argsort(-fitness, kind="stable")[:keep]))
    np.testing.assert_array_equal(survivor_indices_numba(fitness, keep), expected)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(0.0, 12.0), st.integers(1, 400))
def test_sweep_counts_equal_brute_force(seed, radius, n):
    rng = np.random.default_rng(seed)
    u = np.round(rng.normal(60, 15, n), 1)  # rounded: exact ties at the radius happen
    v = np.round(rng.normal(40, 10, n), 1)
    valid = rng.random(n) < 0.85
    expected = neighbour_counts_numpy(u, v, valid, radius)
    np.testing.assert_array_equal(neighbour_counts_numba(u, v, valid, radius), expected)


@pytest.mark.parametrize("share", SHARINGS)
def test_sharing_lowers_crowded_flies_by_k_n_median(share):
    fitness = np.array([2.0, 4.0, 6.0, -1.0])
    counts = np.array([0, 3, 1, 5])
    got = share(fitness, counts, 0.1)
    np.testing.assert_allclose(got, [2.0, 4.0 - 0.1 * 3 * 4.0, 6.0 - 0.1 * 4.0, -1.0])
    none_positive = np.array([-1.0, 0.0])
    np.testing.assert_array_equal(share(none_positive, np.array([2, 2]), 0.1), none_positive)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 200))
def test_sharing_kernel_equals_reference(seed, n):
    rng = np.random.default_rng(seed)
    fitness = np.where(rng.random(n) < 0.2, -1.0, rng.exponential(size=n))
    counts = rng.integers(0, 9, n)
    np.testing.assert_array_equal(
        shared_fitness_numba(fitness, counts, 0.07), shared_fitness(fitness, counts, 0.07)
    )


def test_mutation_is_gaussian_in_image_and_disparity():
    rng = np.random.default_rng(1)
    parent = RIG.backproject(np.array([320.0]), np.array([240.0]), np.array([2.0]))
    xyz = mutated(
        rng,
        np.repeat(parent, 50_000, axis=0),
        RIG,
        sigma_px=3.0,
        sigma_disparity_px=1.5,
        d_min=0.5,
        d_max=20.0,
    )
    u, ur, v, _ = RIG.project(xyz)
    assert np.std(u) == pytest.approx(3.0, rel=0.02)
    assert np.std(v) == pytest.approx(3.0, rel=0.02)
    assert np.std(u - ur) == pytest.approx(1.5, rel=0.02)
    assert np.mean(u - ur) == pytest.approx(RIG.disparity(2.0), abs=0.05)


def test_mutation_keeps_depth_within_search_range():
    rng = np.random.default_rng(2)
    parent = RIG.backproject(np.array([320.0]), np.array([240.0]), np.array([0.55]))
    xyz = mutated(
        rng,
        np.repeat(parent, 1000, axis=0),
        RIG,
        sigma_px=1.0,
        sigma_disparity_px=50.0,
        d_min=0.5,
        d_max=20.0,
    )
    depth = xyz[:, 0] - RIG.mount_x
    assert depth.min() >= 0.5 - 1e-9 and depth.max() <= 20.0 + 1e-9


def test_two_parent_crossover_lies_on_the_segment():
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(1000, 3)), rng.normal(size=(1000, 3))
    child = crossover2(rng, a, b)
    lam = np.sum((child - b) * (a - b), axis=1) / np.sum((a - b) ** 2, axis=1)
    np.testing.assert_allclose(child, lam[:, None] * a + (1 - lam[:, None]) * b, atol=1e-12)
    assert lam.min() >= 0 and lam.max() <= 1 and lam.std() > 0.25  # U[0,1]: σ ≈ 0.29


def test_three_parent_crossover_lies_in_the_triangle():
    rng = np.random.default_rng(4)
    a, b, c = (rng.normal(size=(2000, 3)) for _ in range(3))
    child = crossover3(rng, a, b, c)
    # Barycentric coordinates by least squares on the two edge vectors.
    weights = []
    for i in range(len(child)):
        m = np.stack([a[i] - c[i], b[i] - c[i]], axis=1)
        lam_mu, *_ = np.linalg.lstsq(m, child[i] - c[i], rcond=None)
        weights.append(lam_mu)
    w = np.array(weights)
    np.testing.assert_allclose(
        child, w[:, :1] * a + w[:, 1:] * b + (1 - w.sum(1))[:, None] * c, atol=1e-9
    )
    assert w.min() >= -1e-9 and w.sum(axis=1).max() <= 1 + 1e-9
    # Uniform on the triangle: each weight has mean 1/3.
    np.testing.assert_allclose(w.mean(axis=0), [1 / 3, 1 / 3], atol=0.02)


@pytest.mark.parametrize(("rate2", "rate3"), [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.3, 0.3)])
def test_offspring_operator_shares(rate2, rate3):
    rng = np.random.default_rng(5)
    # Parents on three distinct depths far apart: mutation (σ = 0) copies a parent exactly
    # in depth, crossovers land between them.
    parents = RIG.backproject(
        np.array([300.0, 320, 340]), np.array([240.0] * 3), np.array([1.0, 2.0, 4.0])
    )
    kids = offspring(
        rng,
        parents,
        20_000,
        RIG,
        rate2=rate2,
        rate3=rate3,
        sigma_px=0.0,
        sigma_disparity_px=0.0,
        d_min=0.5,
        d_max=20.0,
    )
    depth = kids[:, 0] - RIG.mount_x
    copies = np.isclose(depth[:, None], [1.0, 2.0, 4.0], rtol=1e-9).any(axis=1)
    # Crossover of two equal parents is also a copy: P = 1/3 with 3 parents drawn uniformly.
    expected = 1 - rate2 * (2 / 3) - rate3 * (1 - 3 / 27)
    assert copies.mean() == pytest.approx(expected, abs=0.015)


@settings(max_examples=30, deadline=None)
@given(
    st.integers(0, 2**32 - 1),
    st.integers(0, 300),
    st.integers(0, 20),
    st.sampled_from([(0.0, 0.0), (0.1, 0.1), (0.5, 0.5), (1.0, 0.0), (0.0, 1.0)]),
)
def test_newcomers_kernel_equals_reference(seed, n, n_uniform, rates):
    parents = random_flies(np.random.default_rng(seed), RIG, 50, d_min=0.5, d_max=20.0, margin=3)
    parents[0, 0] = RIG.mount_x - 0.5  # one parent behind the cameras: projection guarded
    options = dict(sigma_px=3.4, sigma_disparity_px=1.7, d_min=0.5, d_max=20.0)
    a, b = np.random.default_rng(seed + 1), np.random.default_rng(seed + 1)
    children, uniform = newcomers_numpy(
        a, parents, n, n_uniform, RIG, rate2=rates[0], rate3=rates[1], margin=3, **options
    )
    got_children, got_uniform = np.empty((n, 3)), np.empty((n_uniform, 3))
    newcomers_into(
        b,
        parents,
        rates[0],
        rates[1],
        3.4,
        1.7,
        newcomer_constants(RIG, 0.5, 20.0, 3),
        got_children,
        got_uniform,
    )
    np.testing.assert_array_equal(got_children, children)
    np.testing.assert_array_equal(got_uniform, uniform)
    # the two consumed the same numbers: the streams go on alike
    assert a.random() == b.random()


def test_uniform_immigrants_are_random_flies():
    # the newcomers' uniform immigrants are the initialisation's flies, same draws
    expected = random_flies(np.random.default_rng(3), RIG, 40, d_min=0.5, d_max=20.0, margin=3)
    _, uniform = newcomers_numpy(
        np.random.default_rng(3),
        expected[:1],
        0,
        40,
        RIG,
        rate2=0.1,
        rate3=0.1,
        sigma_px=1.0,
        sigma_disparity_px=1.0,
        d_min=0.5,
        d_max=20.0,
        margin=3,
    )
    np.testing.assert_array_equal(uniform, expected)


def test_offspring_same_seed_same_children_for_both_implementations():
    parents = random_flies(np.random.default_rng(6), RIG, 100, d_min=0.5, d_max=20.0, margin=3)
    options = dict(
        rate2=0.2, rate3=0.2, sigma_px=3.0, sigma_disparity_px=1.0, d_min=0.5, d_max=20.0
    )
    a = offspring(np.random.default_rng(7), parents, 500, RIG, **options)
    b = offspring(np.random.default_rng(7), parents, 500, RIG, **options, use_numba=True)
    np.testing.assert_array_equal(a, b)
    c = offspring(np.random.default_rng(8), parents, 500, RIG, **options, use_numba=True)
    assert not np.array_equal(a, c)


def test_neighbour_counter_reuses_its_buffers_across_sizes_and_radii():
    rng = np.random.default_rng(9)
    count = NeighbourCounter()
    for n, radius in ((300, 3.0), (300, 0.0), (50, 12.0), (300, 3.0), (1, 2.0)):
        u, v = rng.uniform(0, 80, n), rng.uniform(0, 60, n)
        valid = rng.random(n) < 0.9
        np.testing.assert_array_equal(
            count(u, v, valid, radius), neighbour_counts_numpy(u, v, valid, radius)
        )


@pytest.mark.parametrize("radius", [0.0, 0.25, 0.5, 1.0, 2.0, 3.0, 4.0])
def test_sweep_counts_pairs_exactly_at_the_radius(radius):
    # A lattice of step R/2 (and points sharing positions): many pairs exactly R apart in u,
    # in v or both, where the band and column bounds have no slack left but rounding.
    step = radius / 2 if radius > 0 else 1.0
    g = np.arange(12) * step
    u, v = np.meshgrid(g, g)
    u = np.concatenate([u.ravel(), u.ravel()[::7]]) + 3.0
    v = np.concatenate([v.ravel(), v.ravel()[::7]]) + 5.0
    valid = np.ones(len(u), dtype=bool)
    expected = neighbour_counts_numpy(u, v, valid, radius)
    assert expected.max() > 0  # some pairs are counted: the test can fail
    np.testing.assert_array_equal(neighbour_counts_numba(u, v, valid, radius), expected)


def test_sweep_stays_small_for_far_spread_points():
    # Two tight clusters 1e7 px apart with R = 1: a grid of R-cells would have 1e14 cells.
    rng = np.random.default_rng(10)
    u = np.concatenate([rng.normal(0, 2, 200), rng.normal(1e7, 2, 200)])
    v = np.concatenate([rng.normal(0, 2, 200), rng.normal(1e7, 2, 200)])
    valid = np.ones(400, dtype=bool)
    assert grid_buffer_size(400) < 10_000
    np.testing.assert_array_equal(
        neighbour_counts_numba(u, v, valid, 1.0), neighbour_counts_numpy(u, v, valid, 1.0)
    )
    assert (neighbour_counts_numba(u, v, ~valid, 1.0) == 0).all()


@pytest.mark.parametrize("use_numba", [False, True])
def test_offspring_written_into_out(use_numba):
    parents = random_flies(np.random.default_rng(6), RIG, 100, d_min=0.5, d_max=20.0, margin=3)
    options = dict(
        rate2=0.2, rate3=0.2, sigma_px=3.0, sigma_disparity_px=1.0, d_min=0.5, d_max=20.0
    )
    expected = offspring(np.random.default_rng(7), parents, 50, RIG, **options)
    out = np.zeros((60, 3))
    got = offspring(
        np.random.default_rng(7),
        parents,
        50,
        RIG,
        **options,
        use_numba=use_numba,
        out=out[5:55],
    )
    np.testing.assert_array_equal(out[5:55], expected)
    assert np.shares_memory(got, out) and (out[:5] == 0).all() and (out[55:] == 0).all()


def test_fly_counts_equal_the_reference_on_projected_flies():
    from flylog.fly.fitness import INVALID_FITNESS, rig_constants
    from flylog.fly.neighbours import fly_neighbour_counts_into

    rng = np.random.default_rng(11)
    xyz = random_flies(rng, RIG, 3000, d_min=0.5, d_max=20.0, margin=3)
    # clusters, as converged flies sit on surfaces: many pairs in the same cells
    xyz[:1000] = xyz[rng.integers(1000, 3000, 1000)] + rng.normal(0, 0.002, (1000, 3))
    fitness = rng.random(3000)
    fitness[rng.random(3000) < 0.1] = INVALID_FITNESS
    radius = sharing_radius(RIG.n_pixels, 3000)
    u, _, v, _ = RIG.project(xyz)
    expected = neighbour_counts_numpy(u, v, fitness > INVALID_FITNESS, radius)
    assert expected.max() > 5  # crowded flies: the test can fail
    counter = NeighbourCounter()
    counts = np.full(3000, -7, dtype=np.int64)
    fly_neighbour_counts_into(
        xyz, rig_constants(RIG), fitness, radius, *counter.scratch(3000), counts
    )
    np.testing.assert_array_equal(counts, expected)


@pytest.mark.parametrize("crowd", [1, 3, 4, 5, 8, 9, 30])
def test_counts_for_every_crowding_of_the_cells(crowd):
    # The grid tests the first 4 flies of a fly's own run and the first 8 of the run below
    # in vector lanes and the rest in a loop: `crowd` flies in each cell of a 4×4 block of
    # R-cells, and sparse flies round them, take the lanes alone, the lanes and the loops.
    rng = np.random.default_rng(crowd)
    radius = 2.0
    corners = np.arange(4) * radius + 10.0
    cu, cv = (c.ravel() for c in np.meshgrid(corners, corners))
    u = np.concatenate(
        [np.repeat(cu, crowd) + rng.uniform(0, radius, 16 * crowd), rng.uniform(0, 40, 60)]
    )
    v = np.concatenate(
        [np.repeat(cv, crowd) + rng.uniform(0, radius, 16 * crowd), rng.uniform(0, 40, 60)]
    )
    valid = rng.random(len(u)) < 0.95
    expected = neighbour_counts_numpy(u, v, valid, radius)
    assert expected.max() >= crowd - 1  # the crowded cells count: the test can fail
    np.testing.assert_array_equal(neighbour_counts_numba(u, v, valid, radius), expected)
