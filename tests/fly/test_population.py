import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flylog.fly.fitness import INVALID_FITNESS
from flylog.fly.population import (
    Population,
    fitness_summary_numba,
    fitness_summary_numpy,
)

SUMMARIES = [fitness_summary_numpy, fitness_summary_numba]


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


@pytest.mark.parametrize("summary", SUMMARIES)
def test_fitness_summary_known_values(summary):
    assert summary(np.array([INVALID_FITNESS, 3.0, 1.0, 2.0, 4.0])) == (4.0, 4, 2.5)
    assert summary(np.array([INVALID_FITNESS, INVALID_FITNESS])) == (
        INVALID_FITNESS, 0, INVALID_FITNESS,
    )  # fmt: skip


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 300))
def test_fitness_summary_kernel_equals_reference(seed, n):
    rng = np.random.default_rng(seed)
    fitness = np.where(rng.random(n) < 0.3, INVALID_FITNESS, rng.exponential(size=n))
    assert fitness_summary_numba(fitness) == fitness_summary_numpy(fitness)


def test_survivors_into_equals_survivors_then():
    rng = np.random.default_rng(1)
    pop = _population(rng, 50)
    keep = rng.permutation(50)[:20]
    newcomers = rng.normal(size=(30, 3))
    expected = pop.survivors_then(keep, newcomers)
    out = _population(rng, 50)
    assert pop.survivors_into(keep, out) == 20
    out.xyz[20:] = newcomers
    for field in ("xyz", "fitness", "vision", "stale", "stamp_ns", "age"):
        np.testing.assert_array_equal(getattr(out, field), getattr(expected, field), field)
    with pytest.raises(ValueError, match="same size"):
        pop.survivors_into(keep, pop)
