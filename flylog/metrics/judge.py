"""The verdict on one metric: is the candidate worse than the base beyond the tolerance,
with confidence 1 − α, given how much the seeds alone move the metric?

The shift candidate − base and its interval come from :mod:`flylog.metrics.shift`
(paired by seed when both sides ran the same seeds and inputs). With ``tol`` the worsening
allowed and the interval read as a worsening (its sign flipped for higher-is-better
metrics):

- regression: the worsening's lower bound exceeds ``tol`` (p_regression ≤ α);
- improvement: its upper bound is below −``tol``;
- no change: the interval lies within [−``tol``, ``tol``] (two one-sided tests, each at α:
  the equivalence test of Schuirmann, J. Pharmacokinet. Biopharm. 15:657, 1987);
- inconclusive: none of these; not a failure. The seeds a side that would settle it are
  estimated from the spread of the values, by a normal approximation.

A candidate that lacks every value the base has is a regression (``missing``).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np
from numpy.typing import ArrayLike

from flylog.metrics.shift import Shift, min_pairs, min_per_side, paired_shift, unpaired_shift

# The most seeds a side an estimate names; beyond, "more than" this.
MAX_SEEDS = 1000


class Direction(enum.Enum):
    HIGHER = "higher"
    LOWER = "lower"


class Verdict(enum.Enum):
    REGRESSION = "regression"
    IMPROVEMENT = "improvement"
    NO_CHANGE = "no change"
    INCONCLUSIVE = "inconclusive"
    MISSING = "missing"  # the candidate lacks every value the base has: a regression
    UNJUDGED = "-"  # shown, not judged (the reason says why)


@dataclass(frozen=True)
class Judgement:
    """What the test found on one metric (NaN where undefined)."""

    verdict: Verdict
    reason: str  # why unjudged or inconclusive; empty otherwise
    shift: Shift | None  # None when not tested
    allowed: float  # worsening allowed, in the metric's unit
    p_regression: float = math.nan
    p_improvement: float = math.nan
    p_no_change: float = math.nan
    seeds_needed: int | None = None  # inconclusive: an estimate of the seeds a side needed

    @property
    def regressed(self) -> bool:
        return self.verdict in (Verdict.REGRESSION, Verdict.MISSING)


def finite(values: ArrayLike) -> np.ndarray:
    x = np.asarray(values, dtype=float)
    return x[np.isfinite(x)]


def shift_of(base: ArrayLike, candidate: ArrayLike, *, paired: bool, alpha: float) -> Shift:
    """The shift of two sides' values; ``paired``: ``base[i]`` and ``candidate[i]`` ran
    the same seed and input (pairs with a missing value on either side are left out)."""
    b = np.asarray(base, dtype=float)
    c = np.asarray(candidate, dtype=float)
    if paired:
        keep = np.isfinite(b) & np.isfinite(c)
        return paired_shift(b[keep], c[keep], alpha)
    return unpaired_shift(finite(b), finite(c), alpha)


def _spread(shift: Shift, base: np.ndarray, candidate: np.ndarray) -> float:
    """sd of one side's values (unpaired, pooled) or of the differences (paired)."""
    if shift.paired:
        keep = np.isfinite(base) & np.isfinite(candidate)
        d = candidate[keep] - base[keep]
        return float(np.std(d, ddof=1)) if len(d) > 1 else math.nan
    x, y = finite(base), finite(candidate)
    if len(x) + len(y) < 3:
        return math.nan
    ss = float(np.sum((x - x.mean()) ** 2) + np.sum((y - y.mean()) ** 2))
    return math.sqrt(ss / (len(x) + len(y) - 2))


