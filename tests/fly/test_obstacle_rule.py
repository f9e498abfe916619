"""The obstacle rule the planner and the metrics share."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from flylog.fly.obstacles import ObstacleFlies, obstacle_mask, obstacle_points, quantile_linear
from flylog.fly.population import Population


def test_rule_keeps_fit_high_and_old_flies_only():
    xyz = np.array([[2.0, 0, 0.5], [2.0, 0, 0.5], [2.0, 0, 0.01], [2.0, 0, 0.5], [2.0, 0, 0.5]])
    fitness = np.array([3.0, 3.0, 3.0, 0.5, -1.0])  # positive median: 3.0 … quantile 0.0: 0.5
    age = np.array([5, 1, 5, 5, 5])
    rule = ObstacleFlies(quantile=0.0, ground_margin=0.05, min_age=3, min_distinctness=0.0)
    # fly 1 is too young, 2 on the ground, 3 at the threshold (not above), 4 invalid
    assert rule.mask(xyz, fitness, age).tolist() == [True, False, False, False, False]
    # without ages (an older cloud) the age test is skipped
    assert rule.mask(xyz, fitness, None).tolist() == [True, True, False, False, False]


def test_obstacle_points_applies_the_same_rule_to_a_population():
    rng = np.random.default_rng(5)
    pop = Population.fresh(rng.uniform(-1, 1, (400, 3)))
    pop.fitness[:] = rng.uniform(-0.5, 2.0, 400)
    pop.age[:] = rng.integers(0, 6, 400)
    rule = ObstacleFlies(quantile=0.3, ground_margin=0.1, min_age=2, min_distinctness=0.0)
    expected = pop.xyz[rule.mask(pop.xyz, pop.fitness, pop.age)]
    got = obstacle_points(pop, quantile=0.3, ground_margin=0.1, min_age=2)
    np.testing.assert_array_equal(got, expected)
    assert 0 < len(got) < 400
    assert obstacle_mask(pop.xyz, pop.fitness, quantile=0.3, ground_margin=0.1).sum() > len(got)


@settings(max_examples=300, deadline=None)
@given(
    st.lists(st.floats(0.0, 1e3, allow_nan=False), min_size=1, max_size=80),
    st.sampled_from([0.0, 0.1, 0.25, 0.5, 0.75, 0.9, 0.99, 1 / 3]),
    st.integers(0, 3),
)
def test_quantile_is_numpys_bit_for_bit(values, q, rounding):
    # rounded values: many ties
    a = np.round(np.array(values), rounding) if rounding < 3 else np.array(values)
    assert quantile_linear(a, q) == float(np.quantile(a, q))


def test_quantile_of_a_populations_fitness_is_numpys():
    rng = np.random.default_rng(9)
    for n in (1, 2, 4999, 5000):
        fitness = rng.lognormal(-3.0, 1.0, n)
        for q in (0.5, 0.3, 0.95):
            assert quantile_linear(fitness, q) == float(np.quantile(fitness, q))
