"""The exact intervals and p-values of flylog.metrics.shift against brute-force
enumerations of the rank tests' permutations (every sign flip, every relabelling)."""

from __future__ import annotations

import itertools
import math
from fractions import Fraction

import numpy as np
import pytest

from flylog.metrics.shift import (
    mann_whitney_cdf,
    min_pairs,
    min_per_side,
    normal_u_cdf,
    paired_shift,
    signed_rank_cdf,
    unpaired_shift,
)


def brute_signed_rank_counts(n: int) -> list[int]:
    counts = [0] * (n * (n + 1) // 2 + 1)
    for signs in itertools.product((0, 1), repeat=n):
        counts[sum(r for r, s in zip(range(1, n + 1), signs, strict=True) if s)] += 1
    return counts


def brute_u_counts(m: int, n: int) -> list[int]:
    counts = [0] * (m * n + 1)
    for xs in itertools.combinations(range(m + n), m):
        ys = [p for p in range(m + n) if p not in xs]
        counts[sum(x < y for x in xs for y in ys)] += 1
    return counts


@pytest.mark.parametrize("n", [1, 2, 5, 8])
def test_signed_rank_distribution_is_every_sign_flip(n: int) -> None:
    counts = brute_signed_rank_counts(n)
    expected = np.cumsum(counts) / 2**n
    np.testing.assert_allclose(signed_rank_cdf(n), expected, rtol=0, atol=1e-15)


@pytest.mark.parametrize(("m", "n"), [(1, 1), (2, 3), (5, 5), (4, 6)])
def test_mann_whitney_distribution_is_every_relabelling(m: int, n: int) -> None:
    counts = brute_u_counts(m, n)
    expected = np.cumsum(counts) / math.comb(m + n, m)
    np.testing.assert_allclose(mann_whitney_cdf(m, n), expected, rtol=0, atol=1e-15)


def test_known_tail_probabilities() -> None:
    assert signed_rank_cdf(5)[0] == 1 / 32 and signed_rank_cdf(5)[1] == 2 / 32
    assert mann_whitney_cdf(5, 5)[4] == pytest.approx(12 / 252, abs=1e-15)
    assert mann_whitney_cdf(5, 5)[5] == pytest.approx(19 / 252, abs=1e-15)
    assert min_pairs(0.05) == 5 and min_pairs(0.1) == 4 and min_pairs(0.01) == 7
    assert min_per_side(0.05) == 3 and min_per_side(0.01) == 5  # 1/20; 1/70 > 0.01


def brute_paired_p_above(d: list[float], theta: float) -> Fraction:
    """P(T⁺ ≥ observed) over every sign flip of the ranks of |d − θ| (no ties)."""
    e = [x - theta for x in d]
    order = sorted(range(len(e)), key=lambda i: abs(e[i]))
    rank = {i: r + 1 for r, i in enumerate(order)}
    observed = sum(rank[i] for i in range(len(e)) if e[i] > 0)
    hits = 0
    for signs in itertools.product((0, 1), repeat=len(e)):
        hits += sum(rank[i] for i in range(len(e)) if signs[i]) >= observed
    return Fraction(hits, 2 ** len(e))


def brute_unpaired_p_above(x: list[float], y: list[float], theta: float) -> Fraction:
    """P(U ≥ observed), U = #{y − θ > x}, over every relabelling of the pooled sample."""
    pooled = x + [v - theta for v in y]
    m = len(x)
    observed = sum(yv - theta > xv for xv in x for yv in y)
    hits = total = 0
    for xs in itertools.combinations(range(len(pooled)), m):
        ys = [i for i in range(len(pooled)) if i not in xs]
        hits += sum(pooled[j] > pooled[i] for i in xs for j in ys) >= observed
        total += 1
    return Fraction(hits, total)


D = [0.31, -0.12, 0.55, 0.08, 0.47, 0.26]  # six paired differences, distinct Walsh averages


@pytest.mark.parametrize("theta", [-0.2, 0.0, 0.1, 0.2, 0.33, 0.6])
def test_paired_p_value_is_the_permutation_tests(theta: float) -> None:
    shift = paired_shift(np.zeros(len(D)), np.array(D), alpha=0.05)
    assert shift.p_above(theta) == pytest.approx(float(brute_paired_p_above(D, theta)), abs=1e-15)
    # the mirror image: the shift below θ is the shift of −d above −θ
    mirror = float(brute_paired_p_above([-v for v in D], -theta))
    assert shift.p_below(theta) == pytest.approx(mirror, abs=1e-15)


X = [0.80, 0.83, 0.79, 0.86, 0.81]
Y = [0.74, 0.78, 0.77, 0.705, 0.765]


@pytest.mark.parametrize("theta", [-0.2, -0.1, -0.052, -0.033, 0.0, 0.05])  # no tie
def test_unpaired_p_value_is_the_permutation_tests(theta: float) -> None:
    shift = unpaired_shift(X, Y, alpha=0.05)
    expected = float(brute_unpaired_p_above(X, Y, theta))
    assert shift.p_above(theta) == pytest.approx(expected, abs=1e-15)


def test_intervals_are_the_set_of_shifts_the_tests_keep() -> None:
    """Test inversion: just inside each end the one-sided test at α keeps the shift, just
    outside it rejects it; the end itself is the (k+1)-th Walsh average or difference."""
    alpha = 0.05
    paired = paired_shift(np.zeros(len(D)), np.array(D), alpha)
    # n = 6: P(T ≤ 2) = 3/64 ≤ 0.05 < P(T ≤ 3) = 5/64, so k = 2: the 3rd smallest
    assert signed_rank_cdf(6)[2] == 3 / 64 and signed_rank_cdf(6)[3] == 5 / 64
    walsh = sorted((D[i] + D[j]) / 2 for i in range(6) for j in range(i, 6))
    assert paired.low == walsh[2] and paired.high == walsh[-3]
    assert paired.estimate == pytest.approx(float(np.median(walsh)))
    unpaired = unpaired_shift(X, Y, alpha)
    diffs = sorted(y - x for x in X for y in Y)
    assert unpaired.low == diffs[4] and unpaired.high == diffs[-5]  # k = 4 (12/252 ≤ α)
    for shift in (paired, unpaired):
        eps = 1e-9
        assert shift.p_above(shift.low - eps) <= alpha < shift.p_above(shift.low + eps)
        assert shift.p_below(shift.high + eps) <= alpha < shift.p_below(shift.high - eps)


def test_too_few_runs_give_an_open_interval() -> None:
    shift = paired_shift([1.0, 2.0], [3.0, 4.0], alpha=0.05)
    assert (shift.low, shift.high) == (-math.inf, math.inf) and shift.estimate == 2.0
    assert shift.test == "wilcoxon-signed-rank" and shift.p_above(0.0) == 0.25
    shift = unpaired_shift([1.0], [3.0], alpha=0.05)
    assert math.isinf(shift.low) and shift.test == "mann-whitney"


def test_equal_runs_pair_to_a_zero_shift() -> None:
    shift = paired_shift([0.9] * 5, [0.9] * 5, alpha=0.05)
    assert (shift.low, shift.estimate, shift.high) == (0.0, 0.0, 0.0)
    assert shift.p_at_most(0.0) == 1 / 32 and shift.p_at_least(0.0) == 1 / 32
    assert shift.p_above(0.0) == 1.0


def test_large_samples_use_the_normal_approximation_of_u() -> None:
    exact = mann_whitney_cdf(100, 100)  # the largest counted exactly
    approx = normal_u_cdf(100, 100)
    # in the tails, where the intervals' ends are read
    k = int(np.searchsorted(exact, 0.05, side="right"))
    assert abs(approx[k] - exact[k]) < 0.001
    assert np.array_equal(mann_whitney_cdf(100, 101), normal_u_cdf(100, 101))
