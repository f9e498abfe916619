"""The overlay's choice of flies: the best k of positive fitness, exactly as a full stable
sort would rank them (ties included), with its partition shortcut."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flylog.replay.pipeline import best_valid_flies


def by_full_sort(fitness: np.ndarray, k: int) -> np.ndarray:
    """The reference: sort every valid fly, keep the last k."""
    valid = np.flatnonzero(fitness > 0)
    k = min(k, len(valid))
    return valid[np.argsort(fitness[valid], kind="stable")[len(valid) - k :]]


def test_known_ranking_with_ties_at_the_cut():
    fitness = np.array([0.5, -1.0, 0.9, 0.5, 0.0, 0.5, np.nan, 0.7])
    # valid: 0 (0.5), 2 (0.9), 3 (0.5), 5 (0.5), 7 (0.7); best 4 keep the later two 0.5s
    np.testing.assert_array_equal(best_valid_flies(fitness, 4), [3, 5, 7, 2])
    np.testing.assert_array_equal(best_valid_flies(fitness, 1), [2])
    np.testing.assert_array_equal(best_valid_flies(fitness, 99), [0, 3, 5, 7, 2])
    assert best_valid_flies(fitness, 0).size == 0
    assert best_valid_flies(np.array([-1.0, 0.0]), 3).size == 0


@settings(max_examples=300, deadline=None)
@given(
    fitness=st.lists(
        st.sampled_from([0.0, -0.0, -1.0, 0.25, 0.5, 1.0, np.inf, np.nan]), max_size=40
    )
    | st.lists(st.floats(allow_nan=True, width=64), max_size=40),
    k=st.integers(0, 50),
)
def test_same_flies_in_the_same_order_as_a_full_sort(fitness, k):
    f = np.array(fitness, dtype=float)
    np.testing.assert_array_equal(best_valid_flies(f, k), by_full_sort(f, k))


@pytest.mark.parametrize("k", [1, 1000, 5000])
def test_a_population_of_5000(k):
    f = np.random.default_rng(k).normal(0.3, 0.4, 5000)
    np.testing.assert_array_equal(best_valid_flies(f, k), by_full_sort(f, k))
