import numpy as np
import pytest

from flylog.fly.fitness import INVALID_FITNESS
from flylog.fly.population import Population, fitness_summary
from flylog.fly.selection import shared_fitness, survivor_indices


def _population(rng: np.random.Generator, n: int) -> Population:
    pop = Population.fresh(rng.normal(size=(n, 3)))
    pop.fitness[:] = rng.random(n)
    pop.vision[:] = rng.random(n)
    pop.stale[:] = rng.random(n) < 0.5
    pop.stamp_ns[:] = rng.integers(0, 100, n)
    pop.age[:] = rng.integers(0, 10, n)
    return pop


def test_survivors_then_into_reused_arrays_equals_a_new_population():
    rng = np.random.default_rng(0)
    pop = _population(rng, 10)
    keep = np.array([7, 2, 5])
    newcomers = rng.normal(size=(7, 3))
    spare = _population(rng, 10)
    buffers = [spare.xyz, spare.fitness, spare.age]
    got = pop.survivors_then(keep, newcomers, out=spare)
    assert got is spare and got.xyz is buffers[0] and got.age is buffers[2]
    expected = pop.survivors_then(keep, newcomers)
    for field in ("xyz", "fitness", "vision", "stale", "stamp_ns", "age"):
        np.testing.assert_array_equal(getattr(got, field), getattr(expected, field), field)
    np.testing.assert_array_equal(expected.xyz, np.concatenate([pop.xyz[keep], newcomers]))
    assert list(expected.age[:3]) == list(pop.age[keep] + 1) and (expected.age[3:] == 0).all()
    assert expected.stale[3:].all() and (expected.fitness[3:] == INVALID_FITNESS).all()
    assert (expected.stamp_ns[3:] == -1).all()


def test_fitness_summary_known_values():
    assert fitness_summary(np.array([INVALID_FITNESS, 3.0, 1.0, 2.0, 4.0])) == (4.0, 4, 2.5)
    none_valid = fitness_summary(np.array([INVALID_FITNESS, INVALID_FITNESS]))
    assert none_valid == (INVALID_FITNESS, 0, INVALID_FITNESS)


@pytest.mark.parametrize("sharing", [False, True])
def test_select_into_equals_selection_then_survivors_then(sharing):
    rng = np.random.default_rng(1)
    pop = _population(rng, 200)
    pop.fitness[:] = np.round(rng.normal(size=200), 1)  # ties, also at the cut
    pop.fitness[rng.random(200) < 0.1] = INVALID_FITNESS
    counts = rng.integers(0, 5, 200) if sharing else None
    ranked = shared_fitness(pop.fitness, counts, 0.1) if sharing else pop.fitness
    keep = survivor_indices(ranked, 120)
    expected = pop.survivors_then(keep, np.zeros((80, 3)))
    out = _population(rng, 200)
    assert pop.select_into(out, 120, counts, 0.1, np.empty(400)) == 120
    out.xyz[120:] = 0.0
    for field in ("xyz", "fitness", "vision", "stale", "stamp_ns", "age"):
        np.testing.assert_array_equal(getattr(out, field), getattr(expected, field), field)
    with pytest.raises(ValueError, match="same size"):
        pop.select_into(pop, 120, counts, 0.1, np.empty(400))


def test_select_sharing_into_counts_then_selects_as_select_into():
    from flylog.fly.fitness import rig_constants
    from flylog.fly.neighbours import NeighbourCounter, neighbour_counts_numpy
    from flylog.fly.operators import random_flies
    from flylog.fly.population import sharing_radius
    from flylog.geometry import StereoRig

    rig = StereoRig(width=64, height=48, focal_px=50.0)
    rng = np.random.default_rng(2)
    pop = _population(rng, 300)
    pop.xyz[:] = random_flies(rng, rig, 300, d_min=0.5, d_max=20.0, margin=3)
    pop.fitness[:] = np.round(rng.random(300), 1)  # ties
    pop.fitness[rng.random(300) < 0.1] = INVALID_FITNESS
    radius = sharing_radius(rig.n_pixels, 300)
    u, _, v, _ = rig.project(pop.xyz)
    counts = neighbour_counts_numpy(u, v, pop.fitness > INVALID_FITNESS, radius)
    assert counts.max() > 0
    expected, got = _population(rng, 300), _population(rng, 300)
    assert pop.select_into(expected, 150, counts, 0.1, np.empty(600)) == 150
    counter = NeighbourCounter()
    k = pop.select_sharing_into(got, 150, 0.1, np.empty(600), rig_constants(rig), radius, counter)
    assert k == 150
    np.testing.assert_array_equal(counter.counts, counts)
    for field in ("fitness", "vision", "stale", "stamp_ns", "age"):
        np.testing.assert_array_equal(getattr(got, field), getattr(expected, field), field)
    np.testing.assert_array_equal(got.xyz[:150], expected.xyz[:150])
