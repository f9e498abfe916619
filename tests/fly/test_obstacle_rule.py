"""The obstacle rule the planner and the metrics share."""

import numpy as np

from flylog.fly.obstacles import ObstacleFlies, obstacle_mask, obstacle_points
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