def seeds_needed(shift: Shift, sd: float, tol: float, alpha: float, worse: float) -> int | None:
    """Seeds a side (pairs, when paired) whose interval would leave out the tolerance
    bounds it now holds: z₁₋α · sd · √(c/n) below the estimate's distance to them (c = 1
    paired, 2 unpaired), and at least the fewest with a finite interval. ``worse``: +1 if
    a higher shift is worse, −1 if lower. Without a spread (too few runs to measure one)
    that fewest; None if no number of seeds settles it (the estimate on a bound)."""
    est = worse * shift.estimate
    lo, hi = sorted((worse * shift.low, worse * shift.high))
    inside = [b for b in (-tol, tol) if lo <= b <= hi] or [-tol, tol]
    margin = min(abs(est - b) for b in inside)
    floor = min_pairs(alpha) if shift.paired else min_per_side(alpha)
    have = min(shift.n_base, shift.n_candidate)
    if not math.isfinite(est):
        return None
    if not math.isfinite(sd) or sd == 0.0:
        return floor if floor > have else None
    if margin == 0.0:
        return None
    z = NormalDist().inv_cdf(1.0 - alpha)
    c = 1.0 if shift.paired else 2.0
    n = math.ceil(c * (z * sd / margin) ** 2 + 1e-9)
    return max(n, floor)


def judge(
    base: ArrayLike,
    candidate: ArrayLike,
    *,
    direction: Direction,
    allowed: float,
    paired: bool,
    alpha: float,
) -> Judgement:
    """The verdict on one metric whose tolerance allows a worsening of ``allowed``."""
    b = np.asarray(base, dtype=float)
    c = np.asarray(candidate, dtype=float)
    if not np.isfinite(b).any():
        return Judgement(Verdict.UNJUDGED, "no base value", None, allowed)
    if not np.isfinite(c).any():
        return Judgement(Verdict.MISSING, "the candidate has no value", None, allowed)
    shift = shift_of(b, c, paired=paired, alpha=alpha)
    # A relative slack of 1e-9 so that a worsening equal to the allowance, written through
    # floats, is allowed.
    tol = allowed + 1e-9 * max(1.0, float(np.abs(b[np.isfinite(b)]).max()))
    if direction is Direction.HIGHER:  # worse = lower
        p_reg, p_imp = shift.p_below(-tol), shift.p_above(tol)
        worse = -1.0
    else:
        p_reg, p_imp = shift.p_above(tol), shift.p_below(-tol)
        worse = 1.0
    p_same = max(shift.p_at_least(-tol), shift.p_at_most(tol))

    def made(verdict: Verdict, reason: str = "", need: int | None = None) -> Judgement:
        return Judgement(verdict, reason, shift, allowed, p_reg, p_imp, p_same, need)

    if p_reg <= alpha:
        return made(Verdict.REGRESSION)
    if p_imp <= alpha:
        return made(Verdict.IMPROVEMENT)
    if p_same <= alpha:
        return made(Verdict.NO_CHANGE)
    need = seeds_needed(shift, _spread(shift, b, c), tol, alpha, worse)
    return made(Verdict.INCONCLUSIVE, _inconclusive_reason(shift, tol, worse, need), need)


def _inconclusive_reason(shift: Shift, tol: float, worse: float, need: int | None) -> str:
    lo, hi = sorted((worse * shift.low, worse * shift.high))
    have = shift.n_base if shift.paired else min(shift.n_base, shift.n_candidate)
    if shift.paired:
        unit = "pair" if have == 1 else "pairs"
    else:
        unit = "seed a side" if have == 1 else "seeds a side"
    units = "pairs" if shift.paired else "seeds a side"
    if math.isinf(lo) and math.isinf(hi):
        what = f"too few runs for an interval ({have} {unit})"
        if need is not None:
            return f"{what}; at least {need} {units} needed"
    elif hi > tol:
        what = f"a worsening beyond {tol:.3g} is not ruled out"
    else:
        what = f"an improvement beyond {tol:.3g} is not ruled out"
    if need is None:
        return f"{what}; more seeds may not settle it (the estimate is on the tolerance)"
    if need > MAX_SEEDS:
        return f"{what}; more than {MAX_SEEDS} {units} needed"
    return f"{what}; about {need} {units} needed ({have} now)"
