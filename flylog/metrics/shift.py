"""The shift between two samples (candidate − base) with an exact distribution-free
confidence interval and one-sided tests against a margin: the Hodges–Lehmann estimate and
its interval from the Wilcoxon signed-rank distribution (paired) or the Mann–Whitney U
distribution (unpaired).

Paired samples (the same seeds and inputs on both sides) give one difference per pair; the
estimate is the median of their Walsh averages ((dᵢ + dⱼ)/2, i ≤ j). Unpaired samples give
every difference yⱼ − xᵢ; the estimate is their median. The interval's ends are order
statistics of those N values: the lower end is the (k+1)-th smallest, the upper the
(k+1)-th largest, k the largest count with P(T ≤ k) ≤ α under the null distribution of the
rank statistic T (a one-sided bound at confidence 1 − α each, a two-sided interval at
1 − 2α; Hollander, Wolfe & Chicken, *Nonparametric Statistical Methods*, 3rd ed., 2014,
§3.2 and §4.3; Bauer, JASA 67:687, 1972). A test of "the shift exceeds θ" rejects exactly
when the lower end exceeds θ: its p-value is P(T ≤ #{values ≤ θ}). Ties (integer and
boolean metrics) make the counts, and so the tests, conservative.

The null distributions are counted exactly (float64 counts: exact up to 2⁵³, relative error
1e-16 beyond): the signed-rank one by subset sums of the ranks 1 … n, the U one by the
recurrence N(m, n, u) = N(m − 1, n, u − n) + N(m, n − 1, u) (Mann & Whitney, 1947), up to
m·n = 10,000 (the normal approximation beyond).
"""

from __future__ import annotations

import functools
import math
from statistics import NormalDist
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike


@functools.lru_cache(maxsize=64)
def signed_rank_cdf(n: int) -> np.ndarray:
    """P(T ≤ t) for t = 0 … n(n+1)/2, T the Wilcoxon signed-rank statistic of n pairs
    under the null (each rank's sign a fair coin)."""
    counts = np.zeros(n * (n + 1) // 2 + 1)
    counts[0] = 1.0
    top = 0
    for rank in range(1, n + 1):
        counts[rank : top + rank + 1] += counts[: top + 1].copy()
        top += rank
    cdf: np.ndarray = np.cumsum(counts) / 2.0**n
    return cdf


# Above this m·n the U distribution is its normal approximation (with a continuity
# correction): the exact count's work grows as (mn)², 0.1 s at 100 × 100.
EXACT_U_LIMIT = 10_000


@functools.lru_cache(maxsize=64)
def mann_whitney_cdf(m: int, n: int) -> np.ndarray:
    """P(U ≤ u) for u = 0 … mn, U the Mann–Whitney statistic of samples of m and n values
    under the null (every one of the C(m+n, m) orders equally likely)."""
    if m * n > EXACT_U_LIMIT:
        return normal_u_cdf(m, n)
    # row[j] holds the counts N(i, j, ·) for the current i; N(0, j) = N(i, 0) = [1].
    row = [np.ones(1) for _ in range(n + 1)]
    for i in range(1, m + 1):
        new = [np.ones(1)]
        for j in range(1, n + 1):
            counts = np.zeros(i * j + 1)
            counts[j : j + len(row[j])] += row[j]  # N(i − 1, j, u − j)
            counts[: len(new[j - 1])] += new[j - 1]  # N(i, j − 1, u)
            new.append(counts)
        row = new
    counts = row[n]
    cdf: np.ndarray = np.cumsum(counts) / counts.sum()
    return cdf


def normal_u_cdf(m: int, n: int) -> np.ndarray:
    """The normal approximation of :func:`mann_whitney_cdf` (continuity-corrected)."""
    normal = NormalDist(m * n / 2.0, math.sqrt(m * n * (m + n + 1) / 12.0))
    return np.array([normal.cdf(u + 0.5) for u in range(m * n + 1)])


class Shift(NamedTuple):
    """The shift of a candidate from a base, in the metric's unit."""

    paired: bool
    n_base: int  # values used (pairs, when paired)
    n_candidate: int
    estimate: float  # Hodges–Lehmann
    low: float  # one-sided 1 − α lower bound (−inf if the samples are too few)
    high: float  # one-sided 1 − α upper bound (+inf if too few)
    values: np.ndarray  # the sorted Walsh averages (paired) or pairwise differences

    @property
    def test(self) -> str:
        return "wilcoxon-signed-rank" if self.paired else "mann-whitney"

    def p_above(self, theta: float) -> float:
        """p-value of the test that the shift exceeds ``theta``."""
        count = int(np.searchsorted(self.values, theta, side="right"))  # values ≤ θ
        return self._cdf(count)

    def p_below(self, theta: float) -> float:
        """p-value of the test that the shift is below ``theta``."""
        count = len(self.values) - int(np.searchsorted(self.values, theta, side="left"))
        return self._cdf(count)

    def p_at_most(self, theta: float) -> float:
        """p-value of the test that the shift is at most ``theta`` (ties with θ count for
        it: a closed bound, so that equal samples are shown equal within a zero margin)."""
        count = len(self.values) - int(np.searchsorted(self.values, theta, side="right"))
        return self._cdf(count)

    def p_at_least(self, theta: float) -> float:
        """p-value of the test that the shift is at least ``theta`` (closed, as above)."""
        return self._cdf(int(np.searchsorted(self.values, theta, side="left")))

    def _cdf(self, count: int) -> float:
        cdf = (
            signed_rank_cdf(self.n_base)
            if self.paired
            else mann_whitney_cdf(self.n_base, self.n_candidate)
        )
        return float(min(1.0, cdf[count]))


def _bounds(values: np.ndarray, cdf: np.ndarray, alpha: float) -> tuple[float, float]:
    k = int(np.searchsorted(cdf, alpha * (1 + 1e-12), side="right")) - 1  # P(T ≤ k) ≤ α
    if k < 0:
        return -math.inf, math.inf
    return float(values[k]), float(values[len(values) - 1 - k])


def paired_shift(base: ArrayLike, candidate: ArrayLike, alpha: float) -> Shift:
    """The shift of paired samples (``candidate[i]`` ran as ``base[i]``, e.g. the same seed
    and input)."""
    d = np.asarray(candidate, dtype=float) - np.asarray(base, dtype=float)
    if len(d) == 0:
        return Shift(True, 0, 0, math.nan, -math.inf, math.inf, np.empty(0))
    i, j = np.triu_indices(len(d))
    walsh = np.sort((d[i] + d[j]) / 2.0)
    low, high = _bounds(walsh, signed_rank_cdf(len(d)), alpha)
    return Shift(True, len(d), len(d), float(np.median(walsh)), low, high, walsh)


def unpaired_shift(base: ArrayLike, candidate: ArrayLike, alpha: float) -> Shift:
    """The shift of independent samples."""
    x = np.asarray(base, dtype=float)
    y = np.asarray(candidate, dtype=float)
    if len(x) == 0 or len(y) == 0:
        return Shift(False, len(x), len(y), math.nan, -math.inf, math.inf, np.empty(0))
    diffs = np.sort((y[None, :] - x[:, None]).ravel())
    low, high = _bounds(diffs, mann_whitney_cdf(len(x), len(y)), alpha)
    return Shift(False, len(x), len(y), float(np.median(diffs)), low, high, diffs)


def min_pairs(alpha: float) -> int:
    """The fewest pairs whose signed-rank interval is finite at ``alpha`` (2⁻ⁿ ≤ α)."""
    return max(1, math.ceil(math.log2(1.0 / alpha) - 1e-12))


def min_per_side(alpha: float) -> int:
    """The fewest values a side (equal sides) whose U interval is finite (1/C(2n, n) ≤ α)."""
    n = 1
    while 1.0 / math.comb(2 * n, n) > alpha * (1 + 1e-12):
        n += 1
    return n
